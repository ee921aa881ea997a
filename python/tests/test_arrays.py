"""Simulations from NumPy arrays, checkpoints and snapshots, particle state in and out,
read-only cached arrays, key-path errors of from_dict, and the package's namespace."""

import pathlib
import re
import timeit

import numpy as np
import pytest

import sparse_mpm as mpm

MATERIALS = [
    {"model": "linear_elastic", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "plane": "strain"},
    {"model": "neo_hookean", "youngs_modulus": 2.0e6, "poisson_ratio": 0.25},
]
DENSITY = [800.0, 1200.0]
OPTIONS = {
    "time": {"end": 0.05, "cfl": 0.4},
    "schemes": {"shape": "quadratic_bspline", "mass": {"velocity": "lumped", "acceleration": "lumped"}, "sort_interval": 7},
    "loads": {"gravity": [0.0, -9.81]},
    "boundaries": [{"edge": "bottom", "condition": "fixed"}, {"edge": "left", "condition": "slip"}],
    "output": {"snapshot_interval": 0.01},
}
GRID = dict(origin=[0.0, 0.0], cell_size=[0.1, 0.1], cells=[12, 10])


def two_bodies(seed=5):
    """Two blocks of particles at random in their cells, body 0 with masses, velocities and
    stresses of its own, body 1 with masses from its density (as a particle file without a
    mass column gets them)."""
    rng = np.random.default_rng(seed)
    bodies = []
    for k, (x0, y0) in enumerate([(0.25, 0.25), (0.65, 0.45)]):
        n = 60 + 10 * k
        x = rng.uniform(x0, x0 + 0.3, n)
        y = rng.uniform(y0, y0 + 0.3, n)
        volume = rng.uniform(0.8, 1.2, n) * 0.0025
        cols = {"x": x, "y": y, "volume": volume}
        if k == 0:
            cols.update(
                vx=rng.normal(0.0, 0.2, n), vy=rng.normal(0.0, 0.2, n), mass=volume * rng.uniform(700, 900, n),
                sxx=rng.normal(0, 10, n), syy=rng.normal(0, 10, n), sxy=rng.normal(0, 10, n),
            )
        bodies.append(cols)
    return bodies


def write_csv(path, cols):
    names = list(cols)
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        for row in zip(*(cols[k] for k in names)):
            f.write(",".join(repr(float(v)) for v in row) + "\n")  # repr: exact round trip


def scene_with_files(tmp_path, bodies):
    scene = dict(OPTIONS, grid=GRID, bodies=[])
    for k, cols in enumerate(bodies):
        write_csv(tmp_path / f"body{k}.csv", cols)
        scene["bodies"].append(
            {"name": f"b{k}", "material": MATERIALS[k], "density": DENSITY[k], "geometry": {"file": f"body{k}.csv"}}
        )
    return scene


def arrays_of(bodies):
    """The particle arrays of all bodies, as the scene builds them (masses from the density
    where the file has none)."""
    out = {key: [] for key in ("x", "y", "mass", "volume", "vx", "vy", "sxx", "syy", "sxy", "body")}
    for k, cols in enumerate(bodies):
        n = len(cols["x"])
        for key in out:
            if key == "body":
                out[key].append(np.full(n, k))
            elif key == "mass":
                out[key].append(cols["mass"] if "mass" in cols else DENSITY[k] * cols["volume"])
            else:
                out[key].append(cols.get(key, np.zeros(n)))
    return {key: np.concatenate(v) for key, v in out.items()}


def from_arrays(bodies, as_particles=True):
    arrays = arrays_of(bodies)
    particles = mpm.Particles(**arrays) if as_particles else arrays
    body_specs = [{"name": f"b{k}", "material": MATERIALS[k]} for k in range(len(bodies))]
    return mpm.Simulation.from_arrays(mpm.Grid(**GRID), particles, body_specs, OPTIONS)


def assert_same_state(a, b):
    pa, pb = a.particles(), b.particles()
    assert list(pa) == list(pb)
    for key in pa:
        np.testing.assert_array_equal(pa[key], pb[key], err_msg=key)
    np.testing.assert_array_equal(a.lumped_mass(), b.lumped_mass())
    for u, v in zip(a.grid_velocity(), b.grid_velocity()):
        np.testing.assert_array_equal(u, v)
    assert a.time == b.time and a.steps == b.steps


@pytest.mark.parametrize("as_particles", [True, False])
def test_from_arrays_equals_scene_with_particle_files(tmp_path, as_particles):
    bodies = two_bodies()
    from_files = mpm.Simulation.from_dict(scene_with_files(tmp_path, bodies), base_dir=tmp_path)
    arrays = from_arrays(bodies, as_particles)
    assert_same_state(from_files, arrays)  # before the first step
    report_files, report_arrays = from_files.run(0.03), arrays.run(0.03)
    assert len(report_files["step"]) > 14  # enough steps for two re-sorts (sort_interval 7)
    for key in mpm.REPORT_COLUMNS:
        np.testing.assert_array_equal(report_arrays[key], report_files[key], err_msg=key)
    assert_same_state(from_files, arrays)
    # Not a tautology: the particles moved, fell and changed their stresses.
    p, initial = arrays.particles(), arrays_of(bodies)
    order = np.argsort(p["id"])
    assert np.abs(p["y"][order] - initial["y"]).max() > 1e-4
    assert not np.array_equal(p["sxx"][order], initial["sxx"])
    assert arrays.end_time == 0.05 and arrays.land_every == 0.01


def test_from_arrays_errors_name_the_key_or_particle():
    bodies = two_bodies()
    arrays = arrays_of(bodies)
    grid = mpm.Grid(**GRID)
    good = [{"name": f"b{k}", "material": MATERIALS[k]} for k in range(2)]
    bad_nu = [good[0], {"name": "b1", "material": dict(MATERIALS[1], poisson_ratio=0.7)}]
    cases = [
        (lambda: mpm.Simulation.from_arrays(grid, arrays, bad_nu, OPTIONS), r"bodies\[1\]\.material\.poisson_ratio"),
        (lambda: mpm.Simulation.from_arrays(grid, arrays, [good[0], {"name": "b1", "material": {"model": "rubber"}}], OPTIONS), r"bodies\[1\]\.material"),
        (lambda: mpm.Simulation.from_arrays(grid, arrays, good[:1], OPTIONS), r"body\[60\] = 1: particle 60 names a body"),
        (lambda: mpm.Simulation.from_arrays(grid, arrays, [dict(good[0], velocity=[1, 0]), good[1]], OPTIONS), r"bodies\[0\]\.velocity"),
        (lambda: mpm.Simulation.from_arrays(grid, arrays, good, {"schemes": {}}), r"options\.time"),
        (lambda: mpm.Simulation.from_arrays(grid, arrays, good, dict(OPTIONS, time={"end": 1.0, "dt": -1.0})), r"time\.dt"),
        (lambda: mpm.Simulation.from_arrays(grid, arrays, good, dict(OPTIONS, schemes={"mass": {"velocity": "heavy"}})), r"schemes\.mass\.velocity"),
        (lambda: mpm.Simulation.from_arrays(grid, arrays, good, dict(OPTIONS, grid=GRID)), r"options\.grid"),
        (lambda: mpm.Simulation.from_arrays(grid, dict(arrays, x=arrays["x"] + 5.0), good, OPTIONS), r"particle 0 at"),
        (lambda: mpm.Simulation.from_arrays(grid, dict(arrays, vx=arrays["vx"][:3]), good, OPTIONS), r"`vx` has 3 entries but 130"),
        (lambda: mpm.Simulation.from_arrays(grid, dict(arrays, colour=arrays["x"]), good, OPTIONS), r"particles\['colour'\]"),
        (lambda: mpm.Simulation.from_arrays(grid, {"x": arrays["x"]}, good, OPTIONS), r"particles\['y'\]: missing"),
        (lambda: mpm.Simulation.from_arrays(grid, dict(arrays, body=-arrays["body"]), good, OPTIONS), r"body\[60\] = -1"),
    ]
    for make, message in cases:
        with pytest.raises(mpm.MpmError, match=message):
            make()


def test_from_arrays_has_no_scene_text():
    sim = from_arrays(two_bodies())
    with pytest.raises(mpm.MpmError, match="scene_toml"):
        sim.scene_toml()


def test_checkpoint_continues_bit_for_bit(tmp_path):
    reference = from_arrays(two_bodies())
    whole = reference.run(0.04)
    sim = from_arrays(two_bodies())
    for _ in range(9):  # stops between two landing times, as run(0.04) would step
        sim.step(max_dt=0.04 - sim.time)
    first = {key: whole[key][:9] for key in whole}
    sim.write_checkpoint(tmp_path / "state.ckpt")
    resumed = mpm.Simulation.from_checkpoint(tmp_path / "state.ckpt", end_time=0.04, land_every=sim.land_every)
    assert resumed.time == sim.time and resumed.steps == sim.steps
    assert_same_state(sim, resumed)
    rest = resumed.run()
    assert resumed.time == 0.04
    assert first["time"][-1] == sim.time - 0.0 and first["time"][-1] % 0.01 > 1e-6
    for key in mpm.REPORT_COLUMNS:
        np.testing.assert_array_equal(np.concatenate([first[key], rest[key]]), whole[key], err_msg=key)
    assert_same_state(reference, resumed)
    with pytest.raises(mpm.MpmError, match="no end time"):
        mpm.Simulation.from_checkpoint(tmp_path / "state.ckpt").run()
    (tmp_path / "junk.ckpt").write_bytes(b"not a checkpoint")
    with pytest.raises(mpm.MpmError, match="junk.ckpt"):
        mpm.Simulation.from_checkpoint(tmp_path / "junk.ckpt")


def test_snapshot_holds_the_particles(tmp_path):
    sim = from_arrays(two_bodies())
    sim.run(0.01)
    sim.write_snapshot(tmp_path / "p.vtp")
    text = (tmp_path / "p.vtp").read_text()
    p = sim.particles()
    assert f'NumberOfPoints="{len(p["x"])}"' in text
    for name in ("velocity", "stress", "mass", "J"):
        assert f'Name="{name}"' in text
    with pytest.raises(mpm.MpmError, match="no_such_dir"):
        sim.write_snapshot(tmp_path / "no_such_dir" / "p.vtp")


def test_grid_fields_of_the_last_step():
    sim = from_arrays(two_bodies())
    sim.step()
    g = sim.grid_fields()
    ops = sim.operators()
    p = sim.particles()
    # m_L = N m with the operators of the last step (the particles have moved since: the
    # operators are those the step assembled at the start of the step, as lumped_mass is).
    np.testing.assert_array_equal(g["mass"], sim.lumped_mass())
    assert g["mass"].shape == g["velocity_x"].shape == (sim.grid().num_nodes,)
    np.testing.assert_array_equal(g["active_nodes"], np.flatnonzero(g["mass"] > 0))
    assert abs(g["mass"].sum() - p["mass"].sum()) <= 1e-12 * p["mass"].sum()
    np.testing.assert_array_equal(g["momentum_x"], g["mass"] * g["velocity_x"])
    assert ops.num_particles == len(p["x"])


def test_set_particle_state_equals_building_with_it():
    bodies = two_bodies()
    rng = np.random.default_rng(9)
    a = from_arrays(bodies)
    p = a.particles()
    new = {k: rng.normal(size=len(p["x"])) for k in ("vx", "vy", "sxx", "syy", "sxy", "bx", "by")}
    a.set_particle_state(**new)
    after = a.particles()
    for k, v in new.items():
        np.testing.assert_array_equal(after[k], v, err_msg=k)
    # the same as building with these arrays (in the original particle order, by id)
    arrays = arrays_of(bodies)
    order = np.argsort(p["id"])
    for k, v in new.items():
        arrays[k] = v[order]
    built = mpm.Simulation.from_arrays(
        mpm.Grid(**GRID), arrays, [{"name": f"b{k}", "material": MATERIALS[k]} for k in range(2)], OPTIONS
    )
    ra, rb = a.run(0.01), built.run(0.01)
    for key in mpm.REPORT_COLUMNS:
        np.testing.assert_array_equal(ra[key], rb[key], err_msg=key)
    # body forces at any time, by particle in the current order
    bx = np.linspace(0.0, 1.0, len(p["x"]))
    a.set_particle_state(bx=bx)
    np.testing.assert_array_equal(a.particles()["bx"], bx)


def test_set_particle_state_errors_name_field_and_particle():
    sim = from_arrays(two_bodies())
    n = len(sim.particles()["x"])
    vx = np.zeros(n)
    vx[17] = np.inf
    cases = [
        (dict(vx=vx), r"vx\[17\] = inf: particle 17 \(id \d+\) must have a finite vx"),
        (dict(sxy=np.zeros(n - 1)), f"`sxy` has {n - 1} entries but {n} are required"),
        (dict(mass=np.ones(n)), "mass: not a particle field that can be set"),
        (dict(vy=[["a"]]), "vy: expected a 1-D array"),
    ]
    for fields, message in cases:
        with pytest.raises(mpm.MpmError, match=message):
            sim.set_particle_state(**fields)
    sim.step()
    # Between steps: set in place, with the same checks; a refused call changes nothing.
    before = sim.particles()
    with pytest.raises(mpm.MpmError, match=r"vx\[17\] = inf"):
        sim.set_particle_state(vx=vx)
    np.testing.assert_array_equal(sim.particles()["vx"], before["vx"])
    sim.set_particle_state(vx=np.full(n, 0.25), sxy=np.full(n, 3.0), by=np.full(n, -1.0))
    after = sim.particles()
    np.testing.assert_array_equal(after["vx"], np.full(n, 0.25))
    np.testing.assert_array_equal(after["sxy"], np.full(n, 3.0))
    np.testing.assert_array_equal(after["vy"], before["vy"])
    row = sim.step()
    # The step starts from the velocities set: the x momentum is near the total mass times 0.25
    # (one short step of the loads and walls changes it little), far from what it was.
    total = before["mass"].sum()
    assert abs(row["momentum_x"] - 0.25 * total) < 0.02 * 0.25 * total, (row["momentum_x"], 0.25 * total)
    assert abs(before["vx"] @ before["mass"] - 0.25 * total) > 0.1 * 0.25 * total


def test_cached_arrays_are_read_only_and_not_copied_per_access():
    n = 200_000
    x = np.linspace(0.1, 0.9, n)
    parts = mpm.Particles(x, x, np.ones(n), np.ones(n))
    assert parts.x is parts.x  # cached: the same object on every access
    for name in ("x", "y", "mass", "volume", "vx", "vy", "sxx", "syy", "sxy", "bx", "by", "body"):
        a = getattr(parts, name)
        assert not a.flags.writeable, name
        assert type(parts).__dict__[name].__doc__, name  # documented
    with pytest.raises(ValueError):
        parts.x[0] = 5.0
    np.testing.assert_array_equal(parts.x, x)
    # 1000 accesses cost about as little as 1000 attribute lookups, not 1000 copies of n floats.
    per_access = min(timeit.repeat(lambda: parts.x[5], number=1000, repeat=3)) / 1000
    copy = min(timeit.repeat(lambda: x.copy(), number=20, repeat=3)) / 20
    assert per_access < copy / 5, (per_access, copy)

    ops = mpm.Operators.assemble(mpm.Grid([0.0, 0.0], [0.25, 0.25], [4, 4]), mpm.Particles([0.3, 0.6], [0.3, 0.7], [1.0, 1.0], [0.1, 0.1]))
    for m in (ops.N, ops.Gx, ops.Gy):
        assert m is ops.matrix({id(ops.N): "N", id(ops.Gx): "Gx", id(ops.Gy): "Gy"}[id(m)])
        for a in (m.data, m.indices, m.indptr):
            assert not a.flags.writeable
    with pytest.raises(ValueError):
        ops.N.data[0] = 1.0
    writeable = ops.N.copy()
    writeable.data[0] = 7.0  # a copy is writeable and independent
    assert ops.N.data[0] != 7.0
    # the cached matrices still work with SciPy's products
    np.testing.assert_allclose((ops.N @ np.ones(2)).sum(), 2.0)
    np.testing.assert_allclose((ops.N.T @ ops.N).toarray(), ops.N.toarray().T @ ops.N.toarray())

    sim = from_arrays(two_bodies())
    p1, p2 = sim.particles(), sim.particles()
    assert p1["x"] is p2["x"] and not p1["x"].flags.writeable
    sim.step()
    p3 = sim.particles()
    assert p3["x"] is not p1["x"]  # a new state, new arrays
    assert not np.array_equal(p3["x"], p1["x"]) or not np.array_equal(p3["vy"], p1["vy"])


def test_version_and_namespace(root):
    cargo = (root / "python" / "Cargo.toml").read_text()
    version = re.search(r'^version = "([^"]+)"', cargo, re.M).group(1)
    assert mpm.__version__ == version
    pyproject = (root / "python" / "pyproject.toml").read_text()
    assert re.search(r'^version = "([^"]+)"', pyproject, re.M).group(1) == version
    public = dir(mpm)
    for name in ("np", "sp", "os", "numpy", "scipy", "typing", "annotations", "Any", "Dict"):
        assert name not in public, name
    for name in mpm.__all__:
        assert hasattr(mpm, name), name
    for name in dir(mpm.Operators):
        if not name.startswith("_"):
            assert getattr(mpm.Operators, name).__doc__, name


@pytest.mark.parametrize(
    "change, path",
    [
        (lambda s: s["bodies"][0]["material"].update(E=1.0), r"bodies\[0\]\.material\.E"),
        (lambda s: s["bodies"][0]["material"].update(youngs_modulus=-5.0), r"bodies\[0\]\.material\.youngs_modulus"),
        (lambda s: s["bodies"][0].update(density="heavy"), r"bodies\[0\]\.density"),
        (lambda s: s["bodies"][0]["geometry"]["rectangle"].update(min=[0.3]), r"bodies\[0\]\.geometry\.rectangle\.min"),
        (lambda s: s["grid"].update(cells=3), r"grid\.cells"),
        (lambda s: s["time"].update(colour="red"), r"time\.colour"),
        (lambda s: s["schemes"].update(mass={"velocity": "lumped", "acceleration": "heavy"}), r"schemes\.mass\.acceleration"),
        (lambda s: s.update(boundaries=[{"edge": "left", "condition": "glue"}]), r"boundaries\[0\]"),
        (lambda s: s["bodies"].append({"name": "b", "material": s["bodies"][0]["material"]}), r"bodies\[1\]"),
    ],
)
def test_from_dict_errors_name_the_key_path(change, path):
    scene = {
        "grid": {"origin": [0.0, 0.0], "cell_size": [0.1, 0.1], "cells": [10, 10]},
        "time": {"end": 0.05},
        "schemes": {"shape": "linear"},
        "bodies": [
            {
                "name": "block",
                "material": {"model": "linear_elastic", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3},
                "density": 1000.0,
                "geometry": {"rectangle": {"min": [0.3, 0.3], "max": [0.7, 0.7]}},
            }
        ],
        "execution": {},  # an empty table after the arrays of tables
    }
    mpm.Simulation.from_dict(scene)  # the scene itself is good
    change(scene)
    with pytest.raises(mpm.MpmError, match=path) as err:
        mpm.Simulation.from_dict(scene)
    assert "line" not in str(err.value)


@pytest.mark.parametrize("name", ["seed_problem", "vibrating_bar", "two_disks", "block_in_box", "cantilever"])
def test_from_dict_of_each_shipped_scene_equals_the_file(root, name):
    tomllib = pytest.importorskip("tomllib")
    path = root / "scenes" / f"{name}.toml"
    scene = tomllib.loads(path.read_text())
    from_file = mpm.Simulation.from_scene(path, allow_large=True)
    from_dict = mpm.Simulation.from_dict(scene, base_dir=root / "scenes", allow_large=True)
    assert from_dict.scene_toml() == from_file.scene_toml()
    assert_same_state(from_file, from_dict)
