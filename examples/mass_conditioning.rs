//! Rank and conditioning of the consistent mass `M_C = N diag(m) Nᵀ` as the particle layout
//! changes, and what that does to the consistent solve and the critical time step.
//!
//! ```text
//! cargo run --release --example mass_conditioning
//! ```
//!
//! Cases on a 12 × 12 grid of unit cells: a 10 × 10-cell block with 1×1, 2×2 and 3×3 particles
//! per cell at regular positions, and a disk (radius 4.3, centre (6.1, 5.9)) cut from 2×2
//! particles per cell, so its boundary cells are partly filled. One particle per cell gives
//! P = 100 particles for 121 active nodes: `rank M_C = rank N ≤ 100`, so `M_C` is singular and
//! the consistent solve must refuse it. The nullity is checked against an SVD of the dense N Nᵀ.

use nalgebra::DMatrix;
use sparse_mpm::mass::{
    solve_condition_number, Constraints, GridMass, MassDiagnostics, MassOptions, MassScheme, Role, SingularityPolicy,
};
use sparse_mpm::material::{LinearElastic, PlaneCondition};
use sparse_mpm::stiffness::critical_time_step;
use sparse_mpm::transfer::{external_force, VectorField};
use sparse_mpm::{Grid, MpmError, Operators, Particles, ShapeFunction};

const CELLS: usize = 12; // grid cells per side, h = 1
const RHO: f64 = 1.0;
const DISK_CENTRE: [f64; 2] = [6.1, 5.9];
const DISK_RADIUS: f64 = 4.3;

fn main() -> sparse_mpm::Result<()> {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [CELLS, CELLS])?;
    let cases = [
        ("block 1x1 ppc", block(1, 1..11, 1..11)?),
        ("block 2x2 ppc", block(2, 1..11, 1..11)?),
        ("block 3x3 ppc", block(3, 1..11, 1..11)?),
        ("disk 2x2 ppc", disk(2)?),
    ];

    // Section 1: rank and conditioning per case.
    println!("Consistent mass M_C = N diag(m) N^T on a {CELLS}x{CELLS} grid (h = 1, rho = {RHO})\n");
    println!(
        "{:<14} {:>5} {:>5} {:>6} {:>7} {:>13} {:>10} {:>4} {:>17}  GridMass::new(Consistent, Error)",
        "case", "nodes", "P", "active", "nullity", "lmin(ML^-1MC)", "cond(M_C)", "tiny", "nodal mass range"
    );
    for (name, p) in &cases {
        let ops = Operators::assemble(&grid, ShapeFunction::Linear, p)?;
        let consistent = MassOptions::plain(MassScheme::Consistent);
        let d = MassDiagnostics::compute(&ops, &p.mass, &consistent)?;
        let outcome = match GridMass::new(&ops, &p.mass, &consistent, &Constraints::none()) {
            Ok(_) => "ok".to_string(),
            Err(e) => short(&e, &grid),
        };
        println!(
            "{:<14} {:>5} {:>5} {:>6} {:>7} {:>13.4e} {:>10.3e} {:>4} {:>8.4}..{:<7.4}  {}",
            name,
            grid.num_nodes(),
            p.len(),
            d.active_nodes,
            d.nullity_estimate,
            d.lambda_min_estimate,
            d.condition_number,
            d.tiny_mass_nodes,
            d.min_nodal_mass,
            d.max_nodal_mass,
            outcome
        );
    }

    // The singular case under the two policies that let the step go on. Two loads: gravity
    // (a rigid-body acceleration, which every mass reproducing rigid motion gets exactly) and a
    // checkerboard f_I = ±m_L,I, which lies in the null space of M_C here (each centre particle
    // sees the average of its four nodes, and a checkerboard averages to zero).
    let p = &cases[0].1;
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, p)?;
    let zeros = vec![0.0; p.len()];
    let gravity = external_force(&ops, &p.mass, &zeros, &vec![-9.81; p.len()]);
    let m_l = sparse_mpm::mass::lumped_mass(&ops, &p.mass);
    let checker = VectorField {
        x: vec![0.0; grid.num_nodes()],
        y: (0..grid.num_nodes())
            .map(|k| {
                let (i, j) = grid.node_ij(k);
                if (i + j) % 2 == 0 {
                    m_l[k]
                } else {
                    -m_l[k]
                }
            })
            .collect(),
    };
    println!("\nblock 1x1 ppc, Consistent with the other singularity policies:");
    for policy in [
        SingularityPolicy::FallbackToLumped,
        SingularityPolicy::Regularize { epsilon: 0.05 },
    ] {
        let options = MassOptions {
            singularity: policy,
            ..MassOptions::plain(MassScheme::Consistent)
        };
        let mass = GridMass::new(&ops, &p.mass, &options, &Constraints::none())?;
        let (a_g, report) = mass.solve(Role::Acceleration, &gravity, None, &ops)?;
        let (a_c, report_c) = mass.solve(Role::Acceleration, &checker, None, &ops)?;
        println!("  {policy:?}: outcome {:?}", report.outcome);
        println!(
            "    cond of the matrix solved {:.3e}; gravity: a_y in [{:.4}, {:.4}] (res. {:.1e}); \
             checkerboard +-m_L: max |a_y| = {:.3} (res. {:.1e})",
            solve_condition_number(&mass, &ops)?,
            range(&mass.active_nodes(), &a_g.y).0,
            range(&mass.active_nodes(), &a_g.y).1,
            report.relative_residual,
            max_abs(&a_c),
            report_c.relative_residual,
        );
    }
    println!("  (lumped gives |a| = 1 for the checkerboard; (1 - eps) M_C + eps M_L gives up to 1/eps = 20)");

    // Cross-check of the nullity: SVD of the dense N Nᵀ on the active nodes.
    println!("\nNullity cross-check, 1 particle per cell (Cholesky pivot count vs SVD of dense N N^T):");
    for (label, cells, range) in [
        ("3x3-cell block on 5x5 grid", 5, 1..4),
        ("10x10-cell block on 12x12 grid", 12, 1..11),
    ] {
        let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [cells, cells])?;
        let p = block(1, range.clone(), range)?;
        let ops = Operators::assemble(&grid, ShapeFunction::Linear, &p)?;
        let d = MassDiagnostics::compute(&ops, &p.mass, &MassOptions::plain(MassScheme::Consistent))?;
        let n = DMatrix::from(&ops.n_matrix());
        let lumped = sparse_mpm::mass::lumped_mass(&ops, &p.mass);
        let active: Vec<usize> = (0..n.nrows()).filter(|&i| lumped[i] > 0.0).collect();
        let n_a = n.select_rows(&active);
        let sv = (&n_a * n_a.transpose()).singular_values();
        let max = sv.max();
        let zero = sv.iter().filter(|&&s| s <= 1e-12 * max).count();
        let smallest_nonzero = sv
            .iter()
            .cloned()
            .filter(|&s| s > 1e-12 * max)
            .fold(f64::INFINITY, f64::min);
        let largest_zero = sv.iter().cloned().filter(|&s| s <= 1e-12 * max).fold(0.0, f64::max);
        println!(
            "  {label:<31} active {:>3}, P {:>3}: nullity estimate {:>2}, SVD nullity {:>2} \
             (expected active - P = {:>2}; sigma: largest 'zero' {largest_zero:.1e}, smallest nonzero {smallest_nonzero:.1e})",
            active.len(),
            p.len(),
            d.nullity_estimate,
            zero,
            active.len() - p.len(),
        );
    }

    // Section 2: critical time steps for the 2×2 block.
    let material = LinearElastic::new(1e4, 0.3, PlaneCondition::Strain)?;
    let p = &cases[1].1;
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, p)?;
    let c = material.wave_speed(RHO);
    println!(
        "\nCritical time step 2/omega_max, block 2x2 ppc, E = 1e4, nu = 0.3 plane strain, rho = {RHO} \
         (c_p = {c:.2}, h/c_p = {:.4e})",
        1.0 / c
    );
    println!("{:>14} {:>12} {:>10}", "scheme", "dt_crit", "/lumped");
    let mut dt_lumped = f64::NAN;
    for scheme in [
        MassScheme::Lumped,
        MassScheme::Blended { gamma: 0.5 },
        MassScheme::Consistent,
        MassScheme::TruncatedSeries { k: 2 },
    ] {
        let mass = GridMass::new(&ops, &p.mass, &MassOptions::plain(scheme), &Constraints::none())?;
        let dt = critical_time_step(&ops, &p.volume, &material, &mass, Role::Acceleration)?;
        if scheme == MassScheme::Lumped {
            dt_lumped = dt;
        }
        println!("{:>#14} {:>12.5e} {:>10.4}", scheme, dt, dt / dt_lumped);
    }
    println!(
        "(1D linear elements: consistent/lumped = 1/sqrt(3) = {:.4})",
        1.0 / 3f64.sqrt()
    );
    Ok(())
}

/// `ppc × ppc` particles per cell at the regular positions `(k + ½)/ppc` of every cell in
/// `cx × cy`, volume `h²/ppc²`, mass `ρ V`.
fn block(ppc: usize, cx: std::ops::Range<usize>, cy: std::ops::Range<usize>) -> sparse_mpm::Result<Particles> {
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in cy {
        for i in cx.clone() {
            for b in 0..ppc {
                for a in 0..ppc {
                    x.push(i as f64 + (a as f64 + 0.5) / ppc as f64);
                    y.push(j as f64 + (b as f64 + 0.5) / ppc as f64);
                }
            }
        }
    }
    with_mass(x, y, 1.0 / (ppc * ppc) as f64)
}

/// The particles of a 2×2-per-cell fill of the whole grid that lie inside the disk.
fn disk(ppc: usize) -> sparse_mpm::Result<Particles> {
    let all = block(ppc, 0..CELLS, 0..CELLS)?;
    let inside: Vec<usize> = (0..all.len())
        .filter(|&p| (all.x[p] - DISK_CENTRE[0]).hypot(all.y[p] - DISK_CENTRE[1]) < DISK_RADIUS)
        .collect();
    let pick = |v: &[f64]| inside.iter().map(|&p| v[p]).collect::<Vec<_>>();
    with_mass(pick(&all.x), pick(&all.y), 1.0 / (ppc * ppc) as f64)
}

fn with_mass(x: Vec<f64>, y: Vec<f64>, volume: f64) -> sparse_mpm::Result<Particles> {
    let np = x.len();
    Particles::new(x, y, vec![RHO * volume; np], vec![volume; np])
}

/// A one-line version of a `GridMass::new` error.
fn short(e: &MpmError, grid: &Grid) -> String {
    match e {
        MpmError::SingularMassMatrix {
            node,
            particles,
            relative_pivot,
            ..
        } => {
            let [x, y] = grid.node_position(*node);
            format!(
                "SingularMassMatrix at node {node} ({x}, {y}), pivot {relative_pivot:.1e}, {} particles touch it",
                particles.len()
            )
        }
        other => other.to_string().chars().take(80).collect(),
    }
}

fn range(active: &[usize], v: &[f64]) -> (f64, f64) {
    active.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &i| {
        (l.min(v[i]), h.max(v[i]))
    })
}

fn max_abs(v: &VectorField) -> f64 {
    v.x.iter().chain(&v.y).fold(0.0, |m, a| m.max(a.abs()))
}
