//! The axially vibrating bar, fixed–free (B1) and fixed–fixed (B2), against its exact solution
//! under lumped and consistent mass and PIC and FLIP, at three resolutions.
//!
//! ```text
//! cargo run --release --example verify_bar
//! ```
//!
//! E = 100, ρ = 1, L = 25, v₀ = 0.1, first mode, two periods, 2 × 2 particles per cell, MUSL,
//! Courant number 0.2 of each scheme's stable step (`sparse_mpm_study::verification::bar`). Printed:
//! the RMS error of the centre-of-mass velocity (relative to its amplitude), the period error
//! and the energy drift; and the fitted order of the period error over the resolutions.

use sparse_mpm::mass::{MassOptions, MassScheme};
use sparse_mpm::simulation::Transfer;
use sparse_mpm_study::verification::bar::{Bar, Ends};
use sparse_mpm_study::verification::{fitted_order, Choices};

const CELLS: [usize; 3] = [10, 20, 40];

fn main() -> Result<(), sparse_mpm::MpmError> {
    for ends in [Ends::FixedFree, Ends::FixedFixed] {
        let bar = Bar {
            amplitude: 0.001,
            ..Bar::new(ends)
        };
        println!("{} (period {}):", bar.name(), bar.period());
        for (mass, transfer) in [
            (MassScheme::Lumped, Transfer::Flip),
            (MassScheme::Consistent, Transfer::Flip),
            (MassScheme::Lumped, Transfer::Pic),
            (MassScheme::Consistent, Transfer::Pic),
        ] {
            let choices = Choices {
                mass: MassOptions::both(mass),
                transfer,
                cfl: 0.2,
                ..Choices::default()
            };
            let mut periods = Vec::new();
            for cells in CELLS {
                let o = bar.run(cells, &choices)?;
                let m = |n: &str| o.metric(n).unwrap_or(f64::NAN);
                println!(
                    "  {:<32} {cells:>3} cells: v_cm RMS error {:>8.4}%, period error {:>+9.4}%, energy drift {:>8.4}%",
                    choices.label(),
                    100.0 * m("rms_error"),
                    100.0 * m("period_error"),
                    100.0 * m("energy_drift")
                );
                periods.push((o.cell_size, m("period_error").abs()));
            }
            println!(
                "  {:<32} fitted order of |period error|: {:.2}",
                "",
                fitted_order(&periods).unwrap_or(f64::NAN)
            );
        }
    }
    Ok(())
}
