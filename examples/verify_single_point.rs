//! A single material point in one bilinear cell (B3) against its exact x(t), v(t).
//!
//! ```text
//! cargo run --release --example verify_single_point
//! ```
//!
//! L = 1, x₀ = ½, M = V = 1, E = 4π², ρ = 1, v₀ = 0.1, Δt = 0.001, to t = 2
//! (`sparse_mpm_study::verification::single_point`); lumped mass, every update scheme, PIC and FLIP.

use sparse_mpm::simulation::{Transfer, UpdateScheme};
use sparse_mpm_study::verification::{single_point, Choices};

fn main() -> Result<(), sparse_mpm::MpmError> {
    println!("single material point: v(t) = v0 cos(2 pi t), x(t) = x0 exp((v0 / 2 pi) sin(2 pi t))");
    for v0 in [single_point::V0, 0.01] {
        println!("v0 = {v0}:");
        for update in [UpdateScheme::Usf, UpdateScheme::Usl, UpdateScheme::Musl] {
            for transfer in [Transfer::Flip, Transfer::Pic] {
                let choices = Choices {
                    update,
                    transfer,
                    ..Choices::default()
                };
                let o = single_point::run(v0, &choices)?;
                let m = |n: &str| o.metric(n).unwrap_or(f64::NAN);
                println!(
                "  {:<28} max |v - v_exact| / v0 = {:.3e}, max |x - x_exact| / amplitude = {:.3e}, energy drift {:.3e}",
                choices.label(),
                m("velocity_error"),
                m("position_error"),
                m("energy_drift")
            );
            }
        }
    }
    Ok(())
}
