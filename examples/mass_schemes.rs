//! The seed assignment's grid solve `a = M⁻¹ f` under every mass scheme, side by side.
//!
//! ```text
//! cargo run --release --example mass_schemes
//! ```
//!
//! Same grid, particles, stresses and body force as src/homework.rs (2 × 1 cells, 4 particles
//! in the right cell). For each scheme: the grid accelerations at the active nodes, what the
//! solve reports, the critical time step `2/ω_max` (E = 100, ν = 0.3, plane stress), and the
//! mass diagnostics. The check at the end: the truncated series `Σ_{l<k} (I − M_L⁻¹M)^l M_L⁻¹`
//! must approach the consistent solve as k grows, and `Blended{γ = 1}` must equal it.

use sparse_mpm::mass::{Constraints, GridMass, MassDiagnostics, MassOptions, MassScheme, Role};
use sparse_mpm::stiffness::critical_time_step;
use sparse_mpm::transfer::{external_force, internal_force, VectorField};
use sparse_mpm::{Operators, ShapeFunction};
use sparse_mpm_study::homework::data::*;

const SCHEMES: [MassScheme; 8] = [
    MassScheme::Lumped,
    MassScheme::Consistent,
    MassScheme::Blended { gamma: 0.5 },
    MassScheme::TruncatedSeries { k: 2 },
    MassScheme::TruncatedSeries { k: 4 },
    MassScheme::TruncatedSeries { k: 16 },
    MassScheme::Iterative {
        tolerance: 1e-10,
        max_iterations: 200,
    },
    MassScheme::Blended { gamma: 1.0 },
];

fn main() -> sparse_mpm::Result<()> {
    // Setup: the seed's grid (nodes numbered up each column, as x_g, y_g) and particles.
    let (grid, particles, material) = sparse_mpm_study::homework::setup()?;
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &particles)?;
    let (m, vol) = (&particles.mass, &particles.volume);

    // f = f_ext + f_int = N (m ∘ b) − [Gx (V∘σxx) + Gy (V∘σxy); Gx (V∘σxy) + Gy (V∘σyy)]
    let f = external_force(&ops, m, &particles.bx, &particles.by).add_scaled(
        1.0,
        &internal_force(&ops, vol, &particles.sxx, &particles.syy, &particles.sxy),
    );

    // Loop: a = M⁻¹ f under each scheme, with its report, critical time step and diagnostics.
    let mut a = Vec::new();
    let mut rows = Vec::new();
    let mut active = Vec::new();
    for scheme in SCHEMES {
        let options = MassOptions::plain(scheme);
        let mass = GridMass::new(&ops, m, &options, &Constraints::none())?;
        let (a_s, report) = mass.solve(Role::Acceleration, &f, None, &ops)?;
        let dt_crit = critical_time_step(&ops, vol, &material, &mass, Role::Acceleration)?;
        let diag = MassDiagnostics::compute(&ops, m, &options)?;
        active = mass.active_nodes();
        a.push(a_s);
        rows.push((format!("{:#}", scheme), report, dt_crit, diag));
    }

    println!("Seed problem (2 x 1 cells, 4 particles, m = {MASS}, V = {VOLUME}): a = M^-1 (f_ext + f_int)");
    println!(
        "active nodes (1-based): {:?}\n",
        active.iter().map(|i| i + 1).collect::<Vec<_>>()
    );
    for (name, comp) in [("a_x", 0), ("a_y", 1)] {
        print!("{:>6}", name);
        for (label, ..) in &rows {
            print!(" {label:>13}");
        }
        println!();
        for &i in &active {
            print!("{:>6}", format!("n={}", i + 1));
            for a_s in &a {
                let v = if comp == 0 { a_s.x[i] } else { a_s.y[i] };
                print!(" {v:>13.6}");
            }
            println!();
        }
        println!();
    }

    println!("Solve reports, critical time steps (E = {E}, nu = {NU}, plane stress) and mass diagnostics");
    println!(
        "{:>14} {:>5} {:>10} {:>11} {:>8} {:>17} {:>4} {:>7} {:>13} {:>10}",
        "scheme",
        "iters",
        "rel.res",
        "dt_crit",
        "/lumped",
        "nodal mass range",
        "tiny",
        "nullity",
        "lmin(ML^-1MC)",
        "cond"
    );
    let dt_lumped = rows[0].2;
    for (label, report, dt_crit, d) in &rows {
        println!(
            "{:>14} {:>5} {:>10.2e} {:>11.5e} {:>8.4} {:>8.4}..{:<7.4} {:>4} {:>7} {:>13.5} {:>10.4}",
            label,
            report.iterations,
            report.relative_residual,
            dt_crit,
            dt_crit / dt_lumped,
            d.min_nodal_mass,
            d.max_nodal_mass,
            d.tiny_mass_nodes,
            d.nullity_estimate,
            d.lambda_min_estimate,
            d.condition_number
        );
    }
    println!("(iterations: CG iterations or series terms, summed over x and y; nullity, lambda_min are of M_C");
    println!(" and do not depend on the scheme; cond is of the matrix the scheme solves with)\n");

    // Comparison: FMPM(k) → consistent as k grows; Blended{1} = consistent.
    let consistent = &a[1];
    println!("Check: max |a(scheme) - a(consistent)| over active nodes and components");
    for k in [1, 2, 4, 16, 64] {
        let a_k = solve(&ops, m, MassScheme::TruncatedSeries { k }, &f)?;
        println!("  series(k = {k:>2}) vs consistent: {:.3e}", max_diff(&a_k, consistent));
    }
    println!("  blended(1.0)    vs consistent: {:.3e}", max_diff(&a[7], consistent));
    println!("  cg(1e-10)       vs consistent: {:.3e}", max_diff(&a[6], consistent));
    let lambda = rows[0].3.lambda_min_estimate;
    println!(
        "  (the series error shrinks like (1 - lambda_min)^k = {:.3}^k, lambda_min(ML^-1 MC) = {lambda:.4})",
        1.0 - lambda
    );
    Ok(())
}

fn solve(ops: &Operators, m: &[f64], scheme: MassScheme, f: &VectorField) -> sparse_mpm::Result<VectorField> {
    let mass = GridMass::new(ops, m, &MassOptions::plain(scheme), &Constraints::none())?;
    Ok(mass.solve(Role::Acceleration, f, None, ops)?.0)
}

fn max_diff(a: &VectorField, b: &VectorField) -> f64 {
    a.x.iter()
        .chain(&a.y)
        .zip(b.x.iter().chain(&b.y))
        .map(|(u, v)| (u - v).abs())
        .fold(0.0, f64::max)
}
