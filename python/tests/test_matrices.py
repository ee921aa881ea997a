"""N, Gx, Gy, M and m_L from Python against the files `mpm matrices` writes, and their identities."""

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

import sparse_mpm as mpm

SCENES = ["seed_problem", "vibrating_bar", "two_disks", "block_in_box"]


@pytest.mark.parametrize("name", SCENES)
def test_matrices_equal_mpm_matrices(name, root, run_mpm, tmp_path):
    scene = root / "scenes" / f"{name}.toml"
    run_mpm("matrices", scene, "--out", tmp_path / "m")
    py = mpm.scene_matrices(scene)
    for key in ("N", "Gx", "Gy"):
        written = sp.csc_array(scipy.io.mmread(tmp_path / "m" / f"{key}.mtx"))
        assert isinstance(py[key], sp.csc_array)
        assert py[key].shape == written.shape
        assert abs(py[key] - written).max() == 0.0, key
    m_written = sp.csc_array(scipy.io.mmread(tmp_path / "m" / "M.mtx"))  # symmetric storage, expanded
    assert isinstance(py["M"], sp.csc_array)
    assert abs(py["M"] - m_written).max() == 0.0
    ml_written = np.asarray(scipy.io.mmread(tmp_path / "m" / "mL.mtx")).ravel()
    np.testing.assert_array_equal(py["mL"], ml_written)


@pytest.mark.parametrize("name", SCENES)
def test_identities(name, root):
    py = mpm.scene_matrices(root / "scenes" / f"{name}.toml")
    n, gx, gy, m_c, m_l = py["N"], py["Gx"], py["Gy"], py["M"], py["mL"]
    masses = py["particles"].mass
    # Columns of N sum to one (partition of unity); columns of Gx, Gy to zero.
    np.testing.assert_allclose(n.sum(axis=0), 1.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(gx.sum(axis=0), 0.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(gy.sum(axis=0), 0.0, rtol=0, atol=1e-9)
    # M = N diag(m) N^T, symmetric, rows summing to m_L = N m.
    expected = n @ sp.diags_array(masses) @ n.T
    assert abs(m_c - expected).max() <= 1e-12 * masses.max()
    assert abs(m_c - m_c.T).max() == 0.0
    np.testing.assert_allclose(m_c.sum(axis=1), m_l, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(n @ masses, m_l, rtol=1e-12, atol=1e-14)
    assert np.isclose(m_l.sum(), masses.sum(), rtol=1e-12)


def test_operators_from_arrays_match_rust_csc():
    grid = mpm.Grid([0.0, 0.0], [0.5, 0.25], [4, 8])
    rng = np.random.default_rng(1)
    x, y = rng.uniform(0.0, 2.0, 50), rng.uniform(0.0, 2.0, 50)
    particles = mpm.Particles(x, y, np.full(50, 0.1), np.full(50, 0.01))
    for shape in ("linear", {"gimp": {"half_width": 0.25}}):
        if shape != "linear":
            grid = mpm.Grid([-1.0, -1.0], [0.5, 0.25], [8, 16])
        ops = mpm.Operators.assemble(grid, particles, shape=shape)
        np.testing.assert_array_equal(ops.N.indptr, ops.col_offsets())
        np.testing.assert_array_equal(ops.N.indices, ops.row_indices())
        np.testing.assert_array_equal(ops.Gx.data, ops.values("Gx"))
        assert ops.N.shape == (grid.num_nodes, 50)
        assert ops.N.has_sorted_indices
        # The cached matrix is read-only; a copy of it is writeable and changes nothing in Rust.
        with pytest.raises(ValueError):
            ops.N.data[:] = 7.0
        changed = ops.N.copy()
        changed.data[:] = 7.0
        assert not np.any(ops.values("N") == 7.0) and not np.any(ops.N.data == 7.0)


def test_seed_problem_lumped_mass_equals_homework(run_mpm):
    import json

    answers = json.loads(run_mpm("homework", "--json"))
    x_g = [0.0, 0.0, 1.0, 1.0, 2.0, 2.0]
    y_g = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0]
    grid = mpm.Grid.from_node_coordinates(x_g, y_g)
    assert grid.node_order == "y_fastest"
    np.testing.assert_array_equal(grid.node_x(), answers["grid"]["x_g"])
    np.testing.assert_array_equal(grid.node_y(), answers["grid"]["y_g"])
    particles = mpm.Particles([1.2, 1.7, 1.3, 1.8], [0.75, 0.81, 0.26, 0.24], [1.0] * 4, [2.0] * 4)
    ops = mpm.Operators.assemble(grid, particles)
    np.testing.assert_allclose(ops.N.toarray(), answers["1D_N"], rtol=0, atol=1e-15)
    np.testing.assert_allclose(mpm.lumped_mass(ops, particles.mass), answers["2B_lumped_mass"], rtol=0, atol=1e-15)
    m_c = mpm.consistent_mass(ops, particles.mass).toarray()
    np.testing.assert_allclose(m_c, answers["2A_mass_matrix"], rtol=0, atol=1e-15)



def test_dispersion_matches_the_bilinear_reference_values_and_names_bad_input():
    import math

    theta, ratio = mpm.dispersion("linear", "consistent", cells=8)
    assert theta.shape == ratio.shape == (4,)
    np.testing.assert_allclose(theta, [math.pi / 4, math.pi / 2, 3 * math.pi / 4, math.pi], rtol=1e-14)
    np.testing.assert_allclose(ratio[[0, 1, 3]], [1.033, 1.139, 4 / math.pi], atol=1e-3)
    # the mixed pair is 2 sin(θ/2)/θ over the whole spectrum
    theta, mixed = mpm.dispersion("linear", "lumped", acceleration_mass="consistent", samples=50)
    np.testing.assert_allclose(mixed, 2 * np.sin(theta / 2) / theta, rtol=1e-12)
    _, lumped = mpm.dispersion({"gimp": {"half_width": 0.25}}, "lumped")
    assert (lumped < 1).all()
    with pytest.raises(mpm.MpmError, match="particles_per_cell"):
        mpm.dispersion("linear", "lumped", particles_per_cell=0)
    with pytest.raises(mpm.MpmError, match="mass"):
        mpm.dispersion("linear", "heavy")
