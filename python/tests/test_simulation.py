"""Simulations from Python against `mpm run`, and errors raised as sparse_mpm.MpmError."""

import csv

import numpy as np
import pytest

import sparse_mpm as mpm


def read_report(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    table = np.array([[float(v) for v in row] for row in body])
    return {name: table[:, k] for k, name in enumerate(header)}


@pytest.mark.parametrize("name", ["seed_problem", "vibrating_bar", "two_disks", "two_disks_contact"])
def test_run_equals_mpm_run_report(name, root, run_mpm, tmp_path):
    scene = root / "scenes" / f"{name}.toml"
    run_mpm("run", scene, "--out", tmp_path / "run")
    expected = read_report(tmp_path / "run" / "report.csv")
    sim = mpm.Simulation.from_scene(scene)
    report = sim.run()
    assert list(report) == list(mpm.REPORT_COLUMNS) == list(expected)
    for key in expected:
        np.testing.assert_array_equal(report[key], expected[key], err_msg=key)
    assert sim.steps == len(expected["step"])
    assert sim.time == expected["time"][-1]


@pytest.mark.parametrize("mass, end", [("lumped", 0.3), ("consistent", 0.15)])
def test_contact_from_a_dict(mass, end):
    """A block on a rigid ramp under tilted gravity slides at g (sin θ − μ cos θ), with the
    lumped mass and with the consistent one (the contact impulses solved through the block's
    mass, its own stabilised as [contact] says)."""
    theta, mu, g = np.radians(30.0), 0.3, 9.81
    elastic = {"model": "linear_elastic", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "plane": "strain"}
    scene = {
        "grid": {"origin": [0.0, 0.0], "cell_size": [0.01, 0.01], "cells": [60, 20]},
        "schemes": {"mass": {"velocity": mass, "acceleration": mass}},
        "time": {"end": end, "cfl": 0.4},
        "loads": {"gravity": [g * np.sin(theta), -g * np.cos(theta)]},
        "bodies": [
            {"name": "block", "material": elastic, "density": 1000.0,
             "geometry": {"rectangle": {"min": [0.05, 0.05], "max": [0.15, 0.1]}}},
            {"name": "ramp", "material": elastic, "density": 1000.0,
             "geometry": {"rectangle": {"min": [0.0, 0.0], "max": [0.6, 0.05]}}},
        ],
        "contact": {"friction": mu, "rigid": ["ramp"], "stabilization": "partial_lumping"},
    }
    sim = mpm.Simulation.from_dict(scene)
    p = sim.particles()
    block = p["body"] == 0
    x0 = (p["mass"] * p["x"])[block].sum() / p["mass"][block].sum()
    report = sim.run()
    p = sim.particles()
    x1 = (p["mass"] * p["x"])[block].sum() / p["mass"][block].sum()
    exact = 0.5 * g * (np.sin(theta) - mu * np.cos(theta)) * sim.time**2
    assert abs((x1 - x0) - exact) < 0.02 * exact
    assert report["contact_force"][-1] > 0 and report["friction_dissipation"][-1] > 0
    with pytest.raises(mpm.MpmError, match="contact.rigid"):
        mpm.Simulation.from_dict({**scene, "contact": {"rigid": ["floor"]}})
    with pytest.raises(mpm.MpmError, match="stabilization"):
        mpm.Simulation.from_dict({**scene, "contact": {"rigid": ["ramp"], "stabilization": "ghost"}})


def test_a_plastic_column_from_a_dict():
    """A Drucker-Prager column released from its geostatic stress: the particles carry their
    plastic state, the report its plastic dissipation, and the energy balance holds; bad
    plastic parameters are refused by name."""
    sand = {"model": "drucker_prager", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "friction_angle": 30.0}
    scene = {
        "grid": {"origin": [-0.01, -0.01], "cell_size": [0.01, 0.01], "cells": [40, 14]},
        "schemes": {"shape": "quadratic_bspline", "transfer": "apic"},
        "time": {"end": 0.1, "cfl": 0.4},
        "loads": {"gravity": [0.0, -9.81]},
        "bodies": [{"name": "sand", "material": sand, "density": 1500.0, "initial_stress": "geostatic",
                    "geometry": {"rectangle": {"min": [0.0, 0.0], "max": [0.1, 0.1]}}}],
        "boundaries": [{"edge": "left", "condition": "slip"}, {"edge": "bottom", "condition": "fixed"}],
    }
    sim = mpm.Simulation.from_dict(scene)
    p = sim.particles()
    # The geostatic stress: the weight above each particle.
    np.testing.assert_allclose(p["syy"], -1500.0 * 9.81 * (0.1 - p["y"]), rtol=1e-12, atol=1e-9)
    assert np.all(p["plastic_strain"] == 0.0)
    report = sim.run()
    p = sim.particles()
    assert p["plastic_strain"].max() > 0.0
    assert report["plastic_dissipation"][-1] > 0.0
    balance = report["total_energy"] + report["plastic_dissipation"] + report["transfer_loss"]
    released = report["potential_energy"][0] - report["potential_energy"][-1]
    assert released > 0.0 and abs(balance[-1] - balance[0]) < 0.05 * released
    for key, value in [("friction_angle", 95.0), ("dilatancy_angle", 40.0), ("cohesion", -1.0)]:
        bad = {**scene, "bodies": [{**scene["bodies"][0], "material": {**sand, key: value}}]}
        with pytest.raises(mpm.MpmError, match=key):
            mpm.Simulation.from_dict(bad)


def test_step_by_step_equals_run(root):
    scene = root / "scenes" / "vibrating_bar.toml"
    whole = mpm.Simulation.from_scene(scene).run(2.0)
    sim = mpm.Simulation.from_scene(scene)
    rows = []
    while sim.time < 2.0 * (1 - 1e-12):
        rows.append(sim.step(max_dt=2.0 - sim.time))
    assert isinstance(rows[0]["step"], int)
    for key in mpm.REPORT_COLUMNS:
        np.testing.assert_array_equal([r[key] for r in rows], whole[key], err_msg=key)


def test_scene_from_dict_and_toml(root):
    text = (root / "scenes" / "seed_problem.toml").read_text()
    from_text = mpm.Simulation.from_toml(text, base_dir=root / "scenes")
    scene = {
        "grid": {"origin": [0.0, 0.0], "cell_size": [0.1, 0.1], "cells": [10, 10]},
        "time": {"end": 0.05},
        "loads": {"gravity": [0.0, -9.81]},
        "bodies": [
            {
                "name": "block",
                "material": {"model": "neo_hookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3},
                "density": 1000.0,
                "geometry": {"rectangle": {"min": [0.3, 0.3], "max": [0.7, 0.7]}},
            }
        ],
    }
    sim = mpm.Simulation.from_dict(scene)
    assert sim.stable_time_step() > 0
    report = sim.run()
    p = sim.particles()
    vy = (p["mass"] * p["vy"]).sum() / p["mass"].sum()
    assert abs(vy - (-9.81 * sim.time)) < 1e-9  # free fall: v = g t
    assert np.all(np.diff(report["time"]) > 0)
    assert from_text.run()["step"][-1] == 1


def test_particle_outside_grid_names_the_particle():
    grid = mpm.Grid([0.0, 0.0], [1.0, 1.0], [2, 1])
    particles = mpm.Particles([0.5, 2.5], [0.5, 0.5], [1.0, 1.0], [1.0, 1.0])
    with pytest.raises(mpm.MpmError, match=r"particle 1 at \(2.5, 0.5\) lies outside the grid"):
        mpm.Operators.assemble(grid, particles)
    assert issubclass(mpm.MpmError, ValueError)


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: mpm.Grid([0.0, 0.0], [0.0, 1.0], [2, 1]), "cell size along x"),
        (lambda: mpm.Grid([0.0, 0.0], [1.0, 1.0], [-1, 1]), "at least one cell along x"),
        (lambda: mpm.Grid([0.0, 0.0], [1.0, 1.0], [10**6, 10**6]), "more than"),
        (lambda: mpm.Grid.from_node_coordinates([0.0, 1.0, 3.0], [0.0, 0.0, 0.0]), "do not form a uniform grid"),
        (lambda: mpm.Particles([0.5], [0.5], [-1.0], [1.0]), "mass"),
        (lambda: mpm.Particles([0.5, 1.0], [0.5], [1.0], [1.0]), "`y` has 1 entries but 2 are required"),
        (lambda: mpm.Particles([np.nan], [0.5], [1.0], [1.0]), "x"),
        (lambda: mpm.Particles([0.5], [0.5], [1.0], [1.0], vx=[1.0, 2.0]), "`vx` has 2 entries but 1"),
        (lambda: mpm.Simulation.from_toml("[grid]\ncells = 3"), "line 2, cells.*expected an array of length 2"),
        (lambda: mpm.Simulation.from_dict({"grid": {"cells": [2, 2]}, "time": {"end": object()}}), "no TOML form"),
        (lambda: mpm.Simulation.from_scene("no/such/scene.toml"), "no/such/scene.toml"),
    ],
)
def test_bad_input_raises_mpm_error(make, message):
    with pytest.raises(mpm.MpmError, match=message):
        make()


def test_bad_shape_and_masses():
    grid = mpm.Grid([0.0, 0.0], [1.0, 1.0], [2, 1])
    particles = mpm.Particles([0.5], [0.5], [1.0], [1.0])
    with pytest.raises(mpm.MpmError, match="shape"):
        mpm.Operators.assemble(grid, particles, shape="cubic")
    with pytest.raises(mpm.MpmError, match="half_width"):
        mpm.Operators.assemble(grid, particles, shape={"gimp": {"half_width": 2.0}})
    ops = mpm.Operators.assemble(grid, particles)
    with pytest.raises(mpm.MpmError, match="`m` has 2 entries but 1 are required"):
        mpm.lumped_mass(ops, [1.0, 2.0])
    with pytest.raises(mpm.MpmError, match="`m` has 0 entries but 1 are required"):
        mpm.consistent_mass(ops, [])
    with pytest.raises(mpm.MpmError, match="operator"):
        ops.matrix("Gz")


def test_failed_step_is_reported(root):
    sim = mpm.Simulation.from_scene(root / "scenes" / "seed_problem.toml")
    with pytest.raises(mpm.MpmError, match="until"):
        sim.run(float("inf"))
    with pytest.raises(mpm.MpmError, match="max_dt"):
        sim.step(max_dt=-1.0)


def test_example_script_runs(root, tmp_path):
    import subprocess
    import sys

    out = tmp_path / "bar.png"
    done = subprocess.run(
        [sys.executable, str(root / "python" / "examples" / "seed_and_bar.py"), "--out", str(out)],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    assert "m_L = N m: [0.    0.    0.927 1.073 1.013 0.987]" in done.stdout
    assert "consistent" in done.stdout
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        assert "no plot" in done.stdout
    else:  # the two panels: velocities, and the error on a log scale
        assert out.stat().st_size > 10_000 and f"plot saved to {out}" in done.stdout


def test_a_scene_dict_selects_the_newmark_integrator():
    scene = {
        "grid": {"origin": [0.0, 0.0], "cell_size": [0.1, 0.1], "cells": [10, 10]},
        "schemes": {
            "mass": {"velocity": "consistent", "acceleration": "consistent"},
            "integrator": {"newmark": {"beta": 0.25, "gamma": 0.5}},
        },
        "time": {"end": 0.02, "dt": 0.01},
        "loads": {"gravity": [0.0, -9.81]},
        "bodies": [
            {
                "name": "block",
                "material": {"model": "neo_hookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3},
                "density": 1000.0,
                "geometry": {"rectangle": {"min": [0.3, 0.3], "max": [0.7, 0.7]}},
            }
        ],
    }
    sim = mpm.Simulation.from_dict(scene)
    report = sim.step()
    assert report["dt"] == 0.01, "a fixed step far above the explicit stable step"
    assert report["acceleration_residual"] <= 1e-10
    scene["time"] = {"end": 0.02, "cfl": 0.5}
    with pytest.raises(mpm.MpmError, match="schemes.integrator"):
        mpm.Simulation.from_dict(scene)
    # A step too short for the clock is refused, changes nothing, and the run goes on.
    scene["time"] = {"end": 0.1, "dt": 0.01}
    sim = mpm.Simulation.from_dict(scene)
    sim.step()
    x = sim.particles()["x"].copy()
    with pytest.raises(mpm.MpmError, match="too short"):
        sim.step(max_dt=1e-20)
    assert np.array_equal(sim.particles()["x"], x)
    assert sim.step()["step"] == 2
    # The truncated series has no place in the Newmark acceleration solve: named as the key.
    scene["schemes"]["mass"] = {"velocity": "consistent", "acceleration": "series:2"}
    with pytest.raises(mpm.MpmError, match="schemes.mass.acceleration"):
        mpm.Simulation.from_dict(scene)


def _column_dict(integrator=None, damping=None):
    scene = {
        "grid": {"origin": [0.0, 0.0], "cell_size": [0.25, 0.25], "cells": [8, 12]},
        "schemes": {"shape": "linear"},
        "time": {"end": 1.0},
        "loads": {"gravity": [0.0, -10.0]},
        "bodies": [
            {
                "name": "column",
                "material": {"model": "neo_hookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.0},
                "density": 80.0,
                "geometry": {"rectangle": {"min": [0.5, 0.0], "max": [1.5, 2.0]}},
            }
        ],
        "boundaries": [
            {"edge": "bottom", "condition": "fixed"},
            {"edge": "left", "condition": "slip"},
            {"edge": "right", "condition": "slip"},
        ],
    }
    if integrator is not None:
        scene["schemes"]["integrator"] = integrator
    if damping is not None:
        scene["loads"]["damping"] = damping
    return scene


def test_a_scene_dict_selects_the_quasi_static_integrator_and_damping():
    sim = mpm.Simulation.from_dict(_column_dict(integrator={"quasi_static": {"load_steps": 4}}))
    reports = [sim.step() for _ in range(4)]
    assert [r["dt"] for r in reports] == [0.25] * 4, "time.end / load_steps"
    assert all(r["acceleration_residual"] <= 1e-10 and r["kinetic_energy"] == 0.0 for r in reports)
    assert reports[-1]["strain_energy"] > 3.9 * reports[1]["strain_energy"]
    bad = _column_dict(integrator={"quasi_static": {"load_steps": 4}})
    bad["time"]["dt"] = 0.1
    with pytest.raises(mpm.MpmError, match="time.dt"):
        mpm.Simulation.from_dict(bad)
    damped = mpm.Simulation.from_dict(_column_dict(damping={"model": "local", "alpha": 0.8}))
    report = damped.step()
    assert "damping_work" in report and "settled" in report
    with pytest.raises(mpm.MpmError, match="loads.damping"):
        mpm.Simulation.from_dict(_column_dict(damping={"model": "local", "alpha": 1.5}))


def test_overrides_change_a_scene_as_an_edit_of_its_text_would():
    """``overrides`` of ``from_toml`` give the particles and the run of the edited text; a bad
    key is refused by name."""
    text = """
[grid]
origin = [-0.25, -0.25]
cell_size = [0.25, 0.25]
cells = [12, 8]

[schemes]
shape = "quadratic_bspline"

[time]
end = 0.02

[loads]
gravity = [0.0, -10.0]

[[bodies]]
name = "ring"
material = { model = "neo_hookean", youngs_modulus = 1.0e5, poisson_ratio = 0.3 }
density = 1000.0
geometry = { annulus = { center = [1.0, 0.75], inner_radius = 0.3, outer_radius = 0.6 } }
"""
    edited = text.replace("density = 1000.0", "density = 800.0\nsampling = \"poisson_disk\"\nseed = 3")
    a = mpm.Simulation.from_toml(
        text, overrides=["bodies[0].density=800.0", "bodies[0].sampling=poisson_disk", "bodies[0].seed=3"]
    )
    b = mpm.Simulation.from_toml(edited)
    ra, rb = a.run(), b.run()
    for key in ["x", "y", "mass", "volume", "vx", "vy"]:
        np.testing.assert_array_equal(a.particles()[key], b.particles()[key])
    np.testing.assert_array_equal(ra["total_energy"], rb["total_energy"])
    with pytest.raises(mpm.MpmError, match="densty"):
        mpm.Simulation.from_toml(text, overrides=["bodies[0].densty=1"])
