"""Grid transfers, the explicit step, mass diagnostics and the critical time step from Python,
against `mpm homework --json` and SciPy products with N, Gx, Gy."""

import json

import numpy as np
import pytest
import scipy.sparse as sp

import sparse_mpm as mpm

# The seed problem (src/homework.rs): grid from node lists, four particles, plane stress.
X_G = [0.0, 0.0, 1.0, 1.0, 2.0, 2.0]
Y_G = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0]
SEED = dict(
    x=[1.2, 1.7, 1.3, 1.8],
    y=[0.75, 0.81, 0.26, 0.24],
    vx=[1.25, 1.1, 0.9, 0.8],
    vy=[0.25, 0.3, 0.33, 0.34],
    sxx=[-5.1, -4.7, -4.1, -3.5],
    syy=[-0.1, -0.2, -0.25, -0.3],
    sxy=[2.1, 2.2, 2.3, 2.5],
)
E, NU, DT = 100.0, 0.3, 0.001


def seed():
    grid = mpm.Grid.from_node_coordinates(X_G, Y_G)
    s = SEED
    particles = mpm.Particles(
        s["x"], s["y"], [1.0] * 4, [2.0] * 4, s["vx"], s["vy"],
        sxx=s["sxx"], syy=s["syy"], sxy=s["sxy"], bx=[5.0] * 4, by=[10.0] * 4,
    )
    return grid, particles


@pytest.fixture(scope="module")
def answers(run_mpm):
    return json.loads(run_mpm("homework", "--json"))


def close(actual, expected):
    np.testing.assert_allclose(actual, expected, rtol=1e-13, atol=1e-13)


def test_seed_forces_equal_homework(answers):
    grid, p = seed()
    ops = mpm.Operators.assemble(grid, p)
    fx, fy = mpm.external_force(ops, p.mass, p.bx, p.by)
    close(fx, answers["3A_external_force"]["x"])
    close(fy, answers["3A_external_force"]["y"])
    fx, fy = mpm.internal_force(ops, p.volume, p.sxx, p.syy, p.sxy)
    close(fx, answers["3B_internal_force"]["x"])
    close(fy, answers["3B_internal_force"]["y"])


def test_seed_step_equals_homework(answers):
    grid, p = seed()
    r = mpm.explicit_step(grid, p, E, NU, DT, position_update="trapezoidal")
    close(r["lumped_mass"], answers["2B_lumped_mass"])
    np.testing.assert_array_equal(r["active_nodes"] + 1, answers["active_nodes"])  # 1-based in the JSON
    for key, name in [
        ("3A_external_force", "external_force"),
        ("3B_internal_force", "internal_force"),
        ("3C_acceleration_lumped", "acceleration"),
        ("4A_grid_velocity", "grid_velocity"),
        ("4B_updated_grid_velocity", "updated_grid_velocity"),
    ]:
        close(r[f"{name}_x"], answers[key]["x"])
        close(r[f"{name}_y"], answers[key]["y"])
    for c in ("xx", "yy", "xy"):
        close(r[f"strain_rate_{c}"], answers["4E_strain_rate"][c])
    after = r["particles"]
    close(after.x, answers["4C_position_seed_rule"]["x"])
    close(after.y, answers["4C_position_seed_rule"]["y"])
    close(after.vx, answers["4D_velocity"]["x"])
    close(after.vy, answers["4D_velocity"]["y"])
    close(after.sxx, answers["4F_stress"]["xx"])
    close(after.syy, answers["4F_stress"]["yy"])
    close(after.sxy, answers["4F_stress"]["xy"])
    # The momentum of the record is q = N (m ∘ v) before the step; the input is unchanged.
    q = r["momentum_x"], r["momentum_y"]
    ops = r["operators"]
    np.testing.assert_array_equal(q, mpm.momentum(ops, p.mass, p.vx, p.vy))
    np.testing.assert_array_equal(p.x, SEED["x"])
    assert r["velocity_report"]["outcome"] == r["acceleration_report"]["outcome"] == "solved"
    assert r["acceleration_report"]["scheme"] == "lumped"
    # ε̇ = sym L.
    close(r["strain_rate_xy"], 0.5 * (r["velocity_gradient_xy"] + r["velocity_gradient_yx"]))
    close(r["strain_rate_xx"], r["velocity_gradient_xx"])
    # The standard position rule.
    std = mpm.explicit_step(grid, p, E, NU, DT)["particles"]
    close(std.x, answers["4C_position_standard"]["x"])
    close(std.y, answers["4C_position_standard"]["y"])


def test_consistent_step_acceleration_equals_homework(answers):
    # The homework's consistent acceleration uses the plain matrix; on the seed problem every
    # node of the support is well covered, so the default scheme gives the same result.
    grid, p = seed()
    r = mpm.explicit_step(grid, p, E, NU, DT, mass="consistent")
    np.testing.assert_allclose(r["acceleration_x"], answers["3C_acceleration_consistent"]["x"], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(r["acceleration_y"], answers["3C_acceleration_consistent"]["y"], rtol=1e-9, atol=1e-9)


def random_problem(seed_value=3, count=60):
    rng = np.random.default_rng(seed_value)
    grid = mpm.Grid([0.0, 0.0], [0.25, 0.5], [8, 4])
    x, y = rng.uniform(0.3, 1.7, count), rng.uniform(0.55, 1.45, count)
    m, vol = rng.uniform(0.5, 2.0, count), rng.uniform(0.01, 0.02, count)
    ops = mpm.Operators.assemble(grid, mpm.Particles(x, y, m, vol), shape="quadratic_bspline")
    return rng, ops, m, vol


def test_transfers_equal_scipy_products():
    rng, ops, m, vol = random_problem()
    vx, vy, bx, by = (rng.normal(size=m.size) for _ in range(4))
    sxx, syy, sxy = (rng.normal(size=m.size) for _ in range(3))
    n, gx, gy = ops.N, ops.Gx, ops.Gy
    qx, qy = mpm.momentum(ops, m, vx, vy)
    np.testing.assert_allclose(qx, n @ (m * vx), rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(qy, n @ (m * vy), rtol=1e-12, atol=1e-13)
    fx, fy = mpm.external_force(ops, m, bx, by)
    np.testing.assert_allclose(fx, n @ (m * bx), rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(fy, n @ (m * by), rtol=1e-12, atol=1e-13)
    fx, fy = mpm.internal_force(ops, vol, sxx, syy, sxy)
    np.testing.assert_allclose(fx, -(gx @ (vol * sxx) + gy @ (vol * sxy)), rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(fy, -(gx @ (vol * sxy) + gy @ (vol * syy)), rtol=1e-12, atol=1e-13)
    assert isinstance(qx, np.ndarray) and qx.shape == (ops.num_nodes,)


def test_mass_diagnostics_and_critical_time_step():
    _, ops, m, vol = random_problem()
    d = mpm.mass_diagnostics(ops, m)
    m_l = mpm.lumped_mass(ops, m)
    active = m_l > 0
    assert d["active_nodes"] == np.count_nonzero(active)
    assert d["max_nodal_mass"] == m_l.max()
    assert d["min_nodal_mass"] == m_l[active].min()
    assert 0.0 <= d["lambda_min_estimate"] <= 1.0
    assert d["condition_number"] >= 1.0
    consistent = mpm.mass_diagnostics(ops, m, mass="consistent")
    assert set(consistent) == set(d)
    # Δt_crit = 2/ω_max: shorter with the consistent mass, and ω_max ∝ √E.
    dt_lumped = mpm.critical_time_step(ops, m, vol, 1e4, 0.25)
    dt_series = mpm.critical_time_step(ops, m, vol, 1e4, 0.25, mass="series:2")
    dt_cons = mpm.critical_time_step(ops, m, vol, 1e4, 0.25, mass="consistent")
    assert 0 < dt_cons < dt_lumped and 0 < dt_series
    assert mpm.critical_time_step(ops, m, vol, 4e4, 0.25) == pytest.approx(dt_lumped / 2, rel=1e-6)


@pytest.mark.parametrize("scheme", ["lumped", "consistent", "blended:0.5", "series:3", "cg", "cg:1e-12"])
def test_mass_schemes_by_name(scheme):
    grid, p = seed()
    r = mpm.explicit_step(grid, p, E, NU, DT, mass=scheme)
    assert np.all(np.isfinite(r["acceleration_x"]))
    assert r["acceleration_report"]["outcome"] == "solved"


def test_bad_input_raises_mpm_error():
    grid, p = seed()
    ops = mpm.Operators.assemble(grid, p)
    cases = [
        (lambda: mpm.momentum(ops, p.mass, p.vx, [1.0]), "`vy` has 1 entries but 4 are required"),
        (lambda: mpm.external_force(ops, [1.0] * 3, p.bx, p.by), "`m` has 3 entries"),
        (lambda: mpm.internal_force(ops, p.volume, p.sxx, p.syy, []), "`sxy` has 0 entries"),
        (lambda: mpm.explicit_step(grid, p, E, NU, -1.0), "dt"),
        (lambda: mpm.explicit_step(grid, p, E, 0.6, DT), "oisson"),
        (lambda: mpm.explicit_step(grid, p, E, NU, DT, mass="diagonal"), "unknown mass scheme"),
        (lambda: mpm.explicit_step(grid, p, E, NU, DT, mass="blended:2"), "gamma"),
        (lambda: mpm.explicit_step(grid, p, E, NU, DT, mass="series:0"), "at least one term"),
        (lambda: mpm.explicit_step(grid, p, E, NU, DT, plane="shell"), "plane"),
        (lambda: mpm.explicit_step(grid, p, E, NU, DT, position_update="euler"), "position_update"),
        (lambda: mpm.mass_diagnostics(ops, [1.0]), "`m` has 1 entries"),
        (lambda: mpm.mass_diagnostics(ops, p.mass, mass="cg:2"), "tolerance"),
        (lambda: mpm.critical_time_step(ops, p.mass, [1.0], E, NU), "`volume` has 1 entries"),
        (lambda: mpm.critical_time_step(ops, p.mass, p.volume, -E, NU), "oung"),
        (lambda: mpm.Particles([0.5], [0.5], [1.0], [1.0], sxx=[1.0, 2.0]), "`sxx` has 2 entries"),
        (lambda: mpm.Particles([0.5], [0.5], [1.0], [1.0], by=[np.nan]), "by"),
    ]
    for make, message in cases:
        with pytest.raises(mpm.MpmError, match=message):
            make()
