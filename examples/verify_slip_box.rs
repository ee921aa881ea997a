//! The box on roller walls: an exact dilatational mode whose velocity is odd across each wall
//! in its normal component and even in its tangential one. The spatial period error of each
//! kernel and mass as the grid is refined, with the walls mirrored (the default) and held
//! (docs/mass.md, "Slip (roller) walls and symmetry planes").
//!
//! ```text
//! cargo run --release --example verify_slip_box
//! ```

use sparse_mpm::boundary::WallRule;
use sparse_mpm::mass::{MassOptions, MassScheme};
use sparse_mpm::shape::ShapeFunction;
use sparse_mpm_study::verification::slip_box::SlipBox;
use sparse_mpm_study::verification::Choices;

fn main() -> sparse_mpm::error::Result<()> {
    let kernels = [
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
        ShapeFunction::Gimp { half_width: 0.25 },
    ];
    println!("| kernel | mass | walls | 16 | 32 | 64 | order 32→64 |");
    println!("|---|---|---|---|---|---|---|");
    for shape in kernels {
        for mass in [MassScheme::Lumped, MassScheme::Consistent] {
            for wall in [WallRule::Mirror, WallRule::Held] {
                if wall == WallRule::Held && mass == MassScheme::Consistent {
                    continue;
                }
                let b = SlipBox {
                    wall: Some(wall),
                    ..SlipBox::HALF
                };
                let choices = Choices {
                    shape,
                    mass: MassOptions::both(mass),
                    cfl: 0.2,
                    ..Choices::default()
                };
                let mut errors = Vec::new();
                for cells in [16, 32, 64] {
                    errors.push(
                        b.run(cells, &choices)?
                            .metric("spatial_period_error")
                            .unwrap_or(f64::NAN),
                    );
                }
                let order = (errors[1].abs() / errors[2].abs()).log2();
                println!(
                    "| {shape} | {mass} | {} | {:+.3e} | {:+.3e} | {:+.3e} | {order:.2} |",
                    wall.name(),
                    errors[0],
                    errors[1],
                    errors[2]
                );
            }
        }
    }
    Ok(())
}
