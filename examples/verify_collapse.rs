//! The granular column collapse against the experimental laws of quasi-2D collapses (Lube et
//! al. 2005): run-out, final height and the time to rest against the aspect ratio `a`, with the
//! lumped and the consistent mass (docs/verification.md, `sparse_mpm_study::verification::collapse`).
//!
//! ```text
//! cargo run --release --example verify_collapse                  # a = 0.5, 1, 2; lumped and consistent
//! cargo run --release --example verify_collapse -- lumped 0.5 1 2 3 4
//! cargo run --release --example verify_collapse -- lumped/consistent 1 -- 40   # 40 cells across L0
//! cargo run --release --example verify_collapse -- flip lumped consistent 0.5 1 2
//! cargo run --release --example verify_collapse -- lumped 1 2 E=1e8 -- 20     # stiffer grains
//! cargo run --release --example verify_collapse -- flip lumped 0.5 1 mu=0.6  # floor with friction
//! ```
//!
//! Masses: `lumped`, `consistent`, `blended:γ` (both solves). Quadratic B-splines, MUSL, APIC,
//! 2 × 2 particles per cell, Courant number 0.4, 30 cells across `L₀` unless given after `--`.
//! APIC with a lumped velocity projection (`lumped`, or `lumped/consistent`: the consistent mass
//! in the acceleration solve), FLIP with a consistent or blended one (APIC's affine momentum
//! belongs to the lumped projection); `flip` before the masses for FLIP with every mass.

use sparse_mpm::mass::{MassOptions, MassScheme, SingularityPolicy};
use sparse_mpm::shape::ShapeFunction;
use sparse_mpm::simulation::{Transfer, UpdateScheme};
use sparse_mpm_study::verification::collapse::{from_band, Collapse};
use sparse_mpm_study::verification::Choices;

fn scheme(name: &str) -> Option<MassScheme> {
    match name {
        "lumped" => Some(MassScheme::Lumped),
        "consistent" => Some(MassScheme::Consistent),
        _ => name
            .strip_prefix("blended:")
            .and_then(|g| g.parse().ok())
            .map(|gamma| MassScheme::Blended { gamma }),
    }
}

/// `velocity` or `velocity/acceleration` as mass options (a singular consistent mass falls back
/// to the lumped one for the step).
fn mass(name: &str) -> Option<MassOptions> {
    let (v, a) = name.split_once('/').unwrap_or((name, name));
    Some(MassOptions {
        velocity: scheme(v)?,
        acceleration: scheme(a)?,
        singularity: SingularityPolicy::FallbackToLumped,
        ..MassOptions::both(MassScheme::Lumped)
    })
}

fn main() -> sparse_mpm::error::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (args, cells) = match args.iter().position(|a| a == "--") {
        Some(k) => (
            args[..k].to_vec(),
            args.get(k + 1).and_then(|c| c.parse().ok()).unwrap_or(30),
        ),
        None => (args, 30usize),
    };
    let flip = args.iter().any(|a| a == "flip");
    let mut masses: Vec<MassOptions> = args.iter().filter_map(|a| mass(a)).collect();
    let mut aspects: Vec<f64> = args.iter().filter_map(|a| a.parse().ok()).collect();
    // `E=…`: Young's modulus (default 10 MPa).
    let youngs_modulus = args
        .iter()
        .find_map(|a| a.strip_prefix("E=").and_then(|e| e.parse().ok()))
        .unwrap_or(Collapse::new(1.0).youngs_modulus);
    // `mu=…`: a slip floor with Coulomb friction μ instead of the fixed floor.
    let floor_friction = args
        .iter()
        .find_map(|a| a.strip_prefix("mu=").and_then(|m| m.parse().ok()));
    if masses.is_empty() {
        masses = ["lumped", "lumped/consistent"].iter().filter_map(|m| mass(m)).collect();
    }
    if aspects.is_empty() {
        aspects = vec![0.5, 1.0, 2.0];
    }
    let c = Collapse {
        youngs_modulus,
        floor_friction,
        ..Collapse::new(1.0)
    };
    println!(
        "Drucker-Prager phi = {} deg, c = 0, psi = 0, E = {:e}, nu = {}, rho = {}; L0 = {}, {cells} cells across L0; \
         quadratic B-splines, MUSL, 2 x 2 particles per cell, CFL 0.4; run for {} sqrt(H0/g); floor: {}",
        c.friction_angle,
        c.youngs_modulus,
        c.poisson_ratio,
        c.density,
        c.width,
        c.duration,
        floor_friction.map_or("fixed".to_string(), |mu| format!("slip with friction {mu}"))
    );
    println!(
        "| transfer, mass | a | run-out | law (Lube et al.) | off | H/L0 | law | at rest after (sqrt(H0/g)) | \
         dissipated | by friction | energy error | stress deviation | steps | seconds |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for &mass in &masses {
        let transfer = if flip || mass.velocity != MassScheme::Lumped {
            Transfer::Flip
        } else {
            Transfer::Apic
        };
        for &a in &aspects {
            let choices = Choices {
                shape: ShapeFunction::QuadraticBSpline,
                update: UpdateScheme::Musl,
                transfer,
                mass,
                particles_per_cell: 2,
                cfl: 0.4,
                implicit_step: None,
            };
            let o = Collapse { aspect: a, ..c }.run(cells, &choices)?;
            let m = |n: &str| o.metric(n).unwrap_or(f64::NAN);
            let band = (m("law_runout_low"), m("law_runout_high"));
            let law = if band.0 == band.1 {
                format!("{:.2}", band.0)
            } else {
                format!("{:.2}-{:.2}", band.0, band.1)
            };
            println!(
                "| {} | {a} | {:.2} | {law} | {:+.0}% | {:.2} | {:.2} | {:.1} | {:.3} | {:.3} | {:.1e} | {:.3} | {} | {:.1} |",
                choices.label(),
                m("runout"),
                100.0 * from_band(m("runout"), band),
                m("final_height"),
                m("law_height"),
                m("stop_time"),
                m("dissipated"),
                m("friction_dissipated"),
                m("energy_error"),
                m("stress_deviation"),
                o.steps,
                o.seconds
            );
        }
    }
    Ok(())
}
