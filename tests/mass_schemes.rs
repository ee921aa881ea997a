//! The mass-solver family: schemes agree where theory says they must, singular matrices are
//! reported with the right node and nullity, and the critical time steps follow the Fourier
//! analysis of the uniform grid.

use nalgebra::DMatrix;
use sparse_mpm::mass::{
    Constraints, GridMass, MassDiagnostics, MassOptions, MassScheme, Role, SingularityPolicy, SolveOutcome,
};
use sparse_mpm::material::{LinearElastic, PlaneCondition};
use sparse_mpm::stiffness::{apply_stiffness, critical_time_step, stiffness_matrix};
use sparse_mpm::transfer::VectorField;
use sparse_mpm::{Grid, MpmError, Operators, Particles, ShapeFunction};

/// Direct solves of well-conditioned mass matrices agree to rounding.
const DIRECT_TOL: f64 = 1e-10;

/// Particles at the 2×2 Gauss points of every cell of a `cells × cells` grid of unit cells (so
/// particle quadrature integrates the bilinear mass and stiffness exactly), density `rho`.
fn gauss_block(cells: usize, rho: f64) -> (Grid, Particles) {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [cells, cells]).unwrap();
    let g = 0.5 / 3f64.sqrt();
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for cj in 0..cells {
        for ci in 0..cells {
            for (a, b) in [(-g, -g), (g, -g), (-g, g), (g, g)] {
                x.push(ci as f64 + 0.5 + a);
                y.push(cj as f64 + 0.5 + b);
            }
        }
    }
    let np = x.len();
    let particles = Particles::new(x, y, vec![rho * 0.25; np], vec![0.25; np]).unwrap();
    (grid, particles)
}

/// A body whose particles do not align with the grid: 3×3 per cell, jittered.
fn jittered_block() -> (Grid, Particles) {
    let grid = Grid::new([0.0, 0.0], [0.5, 0.5], [6, 5]).unwrap();
    let mut state = 12345u64;
    let mut rnd = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut x, mut y, mut m) = (Vec::new(), Vec::new(), Vec::new());
    for cj in 0..5 {
        for ci in 0..6 {
            for a in 0..3 {
                for b in 0..3 {
                    x.push(0.5 * (ci as f64 + (a as f64 + 0.2 + 0.6 * rnd()) / 3.0));
                    y.push(0.5 * (cj as f64 + (b as f64 + 0.2 + 0.6 * rnd()) / 3.0));
                    m.push(0.5 + rnd());
                }
            }
        }
    }
    let np = x.len();
    (grid, Particles::new(x, y, m, vec![0.02; np]).unwrap())
}

fn rhs(n: usize) -> VectorField {
    VectorField {
        x: (0..n).map(|i| ((i * 7 % 11) as f64 - 5.0) * 0.3).collect(),
        y: (0..n).map(|i| ((i * 5 % 13) as f64 - 6.0) * 0.2).collect(),
    }
}

fn solve(ops: &Operators, p: &Particles, scheme: MassScheme) -> (VectorField, sparse_mpm::mass::SolveReport) {
    let mass = GridMass::new(ops, &p.mass, &MassOptions::plain(scheme), &Constraints::none()).unwrap();
    mass.solve(Role::Acceleration, &rhs(ops.num_nodes()), None, ops)
        .unwrap()
}

fn max_diff(a: &VectorField, b: &VectorField) -> f64 {
    a.x.iter()
        .chain(&a.y)
        .zip(b.x.iter().chain(&b.y))
        .map(|(u, v)| (u - v).abs())
        .fold(0.0, f64::max)
}

fn max_abs(a: &VectorField) -> f64 {
    a.x.iter().chain(&a.y).map(|u| u.abs()).fold(0.0, f64::max)
}

#[test]
fn blended_with_gamma_zero_equals_lumped_and_gamma_one_equals_consistent() {
    let (grid, p) = jittered_block();
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &p).unwrap();
    let (lumped, _) = solve(&ops, &p, MassScheme::Lumped);
    let (consistent, _) = solve(&ops, &p, MassScheme::Consistent);
    let (b0, _) = solve(&ops, &p, MassScheme::Blended { gamma: 0.0 });
    let (b1, _) = solve(&ops, &p, MassScheme::Blended { gamma: 1.0 });
    assert!(max_diff(&b0, &lumped) <= DIRECT_TOL * max_abs(&lumped));
    assert!(max_diff(&b1, &consistent) <= DIRECT_TOL * max_abs(&consistent));
    assert!(
        max_diff(&lumped, &consistent) > 1e-3 * max_abs(&consistent),
        "the test needs schemes that differ"
    );
}

#[test]
fn consistent_solve_matches_a_dense_solve_and_reports_a_small_residual() {
    let (grid, p) = jittered_block();
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &p).unwrap();
    let (u, report) = solve(&ops, &p, MassScheme::Consistent);
    assert!(
        report.relative_residual < 1e-12,
        "residual {}",
        report.relative_residual
    );
    assert_eq!(report.outcome, SolveOutcome::Solved);
    // Independent: dense N diag(m) Nᵀ on the nodes with mass, solved by LU.
    let n = DMatrix::from(&ops.n_matrix());
    let m = &n * DMatrix::from_diagonal(&nalgebra::DVector::from_vec(p.mass.clone())) * n.transpose();
    let active: Vec<usize> = (0..m.nrows()).filter(|&i| m.row(i).sum() > 0.0).collect();
    let maa = DMatrix::from_fn(active.len(), active.len(), |a, b| m[(active[a], active[b])]);
    let r = rhs(ops.num_nodes());
    let b = nalgebra::DVector::from_iterator(active.len(), active.iter().map(|&i| r.x[i]));
    let x = maa.lu().solve(&b).unwrap();
    for (k, &i) in active.iter().enumerate() {
        assert!(
            (u.x[i] - x[k]).abs() <= 1e-9 * x.amax(),
            "node {i}: {} vs {}",
            u.x[i],
            x[k]
        );
    }
}

#[test]
fn truncated_series_approaches_consistent_as_k_grows() {
    let (grid, p) = jittered_block();
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &p).unwrap();
    let (consistent, _) = solve(&ops, &p, MassScheme::Consistent);
    let (lumped, _) = solve(&ops, &p, MassScheme::Lumped);
    let (k1, _) = solve(&ops, &p, MassScheme::TruncatedSeries { k: 1 });
    assert!(
        max_diff(&k1, &lumped) <= DIRECT_TOL * max_abs(&lumped),
        "k = 1 is lumped"
    );
    let errors: Vec<f64> = [1, 2, 4, 8, 16, 64, 400]
        .iter()
        .map(|&k| max_diff(&solve(&ops, &p, MassScheme::TruncatedSeries { k }).0, &consistent))
        .collect();
    for w in errors.windows(2) {
        assert!(w[1] < w[0], "error must fall with k: {errors:?}");
    }
    assert!(errors[errors.len() - 1] < 1e-8 * max_abs(&consistent), "{errors:?}");
}

#[test]
fn iterative_matches_consistent_to_its_tolerance() {
    let (grid, p) = jittered_block();
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &p).unwrap();
    let (consistent, _) = solve(&ops, &p, MassScheme::Consistent);
    for tolerance in [1e-4, 1e-8, 1e-12] {
        let (u, report) = solve(
            &ops,
            &p,
            MassScheme::Iterative {
                tolerance,
                max_iterations: 500,
            },
        );
        assert!(report.relative_residual <= tolerance * 1.01, "{report:?}");
        assert!(report.iterations > 0 && report.iterations < 500);
        // Error ≤ κ · residual; the preconditioned matrix here has κ < 100.
        assert!(
            max_diff(&u, &consistent) <= 100.0 * tolerance * max_abs(&consistent),
            "tol {tolerance}"
        );
    }
}

/// One particle at the centre of each cell of a 4 × 4 grid: 25 nodes, N of rank 16.
fn one_particle_per_cell() -> (Grid, Particles) {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [4, 4]).unwrap();
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in 0..4 {
        for i in 0..4 {
            x.push(i as f64 + 0.5);
            y.push(j as f64 + 0.5);
        }
    }
    (grid, Particles::new(x, y, vec![1.0; 16], vec![1.0; 16]).unwrap())
}

#[test]
fn one_particle_per_cell_is_reported_singular_with_the_right_nullity() {
    let (grid, p) = one_particle_per_cell();
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &p).unwrap();
    // Independent nullity: 25 − rank of the dense M from its singular values.
    let n = DMatrix::from(&ops.n_matrix());
    let m = &n * n.transpose();
    let sv = m.clone().svd(false, false).singular_values;
    let rank = sv.iter().filter(|&&s| s > 1e-10 * sv.max()).count();
    assert_eq!(rank, 16);
    let diag = MassDiagnostics::compute(&ops, &p.mass, &MassOptions::plain(MassScheme::Consistent)).unwrap();
    assert_eq!(diag.active_nodes, 25);
    assert_eq!(diag.nullity_estimate, 25 - rank);
    assert!(diag.lambda_min_estimate < 1e-8, "λ_min = {}", diag.lambda_min_estimate);
    assert!(diag.condition_number.is_infinite());
    let err = GridMass::new(
        &ops,
        &p.mass,
        &MassOptions::plain(MassScheme::Consistent),
        &Constraints::none(),
    )
    .unwrap_err();
    match err {
        MpmError::SingularMassMatrix { node, particles, .. } => {
            assert!(node < 25);
            assert_eq!(particles, ops.particles_touching(node));
            assert!(!particles.is_empty());
        }
        other => panic!("expected a singular mass matrix, got {other}"),
    }
}

#[test]
fn singular_mass_falls_back_to_lumped_or_is_regularized_when_asked() {
    let (grid, p) = one_particle_per_cell();
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &p).unwrap();
    let (lumped, _) = solve(&ops, &p, MassScheme::Lumped);
    let r = rhs(ops.num_nodes());
    let options = |policy| MassOptions {
        singularity: policy,
        ..MassOptions::plain(MassScheme::Consistent)
    };
    let mass = GridMass::new(
        &ops,
        &p.mass,
        &options(SingularityPolicy::FallbackToLumped),
        &Constraints::none(),
    )
    .unwrap();
    let (u, report) = mass.solve(Role::Acceleration, &r, None, &ops).unwrap();
    assert!(matches!(
        report.outcome,
        SolveOutcome::FellBackToLumped { node: Some(_), .. }
    ));
    assert!(max_diff(&u, &lumped) <= DIRECT_TOL * max_abs(&lumped));
    let epsilon = 0.1;
    let mass = GridMass::new(
        &ops,
        &p.mass,
        &options(SingularityPolicy::Regularize { epsilon }),
        &Constraints::none(),
    )
    .unwrap();
    let (u, report) = mass.solve(Role::Acceleration, &r, None, &ops).unwrap();
    assert!(matches!(
        report.outcome,
        SolveOutcome::Regularized { node: Some(_), .. }
    ));
    assert!(report.relative_residual < 1e-10);
    // The regularized solve equals the blended scheme with γ = 1 − ε.
    let (blend, _) = solve(&ops, &p, MassScheme::Blended { gamma: 1.0 - epsilon });
    assert!(max_diff(&u, &blend) <= DIRECT_TOL * max_abs(&blend));
}

#[test]
fn iterative_solve_of_a_singular_mass_is_an_error_naming_a_node() {
    let (grid, p) = one_particle_per_cell();
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &p).unwrap();
    let options = MassOptions::plain(MassScheme::Iterative {
        tolerance: 1e-12,
        max_iterations: 200,
    });
    let mass = GridMass::new(&ops, &p.mass, &options, &Constraints::none()).unwrap();
    match mass.solve(Role::Acceleration, &rhs(ops.num_nodes()), None, &ops) {
        Err(MpmError::SingularMassMatrix { node, .. }) => assert!(node < 25),
        other => panic!("expected a singular mass matrix error, got {other:?}"),
    }
}

#[test]
fn fixed_dofs_are_eliminated_and_keep_their_prescribed_values() {
    let (grid, p) = jittered_block();
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &p).unwrap();
    let n = ops.num_nodes();
    let constraints = Constraints {
        fixed_x: (0..7).collect(),
        fixed_y: vec![3, 10, 17],
    };
    let mut prescribed = VectorField::zeros(n);
    prescribed.x.iter_mut().take(7).for_each(|v| *v = 0.25);
    prescribed.y[10] = -1.0;
    for scheme in [
        MassScheme::Lumped,
        MassScheme::Consistent,
        MassScheme::Iterative {
            tolerance: 1e-12,
            max_iterations: 500,
        },
    ] {
        let mass = GridMass::new(&ops, &p.mass, &MassOptions::plain(scheme), &constraints).unwrap();
        let r = rhs(n);
        let (u, _) = mass.solve(Role::Velocity, &r, Some(&prescribed), &ops).unwrap();
        for i in 0..7 {
            assert_eq!(u.x[i], 0.25, "{scheme:?}");
        }
        assert_eq!(u.y[10], -1.0);
        if scheme == MassScheme::Lumped {
            continue;
        }
        // Free rows satisfy M u = r exactly (prescribed values included in u).
        let m = mass.consistent_matrix().unwrap();
        let mu = DMatrix::from(m.as_ref()) * nalgebra::DVector::from_vec(u.x.clone());
        let [fx, _] = mass.free_dofs();
        for &i in &fx {
            assert!(
                (mu[i] - r.x[i]).abs() < 1e-8,
                "{scheme:?} row {i}: {} vs {}",
                mu[i],
                r.x[i]
            );
        }
    }
}

#[test]
fn symbolic_analysis_is_reused_while_the_pattern_is_unchanged() {
    let (grid, mut p) = jittered_block();
    let mut ops = Operators::assemble(&grid, ShapeFunction::Linear, &p).unwrap();
    let options = MassOptions::plain(MassScheme::Consistent);
    let mut mass = GridMass::new(&ops, &p.mass, &options, &Constraints::none()).unwrap();
    assert_eq!(mass.symbolic_analyses(Role::Acceleration), 1);
    // Move every particle a little inside its cell: same cells, same pattern.
    p.x.iter_mut().for_each(|x| *x += 1e-3);
    ops.reassemble(&grid, ShapeFunction::Linear, &p.x, &p.y).unwrap();
    mass.update(&ops, &p.mass, &options, &Constraints::none()).unwrap();
    assert_eq!(mass.symbolic_analyses(Role::Acceleration), 1);
    let (_, report) = mass
        .solve(Role::Acceleration, &rhs(ops.num_nodes()), None, &ops)
        .unwrap();
    assert!(report.relative_residual < 1e-12);
    // Drop a column of cells: the pattern changes and the analysis is redone.
    let keep: Vec<usize> = (0..p.len()).filter(|&i| p.x[i] < 2.5).collect();
    let pick = |v: &Vec<f64>| keep.iter().map(|&i| v[i]).collect::<Vec<_>>();
    let q = Particles::new(pick(&p.x), pick(&p.y), pick(&p.mass), pick(&p.volume)).unwrap();
    ops.reassemble(&grid, ShapeFunction::Linear, &q.x, &q.y).unwrap();
    mass.update(&ops, &q.mass, &options, &Constraints::none()).unwrap();
    assert_eq!(mass.symbolic_analyses(Role::Acceleration), 2);
}

#[test]
fn assembled_stiffness_equals_the_matrix_free_internal_force() {
    let (grid, p) = jittered_block();
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &p).unwrap();
    let material = LinearElastic::new(1000.0, 0.3, PlaneCondition::Strain).unwrap();
    let k = DMatrix::from(&stiffness_matrix(&ops, &p.volume, &material));
    let n = ops.num_nodes();
    let u = rhs(n);
    let ku = &k * nalgebra::DVector::from_iterator(2 * n, u.x.iter().chain(&u.y).cloned());
    let free = apply_stiffness(&ops, &p.volume, &material, &u);
    for i in 0..n {
        assert!((ku[i] - free.x[i]).abs() < 1e-9 * ku.amax() && (ku[n + i] - free.y[i]).abs() < 1e-9 * ku.amax());
    }
    assert!((&k - k.transpose()).amax() < 1e-9 * k.amax(), "K is symmetric");
}

/// sup over wavenumbers of λ_max(K̂(θ)) / M̂(θ) for bilinear elements on unit cells, plane
/// strain, density 1: the Fourier symbols of the exactly integrated stiffness and mass.
fn lattice_max_eigenvalue(material: &LinearElastic, consistent: bool) -> f64 {
    let (c11, c12) = material.normal_stiffness();
    let g = material.shear_modulus();
    let k1 = |t: f64| 2.0 - 2.0 * t.cos();
    let m1 = |t: f64| (2.0 + t.cos()) / 3.0;
    let steps = 400;
    let mut best: f64 = 0.0;
    for a in 0..=steps {
        for b in 0..=steps {
            let (tx, ty) = (
                std::f64::consts::PI * a as f64 / steps as f64,
                std::f64::consts::PI * b as f64 / steps as f64,
            );
            let kxx = c11 * k1(tx) * m1(ty) + g * m1(tx) * k1(ty);
            let kyy = c11 * m1(tx) * k1(ty) + g * k1(tx) * m1(ty);
            let kxy = (c12 + g) * tx.sin() * ty.sin();
            let lmax = 0.5 * (kxx + kyy) + (0.25 * (kxx - kyy).powi(2) + kxy * kxy).sqrt();
            let mass = if consistent { m1(tx) * m1(ty) } else { 1.0 };
            best = best.max(lmax / mass);
        }
    }
    best
}

#[test]
fn consistent_critical_time_step_is_below_lumped_by_the_fourier_ratio() {
    let (grid, p) = gauss_block(24, 1.0);
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &p).unwrap();
    let material = LinearElastic::new(100.0, 0.3, PlaneCondition::Strain).unwrap();
    // Every boundary node fixed: the interior problem of the infinite lattice.
    let boundary: Vec<usize> = (0..grid.num_nodes())
        .filter(|&id| {
            let (i, j) = grid.node_ij(id);
            i == 0 || j == 0 || i == 24 || j == 24
        })
        .collect();
    let constraints = Constraints {
        fixed_x: boundary.clone(),
        fixed_y: boundary,
    };
    let dt = |scheme| {
        let mass = GridMass::new(&ops, &p.mass, &MassOptions::plain(scheme), &constraints).unwrap();
        critical_time_step(&ops, &p.volume, &material, &mass, Role::Acceleration).unwrap()
    };
    let (dt_l, dt_c) = (dt(MassScheme::Lumped), dt(MassScheme::Consistent));
    let theory_l = 2.0 / lattice_max_eigenvalue(&material, false).sqrt();
    let theory_c = 2.0 / lattice_max_eigenvalue(&material, true).sqrt();
    // The finite grid's highest modes sit within (π/24)² of the lattice's: about 2%.
    assert!(
        (dt_l / theory_l - 1.0).abs() < 0.03,
        "lumped {dt_l} vs lattice {theory_l}"
    );
    assert!(
        (dt_c / theory_c - 1.0).abs() < 0.03,
        "consistent {dt_c} vs lattice {theory_c}"
    );
    assert!(dt_c < dt_l);
    let ratio = dt_c / dt_l;
    eprintln!("dt_l {dt_l} theory {theory_l}; dt_c {dt_c} theory {theory_c}; ratio {ratio}");
    assert!(
        (ratio / (theory_c / theory_l) - 1.0).abs() < 0.02,
        "ratio {ratio} vs {}",
        theory_c / theory_l
    );
    // The blend lies between.
    let dt_b = dt(MassScheme::Blended { gamma: 0.5 });
    assert!(dt_c < dt_b && dt_b < dt_l);
}

/// A solve with the conjugate gradient depends on its right-hand side alone: solving another
/// system in between (as a frequency estimate does between two steps) leaves the next result
/// bit for bit the same, and the iterations with it.
#[test]
fn an_iterative_solve_does_not_depend_on_the_solves_before_it() {
    let (grid, p) = jittered_block();
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &p).unwrap();
    let scheme = MassScheme::Iterative {
        tolerance: 1e-10,
        max_iterations: 500,
    };
    let mass = GridMass::new(&ops, &p.mass, &MassOptions::both(scheme), &Constraints::none()).unwrap();
    let n = ops.num_nodes();
    let b = rhs(n);
    let mut other = rhs(n);
    other
        .x
        .iter_mut()
        .enumerate()
        .for_each(|(i, v)| *v *= if i % 2 == 0 { -3.0 } else { 0.5 });
    for role in [Role::Velocity, Role::Acceleration] {
        let (first, r1) = mass.solve(role, &b, None, &ops).unwrap();
        mass.solve(role, &other, None, &ops).unwrap();
        let (again, r2) = mass.solve(role, &b, None, &ops).unwrap();
        assert!(r1.iterations > 0);
        assert_eq!(
            (r1.iterations, &first.x, &first.y),
            (r2.iterations, &again.x, &again.y),
            "{role:?}"
        );
    }
}
