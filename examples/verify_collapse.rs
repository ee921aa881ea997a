//! The granular column collapse against the experimental laws of quasi-2D collapses (Lube et
//! al. 2005): run-out, final height and the time to rest against the aspect ratio `a`, with the
//! lumped and the consistent mass (docs/verification.md, `sparse_mpm_study::verification::collapse`).
//!
//! ```text
//! cargo run --release --example verify_collapse                  # a = 0.5, 1, 2; lumped and consistent
//! cargo run --release --example verify_collapse -- lumped 0.5 1 2 3 4
//! cargo run --release --example verify_collapse -- blended:0.5 1 -- 40   # 40 cells across L0
//! ```
//!
//! Masses: `lumped`, `consistent`, `blended:γ` (both solves). Quadratic B-splines, MUSL, APIC,
//! 2 × 2 particles per cell, Courant number 0.4, 20 cells across `L₀` unless given after `--`.

use sparse_mpm::mass::{MassOptions, MassScheme};
use sparse_mpm::shape::ShapeFunction;
use sparse_mpm::simulation::{Transfer, UpdateScheme};
use sparse_mpm_study::verification::collapse::{from_band, Collapse};
use sparse_mpm_study::verification::Choices;

fn mass(name: &str) -> Option<MassScheme> {
    match name {
        "lumped" => Some(MassScheme::Lumped),
        "consistent" => Some(MassScheme::Consistent),
        _ => name
            .strip_prefix("blended:")
            .and_then(|g| g.parse().ok())
            .map(|gamma| MassScheme::Blended { gamma }),
    }
}

fn main() -> sparse_mpm::error::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (args, cells) = match args.iter().position(|a| a == "--") {
        Some(k) => (args[..k].to_vec(), args[k + 1].parse().unwrap_or(20)),
        None => (args, 20usize),
    };
    let mut masses: Vec<MassScheme> = args.iter().filter_map(|a| mass(a)).collect();
    let mut aspects: Vec<f64> = args.iter().filter_map(|a| a.parse().ok()).collect();
    if masses.is_empty() {
        masses = vec![MassScheme::Lumped, MassScheme::Consistent];
    }
    if aspects.is_empty() {
        aspects = vec![0.5, 1.0, 2.0];
    }
    let c = Collapse::new(1.0);
    println!(
        "Drucker-Prager phi = {} deg, c = 0, psi = 0, E = {:e}, nu = {}, rho = {}; L0 = {}, {cells} cells across L0; \
         quadratic B-splines, MUSL, APIC, 2 x 2 particles per cell, CFL 0.4; run for {} sqrt(H0/g)",
        c.friction_angle, c.youngs_modulus, c.poisson_ratio, c.density, c.width, c.duration
    );
    println!(
        "| mass | a | run-out | law (Lube et al.) | off | H/L0 | law | at rest after (sqrt(H0/g)) | \
         dissipated | energy error | stress deviation | steps | seconds |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for &scheme in &masses {
        for &a in &aspects {
            let choices = Choices {
                shape: ShapeFunction::QuadraticBSpline,
                update: UpdateScheme::Musl,
                transfer: Transfer::Apic,
                mass: MassOptions::both(scheme),
                particles_per_cell: 2,
                cfl: 0.4,
                implicit_step: None,
            };
            let o = Collapse::new(a).run(cells, &choices)?;
            let m = |n: &str| o.metric(n).unwrap_or(f64::NAN);
            let band = (m("law_runout_low"), m("law_runout_high"));
            let law = if band.0 == band.1 {
                format!("{:.2}", band.0)
            } else {
                format!("{:.2}-{:.2}", band.0, band.1)
            };
            println!(
                "| {scheme:#} | {a} | {:.2} | {law} | {:+.0}% | {:.2} | {:.2} | {:.1} | {:.3} | {:.1e} | {:.3} | {} | {:.1} |",
                m("runout"),
                100.0 * from_band(m("runout"), band),
                m("final_height"),
                m("law_height"),
                m("stop_time"),
                m("dissipated"),
                m("energy_error"),
                m("stress_deviation"),
                o.steps,
                o.seconds
            );
        }
    }
    Ok(())
}
