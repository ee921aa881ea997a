//! One explicit step against an independent dense implementation written here, invariants
//! of the step (rigid translation, free fall), and input validation (step, particles,
//! material).

mod common;

use common::*;
use nalgebra::{DMatrix, DVector};
use sparse_mpm::mass::{MassOptions, MassScheme, SolveOutcome};
use sparse_mpm::material::{LinearElastic, PlaneCondition};
use sparse_mpm::step::{explicit_step, PositionUpdate, StepOptions, StepRecord};
use sparse_mpm::{Grid, MpmError, NodeOrder, Particles};

/// The library's documented default: a node is active when `m_L > 1e-12 · max m_L`.
const ACTIVE_TOL: f64 = 1e-12;
/// Agreement of the library's step with the dense step, relative to the largest magnitude of
/// each compared quantity. Both evaluate the same formulas in different summation orders (and,
/// for the consistent mass, with different factorizations of a matrix with condition ≲ 1e3),
/// so differences are ~1e-13 relative; a wrong term or sign would be O(1).
const STEP_REL_TOL: f64 = 1e-9;
/// Young's modulus and Poisson's ratio of the test material.
const YOUNG: f64 = 1.0e3;
const POISSON: f64 = 0.3;
/// Time step: small enough that particles stay inside the grid after one step.
const DT: f64 = 1.0e-3;

/// Dense quantities of one step, from the reference.
struct RefStep {
    lumped: DVector<f64>,
    active: Vec<usize>,
    momentum: [DVector<f64>; 2],
    external_force: [DVector<f64>; 2],
    internal_force: [DVector<f64>; 2],
    acceleration: [DVector<f64>; 2],
    grid_velocity: [DVector<f64>; 2],
    updated_grid_velocity: [DVector<f64>; 2],
    /// `[Lxx, Lxy, Lyx, Lyy]` with `Lab = ∂v_a/∂x_b`.
    velocity_gradient: [DVector<f64>; 4],
    /// `[ε̇xx, ε̇yy, ε̇xy]`.
    strain_rate: [DVector<f64>; 3],
    /// The particles after the step.
    after: Particles,
}

/// In-plane stiffness `(C11, C12)` and shear modulus, written from the textbook formulas.
fn stiffness(e: f64, nu: f64, plane: PlaneCondition) -> (f64, f64, f64) {
    let g = e / (2.0 * (1.0 + nu));
    match plane {
        PlaneCondition::Stress => (e / (1.0 - nu * nu), nu * e / (1.0 - nu * nu), g),
        PlaneCondition::Strain => {
            let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
            (lambda + 2.0 * g, lambda, g)
        }
    }
}

/// An explicit USL step with FLIP velocity update, with dense matrices throughout.
fn reference_step(
    grid: &Grid,
    p: &Particles,
    plane: PlaneCondition,
    dt: f64,
    mass: MassScheme,
    position_update: PositionUpdate,
) -> RefStep {
    let ops = ref_operators(grid, &p.x, &p.y);
    let (n, gx, gy) = (&ops.n, &ops.gx, &ops.gy);
    let m = dvec(&p.mass);
    let vol = dvec(&p.volume);
    let lumped = n * &m;
    let max = lumped.max();
    let active: Vec<usize> = (0..lumped.len()).filter(|&i| lumped[i] > ACTIVE_TOL * max).collect();
    let q = [n * m.component_mul(&dvec(&p.vx)), n * m.component_mul(&dvec(&p.vy))];
    let f_ext = [n * m.component_mul(&dvec(&p.bx)), n * m.component_mul(&dvec(&p.by))];
    let (txx, tyy, txy) = (
        vol.component_mul(&dvec(&p.sxx)),
        vol.component_mul(&dvec(&p.syy)),
        vol.component_mul(&dvec(&p.sxy)),
    );
    let f_int = [-(gx * &txx + gy * &txy), -(gx * &txy + gy * &tyy)];

    let consistent = DMatrix::from_diagonal(&m);
    let consistent = n * consistent * n.transpose();
    let m_aa = consistent.select_rows(active.iter()).select_columns(active.iter());
    let d_aa = DVector::from_iterator(active.len(), active.iter().map(|&i| lumped[i]));
    let dense_solve = |matrix: DMatrix<f64>, r_a: &DVector<f64>| {
        matrix
            .cholesky()
            .expect("the solved matrix is positive definite")
            .solve(r_a)
    };
    let solve = |r: &DVector<f64>| -> DVector<f64> {
        let r_a = DVector::from_iterator(active.len(), active.iter().map(|&i| r[i]));
        let x_a = match mass {
            MassScheme::Lumped => r_a.component_div(&d_aa),
            // CG converged far below the comparison tolerance equals the direct solve.
            MassScheme::Consistent | MassScheme::Iterative { .. } => dense_solve(m_aa.clone(), &r_a),
            MassScheme::Blended { gamma } => {
                dense_solve(DMatrix::from_diagonal(&d_aa) * (1.0 - gamma) + &m_aa * gamma, &r_a)
            }
            // u = Σ_{l<k} (I − M_L⁻¹ M)^l M_L⁻¹ r
            MassScheme::TruncatedSeries { k } => {
                let mut term = r_a.component_div(&d_aa);
                let mut sum = term.clone();
                for _ in 1..k {
                    term = &term - (&m_aa * &term).component_div(&d_aa);
                    sum += &term;
                }
                sum
            }
        };
        let mut out = DVector::zeros(r.len());
        for (k, &i) in active.iter().enumerate() {
            out[i] = x_a[k];
        }
        out
    };
    let a = [solve(&(&f_ext[0] + &f_int[0])), solve(&(&f_ext[1] + &f_int[1]))];
    let v = [solve(&q[0]), solve(&q[1])];
    let mut v_new = [&v[0] + dt * &a[0], &v[1] + dt * &a[1]];

    let nt = n.transpose();
    // (8b) An inactive node in some particle's support (the particle's cell) takes the mean of
    // Nᵀ v̄′ over the particles whose cell has it.
    let interpolated = [&nt * &v_new[0], &nt * &v_new[1]];
    let supports: Vec<Vec<usize>> = (0..p.len()).map(|k| ref_support(grid, p.x[k], p.y[k])).collect();
    for i in (0..lumped.len()).filter(|i| !active.contains(i)) {
        let touching: Vec<usize> = (0..p.len()).filter(|&k| supports[k].contains(&i)).collect();
        if !touching.is_empty() {
            for c in 0..2 {
                v_new[c][i] = touching.iter().map(|&k| interpolated[c][k]).sum::<f64>() / touching.len() as f64;
            }
        }
    }
    let mut after = p.clone();
    let (vpx, vpy) = (&nt * &v_new[0], &nt * &v_new[1]);
    for k in 0..p.len() {
        match position_update {
            PositionUpdate::GridVelocity => {
                after.x[k] = p.x[k] + dt * vpx[k];
                after.y[k] = p.y[k] + dt * vpy[k];
            }
            PositionUpdate::Trapezoidal => {
                after.x[k] = p.x[k] + 0.5 * dt * (p.vx[k] + vpx[k]);
                after.y[k] = p.y[k] + 0.5 * dt * (p.vy[k] + vpy[k]);
            }
        }
    }
    let (apx, apy) = (&nt * &a[0], &nt * &a[1]);
    let l = [
        gx.transpose() * &v_new[0],
        gy.transpose() * &v_new[0],
        gx.transpose() * &v_new[1],
        gy.transpose() * &v_new[1],
    ];
    let rate = [l[0].clone(), l[3].clone(), 0.5 * (&l[1] + &l[2])];
    let (c11, c12, g) = stiffness(YOUNG, POISSON, plane);
    for k in 0..p.len() {
        after.vx[k] = p.vx[k] + dt * apx[k];
        after.vy[k] = p.vy[k] + dt * apy[k];
        let (exx, eyy, exy) = (rate[0][k] * dt, rate[1][k] * dt, rate[2][k] * dt);
        after.sxx[k] = p.sxx[k] + c11 * exx + c12 * eyy;
        after.syy[k] = p.syy[k] + c12 * exx + c11 * eyy;
        after.sxy[k] = p.sxy[k] + 2.0 * g * exy;
        // V det(I + Δt L), L = [[Lxx, Lxy], [Lyx, Lyy]] = [[l0, l1], [l2, l3]].
        after.volume[k] = p.volume[k] * ((1.0 + dt * l[0][k]) * (1.0 + dt * l[3][k]) - dt * dt * l[1][k] * l[2][k]);
    }
    RefStep {
        lumped,
        active,
        momentum: q,
        external_force: f_ext,
        internal_force: f_int,
        acceleration: a,
        grid_velocity: v,
        updated_grid_velocity: v_new,
        velocity_gradient: l,
        strain_rate: rate,
        after,
    }
}

fn material(plane: PlaneCondition) -> LinearElastic {
    LinearElastic::new(YOUNG, POISSON, plane).unwrap()
}

fn options(mass: MassScheme, position_update: PositionUpdate) -> StepOptions {
    StepOptions {
        dt: DT,
        mass: MassOptions::plain(mass),
        position_update,
        ..StepOptions::default()
    }
}

fn assert_close(name: &str, got: &[f64], expected: &[f64]) {
    let scale = expected
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    let diff = max_abs_diff_slice(got, expected);
    assert!(
        diff <= STEP_REL_TOL * scale,
        "{name}: differs by {diff} (scale {scale})\n got {got:?}\nwant {expected:?}"
    );
}

/// Compares every field of a step record and the updated particles with the reference.
fn compare(record: &StepRecord, after: &Particles, r: &RefStep) {
    assert_close("lumped mass", record.mass.lumped(), r.lumped.as_slice());
    assert_eq!(record.mass.active_nodes(), r.active, "active nodes");
    let pairs = [
        ("momentum", &record.momentum, &r.momentum),
        ("external force", &record.external_force, &r.external_force),
        ("internal force", &record.internal_force, &r.internal_force),
        ("acceleration", &record.acceleration, &r.acceleration),
        ("grid velocity", &record.grid_velocity, &r.grid_velocity),
        (
            "updated grid velocity",
            &record.updated_grid_velocity,
            &r.updated_grid_velocity,
        ),
    ];
    for (name, got, want) in pairs {
        assert_close(&format!("{name} x"), &got.x, want[0].as_slice());
        assert_close(&format!("{name} y"), &got.y, want[1].as_slice());
    }
    let l = &record.velocity_gradient;
    for (name, got, want) in [
        ("Lxx", &l.xx, &r.velocity_gradient[0]),
        ("Lxy", &l.xy, &r.velocity_gradient[1]),
        ("Lyx", &l.yx, &r.velocity_gradient[2]),
        ("Lyy", &l.yy, &r.velocity_gradient[3]),
    ] {
        assert_close(name, got, want.as_slice());
    }
    let e = &record.strain_rate;
    for (name, got, want) in [
        ("strain rate xx", &e.xx, &r.strain_rate[0]),
        ("strain rate yy", &e.yy, &r.strain_rate[1]),
        ("strain rate xy", &e.xy, &r.strain_rate[2]),
    ] {
        assert_close(name, got, want.as_slice());
    }
    let w = &r.after;
    for (name, got, want) in [
        ("x", &after.x, &w.x),
        ("y", &after.y, &w.y),
        ("vx", &after.vx, &w.vx),
        ("vy", &after.vy, &w.vy),
        ("sxx", &after.sxx, &w.sxx),
        ("syy", &after.syy, &w.syy),
        ("sxy", &after.sxy, &w.sxy),
        ("volume", &after.volume, &w.volume),
    ] {
        assert_close(name, got, want);
    }
    assert_eq!(after.mass, w.mass, "mass never changes");
    assert_eq!((&after.bx, &after.by), (&w.bx, &w.by), "body force never changes");
}

fn run_and_compare(grid: &Grid, p: &Particles, plane: PlaneCondition, mass: MassScheme, update: PositionUpdate) {
    let reference = reference_step(grid, p, plane, DT, mass, update);
    let mut after = p.clone();
    let record = explicit_step(grid, &mut after, &material(plane), &options(mass, update)).unwrap();
    assert_eq!(record.velocity_report.outcome, SolveOutcome::Solved);
    assert_eq!(record.acceleration_report.outcome, SolveOutcome::Solved);
    compare(&record, &after, &reference);
}

#[test]
fn explicit_step_with_lumped_mass_matches_a_dense_reference_step() {
    for (g, grid) in test_grids().iter().enumerate() {
        let p = random_particles(grid, 90, 2000 + g as u64);
        run_and_compare(
            grid,
            &p,
            PlaneCondition::Stress,
            MassScheme::Lumped,
            PositionUpdate::GridVelocity,
        );
    }
}

#[test]
fn explicit_step_with_lumped_mass_matches_the_reference_on_the_seed() {
    let grid = seed_grid();
    let p = seed_particles()
        .with_velocity(vec![0.1, -0.2, 0.3, 0.0], vec![0.0, 0.5, -0.1, 0.2])
        .unwrap()
        .with_stress(
            vec![1.0, 2.0, -3.0, 0.5],
            vec![0.0, -1.0, 2.0, 4.0],
            vec![0.3, 0.0, -0.7, 1.1],
        )
        .unwrap()
        .with_uniform_body_force(5.0, 10.0)
        .unwrap();
    run_and_compare(
        &grid,
        &p,
        PlaneCondition::Stress,
        MassScheme::Lumped,
        PositionUpdate::GridVelocity,
    );
}

#[test]
fn explicit_step_with_consistent_mass_matches_a_dense_reference_step() {
    for (k, order) in [
        (2, NodeOrder::XFastest),
        (3, NodeOrder::YFastest),
        (2, NodeOrder::YFastest),
    ] {
        let grid = Grid::new([0.25, -1.0], [0.5, 0.25], [4, 3])
            .unwrap()
            .with_node_order(order);
        let (x, y) = positions_per_cell(&grid, k, 0.3, 2100 + k as u64);
        let p = random_particles_at(x, y, 2110);
        run_and_compare(
            &grid,
            &p,
            PlaneCondition::Stress,
            MassScheme::Consistent,
            PositionUpdate::GridVelocity,
        );
    }
}

/// The other schemes of the mass-solver family against their dense definitions:
/// `(1 − γ) M_L + γ M`, the truncated series `Σ_{l<k} (I − M_L⁻¹ M)^l M_L⁻¹`, and CG on `M`
/// converged far below the comparison tolerance.
#[test]
fn explicit_step_with_blended_series_and_iterative_mass_matches_a_dense_reference_step() {
    let grid = Grid::new([0.25, -1.0], [0.5, 0.25], [4, 3]).unwrap();
    let (x, y) = positions_per_cell_in(&grid, vec![0, 1, 2], 2, 0.3, 2150);
    let p = random_particles_at(x, y, 2151);
    for scheme in [
        MassScheme::Blended { gamma: 0.0 },
        MassScheme::Blended { gamma: 0.35 },
        MassScheme::Blended { gamma: 1.0 },
        MassScheme::TruncatedSeries { k: 1 },
        MassScheme::TruncatedSeries { k: 4 },
        MassScheme::Iterative {
            tolerance: 1e-13,
            max_iterations: 500,
        },
    ] {
        run_and_compare(&grid, &p, PlaneCondition::Stress, scheme, PositionUpdate::GridVelocity);
    }
}

#[test]
fn explicit_step_with_consistent_mass_and_inactive_nodes_matches_the_reference() {
    let grid = Grid::new([0.0, 0.0], [0.5, 0.5], [4, 3]).unwrap();
    let (x, y) = positions_per_cell_in(&grid, vec![1, 2], 2, 0.3, 2200);
    let p = random_particles_at(x, y, 2201);
    let reference = reference_step(
        &grid,
        &p,
        PlaneCondition::Stress,
        DT,
        MassScheme::Consistent,
        Default::default(),
    );
    assert!(
        reference.active.len() < ref_num_nodes(&grid),
        "the fixture must have inactive nodes"
    );
    run_and_compare(
        &grid,
        &p,
        PlaneCondition::Stress,
        MassScheme::Consistent,
        PositionUpdate::GridVelocity,
    );
}

/// Particles exactly on grid lines at the edge of the body, whose cells hold nodes without
/// mass: exercises step (8b) (those nodes take the particles' interpolated velocity).
#[test]
fn explicit_step_with_particles_on_grid_lines_at_the_edge_of_the_body_matches_the_reference() {
    for order in [NodeOrder::XFastest, NodeOrder::YFastest] {
        let grid = Grid::new([0.0, 0.0], [0.5, 0.5], [4, 3])
            .unwrap()
            .with_node_order(order);
        let (mut x, mut y) = positions_per_cell_in(&grid, vec![0, 1], 2, 0.3, 2250);
        // On the line x = 1 (right edge), on the node (1, 1), and on the node (1, 0).
        x.extend([1.0, 1.0, 1.0]);
        y.extend([0.6, 1.0, 0.0]);
        let p = random_particles_at(x, y, 2251);
        let reference = reference_step(
            &grid,
            &p,
            PlaneCondition::Stress,
            DT,
            MassScheme::Lumped,
            PositionUpdate::GridVelocity,
        );
        let extended = (0..ref_num_nodes(&grid))
            .filter(|i| !reference.active.contains(i))
            .filter(|&i| reference.updated_grid_velocity[0][i] != 0.0)
            .count();
        assert!(
            extended >= 2,
            "the fixture must have massless nodes in a particle's cell"
        );
        for scheme in [MassScheme::Lumped, MassScheme::Consistent] {
            run_and_compare(&grid, &p, PlaneCondition::Stress, scheme, PositionUpdate::GridVelocity);
        }
    }
}

#[test]
fn explicit_step_with_the_trapezoidal_position_update_matches_the_reference() {
    for (g, grid) in test_grids().iter().enumerate().take(4) {
        let p = random_particles(grid, 90, 2300 + g as u64);
        run_and_compare(
            grid,
            &p,
            PlaneCondition::Stress,
            MassScheme::Lumped,
            PositionUpdate::Trapezoidal,
        );
    }
}

#[test]
fn explicit_step_with_a_plane_strain_material_matches_the_reference() {
    let grid = &test_grids()[3];
    let p = random_particles(grid, 90, 2400);
    run_and_compare(
        grid,
        &p,
        PlaneCondition::Strain,
        MassScheme::Lumped,
        PositionUpdate::GridVelocity,
    );
}

/// Relative tolerance for "unchanged" and "exact" invariants: every operation involved is a
/// ratio or weighted average that reproduces constants up to a few ulps.
const INVARIANT_REL_TOL: f64 = 1e-12;

/// Dense particles filling a grid: every node carries mass through a non-zero weight.
fn filled(grid: &Grid, seed: u64) -> Particles {
    let (x, y) = positions_per_cell(grid, 2, 0.45, seed);
    random_particles_at(x, y, seed + 1)
}

fn rigid_translation_check(grid: &Grid, p: Particles, mass: MassScheme) {
    let (vx, vy) = (0.7, -0.4);
    let n = p.len();
    let p = p
        .with_velocity(vec![vx; n], vec![vy; n])
        .unwrap()
        .with_stress(vec![0.0; n], vec![0.0; n], vec![0.0; n])
        .unwrap()
        .with_uniform_body_force(0.0, 0.0)
        .unwrap();
    let mut after = p.clone();
    explicit_step(
        grid,
        &mut after,
        &material(PlaneCondition::Stress),
        &options(mass, Default::default()),
    )
    .unwrap();
    let h_min = grid.cell_size()[0].min(grid.cell_size()[1]);
    // A strain rate of a few ulps of |v|/h gives a stress of that times E dt.
    let stress_tol = INVARIANT_REL_TOL * YOUNG * DT * (vx.abs() + vy.abs()) / h_min;
    for k in 0..n {
        let (dx, dy) = (after.x[k] - p.x[k], after.y[k] - p.y[k]);
        assert!(
            (dx - vx * DT).abs() <= INVARIANT_REL_TOL && (dy - vy * DT).abs() <= INVARIANT_REL_TOL,
            "particle {k} at ({}, {}) moved by ({dx}, {dy}), expected ({}, {})",
            p.x[k],
            p.y[k],
            vx * DT,
            vy * DT
        );
        assert!(
            (after.vx[k] - vx).abs() <= INVARIANT_REL_TOL && (after.vy[k] - vy).abs() <= INVARIANT_REL_TOL,
            "particle {k}: velocity changed to ({}, {})",
            after.vx[k],
            after.vy[k]
        );
        for (name, s) in [("sxx", after.sxx[k]), ("syy", after.syy[k]), ("sxy", after.sxy[k])] {
            assert!(
                s.abs() <= stress_tol,
                "particle {k} at ({}, {}): {name} = {s} after a rigid translation",
                p.x[k],
                p.y[k]
            );
        }
        assert!((after.volume[k] - p.volume[k]).abs() <= INVARIANT_REL_TOL * p.volume[k]);
    }
}

#[test]
fn rigid_translation_moves_every_particle_by_v_dt_and_leaves_stress_unchanged() {
    for (g, grid) in test_grids().iter().enumerate() {
        rigid_translation_check(grid, filled(grid, 2500 + g as u64), MassScheme::Lumped);
        rigid_translation_check(grid, filled(grid, 2510 + g as u64), MassScheme::Consistent);
    }
}

#[test]
fn rigid_translation_of_random_particles_including_grid_lines_leaves_stress_unchanged() {
    // Many particles, so every node of the grid gets mass through a non-zero weight.
    let grid = &test_grids()[1];
    rigid_translation_check(grid, random_particles(grid, 300, 2520), MassScheme::Lumped);
}

/// Regression: a body filling the cells `0 ≤ x < 1` plus one particle exactly on the grid
/// line `x = 1` (its right edge). Under the right-hand convention that particle belongs to the
/// empty cell to its right: it has weight 0 but gradient `±1/h` on the nodes at `x = 1.5`,
/// which carry no mass. Before step (8b) their velocity was left at 0, so a uniform velocity
/// gave that particle `Lxx ≠ 0` and a rigid translation created stress (σxx ≈ −1.54 here).
#[test]
fn rigid_translation_of_a_particle_on_the_grid_line_at_the_edge_of_the_body_leaves_stress_unchanged() {
    let grid = Grid::new([0.0, 0.0], [0.5, 0.5], [4, 3]).unwrap();
    let (mut x, mut y) = positions_per_cell_in(&grid, vec![0, 1], 2, 0.3, 2600);
    x.push(1.0);
    y.push(0.6);
    rigid_translation_check(&grid, random_particles_at(x, y, 2601), MassScheme::Lumped);
}

fn free_fall_check(grid: &Grid, p: Particles, mass: MassScheme) {
    let (bx, by) = (5.0, -10.0);
    let n = p.len();
    let p = p
        .with_stress(vec![0.0; n], vec![0.0; n], vec![0.0; n])
        .unwrap()
        .with_uniform_body_force(bx, by)
        .unwrap();
    let mut after = p.clone();
    let record = explicit_step(
        grid,
        &mut after,
        &material(PlaneCondition::Stress),
        &options(mass, Default::default()),
    )
    .unwrap();
    // The grid acceleration is b at every active node.
    for &i in &record.mass.active_nodes() {
        assert!(
            (record.acceleration.x[i] - bx).abs() <= INVARIANT_REL_TOL * bx.abs()
                && (record.acceleration.y[i] - by).abs() <= INVARIANT_REL_TOL * by.abs(),
            "node {i}: a = ({}, {})",
            record.acceleration.x[i],
            record.acceleration.y[i]
        );
    }
    // |v| ≤ 1 and |b dt| ≤ 0.01: the difference v_new − v_old is exact to a few ulps of 1.
    for k in 0..n {
        let (dvx, dvy) = (after.vx[k] - p.vx[k], after.vy[k] - p.vy[k]);
        assert!(
            (dvx - bx * DT).abs() <= INVARIANT_REL_TOL && (dvy - by * DT).abs() <= INVARIANT_REL_TOL,
            "particle {k}: Δv = ({dvx}, {dvy}), expected ({}, {})",
            bx * DT,
            by * DT
        );
    }
}

#[test]
fn free_fall_adds_b_dt_to_every_particle_velocity() {
    for (g, grid) in test_grids().iter().enumerate() {
        free_fall_check(grid, random_particles(grid, 90, 2700 + g as u64), MassScheme::Lumped);
        free_fall_check(grid, filled(grid, 2710 + g as u64), MassScheme::Consistent);
    }
}

/// Runs a step that must fail and checks the particles are untouched.
fn failing_step(grid: &Grid, p: &Particles, material: &LinearElastic, options: &StepOptions) -> MpmError {
    let mut q = p.clone();
    let err = explicit_step(grid, &mut q, material, options).unwrap_err();
    assert_bitwise_equal(&q, p, &format!("after the failed step ({err})"));
    err
}

/// Every field of two particle states holds the same bits (so NaN equals NaN).
fn assert_bitwise_equal(a: &Particles, b: &Particles, context: &str) {
    let fields = |p: &Particles| {
        [
            ("x", p.x.clone()),
            ("y", p.y.clone()),
            ("vx", p.vx.clone()),
            ("vy", p.vy.clone()),
            ("mass", p.mass.clone()),
            ("volume", p.volume.clone()),
            ("sxx", p.sxx.clone()),
            ("syy", p.syy.clone()),
            ("sxy", p.sxy.clone()),
            ("bx", p.bx.clone()),
            ("by", p.by.clone()),
        ]
    };
    for ((name, fa), (_, fb)) in fields(a).into_iter().zip(fields(b)) {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&fa), bits(&fb), "field `{name}` changed {context}");
    }
}

#[test]
fn a_non_positive_or_non_finite_time_step_is_rejected_and_particles_are_unchanged() {
    let grid = &test_grids()[1];
    let p = random_particles(grid, 30, 2800);
    for dt in [0.0, -1e-3, f64::NAN, f64::INFINITY] {
        let opts = StepOptions {
            dt,
            ..StepOptions::default()
        };
        match failing_step(grid, &p, &material(PlaneCondition::Stress), &opts) {
            MpmError::InvalidParameter { name, value, .. } => {
                assert_eq!(name, "dt");
                assert!(value == dt || (value.is_nan() && dt.is_nan()));
            }
            other => panic!("dt = {dt}: expected InvalidParameter, got {other:?}"),
        }
    }
}

#[test]
fn a_particle_outside_the_grid_fails_the_step_and_particles_are_unchanged() {
    let grid = &test_grids()[1];
    let mut p = random_particles(grid, 30, 2810);
    p.x[17] = grid.bounds()[1] + 0.01;
    match failing_step(grid, &p, &material(PlaneCondition::Stress), &StepOptions::default()) {
        MpmError::ParticleOutsideGrid { particle, .. } => assert_eq!(particle, 17),
        other => panic!("expected ParticleOutsideGrid, got {other:?}"),
    }
}

#[test]
fn a_singular_consistent_mass_fails_the_step_and_particles_are_unchanged() {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [3, 3]).unwrap();
    let (x, y) = positions_per_cell(&grid, 1, 0.3, 2820);
    let p = random_particles_at(x, y, 2821);
    let opts = options(MassScheme::Consistent, Default::default());
    match failing_step(&grid, &p, &material(PlaneCondition::Stress), &opts) {
        MpmError::SingularMassMatrix { particles, .. } => assert!(!particles.is_empty()),
        other => panic!("expected SingularMassMatrix, got {other:?}"),
    }
}

#[test]
fn an_invalid_material_or_particle_state_fails_the_step_and_particles_are_unchanged() {
    let grid = &test_grids()[1];
    let p = random_particles(grid, 30, 2830);
    let bad_material = LinearElastic {
        youngs_modulus: YOUNG,
        poisson_ratio: 0.5,
        plane: PlaneCondition::Stress,
    };
    match failing_step(grid, &p, &bad_material, &StepOptions::default()) {
        MpmError::InvalidParameter { name, .. } => assert_eq!(name, "poisson_ratio"),
        other => panic!("expected InvalidParameter, got {other:?}"),
    }
    let mut bad = p.clone();
    bad.mass[3] = -1.0;
    match failing_step(grid, &bad, &material(PlaneCondition::Stress), &StepOptions::default()) {
        MpmError::InvalidParticleValue { particle, field, .. } => assert_eq!((particle, field), (3, "mass")),
        other => panic!("expected InvalidParticleValue, got {other:?}"),
    }
    let mut bad = p.clone();
    bad.sxy[11] = f64::NAN;
    match failing_step(grid, &bad, &material(PlaneCondition::Stress), &StepOptions::default()) {
        MpmError::InvalidParticleValue { particle, field, .. } => assert_eq!((particle, field), (11, "sxy")),
        other => panic!("expected InvalidParticleValue, got {other:?}"),
    }
    let mut bad = p.clone();
    bad.vy.pop();
    match failing_step(grid, &bad, &material(PlaneCondition::Stress), &StepOptions::default()) {
        MpmError::LengthMismatch { field, expected, found } => assert_eq!((field, expected, found), ("vy", 30, 29)),
        other => panic!("expected LengthMismatch, got {other:?}"),
    }
}

fn length_mismatch_field(result: Result<Particles, MpmError>) -> (&'static str, usize, usize) {
    match result {
        Err(MpmError::LengthMismatch { field, expected, found }) => (field, expected, found),
        other => panic!("expected LengthMismatch, got {other:?}"),
    }
}

#[test]
fn particles_with_mismatched_lengths_are_rejected_naming_the_field() {
    let v = |n: usize| vec![1.0; n];
    assert_eq!(
        length_mismatch_field(Particles::new(v(3), v(2), v(3), v(3))),
        ("y", 3, 2)
    );
    assert_eq!(
        length_mismatch_field(Particles::new(v(3), v(3), v(4), v(3))),
        ("mass", 3, 4)
    );
    assert_eq!(
        length_mismatch_field(Particles::new(v(3), v(3), v(3), v(0))),
        ("volume", 3, 0)
    );
    let p = Particles::new(v(3), v(3), v(3), v(3)).unwrap();
    assert_eq!(length_mismatch_field(p.clone().with_velocity(v(2), v(3))), ("vx", 3, 2));
    assert_eq!(length_mismatch_field(p.clone().with_velocity(v(3), v(5))), ("vy", 3, 5));
    assert_eq!(
        length_mismatch_field(p.clone().with_stress(v(3), v(1), v(3))),
        ("syy", 3, 1)
    );
    assert_eq!(
        length_mismatch_field(p.clone().with_stress(v(3), v(3), v(4))),
        ("sxy", 3, 4)
    );
    assert_eq!(
        length_mismatch_field(p.clone().with_body_force(v(3), v(2))),
        ("by", 3, 2)
    );
}

fn invalid_value(result: Result<Particles, MpmError>) -> (usize, &'static str, f64) {
    match result {
        Err(MpmError::InvalidParticleValue {
            particle, field, value, ..
        }) => (particle, field, value),
        other => panic!("expected InvalidParticleValue, got {other:?}"),
    }
}

#[test]
fn particles_with_nan_positions_or_non_positive_mass_are_rejected_naming_particle_and_field() {
    let v = || vec![0.5, 0.6, 0.7, 0.8];
    let with = |i: usize, value: f64| {
        let mut w = v();
        w[i] = value;
        w
    };
    let (p, f, val) = invalid_value(Particles::new(with(2, f64::NAN), v(), v(), v()));
    assert_eq!((p, f), (2, "x"));
    assert!(val.is_nan());
    assert_eq!(
        invalid_value(Particles::new(v(), with(1, f64::INFINITY), v(), v())),
        (1, "y", f64::INFINITY)
    );
    assert_eq!(
        invalid_value(Particles::new(v(), v(), with(3, 0.0), v())),
        (3, "mass", 0.0)
    );
    assert_eq!(
        invalid_value(Particles::new(v(), v(), with(0, -2.0), v())),
        (0, "mass", -2.0)
    );
    assert_eq!(
        invalid_value(Particles::new(v(), v(), v(), with(1, -0.0))),
        (1, "volume", -0.0)
    );
    let ok = Particles::new(v(), v(), v(), v()).unwrap();
    let (p, f, _) = invalid_value(ok.clone().with_velocity(v(), with(3, f64::NAN)));
    assert_eq!((p, f), (3, "vy"));
    assert_eq!(
        invalid_value(ok.with_uniform_body_force(f64::NEG_INFINITY, 0.0)).1,
        "bx"
    );
}

#[test]
fn linear_elastic_rejects_incompressible_or_out_of_range_poisson_ratio_and_non_positive_modulus() {
    for nu in [0.5, 0.7, -1.0, -1.5, f64::NAN] {
        match LinearElastic::new(1.0, nu, PlaneCondition::Stress) {
            Err(MpmError::InvalidParameter { name, .. }) => assert_eq!(name, "poisson_ratio", "ν = {nu}"),
            other => panic!("ν = {nu}: expected InvalidParameter, got {other:?}"),
        }
    }
    for e in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        match LinearElastic::new(e, 0.3, PlaneCondition::Strain) {
            Err(MpmError::InvalidParameter { name, .. }) => assert_eq!(name, "youngs_modulus", "E = {e}"),
            other => panic!("E = {e}: expected InvalidParameter, got {other:?}"),
        }
    }
    for (e, nu) in [(1.0, 0.0), (200e9, 0.3), (5.0, 0.499), (5.0, -0.99)] {
        assert!(
            LinearElastic::new(e, nu, PlaneCondition::Stress).is_ok(),
            "E = {e}, ν = {nu}"
        );
    }
}

#[test]
fn linear_elastic_stiffness_matches_the_textbook_formulas() {
    for plane in [PlaneCondition::Stress, PlaneCondition::Strain] {
        for (e, nu) in [(1.0, 0.0), (210e9, 0.3), (3.0, 0.45), (2.0, -0.5)] {
            let m = LinearElastic::new(e, nu, plane).unwrap();
            let (c11, c12, g) = stiffness(e, nu, plane);
            let (l11, l12) = m.normal_stiffness();
            let tol = 1e-14 * c11.abs().max(c12.abs());
            assert!(
                (l11 - c11).abs() <= tol && (l12 - c12).abs() <= tol,
                "{plane:?} E={e} ν={nu}"
            );
            assert!((m.shear_modulus() - g).abs() <= 1e-14 * g);
            let [dxx, dyy, dxy] = m.stress_increment(1e-3, -2e-3, 5e-4);
            assert!((dxx - (c11 * 1e-3 - c12 * 2e-3)).abs() <= tol * 1e-2);
            assert!((dyy - (c12 * 1e-3 - c11 * 2e-3)).abs() <= tol * 1e-2);
            assert!((dxy - 2.0 * g * 5e-4).abs() <= tol * 1e-2);
        }
    }
}
