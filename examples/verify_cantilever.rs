//! The cantilever under gravity (B9): no closed form, so a refinement study of the largest tip
//! deflection with its Richardson extrapolation, for the lumped and the consistent mass.
//!
//! ```text
//! cargo run --release --example verify_cantilever
//! ```
//!
//! The shipped scene `scenes/cantilever.toml` (a 4 × 1 neo-Hookean beam, E = 1e7, ν = 0.3,
//! ρ = 1050, g = 10, clamped at x = 0, released at rest, to t = 1.5) on 8, 16 and 32 cells along
//! the beam, quadratic B-splines (bilinear functions lock in bending), MUSL, FLIP, Courant number
//! 0.2 (`sparse_mpm_study::verification::cantilever`).

use sparse_mpm::mass::{MassOptions, MassScheme};
use sparse_mpm::ShapeFunction;
use sparse_mpm_study::verification::{cantilever, Choices};

const CELLS: [usize; 3] = [8, 16, 32];

fn main() -> Result<(), sparse_mpm::MpmError> {
    println!("cantilever: largest downward tip deflection (small-deflection theory: about 0.8 for a sudden release)");
    for scheme in [MassScheme::Lumped, MassScheme::Consistent] {
        let choices = Choices {
            shape: ShapeFunction::QuadraticBSpline,
            mass: MassOptions::both(scheme),
            cfl: 0.2,
            ..Choices::default()
        };
        let mut f = [0.0; 3];
        for (k, cells) in CELLS.into_iter().enumerate() {
            f[k] = cantilever::run(cells, &choices)?
                .metric("tip_deflection")
                .unwrap_or(f64::NAN);
        }
        let extrapolated = match cantilever::extrapolate(f, 2.0) {
            Some((limit, order)) => format!("extrapolated {limit:.4} (observed order {order:.2})"),
            None => "the differences do not shrink yet: no extrapolation".into(),
        };
        println!(
            "  {:<#11} {} cells: {:.4}, {:.4}, {:.4}; {extrapolated}",
            scheme,
            CELLS.map(|c| c.to_string()).join(", "),
            f[0],
            f[1],
            f[2]
        );
    }
    Ok(())
}
