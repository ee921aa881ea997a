//! The fringe stabilisations of the consistent mass: symmetric, positive semi-definite changes
//! that keep the row sums, vanish where they must, and act where a body's edge leaves nodes with
//! little support.

use nalgebra::{DMatrix, SymmetricEigen};
use sparse_mpm::mass::stabilization::{ghost_penalty, partially_lumped};
use sparse_mpm::mass::{active_nodes, consistent_mass, lumped_mass, Stabilization};
use sparse_mpm::{Grid, Operators, Particles, ShapeFunction};

/// Relative round-off allowance for sums over a few hundred entries.
const ROUND_OFF: f64 = 1e-12;

const SHAPES: [ShapeFunction; 4] = [
    ShapeFunction::Linear,
    ShapeFunction::Gimp { half_width: 0.25 },
    ShapeFunction::QuadraticBSpline,
    ShapeFunction::CubicBSpline,
];

/// A disk of 2 × 2 particles per unit cell whose edge particles sit just past grid lines.
fn disk() -> Particles {
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in 0..32 {
        for i in 0..32 {
            let (px, py) = ((i as f64 + 0.5) / 2.0, (j as f64 + 0.5) / 2.0);
            if (px - 8.0f64).hypot(py - 8.0) < 4.5 {
                x.push(px + 0.27);
                y.push(py + 0.11);
            }
        }
    }
    let n = x.len();
    Particles::new(x, y, vec![0.25; n], vec![0.25; n]).unwrap()
}

fn dense(m: &nalgebra_sparse::CscMatrix<f64>) -> DMatrix<f64> {
    let mut d = DMatrix::zeros(m.nrows(), m.ncols());
    for (i, j, v) in m.triplet_iter() {
        d[(i, j)] += *v;
    }
    d
}

fn setup(shape: ShapeFunction) -> (Grid, Operators, Vec<f64>, Vec<bool>) {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [16, 16]).unwrap();
    let p = disk();
    let ops = Operators::assemble(&grid, shape, &p).unwrap();
    let lumped = lumped_mass(&ops, &p.mass);
    let mut active = vec![false; lumped.len()];
    active_nodes(&lumped, 1e-12).into_iter().for_each(|i| active[i] = true);
    (grid, ops, lumped, active)
}

#[test]
fn the_ghost_penalty_is_symmetric_positive_semidefinite_and_zero_on_polynomials_of_the_kernel_degree() {
    for shape in SHAPES {
        let (grid, ops, lumped, active) = setup(shape);
        let p = dense(&ghost_penalty(&ops, &lumped, &active, 1.0));
        let scale = p.abs().max();
        assert!(scale > 0.0, "{}: the disk's boundary faces are penalised", shape.name());
        assert!(
            (&p - p.transpose()).abs().max() <= ROUND_OFF * scale,
            "{}: symmetric",
            shape.name()
        );
        let eig = SymmetricEigen::new(p.clone()).eigenvalues;
        assert!(
            eig.min() >= -ROUND_OFF * scale,
            "{}: PSD, λ_min = {}",
            shape.name(),
            eig.min()
        );
        // Nodal values that are polynomials of degree ≤ p in each index: their (p+1)-th
        // differences, the jumps of the p-th derivative, vanish.
        let degree = match shape {
            ShapeFunction::QuadraticBSpline => 2,
            ShapeFunction::CubicBSpline => 3,
            _ => 1,
        };
        let n = grid.num_nodes();
        for (a, b) in [
            (0, 0),
            (1, 0),
            (0, 1),
            (1, 1),
            (degree, 0),
            (0, degree),
            (degree, degree),
        ] {
            let u = nalgebra::DVector::from_fn(n, |id, _| {
                let (i, j) = grid.node_ij(id);
                (i as f64 / 7.0).powi(a) * (j as f64 / 5.0).powi(b)
            });
            let pu = &p * &u;
            assert!(
                pu.amax() <= 1e-10 * scale * u.amax(),
                "{}: P (i^{a} j^{b}) = {:e}",
                shape.name(),
                pu.amax()
            );
        }
        // A kink is penalised.
        let kink = nalgebra::DVector::from_fn(n, |id, _| (grid.node_ij(id).0 as f64 - 8.0).abs());
        assert!((kink.transpose() * &p * &kink)[0] > 0.0, "{}", shape.name());
    }
}

#[test]
fn partial_lumping_keeps_row_sums_symmetry_and_the_interior_and_lumps_the_fringe() {
    for shape in SHAPES {
        let (_, ops, lumped, _) = setup(shape);
        let p = disk();
        let m = consistent_mass(&ops, &p.mass);
        let theta = 0.5;
        let s = partially_lumped(&m, &lumped, theta);
        let (md, sd) = (dense(&m), dense(&s));
        let scale = md.abs().max();
        assert!((&sd - sd.transpose()).abs().max() <= ROUND_OFF * scale);
        for i in 0..md.nrows() {
            assert!(
                (sd.row(i).sum() - lumped[i]).abs() <= ROUND_OFF * scale,
                "{}: row sum",
                shape.name()
            );
        }
        // M' − M is a weighted graph Laplacian: positive semi-definite.
        let eig = SymmetricEigen::new(&sd - &md).eigenvalues;
        assert!(eig.min() >= -ROUND_OFF * scale, "{}", shape.name());
        // Couplings between nodes at least as heavy as half their heaviest neighbour are kept;
        // some fringe coupling is lumped.
        let phi: Vec<f64> = (0..md.nrows())
            .map(|i| {
                let heaviest = (0..md.ncols())
                    .filter(|&j| md[(i, j)] != 0.0)
                    .map(|j| lumped[j])
                    .fold(lumped[i], f64::max);
                if heaviest > 0.0 {
                    lumped[i] / heaviest
                } else {
                    1.0
                }
            })
            .collect();
        let mut lumped_couplings = 0;
        for i in 0..md.nrows() {
            for j in 0..md.ncols() {
                if i != j && md[(i, j)] != 0.0 {
                    if phi[i].min(phi[j]) >= theta {
                        assert_eq!(sd[(i, j)], md[(i, j)], "{}: well-supported coupling kept", shape.name());
                    } else {
                        lumped_couplings += 1;
                        assert!(sd[(i, j)].abs() < md[(i, j)].abs(), "{}", shape.name());
                    }
                }
            }
        }
        assert!(
            lumped_couplings > 0,
            "{}: the fringe has couplings to lump",
            shape.name()
        );
    }
}

#[test]
fn stabilisations_keep_a_uniform_velocity_uniform_and_validate_their_parameters() {
    for stabilization in [
        Stabilization::GhostPenalty { gamma: 0.1 },
        Stabilization::PartialLumping { threshold: 0.5 },
    ] {
        for shape in SHAPES {
            let (_, ops, lumped, active) = setup(shape);
            let p = disk();
            let m = consistent_mass(&ops, &p.mass);
            let s = dense(&stabilization.apply(&ops, &m, &lumped, &active).unwrap());
            // M_s 1 = m_L: the momentum of a uniform velocity projects back to it.
            let ones = nalgebra::DVector::from_element(lumped.len(), 1.0);
            let row_sums = &s * ones;
            for i in 0..lumped.len() {
                assert!((row_sums[i] - lumped[i]).abs() <= ROUND_OFF * lumped.iter().cloned().fold(0.0, f64::max));
            }
        }
    }
    let (_, ops, lumped, active) = setup(ShapeFunction::Linear);
    let p = disk();
    assert!(Stabilization::None
        .apply(&ops, &consistent_mass(&ops, &p.mass), &lumped, &active)
        .is_none());
    for bad in [
        Stabilization::GhostPenalty { gamma: -1.0 },
        Stabilization::GhostPenalty { gamma: f64::NAN },
        Stabilization::PartialLumping { threshold: 0.0 },
        Stabilization::PartialLumping { threshold: 1.5 },
    ] {
        let options = sparse_mpm::mass::MassOptions {
            stabilization: bad,
            ..sparse_mpm::mass::MassOptions::both(sparse_mpm::mass::MassScheme::Consistent)
        };
        let err = sparse_mpm::mass::GridMass::new(&ops, &p.mass, &options, &Default::default()).unwrap_err();
        assert!(
            matches!(err, sparse_mpm::MpmError::InvalidParameter { .. }),
            "{bad:?}: {err}"
        );
    }
}

#[test]
fn the_linear_extension_penalty_is_symmetric_semidefinite_zero_on_linear_fields_and_absent_inside() {
    use sparse_mpm::mass::extension::{extension_penalty, relative_support};
    for shape in SHAPES {
        let (grid, ops, lumped, active) = setup(shape);
        let particles = disk();
        let m = consistent_mass(&ops, &particles.mass);
        let p = dense(&extension_penalty(&ops, &m, &lumped, &active, 1.0, 0.5, 0.2));
        let scale = p.abs().max();
        assert!(scale > 0.0, "{}: the fringe is penalised", shape.name());
        assert!(
            (&p - p.transpose()).abs().max() <= ROUND_OFF * scale,
            "{}: symmetric",
            shape.name()
        );
        let eig = SymmetricEigen::new(p.clone()).eigenvalues;
        assert!(
            eig.min() >= -ROUND_OFF * scale,
            "{}: PSD, λ_min = {}",
            shape.name(),
            eig.min()
        );
        let n = grid.num_nodes();
        // Constants, linear and bilinear nodal fields (degree ≤ 1 along each axis) pass unchanged.
        for (a, b, kept) in [
            (0, 0, true),
            (1, 0, true),
            (0, 1, true),
            (1, 1, true),
            (2, 0, false),
            (0, 2, false),
        ] {
            let u = nalgebra::DVector::from_fn(n, |id, _| {
                let [x, y] = grid.node_position(id);
                (x / 7.0).powi(a) * (y / 5.0).powi(b)
            });
            let pu = (&p * &u).amax();
            if kept {
                assert!(
                    pu <= 1e-10 * scale * u.amax(),
                    "{}: P x^{a} y^{b} = {pu:e}",
                    shape.name()
                );
            } else {
                assert!(
                    pu > 1e-6 * scale * u.amax(),
                    "{}: x^{a} y^{b} is penalised",
                    shape.name()
                );
            }
        }
        // Nodes inside the disk, whose whole neighbourhood is well supported, are untouched.
        let phi = relative_support(&m, &lumped);
        let (ci, cj) = (8usize, 8usize);
        let centre = grid.node_index(ci, cj);
        assert!(phi[centre] > 0.9);
        assert_eq!(
            p.row(centre).amax(),
            0.0,
            "{}: the centre node is not penalised",
            shape.name()
        );
    }
}

#[test]
fn the_stencil_form_of_the_linear_extension_penalty_equals_the_compressed_column_one() {
    use sparse_mpm::mass::extension::{extension_penalty, full_support_inertia};
    use sparse_mpm::mass::StencilMass;
    use sparse_mpm::NodeOrder;
    for order in [NodeOrder::XFastest, NodeOrder::YFastest] {
        for shape in SHAPES {
            // A non-square grid, so that the two strides differ.
            let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [18, 16])
                .unwrap()
                .with_node_order(order);
            let particles = disk();
            let ops = Operators::assemble(&grid, shape, &particles).unwrap();
            let lumped = lumped_mass(&ops, &particles.mass);
            let mut active = vec![false; lumped.len()];
            active_nodes(&lumped, 1e-12).into_iter().for_each(|i| active[i] = true);
            let m = consistent_mass(&ops, &particles.mass);
            let (gamma, threshold, onset) = (0.7, 0.5, 0.2);
            let reference = dense(&(&m + &extension_penalty(&ops, &m, &lumped, &active, gamma, threshold, onset)));
            let mut stencil = StencilMass::default();
            stencil.reassemble_extended(&ops, &particles.mass);
            // The widened layout holds the same plain matrix.
            let plain = dense(&stencil.to_csc());
            let scale = dense(&m).abs().max();
            assert!(
                (&plain - dense(&m)).abs().max() <= ROUND_OFF * scale,
                "{} {order:?}: plain",
                shape.name()
            );
            let full = full_support_inertia(shape, &grid);
            stencil.add_extension_penalty(grid.nodes_per_axis(), &lumped, &active, [gamma, threshold, onset], full);
            let stabilized = dense(&stencil.to_csc());
            let penalised = (&reference - dense(&m)).abs().max();
            assert!(penalised > 1e-3 * scale, "{}: the fringe is penalised", shape.name());
            let diff = (&stabilized - &reference).abs().max();
            assert!(
                diff <= ROUND_OFF * scale,
                "{} {order:?}: |M_s − ref| = {diff:e}",
                shape.name()
            );
            // The stencil product is the same matrix, and row sums are the lumped mass.
            let ones = vec![1.0; grid.num_nodes()];
            let row_sums = stencil.mul(&ones);
            for (i, (r, l)) in row_sums.iter().zip(&lumped).enumerate() {
                assert!(
                    (r - l).abs() <= ROUND_OFF * scale,
                    "{}: row {i}: {r} vs {l}",
                    shape.name()
                );
            }
            let x: Vec<f64> = (0..grid.num_nodes())
                .map(|i| ((i * 37 % 101) as f64 - 50.0) / 50.0)
                .collect();
            let y = stencil.mul(&x);
            let expected = &reference * nalgebra::DVector::from_column_slice(&x);
            for i in 0..x.len() {
                assert!(
                    (y[i] - expected[i]).abs() <= 1e-11 * scale,
                    "{}: (M_s x)_{i}",
                    shape.name()
                );
            }
            // Within the diagonal preconditioner: the penalty raises some diagonals above m_L.
            let diagonal = stencil.diagonal();
            assert!(
                (0..diagonal.len()).any(|i| diagonal[i] > lumped[i] * (1.0 + 1e-9)),
                "{}: some diagonal exceeds its row sum",
                shape.name()
            );
        }
    }
}
