"""Hostile or careless inputs: a scene dict that contains itself or is nested without end, node
lists longer than the grid, Ctrl-C during a run, and arrays of physical quantities that are
complex, not finite, not positive or of the wrong length. Each is refused with an error naming
the key path or the argument (or, for Ctrl-C, stops the run between two steps).

A call that would crash the interpreter if its check regressed runs in a child process, so
that the regression shows as a failed test, not as a dead test run."""

import copy
import os
import select
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import sparse_mpm as mpm

SCENE = {
    "grid": {"origin": [0.0, 0.0], "cell_size": [0.1, 0.1], "cells": [10, 10]},
    "time": {"end": 0.05},
    "bodies": [
        {
            "name": "block",
            "material": {"model": "neo_hookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3},
            "density": 1000.0,
            "geometry": {"rectangle": {"min": [0.3, 0.3], "max": [0.7, 0.7]}},
        }
    ],
}


def run_python(code: str, timeout: float = 300.0) -> subprocess.CompletedProcess:
    """`code` run by this interpreter in a child process (one BLAS thread), with `scene` set to
    a copy of `SCENE`; its output captured."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    program = f"scene = {SCENE!r}\n" + textwrap.dedent(code)
    return subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, timeout=timeout, env=env)


def assert_child_ok(done: subprocess.CompletedProcess) -> str:
    assert done.returncode == 0, f"child exited with {done.returncode}\n{done.stdout}\n{done.stderr}"
    return done.stdout


def small_problem():
    grid = mpm.Grid([0.0, 0.0], [0.25, 0.25], [4, 4])
    particles = mpm.Particles([0.3, 0.6], [0.3, 0.7], [1.0, 2.0], [0.1, 0.2])
    return grid, particles, mpm.Operators.assemble(grid, particles)


# 1. A dict or list that contains itself.


def test_self_referencing_dict_is_refused():
    out = assert_child_ok(
        run_python(
            """
            import numpy as np
            import sparse_mpm as mpm

            def refused(make):
                try:
                    make()
                except ValueError as e:
                    print("refused:", e)
                else:
                    print("accepted")

            d = dict(scene, loads={})
            d["loads"]["again"] = d["loads"]
            refused(lambda: mpm.Simulation.from_dict(d))
            d = dict(scene, boundaries=[])
            d["boundaries"].append(d["boundaries"])
            refused(lambda: mpm.Simulation.from_dict(d))
            d = dict(scene)
            d["me"] = d  # from_dict copies the top level: the copy holds the original
            refused(lambda: mpm.Simulation.from_dict(d))
            a = np.empty(1, dtype=object)
            a[0] = a  # an object array holding itself: a new list each time it is listed
            refused(lambda: mpm.Simulation.from_dict(dict(scene, loads={"gravity": a})))
            shape = {"gimp": {}}
            shape["gimp"]["half_width"] = shape
            grid = mpm.Grid([0.0, 0.0], [0.25, 0.25], [4, 4])
            particles = mpm.Particles([0.3], [0.3], [1.0], [0.1])
            refused(lambda: mpm.Operators.assemble(grid, particles, shape))
            options = {"time": {"end": 1.0}, "output": {}}
            options["output"]["x"] = [options]
            refused(lambda: mpm.Simulation.from_arrays(grid, particles, [{"name": "b", "material": {}}], options))
            """
        )
    )
    lines = out.splitlines()
    assert len(lines) == 6, out
    assert all(line.startswith("refused:") for line in lines), out
    assert "loads contains itself at key path loads.again" in lines[0]
    assert "boundaries contains itself at key path boundaries[0]" in lines[1]
    assert "me contains itself at key path me.me" in lines[2]
    assert "loads.gravity contains itself at key path loads.gravity[0]" in lines[3]
    assert "shape contains itself at key path shape.gimp.half_width" in lines[4]
    # from_arrays copies the top level of options: its `output` is where the loop closes.
    assert "output contains itself at key path output.x[0].output" in lines[5]


# 2. A dict or list nested without end (deeper than Python's own recursion limit).


def test_deeply_nested_dict_is_refused():
    out = assert_child_ok(
        run_python(
            """
            import sparse_mpm as mpm

            def refused(make):
                try:
                    make()
                except ValueError as e:
                    print("refused:", str(e)[:40], "…", str(e)[-80:])
                else:
                    print("accepted")

            # Built in a loop: 200 000 levels, far past Python's recursion limit.
            deep = {}
            inner = deep
            for _ in range(200_000):
                inner["a"] = {}
                inner = inner["a"]
            refused(lambda: mpm.Simulation.from_dict(dict(scene, loads=deep)))
            deep_list = []
            inner = deep_list
            for _ in range(200_000):
                inner.append([])
                inner = inner[0]
            refused(lambda: mpm.Simulation.from_dict(dict(scene, loads={"gravity": deep_list})))
            grid = mpm.Grid([0.0, 0.0], [0.25, 0.25], [4, 4])
            particles = mpm.Particles([0.3], [0.3], [1.0], [0.1])
            refused(lambda: mpm.Operators.assemble(grid, particles, {"gimp": deep}))
            refused(
                lambda: mpm.Simulation.from_arrays(
                    grid, particles, [{"name": "b", "material": deep}], {"time": {"end": 1.0}}
                )
            )
            """
        )
    )
    lines = out.splitlines()
    assert len(lines) == 4, out
    assert all(line.startswith("refused:") for line in lines), out
    assert all("nested more than 64 levels deep" in line for line in lines), out
    assert lines[0].startswith("refused: loads.a.a.a"), out
    assert lines[1].startswith("refused: loads.gravity[0][0][0]"), out
    assert lines[2].startswith("refused: shape.gimp.a.a"), out
    assert lines[3].startswith("refused: bodies[0].material.a.a"), out


def test_oversized_scene_dict_is_refused_naming_the_key():
    scene = copy.deepcopy(SCENE)
    with pytest.raises(mpm.MpmError, match=r"loads.many: 3000000 values, more than the 2000000"):
        mpm.Simulation.from_dict(dict(scene, loads={"many": [0.0] * 3_000_000}))
    with pytest.raises(mpm.MpmError, match=r"bodies\[0\].name: a string of 20000000 characters"):
        mpm.Simulation.from_dict(dict(scene, bodies=[dict(scene["bodies"][0], name="x" * 20_000_000)]))
    # A scene a few levels deep with a few values is read as before.
    assert mpm.Simulation.from_dict(scene).steps == 0


# 3. Node lists (and other index arrays) no longer than what the grid holds.


def test_huge_node_list_is_refused_before_allocating():
    out = assert_child_ok(
        run_python(
            """
            import resource
            import numpy as np
            import sparse_mpm as mpm

            # The limit the failure was seen under; what is refused here must not come near it.
            resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))
            nodes = list(range(10_000_000))
            array = np.arange(10_000_000)
            grid = mpm.Grid([0.0, 0.0], [0.1, 0.1], [10, 10])
            particles = mpm.Particles([0.5], [0.5], [1.0], [0.01])
            body = [{"name": "b", "material": {"model": "neo_hookean", "youngs_modulus": 1e5, "poisson_ratio": 0.3}}]
            walls = [{"edge": "left", "condition": "fixed"}, {"nodes": array, "condition": "fixed"}]
            before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
            for make in (
                lambda: mpm.Simulation.from_dict(dict(scene, boundaries=[{"nodes": nodes, "condition": "fixed"}])),
                lambda: mpm.Simulation.from_arrays(grid, particles, body, {"time": {"end": 1.0}, "boundaries": walls}),
                lambda: mpm.Particles([0.5], [0.5], [1.0], [0.01], body=array),
            ):
                try:
                    make()
                except ValueError as e:
                    print("refused:", e)
                else:
                    print("accepted")
            grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
            print("grown_kib", grown)
            """
        )
    )
    lines = out.splitlines()
    assert len(lines) == 4, out
    assert "`boundaries[0].nodes`: lists 10000000 nodes, more than the 121 nodes of the grid" in lines[0]
    assert "`boundaries[1].nodes`: lists 10000000 nodes, more than the 121 nodes of the grid" in lines[1]
    assert "`body` has 10000000 entries but 1 are required" in lines[2]
    # Refused from the lengths: nothing near the size of the lists was allocated (a copy of
    # ten million nodes, as values or as text, takes hundreds of MB).
    grown_kib = int(lines[3].split()[1])
    assert grown_kib < 64 * 1024, out


def test_node_list_within_the_grid_is_accepted():
    scene = copy.deepcopy(SCENE)
    bottom = np.arange(11)
    sim = mpm.Simulation.from_dict(dict(scene, boundaries=[{"nodes": bottom, "condition": "fixed"}]))
    assert sim.steps == 0
    with pytest.raises(mpm.MpmError, match="lists 122 nodes, more than the 121 nodes"):
        mpm.Simulation.from_dict(dict(scene, boundaries=[{"nodes": list(range(122)), "condition": "fixed"}]))


# 4. Ctrl-C stops a run between two steps.


def test_ctrl_c_stops_run():
    code = textwrap.dedent(
        """
        import signal
        import sys
        import numpy as np
        import sparse_mpm as mpm

        signal.signal(signal.SIGINT, signal.default_int_handler)
        grid = mpm.Grid([0.0, 0.0], [0.05, 0.05], [20, 20])
        x, y = (a.ravel() for a in np.meshgrid(np.arange(0.3, 0.7, 0.025), np.arange(0.3, 0.7, 0.025)))
        volume = np.full(x.size, 0.025**2)
        body = {"name": "b", "material": {"model": "neo_hookean", "youngs_modulus": 1e5, "poisson_ratio": 0.3}}
        # A block at rest, no loads: about a million steps (tens of seconds; the run keeps a
        # report row of 200 bytes per step, which `run` checks it has the memory for), so an
        # interrupt ends this run.
        sim = mpm.Simulation.from_arrays(
            grid, {"x": x, "y": y, "volume": volume, "mass": 1000.0 * volume}, [body],
            {"time": {"end": 2000.0}},
        )
        print("running", flush=True)
        try:
            sim.run()
        except KeyboardInterrupt:
            # Stopped between whole steps: the state is usable and the next step runs.
            steps, t = sim.steps, sim.time
            p = sim.particles()
            assert steps > 0 and 0.0 < t < 2000.0, (steps, t)
            assert all(np.all(np.isfinite(a)) for a in p.values())
            sim.step()
            assert sim.steps == steps + 1 and sim.time > t
            print("interrupted after", steps, "steps; consistent", flush=True)
            raise
        """
    )
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    child = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
    )
    try:
        ready, _, _ = select.select([child.stdout], [], [], 120.0)
        assert ready, "the child did not start its run"
        assert child.stdout.readline().strip() == "running"
        time.sleep(1.0)  # well inside the run
        assert child.poll() is None, "the run ended by itself"
        child.send_signal(signal.SIGINT)
        # Generous: the point is that it stops at all.
        out, err = child.communicate(timeout=60.0)
    except subprocess.TimeoutExpired:
        child.kill()
        child.communicate()
        pytest.fail("Ctrl-C did not stop Simulation.run within 60 s")
    finally:
        if child.poll() is None:
            child.kill()
            child.communicate()
    assert "KeyboardInterrupt" in err, err
    assert child.returncode != 0
    assert "consistent" in out, (out, err)


# 5. Arrays of physical quantities: real, finite, positive where physical, one per particle.


def _functions(ops, grid, p, bad, name):
    """The module's functions, `bad` given as the argument `name` and good values elsewhere."""
    n = ops.num_particles
    args = dict(m=np.ones(n), vx=np.zeros(n), vy=np.zeros(n), bx=np.zeros(n), by=np.zeros(n),
                volume=np.full(n, 0.1), sxx=np.zeros(n), syy=np.zeros(n), sxy=np.zeros(n))
    args[name] = bad
    a = args
    calls = {
        "m": [
            lambda: mpm.lumped_mass(ops, a["m"]),
            lambda: mpm.consistent_mass(ops, a["m"]),
            lambda: mpm.momentum(ops, a["m"], a["vx"], a["vy"]),
            lambda: mpm.external_force(ops, a["m"], a["bx"], a["by"]),
            lambda: mpm.mass_diagnostics(ops, a["m"]),
            lambda: mpm.critical_time_step(ops, a["m"], a["volume"], 1e4, 0.3),
        ],
        "vx": [lambda: mpm.momentum(ops, a["m"], a["vx"], a["vy"])],
        "vy": [lambda: mpm.momentum(ops, a["m"], a["vx"], a["vy"])],
        "bx": [lambda: mpm.external_force(ops, a["m"], a["bx"], a["by"])],
        "by": [lambda: mpm.external_force(ops, a["m"], a["bx"], a["by"])],
        "volume": [
            lambda: mpm.internal_force(ops, a["volume"], a["sxx"], a["syy"], a["sxy"]),
            lambda: mpm.critical_time_step(ops, a["m"], a["volume"], 1e4, 0.3),
        ],
        "sxx": [lambda: mpm.internal_force(ops, a["volume"], a["sxx"], a["syy"], a["sxy"])],
        "syy": [lambda: mpm.internal_force(ops, a["volume"], a["sxx"], a["syy"], a["sxy"])],
        "sxy": [lambda: mpm.internal_force(ops, a["volume"], a["sxx"], a["syy"], a["sxy"])],
    }
    return calls[name]


ARGUMENTS = ["m", "vx", "vy", "bx", "by", "volume", "sxx", "syy", "sxy"]


@pytest.mark.parametrize("name", ARGUMENTS)
def test_nan_mass_is_refused_naming_index(name):
    grid, p, ops = small_problem()
    for call in _functions(ops, grid, p, np.array([1.0, np.nan]), name):
        with pytest.raises(mpm.MpmError, match=rf"particle 1: `{name}` = NaN is invalid: values must be finite"):
            call()
    with pytest.raises(mpm.MpmError, match=r"particle 0: `mass` = NaN is invalid"):
        mpm.Particles([0.3, 0.6], [0.3, 0.7], [np.nan, 1.0], [0.1, 0.1])


@pytest.mark.parametrize("name", ARGUMENTS)
@pytest.mark.parametrize("value", [np.inf, -np.inf])
def test_infinite_value_is_refused_naming_argument_and_index(name, value):
    grid, p, ops = small_problem()
    shown = "inf" if value > 0 else "-inf"
    for call in _functions(ops, grid, p, np.array([1.0, value]), name):
        with pytest.raises(mpm.MpmError, match=rf"particle 1: `{name}` = {shown} is invalid"):
            call()


@pytest.mark.parametrize("name", ["m", "volume"])
@pytest.mark.parametrize("value", [-1.0, 0.0])
def test_negative_volume_is_refused(name, value):
    """Masses and volumes are positive; zero and negative ones are refused by every function."""
    grid, p, ops = small_problem()
    shown = "-1" if value < 0 else "0"
    for call in _functions(ops, grid, p, np.array([1.0, value]), name):
        with pytest.raises(mpm.MpmError, match=rf"particle 1: `{name}` = {shown} is invalid: must be positive"):
            call()
    field = {"m": "mass", "volume": "volume"}[name]
    arrays = dict(x=[0.3, 0.6], y=[0.3, 0.7], mass=[1.0, 1.0], volume=[0.1, 0.1])
    arrays[field] = [1.0, value]
    with pytest.raises(mpm.MpmError, match=rf"particle 1: `{field}` = {shown} is invalid: must be positive"):
        mpm.Particles(**arrays)


@pytest.mark.parametrize("name", ARGUMENTS)
def test_complex_array_is_refused(name):
    grid, p, ops = small_problem()
    for call in _functions(ops, grid, p, np.array([1.0, 1.0 + 0.5j]), name):
        with pytest.raises(TypeError, match=rf"^{name}: a complex array \(dtype complex128\) is refused"):
            call()
    # Even with a zero imaginary part: the dtype says what the values are.
    for call in _functions(ops, grid, p, np.ones(2, dtype=complex), name):
        with pytest.raises(TypeError, match=rf"^{name}: a complex array"):
            call()


def test_complex_array_is_refused_by_particles_grid_and_simulation():
    with pytest.raises(TypeError, match=r"^volume: a complex array"):
        mpm.Particles([0.3], [0.3], [1.0], [0.1 + 0j])
    with pytest.raises(TypeError, match=r"^sxy: a complex array"):
        mpm.Particles([0.3], [0.3], [1.0], [0.1], sxy=[1j])
    with pytest.raises(TypeError, match=r"^y_g: a complex array"):
        mpm.Grid.from_node_coordinates([0.0, 1.0, 0.0, 1.0], np.array([0, 0, 1, 1], dtype=np.complex64))
    grid = mpm.Grid([0.0, 0.0], [0.25, 0.25], [4, 4])
    body = {"name": "b", "material": {"model": "neo_hookean", "youngs_modulus": 1e5, "poisson_ratio": 0.3}}
    sim = mpm.Simulation.from_arrays(
        grid, {"x": [0.4, 0.6], "y": [0.4, 0.6], "mass": [1.0, 1.0], "volume": [0.01, 0.01]}, [body],
        {"time": {"end": 1.0}},
    )
    with pytest.raises(TypeError, match=r"^vx: a complex array"):
        sim.set_particle_state(vx=np.array([1.0, 2.0 + 1j]))


def test_other_dtypes_and_shapes_are_refused_naming_argument():
    grid, p, ops = small_problem()
    with pytest.raises(TypeError, match=r"^m: expected an array of real numbers .* found dtype bool"):
        mpm.lumped_mass(ops, [True, True])
    with pytest.raises(TypeError, match=r"^sxx: expected an array of real numbers .* found dtype <U"):
        mpm.internal_force(ops, [0.1, 0.1], ["1", "2"], [0, 0], [0, 0])
    with pytest.raises(TypeError, match=r"^vy: expected a 1-D array of real numbers"):
        mpm.momentum(ops, [1.0, 1.0], [0.0, 0.0], [0.0, [1.0]])
    with pytest.raises(mpm.MpmError, match=r"^m: expected a 1-D array, found one of shape \[2, 1\]"):
        mpm.lumped_mass(ops, np.ones((2, 1)))
    with pytest.raises(mpm.MpmError, match=r"body\[0\] = 0.5: particle 0 needs a body index"):
        mpm.Particles([0.3], [0.3], [1.0], [0.1], body=[0.5])


def test_wrong_length_is_refused_naming_both_lengths():
    grid, p, ops = small_problem()
    with pytest.raises(mpm.MpmError, match=r"`m` has 3 entries but 2 are required"):
        mpm.lumped_mass(ops, [1.0, 1.0, 1.0])
    with pytest.raises(mpm.MpmError, match=r"`sxy` has 1 entries but 2 are required"):
        mpm.internal_force(ops, [0.1, 0.1], [0.0, 0.0], [0.0, 0.0], [0.0])
    with pytest.raises(mpm.MpmError, match=r"`volume` has 3 entries but 2 are required"):
        mpm.critical_time_step(ops, [1.0, 1.0], [0.1, 0.1, 0.1], 1e4, 0.3)
    with pytest.raises(mpm.MpmError, match=r"`y` has 1 entries but 2 are required"):
        mpm.Particles([0.3, 0.6], [0.3], [1.0, 1.0], [0.1, 0.1])


def test_integer_arrays_are_taken_as_floats():
    grid, p, ops = small_problem()
    np.testing.assert_array_equal(mpm.lumped_mass(ops, [1, 2]), mpm.lumped_mass(ops, [1.0, 2.0]))
    np.testing.assert_array_equal(
        mpm.internal_force(ops, np.array([1, 1], dtype=np.uint8), [1, 2], [3, 4], [5, 6])[0],
        mpm.internal_force(ops, [1.0, 1.0], [1.0, 2.0], [3.0, 4.0], [5.0, 6.0])[0],
    )
    # float32 is real too (converted to float64).
    np.testing.assert_array_equal(
        mpm.lumped_mass(ops, np.array([1.0, 2.0], dtype=np.float32)), mpm.lumped_mass(ops, [1.0, 2.0])
    )


def test_oversized_scene_text_is_refused_before_parsing():
    text = "# padding\n" * (2 * 1024 * 1024)
    with pytest.raises(mpm.MpmError, match="more than the"):
        mpm.Simulation.from_toml(text)


def test_masses_on_the_largest_grid_are_refused_before_allocating_under_a_memory_limit():
    done = run_python(
        """
        import resource
        import sparse_mpm as mpm

        # 2.56e8 nodes (within the grid's limit of 2^28), one particle, 3 GB of address space:
        # the node arrays of the masses and their copies do not fit.
        resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))
        grid = mpm.Grid([0.0, 0.0], [0.001, 0.001], [16000, 16000])
        particles = mpm.Particles([0.5], [0.5], [1.0], [1e-6])
        ops = mpm.Operators.assemble(grid, particles)
        for name, call in (
            ("consistent", lambda: mpm.consistent_mass(ops, [1.0])),
            ("lumped", lambda: mpm.lumped_mass(ops, [1.0])),
        ):
            try:
                call()
            except mpm.MpmError as e:
                print(name, "refused:", e)
            else:
                print(name, "accepted")
        """
    )
    out = assert_child_ok(done)
    lines = out.splitlines()
    assert len(lines) == 2, out
    for line, name in zip(lines, ("consistent", "lumped")):
        assert line.startswith(f"{name} refused:") and "this process can have" in line, out
