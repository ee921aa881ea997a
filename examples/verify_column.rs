//! The elastic column under its own weight, quasi-static: the stress error against the exact
//! `σ_yy(Y) = −ρ₀ g (l0 − Y)` for each kernel as the grid is refined, and its observed order
//! (docs/verification.md).
//!
//! ```text
//! cargo run --release --example verify_column            # E = 1 MPa (small strain)
//! cargo run --release --example verify_column -- large   # E = 10 kPa (the column halves)
//! ```

use sparse_mpm::shape::FAMILIES;
use sparse_mpm_study::verification::column::Column;
use sparse_mpm_study::verification::Choices;

fn main() -> sparse_mpm::error::Result<()> {
    let large = std::env::args().nth(1).as_deref() == Some("large");
    let column = if large {
        Column::LARGE_STRAIN
    } else {
        Column::SMALL_STRAIN
    };
    println!(
        "column E = {} Pa, rho0 = {}, g = {}, l0 = {}, {} load steps, 2 x 2 particles per cell",
        column.youngs_modulus, column.density, column.gravity, column.height, column.load_steps
    );
    println!("| shape | cells high | stress error | order | Newton (max) | final height / l0 |");
    println!("|---|---|---|---|---|---|");
    for shape in FAMILIES {
        let choices = Choices {
            shape,
            ..Choices::default()
        };
        let mut last: Option<(usize, f64)> = None;
        for cells in [8, 16, 32, 64] {
            let o = column.run(cells, &choices)?;
            let e = o.metric("stress_error").unwrap_or(f64::NAN);
            let order = last.map_or("–".to_string(), |(c, e0)| {
                format!("{:.2}", (e0 / e).ln() / (cells as f64 / c as f64).ln())
            });
            println!(
                "| {} | {cells} | {e:.3e} | {order} | {} | {:.4} |",
                shape.name(),
                o.metric("newton_iterations").unwrap_or(f64::NAN),
                o.metric("final_height").unwrap_or(f64::NAN)
            );
            last = Some((cells, e));
        }
    }
    Ok(())
}
