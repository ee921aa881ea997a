//! The two tiers of particle ↔ grid products agree: the fused kernels the time loop calls
//! (`sparse_mpm::kernels`) equal the single products of `transfer` and `mass` to round-off, for
//! every shape function, transfer and update scheme.

mod common;

use sparse_mpm::kernels::{self, ApicInertia, G2pRule, GridField, GridState, P2gTerms, ParticleScratch, Stress};
use sparse_mpm::mass::lumped_mass;
use sparse_mpm::parallel::Workers;
use sparse_mpm::simulation::Transfer;
use sparse_mpm::step::PositionUpdate;
use sparse_mpm::transfer::{external_force, internal_force, interpolate, momentum, velocity_gradient, VectorField};
use sparse_mpm::{Grid, Operators, Particles, ShapeFunction};

/// Round-off allowance relative to the largest magnitude compared.
const ROUND_OFF: f64 = 1e-12;

const SHAPES: [ShapeFunction; 4] = sparse_mpm::shape::FAMILIES;

fn close(a: &[f64], b: &[f64], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    let scale = a.iter().chain(b).map(|v| v.abs()).fold(1e-300, f64::max);
    let diff = a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    assert!(
        diff <= ROUND_OFF * scale,
        "{what}: differ by {diff:e} (scale {scale:e})"
    );
}

fn close_field(a: &VectorField, b: &VectorField, what: &str) {
    close(&a.x, &b.x, &format!("{what} x"));
    close(&a.y, &b.y, &format!("{what} y"));
}

/// Random particles inside the region every kernel accepts, with random affine moments.
fn setup(shape: ShapeFunction, seed: u64) -> (Grid, Operators, Particles) {
    let grid = Grid::new([0.0, 0.0], [0.25, 0.25], [12, 12]).unwrap();
    let (mut x, mut y) = common::random_positions(&grid, 150, seed);
    // Keep clear of the edge by the widest margin (cubic: 2 cells).
    for v in x.iter_mut().chain(y.iter_mut()) {
        *v = 0.55 + *v * (1.9 / 3.0);
    }
    let mut p = common::random_particles_at(x, y, seed);
    for k in 0..p.len() {
        let s = (k as f64 * 0.37).sin();
        p.affine_xx[k] = 0.3 * s;
        p.affine_xy[k] = -0.2 * s;
        p.affine_yx[k] = 0.1;
        p.affine_yy[k] = 0.25 * (k as f64).cos();
    }
    let ops = Operators::assemble(&grid, shape, &p).unwrap();
    (grid, ops, p)
}

/// `Σ_p N_Ip m_p C_p (x_I − x_p)`, written independently of the kernels.
fn apic_term(ops: &Operators, grid: &Grid, p: &Particles, inertia: ApicInertia) -> VectorField {
    let mut out = VectorField::zeros(ops.num_nodes());
    for k in 0..p.len() {
        let b = [p.affine_xx[k], p.affine_xy[k], p.affine_yx[k], p.affine_yy[k]];
        let d = match inertia {
            ApicInertia::StoredC => [1.0, 1.0],
            ApicInertia::Constant(d) => d,
            ApicInertia::Column => {
                let mut d = [0.0, 0.0];
                for (i, n, _, _) in ops.column(k) {
                    let [xi, yi] = grid.node_position(i);
                    d[0] += n * (xi - p.x[k]).powi(2);
                    d[1] += n * (yi - p.y[k]).powi(2);
                }
                d
            }
        };
        let c = [b[0] / d[0], b[1] / d[1], b[2] / d[0], b[3] / d[1]];
        for (i, n, _, _) in ops.column(k) {
            let [xi, yi] = grid.node_position(i);
            let (dx, dy) = (xi - p.x[k], yi - p.y[k]);
            out.x[i] += n * p.mass[k] * (c[0] * dx + c[1] * dy);
            out.y[i] += n * p.mass[k] * (c[2] * dx + c[3] * dy);
        }
    }
    out
}

#[test]
fn p2g_equals_the_single_products_for_every_shape_function_with_and_without_apic() {
    let gravity = [0.3, -9.8];
    for (s, shape) in SHAPES.into_iter().enumerate() {
        let (grid, ops, p) = setup(shape, 11 + s as u64);
        let m_l = lumped_mass(&ops, &p.mass);
        let q = momentum(&ops, &p.mass, &p.vx, &p.vy);
        let f_ext = external_force(&ops, &p.mass, &p.bx, &p.by);
        let f_int = internal_force(&ops, &p.volume, &p.sxx, &p.syy, &p.sxy);
        let with_gravity = |f: &VectorField| VectorField {
            x: (0..f.len()).map(|i| f.x[i] + m_l[i] * gravity[0]).collect(),
            y: (0..f.len()).map(|i| f.y[i] + m_l[i] * gravity[1]).collect(),
        };
        for apic in [None, Some(ApicInertia::of(shape, &grid))] {
            let mut state = GridState::new(&grid);
            let mut lumped = vec![0.0; grid.num_nodes()];
            kernels::p2g(
                &ops,
                &p,
                P2gTerms {
                    apic,
                    gravity,
                    stress: Stress::Include,
                },
                &mut lumped,
                &mut state,
                &Workers::default(),
            );
            close(&lumped, &m_l, "m_L");
            let expected_q = match apic {
                None => q.clone(),
                Some(kind) => q.add_scaled(1.0, &apic_term(&ops, &grid, &p, kind)),
            };
            close_field(&state.momentum, &expected_q, &format!("{} q", shape.name()));
            close_field(&state.force, &with_gravity(&f_ext.add_scaled(1.0, &f_int)), "f");
            let omit = Stress::Omit;
            kernels::p2g(
                &ops,
                &p,
                P2gTerms {
                    apic,
                    gravity,
                    stress: omit,
                },
                &mut lumped,
                &mut state,
                &Workers::default(),
            );
            close_field(&state.force, &with_gravity(&f_ext), "f without stress");
            // USF adds the internal force afterwards.
            kernels::add_internal_force(&ops, &p.volume, &p.sxx, &p.syy, &p.sxy, &mut state.force);
            close_field(
                &state.force,
                &with_gravity(&f_ext.add_scaled(1.0, &f_int)),
                "f after USF",
            );
            // MUSL's re-projection is the momentum again.
            kernels::reproject_momentum(&ops, &p, apic, &mut state, &Workers::default());
            close_field(&state.momentum, &expected_q, "q'");
        }
    }
}

/// A grid state with random projected and updated velocities (and series and motion fields).
fn random_grid(grid: &Grid, seed: u64) -> GridState {
    let mut state = GridState::new(grid);
    let n = grid.num_nodes();
    let f = |i: usize, a: f64| ((i as f64 + seed as f64) * a).sin();
    for i in 0..n {
        state.projected.x[i] = f(i, 0.7);
        state.projected.y[i] = f(i, 1.3);
        state.updated.x[i] = f(i, 0.7) + 0.1 * f(i, 2.1);
        state.updated.y[i] = f(i, 1.3) - 0.2 * f(i, 0.4);
        state.series.x[i] = f(i, 0.9);
        state.series.y[i] = f(i, 1.9);
        state.motion.x[i] = f(i, 0.3);
        state.motion.y[i] = f(i, 2.7);
    }
    state
}

#[test]
fn g2p_equals_the_single_products_for_every_transfer_position_rule_and_update_scheme() {
    let dt = 1e-2;
    let transfers = [
        Transfer::Pic,
        Transfer::Flip,
        Transfer::Blend { flip: 0.7 },
        Transfer::Apic,
        Transfer::Xpic { k: 3 },
        Transfer::Fmpm { k: 3 },
    ];
    for (s, shape) in SHAPES.into_iter().enumerate() {
        let (grid, ops, p0) = setup(shape, 31 + s as u64);
        let state = random_grid(&grid, s as u64);
        let (v, w, series) = (&state.projected, &state.updated, &state.series);
        let v_pic = interpolate(&ops, w);
        let v_ref = interpolate(&ops, v);
        let v_series = interpolate(&ops, series);
        let v_motion = interpolate(&ops, &state.motion);
        // The implicit step moves the particles by its motion field (never with a series
        // transfer).
        let motions = |t: Transfer| match t {
            Transfer::Xpic { .. } | Transfer::Fmpm { .. } => vec![None],
            _ => vec![None, Some(GridField::Motion)],
        };
        for transfer in transfers {
            for (position, motion) in [PositionUpdate::GridVelocity, PositionUpdate::Trapezoidal]
                .into_iter()
                .flat_map(|position| motions(transfer).into_iter().map(move |m| (position, m)))
            {
                // USL asks for the gradient of the field the stress reads; MUSL and USF do not.
                for gradient in [
                    None,
                    Some(GridField::Updated),
                    Some(GridField::Series),
                    Some(GridField::Motion),
                ] {
                    let mut p = p0.clone();
                    let mut scratch = ParticleScratch::default();
                    let rule = G2pRule {
                        transfer,
                        position,
                        inertia: ApicInertia::of(shape, &grid),
                        gradient,
                        motion,
                    };
                    kernels::g2p(&ops, &state, &rule, dt, &mut p, &mut scratch, &Workers::default());
                    let what = format!("{} {transfer:?} {position:?} {gradient:?} {motion:?}", shape.name());
                    let expected: (Vec<f64>, Vec<f64>) = (0..p.len())
                        .map(|k| {
                            let (old, pic, dv) = (
                                [p0.vx[k], p0.vy[k]],
                                [v_pic.x[k], v_pic.y[k]],
                                [v_pic.x[k] - v_ref.x[k], v_pic.y[k] - v_ref.y[k]],
                            );
                            let pick = |c: usize| match transfer {
                                Transfer::Pic | Transfer::Apic => pic[c],
                                Transfer::Flip => old[c] + dv[c],
                                Transfer::Blend { flip } => flip * (old[c] + dv[c]) + (1.0 - flip) * pic[c],
                                _ => [v_series.x[k], v_series.y[k]][c],
                            };
                            (pick(0), pick(1))
                        })
                        .unzip();
                    close(&p.vx, &expected.0, &format!("{what}: vx"));
                    close(&p.vy, &expected.1, &format!("{what}: vy"));
                    let displacement: (Vec<f64>, Vec<f64>) = (0..p.len())
                        .map(|k| {
                            let (old, new) = ([p0.vx[k], p0.vy[k]], [p.vx[k], p.vy[k]]);
                            let rate = |c: usize| match transfer {
                                _ if motion.is_some() => [v_motion.x[k], v_motion.y[k]][c],
                                Transfer::Xpic { .. } => [v_ref.x[k], v_ref.y[k]][c] + 0.5 * (new[c] - old[c]),
                                Transfer::Fmpm { .. } => 0.5 * (old[c] + new[c]),
                                _ if position == PositionUpdate::Trapezoidal => {
                                    0.5 * (old[c] + [v_pic.x[k], v_pic.y[k]][c])
                                }
                                _ => [v_pic.x[k], v_pic.y[k]][c],
                            };
                            (dt * rate(0), dt * rate(1))
                        })
                        .unzip();
                    close(&scratch.displacement.x, &displacement.0, &format!("{what}: dx"));
                    close(&scratch.displacement.y, &displacement.1, &format!("{what}: dy"));
                    if let Some(field) = gradient {
                        let l = velocity_gradient(&ops, state.field(field));
                        let got = &scratch.velocity_gradient;
                        for (c, want) in [&l.xx, &l.xy, &l.yx, &l.yy].into_iter().enumerate() {
                            close(&got[c], want, &format!("{what}: L[{c}]"));
                        }
                    }
                    if transfer == Transfer::Apic {
                        // B_p = Σ_I N_I w_I (x_I − x_p)ᵀ (GIMP, B-splines); bilinear: C_p = Gᵀ w.
                        let l = velocity_gradient(&ops, w);
                        for k in 0..p.len() {
                            let b = if shape == ShapeFunction::Linear {
                                [l.xx[k], l.xy[k], l.yx[k], l.yy[k]]
                            } else {
                                let mut b = [0.0; 4];
                                for (i, n, _, _) in ops.column(k) {
                                    let [xi, yi] = grid.node_position(i);
                                    let (dx, dy) = (xi - p0.x[k], yi - p0.y[k]);
                                    b = [
                                        b[0] + n * w.x[i] * dx,
                                        b[1] + n * w.x[i] * dy,
                                        b[2] + n * w.y[i] * dx,
                                        b[3] + n * w.y[i] * dy,
                                    ];
                                }
                                b
                            };
                            let got = [p.affine_xx[k], p.affine_xy[k], p.affine_yx[k], p.affine_yy[k]];
                            close(&got, &b, &format!("{what}: B of particle {k}"));
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn the_velocity_gradient_kernel_equals_the_single_products() {
    for (s, shape) in SHAPES.into_iter().enumerate() {
        let (grid, ops, _) = setup(shape, 51 + s as u64);
        let state = random_grid(&grid, 3);
        let mut l = [Vec::new(), Vec::new(), Vec::new(), Vec::new()];
        kernels::velocity_gradient_into(&ops, &state.updated, &mut l, &Workers::default());
        let want = velocity_gradient(&ops, &state.updated);
        for (c, w) in [&want.xx, &want.xy, &want.yx, &want.yy].into_iter().enumerate() {
            close(&l[c], w, &format!("{} L[{c}]", shape.name()));
        }
    }
}

/// p2g's `Σ_I x_I × q_I` equals the sum over the node positions of `Grid::node_position`, for
/// both node orders (the kernel forms the coordinates as it walks the nodes).
#[test]
fn p2g_angular_momentum_equals_the_sum_over_node_positions_in_both_node_orders() {
    for order in [
        sparse_mpm::grid::NodeOrder::XFastest,
        sparse_mpm::grid::NodeOrder::YFastest,
    ] {
        for shape in SHAPES {
            let (grid, _, p) = setup(shape, 29);
            let grid = grid.with_node_order(order);
            let ops = Operators::assemble(&grid, shape, &p).unwrap();
            let mut state = GridState::new(&grid);
            let mut lumped = vec![0.0; grid.num_nodes()];
            let workers = Workers::default();
            let terms = P2gTerms {
                apic: None,
                gravity: [0.0, 0.0],
                stress: Stress::Include,
            };
            kernels::p2g(&ops, &p, terms, &mut lumped, &mut state, &workers);
            let expected: f64 = (0..grid.num_nodes())
                .map(|i| {
                    let [x, y] = grid.node_position(i);
                    x * state.momentum.y[i] - y * state.momentum.x[i]
                })
                .sum();
            let scale: f64 = (0..grid.num_nodes())
                .map(|i| {
                    let [x, y] = grid.node_position(i);
                    (x * state.momentum.y[i]).abs() + (y * state.momentum.x[i]).abs()
                })
                .sum();
            assert!(
                (state.angular_momentum - expected).abs() <= ROUND_OFF * scale,
                "{order:?} {}: {} against {expected}",
                shape.name(),
                state.angular_momentum
            );
        }
    }
}

/// (8b) with one work array reused over several configurations equals the mean of the
/// touching particles' interpolated velocities, written here from the operators' columns.
#[test]
fn the_massless_node_extension_with_reused_work_arrays_equals_the_mean_of_its_particles() {
    let mut scratch = kernels::ExtensionScratch::default();
    for (s, shape) in SHAPES.into_iter().enumerate() {
        for seed in [3u64, 8] {
            let (grid, ops, p) = setup(shape, seed + s as u64);
            let n = grid.num_nodes();
            let m_l = lumped_mass(&ops, &p.mass);
            let max = m_l.iter().cloned().fold(0.0, f64::max);
            // Light nodes count as inactive, so that many supports hold some.
            let is_active: Vec<bool> = m_l.iter().map(|&m| m > 0.2 * max).collect();
            let v0 = random_grid(&grid, seed).projected;
            let (mut sum, mut count) = (vec![[0.0; 2]; n], vec![0usize; n]);
            for k in 0..p.len() {
                let column: Vec<_> = ops.column(k).collect();
                let vp = column.iter().fold([0.0, 0.0], |[x, y], &(i, nv, _, _)| {
                    [x + nv * v0.x[i], y + nv * v0.y[i]]
                });
                for &(i, ..) in column.iter().filter(|&&(i, ..)| !is_active[i]) {
                    sum[i] = [sum[i][0] + vp[0], sum[i][1] + vp[1]];
                    count[i] += 1;
                }
            }
            let mut v = v0.clone();
            assert!(kernels::extend_to_inactive_nodes(
                &ops,
                &is_active,
                &mut v,
                &mut scratch
            ));
            let expected = VectorField {
                x: (0..n)
                    .map(|i| {
                        if count[i] > 0 {
                            sum[i][0] / count[i] as f64
                        } else {
                            v0.x[i]
                        }
                    })
                    .collect(),
                y: (0..n)
                    .map(|i| {
                        if count[i] > 0 {
                            sum[i][1] / count[i] as f64
                        } else {
                            v0.y[i]
                        }
                    })
                    .collect(),
            };
            close_field(
                &v,
                &expected,
                &format!("{} seed {seed}: extended velocity", shape.name()),
            );
            // The extension as a matrix: E v0 on the nodes it reaches, nothing elsewhere.
            let e = sparse_mpm::transfer::extension_matrix(&ops, &is_active);
            let (mut ex, mut ey) = (vec![0.0; n], vec![0.0; n]);
            for (i, j, &w) in e.triplet_iter() {
                ex[i] += w * v0.x[j];
                ey[i] += w * v0.y[j];
            }
            for i in 0..n {
                let (want, got) = if count[i] > 0 {
                    ([v.x[i], v.y[i]], [ex[i], ey[i]])
                } else {
                    ([0.0, 0.0], [ex[i], ey[i]])
                };
                for c in 0..2 {
                    assert!(
                        (got[c] - want[c]).abs() <= 1e-12 * (1.0 + want[c].abs()),
                        "{} seed {seed}: E v at node {i}: {} against {}",
                        shape.name(),
                        got[c],
                        want[c]
                    );
                }
            }
        }
    }
}
