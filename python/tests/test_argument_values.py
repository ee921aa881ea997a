"""Every numeric argument of the Python API and every number of a scene dict given NaN, ±inf, 0,
a negative, a huge or a tiny value, or a string: each call raises an ``Exception`` (an
``MpmError``, ``TypeError`` or ``ValueError`` naming what is wrong) or returns finite numbers.
No call panics (pyo3's ``PanicException`` is not an ``Exception``), aborts or hangs: the walk
runs in a child process under a time limit, so that an abort shows as a failed test."""

import os
import subprocess
import sys
import textwrap

CHILD = r'''
import math, sys
import numpy as np
import sparse_mpm as mpm

VALUES = [math.nan, math.inf, -math.inf, 0.0, -1.0, 1e300, -1e300, 1e-300, 1e30, "1.0"]
INTEGERS = [0, -1, 2**40, 2**62, 1.5, "3"]
failures, cases = [], 0


def finite(value):
    """Whether every number in a result is finite (arrays, dicts, tuples, scalars)."""
    if isinstance(value, dict):
        return all(finite(v) for v in value.values())
    if isinstance(value, (list, tuple)):
        return all(finite(v) for v in value)
    if isinstance(value, np.ndarray) and value.dtype.kind == "f":
        return bool(np.isfinite(value).all())
    if isinstance(value, float):
        return math.isfinite(value)
    return True


def probe(name, call, allow_inf=False):
    global cases
    cases += 1
    try:
        out = call()
    except Exception as e:  # an error naming what is wrong is the expected refusal
        if not str(e):
            failures.append(f"{name}: {type(e).__name__} without a message")
        return
    except BaseException as e:  # a panic, or anything else that is not an Exception
        failures.append(f"{name}: {type(e).__name__}: {e}")
        return
    if not allow_inf and not finite(out):
        failures.append(f"{name}: accepted, returned a value that is not finite")


grid = mpm.Grid([0.0, 0.0], [0.25, 0.25], [8, 8])
particles = mpm.Particles([0.8, 1.1, 0.9], [0.8, 0.9, 1.2], [1.0, 2.0, 1.5], [0.01, 0.02, 0.015])
ops = mpm.Operators.assemble(grid, particles)
m, vol = [1.0, 2.0, 1.5], [0.01, 0.02, 0.015]

for v in VALUES:
    for i in range(2):
        o = [0.0, 0.0]; o[i] = v
        probe(f"Grid(origin[{i}]={v!r})", lambda: mpm.Grid(o, [0.25, 0.25], [8, 8]))
        h = [0.25, 0.25]; h[i] = v
        probe(f"Grid(cell_size[{i}]={v!r})", lambda: mpm.Grid([0.0, 0.0], h, [8, 8]))
    # A stable step may be infinite (no stiffness); its inputs must not give NaN or a panic.
    probe(f"critical_time_step(youngs_modulus={v!r})",
          lambda: mpm.critical_time_step(ops, m, vol, v, 0.3), allow_inf=True)
    probe(f"critical_time_step(poisson_ratio={v!r})",
          lambda: mpm.critical_time_step(ops, m, vol, 1e4, v), allow_inf=True)
    for arg in range(3):
        args = [1e4, 0.3, 1e-4]; args[arg] = v
        label = ["youngs_modulus", "poisson_ratio", "dt"][arg]
        probe(f"explicit_step({label}={v!r})", lambda: {
            k: r for k, r in mpm.explicit_step(grid, particles, *args).items()
            if k not in ("operators", "particles")
        })
for n in INTEGERS:
    for i in range(2):
        c = [8, 8]; c[i] = n
        probe(f"Grid(cells[{i}]={n!r})", lambda: mpm.Grid([0.0, 0.0], [0.25, 0.25], c))
    for key in ["particles_per_cell", "samples", "cells"]:
        # NaN marks the wavenumbers where a mass symbol vanishes (documented).
        probe(f"dispersion({key}={n!r})", lambda: mpm.dispersion(**{key: n}), allow_inf=True)

SCENE = {
    "grid": {"origin": [0.0, 0.0], "cell_size": [0.1, 0.1], "cells": [10, 10]},
    "time": {"end": 0.01},
    "loads": {"gravity": [0.0, -9.81]},
    "bodies": [{
        "name": "block",
        "material": {"model": "neo_hookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3},
        "density": 1000.0,
        "velocity": [0.1, 0.0],
        "geometry": {"rectangle": {"min": [0.3, 0.3], "max": [0.7, 0.7]}},
    }],
}


def paths(value, path=()):
    if isinstance(value, dict):
        for k, v in value.items():
            yield from paths(v, path + (k,))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from paths(v, path + (i,))
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        yield path


def with_value(path, v):
    import copy
    scene = copy.deepcopy(SCENE)
    at = scene
    for step in path[:-1]:
        at = at[step]
    at[path[-1]] = v
    return scene


def steps(scene):
    sim = mpm.Simulation.from_dict(scene)
    return [sim.step() for _ in range(3)]


for path in list(paths(SCENE)):
    for v in VALUES + [2**40]:
        probe(f"from_dict {path} = {v!r}", lambda: steps(with_value(path, v)))

sim = mpm.Simulation.from_dict(SCENE)
for v in VALUES:
    probe(f"step(max_dt={v!r})", lambda: sim.step(max_dt=v))
    probe(f"land_every = {v!r}", lambda: setattr(sim, "land_every", v))
    probe(f"run(until={v!r})", lambda: mpm.Simulation.from_dict(SCENE).run(until=v))
print(f"{cases} cases")
for f in failures:
    print("FAIL", f)
'''


def test_every_numeric_argument_is_refused_or_gives_finite_numbers():
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(CHILD)], capture_output=True, text=True, timeout=600, env=env
    )
    assert done.returncode == 0, f"child exited with {done.returncode}\n{done.stdout[-4000:]}\n{done.stderr[-4000:]}"
    cases = [line for line in done.stdout.splitlines() if line.endswith(" cases")]
    assert cases and int(cases[0].split()[0]) > 300, done.stdout
    failures = [line for line in done.stdout.splitlines() if line.startswith("FAIL")]
    assert not failures, f"{len(failures)} failures:\n" + "\n".join(failures)
