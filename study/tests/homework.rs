//! The seed assignment's answers, checked against a computation written here from the
//! assignment's formulas alone: a loop over every (node, particle) pair with the tent
//! function, dense sums, and the readings stated in docs/homework.md.

use sparse_mpm_study::homework::{self, data::*};

/// Independent sums of a handful of terms agree with the library to rounding.
const TOL: f64 = 1e-12;

const NODES: usize = 6;
const PARTICLES: usize = 4;

fn tent(xi: f64) -> f64 {
    (1.0 - xi.abs()).max(0.0)
}

/// N(n,p) from the node coordinates, cell size 1.
fn n(node: usize, p: usize) -> f64 {
    tent(X_P[p] - X_G[node]) * tent(Y_P[p] - Y_G[node])
}

/// (dN/dx, dN/dy) away from grid lines (no seed particle lies on one).
fn dn(node: usize, p: usize) -> (f64, f64) {
    let (dx, dy) = (X_P[p] - X_G[node], Y_P[p] - Y_G[node]);
    let d = |xi: f64| if xi.abs() < 1.0 { -xi.signum() } else { 0.0 };
    (d(dx) * tent(dy), tent(dx) * d(dy))
}

struct Reference {
    mass: [[f64; NODES]; NODES],
    lumped: [f64; NODES],
    fext: [[f64; 2]; NODES],
    fint: [[f64; 2]; NODES],
    acc: [[f64; 2]; NODES],
    vgrid: [[f64; 2]; NODES],
    vnew: [[f64; 2]; NODES],
    x_seed: [[f64; 2]; PARTICLES],
    x_std: [[f64; 2]; PARTICLES],
    v: [[f64; 2]; PARTICLES],
    rate: [[f64; 3]; PARTICLES],
    stress: [[f64; 3]; PARTICLES],
}

fn reference() -> Reference {
    let mut r = Reference {
        mass: [[0.0; NODES]; NODES],
        lumped: [0.0; NODES],
        fext: [[0.0; 2]; NODES],
        fint: [[0.0; 2]; NODES],
        acc: [[0.0; 2]; NODES],
        vgrid: [[0.0; 2]; NODES],
        vnew: [[0.0; 2]; NODES],
        x_seed: [[0.0; 2]; PARTICLES],
        x_std: [[0.0; 2]; PARTICLES],
        v: [[0.0; 2]; PARTICLES],
        rate: [[0.0; 3]; PARTICLES],
        stress: [[0.0; 3]; PARTICLES],
    };
    for a in 0..NODES {
        let mut q = [0.0; 2];
        for p in 0..PARTICLES {
            for b in 0..NODES {
                r.mass[a][b] += n(b, p) * n(a, p) * MASS;
            }
            r.lumped[a] += n(a, p) * MASS;
            r.fext[a][0] += n(a, p) * MASS * BODY_FORCE[0];
            r.fext[a][1] += n(a, p) * MASS * BODY_FORCE[1];
            let (gx, gy) = dn(a, p);
            r.fint[a][0] -= VOLUME * (gx * SXX[p] + gy * SXY[p]);
            r.fint[a][1] -= VOLUME * (gx * SXY[p] + gy * SYY[p]);
            q[0] += n(a, p) * MASS * VX[p];
            q[1] += n(a, p) * MASS * VY[p];
        }
        if r.lumped[a] != 0.0 {
            for k in 0..2 {
                r.acc[a][k] = (r.fext[a][k] + r.fint[a][k]) / r.lumped[a];
                r.vgrid[a][k] = q[k] / r.lumped[a];
                r.vnew[a][k] = r.vgrid[a][k] + r.acc[a][k] * DT;
            }
        }
    }
    let (c11, c12) = (E / (1.0 - NU * NU), NU * E / (1.0 - NU * NU));
    let g = E / (2.0 * (1.0 + NU));
    for p in 0..PARTICLES {
        let (mut vi, mut ai, mut l) = ([0.0; 2], [0.0; 2], [[0.0; 2]; 2]);
        for a in 0..NODES {
            let (gx, gy) = dn(a, p);
            for k in 0..2 {
                vi[k] += n(a, p) * r.vnew[a][k];
                ai[k] += n(a, p) * r.acc[a][k];
                l[k][0] += r.vnew[a][k] * gx;
                l[k][1] += r.vnew[a][k] * gy;
            }
        }
        let (x0, v0) = ([X_P[p], Y_P[p]], [VX[p], VY[p]]);
        for k in 0..2 {
            r.x_seed[p][k] = x0[k] + DT / 2.0 * (v0[k] + vi[k]);
            r.x_std[p][k] = x0[k] + DT * vi[k];
            r.v[p][k] = v0[k] + DT * ai[k];
        }
        r.rate[p] = [l[0][0], l[1][1], 0.5 * (l[0][1] + l[1][0])];
        let [exx, eyy, exy] = r.rate[p];
        r.stress[p] = [
            SXX[p] + DT * (c11 * exx + c12 * eyy),
            SYY[p] + DT * (c12 * exx + c11 * eyy),
            SXY[p] + DT * 2.0 * g * exy,
        ];
    }
    r
}

fn close(a: f64, b: f64) -> bool {
    approx::relative_eq!(a, b, epsilon = TOL, max_relative = TOL)
}

#[test]
fn shape_function_n_3_2_is_0_057_by_hand() {
    // Node 3 at (1, 0), particle 2 at (1.7, 0.81): (1 − 0.7)(1 − 0.81) = 0.3 · 0.19.
    let hw = homework::solve().unwrap();
    assert!(close(hw.n_3_2, 0.057), "N(3,2) = {}", hw.n_3_2);
}

#[test]
fn shape_functions_and_gradients_match_the_pairwise_formula() {
    let hw = homework::solve().unwrap();
    for a in 0..NODES {
        for p in 0..PARTICLES {
            assert!(close(hw.shape_values[(a, p)], n(a, p)), "shape n={a} p={p}");
            assert!(close(hw.n[(a, p)], n(a, p)), "N n={a} p={p}");
            let (gx, gy) = dn(a, p);
            assert!(
                close(hw.shape_dx[(a, p)], gx) && close(hw.gx[(a, p)], gx),
                "dN/dx n={a} p={p}"
            );
            assert!(
                close(hw.shape_dy[(a, p)], gy) && close(hw.gy[(a, p)], gy),
                "dN/dy n={a} p={p}"
            );
        }
    }
    for (p, s) in hw.column_sums.iter().enumerate() {
        assert!(close(*s, 1.0), "column {p} sums to {s}");
    }
}

#[test]
fn mass_matrix_and_lumped_mass_match_the_pairwise_formula() {
    let hw = homework::solve().unwrap();
    let r = reference();
    for a in 0..NODES {
        for b in 0..NODES {
            assert!(close(hw.mass_matrix[(a, b)], r.mass[a][b]), "m({a},{b})");
        }
        assert!(close(hw.step.mass.lumped()[a], r.lumped[a]), "M({a})");
        assert!(close(hw.row_sums[a], r.lumped[a]), "row sum {a}");
    }
    // By hand: node 3 collects 0.2 + 0.057 + 0.518 + 0.152 from the four particles.
    let by_hand = [0.0, 0.0, 0.927, 1.073, 1.013, 0.987];
    for (a, m) in by_hand.iter().enumerate() {
        assert!(close(hw.step.mass.lumped()[a], *m), "lumped mass at node {}", a + 1);
    }
}

#[test]
fn forces_accelerations_and_grid_velocities_match_the_pairwise_formula() {
    let hw = homework::solve().unwrap();
    let (r, s) = (reference(), &hw.step);
    for a in 0..NODES {
        let pairs = [
            (&s.external_force, r.fext[a]),
            (&s.internal_force, r.fint[a]),
            (&s.acceleration, r.acc[a]),
            (&s.grid_velocity, r.vgrid[a]),
            (&s.updated_grid_velocity, r.vnew[a]),
        ];
        for (k, (field, want)) in pairs.iter().enumerate() {
            assert!(
                close(field.x[a], want[0]) && close(field.y[a], want[1]),
                "quantity {k} at node {a}"
            );
        }
    }
    assert_eq!(hw.active_nodes_1_based(), vec![3, 4, 5, 6]);
}

#[test]
fn particle_updates_match_the_pairwise_formula() {
    let hw = homework::solve().unwrap();
    let (r, after) = (reference(), &hw.after);
    for p in 0..PARTICLES {
        assert!(
            close(after.x[p], r.x_seed[p][0]) && close(after.y[p], r.x_seed[p][1]),
            "4(C) seed rule p={p}"
        );
        let std = &hw.position_standard;
        assert!(
            close(std.x[p], r.x_std[p][0]) && close(std.y[p], r.x_std[p][1]),
            "4(C) standard p={p}"
        );
        assert!(
            close(after.vx[p], r.v[p][0]) && close(after.vy[p], r.v[p][1]),
            "4(D) p={p}"
        );
        let rate = &hw.step.strain_rate;
        assert!(close(rate.xx[p], r.rate[p][0]), "4(E) exx p={p}");
        assert!(close(rate.yy[p], r.rate[p][1]), "4(E) eyy p={p}");
        assert!(close(rate.xy[p], r.rate[p][2]), "4(E) exy p={p}");
        assert!(close(after.sxx[p], r.stress[p][0]), "4(F) sxx p={p}");
        assert!(close(after.syy[p], r.stress[p][1]), "4(F) syy p={p}");
        assert!(close(after.sxy[p], r.stress[p][2]), "4(F) sxy p={p}");
    }
}

#[test]
fn consistent_accelerations_solve_the_mass_matrix_system() {
    let hw = homework::solve().unwrap();
    let (r, a) = (reference(), &hw.acceleration_consistent);
    for i in 0..NODES {
        // Σ_j m(i,j) a_j = F_i + f_i on the active nodes.
        let mut row = [0.0; 2];
        for j in 0..NODES {
            row[0] += r.mass[i][j] * a.x[j];
            row[1] += r.mass[i][j] * a.y[j];
        }
        let f = [r.fext[i][0] + r.fint[i][0], r.fext[i][1] + r.fint[i][1]];
        if r.lumped[i] > 0.0 {
            assert!(
                (row[0] - f[0]).abs() < 1e-9 && (row[1] - f[1]).abs() < 1e-9,
                "residual at node {i}"
            );
        } else {
            assert_eq!((a.x[i], a.y[i]), (0.0, 0.0), "inactive node {i}");
        }
    }
}

#[test]
fn json_holds_every_question_with_numbers() {
    let hw = homework::solve().unwrap();
    let json = hw.to_json();
    let keys = [
        "1A_shape_N",
        "1B_dshape_dN_dx",
        "1B_dshape_dN_dy",
        "1C_N_3_2",
        "1D_N",
        "1D_column_sums",
        "2A_mass_matrix",
        "2B_lumped_mass",
        "2C_row_sums",
        "3A_external_force",
        "3B_internal_force",
        "3C_acceleration_lumped",
        "3C_acceleration_consistent",
        "4A_grid_velocity",
        "4B_updated_grid_velocity",
        "4C_position_seed_rule",
        "4C_position_standard",
        "4D_velocity",
        "4E_strain_rate",
        "4F_stress",
        "4F_stress_literal_as_typed",
    ];
    for key in keys {
        assert!(json.get(key).is_some(), "missing {key}");
    }
    assert_eq!(json["1C_N_3_2"].as_f64(), Some(hw.n_3_2));
    assert_eq!(json["2A_mass_matrix"][2][3].as_f64(), Some(hw.mass_matrix[(2, 3)]));
    assert_eq!(json["4F_stress"]["xy"][1].as_f64(), Some(hw.after.sxy[1]));
}

#[test]
fn report_labels_every_question() {
    let report = homework::solve().unwrap().report();
    for q in [
        "1(A)", "1(B)", "1(C)", "1(D)", "2(A)", "2(B)", "2(C)", "3(A)", "3(B)", "3(C)", "4(A)", "4(B)", "4(C)", "4(D)",
        "4(E)", "4(F)",
    ] {
        assert!(report.contains(q), "report lacks {q}");
    }
    assert!(report.contains("N(3,2) = 0.05700000"));
    assert!(
        !report.contains("NaN") && !report.contains("inf"),
        "a non-finite number was printed"
    );
}
