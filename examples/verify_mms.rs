//! Manufactured solutions with their body forces: the axis-aligned displacement field (B5) and
//! the generalised vortex (B6), displacement error against the exact motion at four
//! resolutions, and the fitted convergence order, for each shape function.
//!
//! ```text
//! cargo run --release --example verify_mms
//! ```
//!
//! `sparse_mpm_study::verification::manufactured`: B5 on the unit square (E = 1e4, ν = 0.3, ρ₀ = 1,
//! A = 0.05, one period, rollers), B6 on the ring 0.75 < R < 1.25 (E = 1000, ν = 0.3,
//! ρ₀ = 1000, A = 0.05 here: the published A = 1 shears the ring sevenfold), to the time of the
//! largest shear. 2 × 2 particles per cell, MUSL, FLIP, lumped mass, Courant number 0.2.
//! Printed: `max_t` of the volume-weighted RMS displacement error over the amplitude.

use sparse_mpm::ShapeFunction;
use sparse_mpm_study::verification::manufactured::{run, AxisAlignedMms, GeneralisedVortex, Manufactured};
use sparse_mpm_study::verification::{fitted_order, Choices};

fn study(problem: &impl Manufactured, cells: &[usize]) -> Result<(), sparse_mpm::MpmError> {
    println!("{}:", problem.name());
    for shape in [
        ShapeFunction::Linear,
        ShapeFunction::Gimp { half_width: 0.25 },
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
    ] {
        let choices = Choices {
            shape,
            cfl: 0.2,
            ..Choices::default()
        };
        let mut points = Vec::new();
        let mut line = format!("  {:<18}", shape.name());
        for &c in cells {
            match run(problem, c, &choices) {
                Ok(o) => {
                    let e = o.metric("displacement_error_l2").unwrap_or(f64::NAN);
                    line += &format!(" {c:>3}: {e:.3e}");
                    points.push((o.cell_size, e));
                }
                Err(e) => {
                    line += &format!(
                        " {c:>3}: failed ({})",
                        e.to_string().chars().take(40).collect::<String>()
                    )
                }
            }
        }
        println!("{line}   order {:.2}", fitted_order(&points).unwrap_or(f64::NAN));
    }
    Ok(())
}

fn main() -> Result<(), sparse_mpm::MpmError> {
    study(&AxisAlignedMms::default(), &[8, 16, 32, 64])?;
    let vortex = GeneralisedVortex {
        amplitude: 0.05,
        ..GeneralisedVortex::default()
    };
    study(&vortex, &[16, 32, 64, 128])?;
    Ok(())
}
