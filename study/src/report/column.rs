//! The column part: the stress error of the column under its own weight against the cell
//! size, per kernel, quasi-static and relaxed dynamically with each mass.

use std::fmt::Write as _;

use super::{empty_chart, fmt_order, mass_label, series, Finished, Page};
use sparse_mpm::error::Result;

/// The runs of one kind (`problem` and mass label) and shape, as `(cells, error)` in order.
fn errors(ok: &[Finished], shape: &str, problem: &str, mass: Option<&str>) -> Vec<(usize, f64)> {
    ok.iter()
        .filter(|(r, o)| {
            r.choices.shape.name() == shape && o.problem == problem && mass.is_none_or(|m| mass_label(r) == m)
        })
        .map(|(r, o)| (r.cells, o.metric("stress_error").unwrap_or(f64::NAN)))
        .collect()
}

/// Writes the column section: the problem, one table row per kernel and kind of run (errors on
/// each grid and the order fitted to them), and the plot of the errors against the cell count.
pub(super) fn write(ok: &[Finished], page: &mut Page) -> Result<()> {
    writeln!(
        page.md,
        "## The column under its own weight\n\nAn elastic column (l0 = 50, one cell wide, ν = 0, ρ₀ = 80, \
         g = 10, 2 × 2 particles per cell) with its base fixed and its sides on rollers, whose stress is \
         σ_yy = −ρ₀ g (l0 − Y) at any deformation. The error is Σ |σ_yy − σ_exact| V⁰ / Σ ρ₀ g l0 V⁰ \
         (docs/verification.md). Quasi-static: 20 load increments with the exact tangent, no mass, at E = \
         1 MPa (4% strain) and E = 10 kPa (the column ends at a third of its height). Relaxed: the explicit \
         step under the weight, applied over two periods of the first mode, with local damping (α = 0.8) \
         until its motion has settled, E = 1 MPa, with each mass: how close the damped dynamics comes to the static answer, and whether the mass \
         changes the cell-crossing noise it settles with.\n"
    )
    .ok();
    let mut shapes: Vec<&str> = Vec::new();
    for (r, _) in ok {
        if !shapes.contains(&r.choices.shape.name()) {
            shapes.push(r.choices.shape.name());
        }
    }
    let kinds: [(&str, &str, Option<&str>); 4] = [
        ("quasi-static, E = 1 MPa", "column", None),
        ("quasi-static, E = 10 kPa", "column_large_strain", None),
        ("relaxed, lumped", "column_relaxed", Some("lumped")),
        ("relaxed, consistent", "column_relaxed", Some("consistent")),
    ];
    let cells: Vec<usize> = shapes
        .first()
        .map(|s| errors(ok, s, "column", None).iter().map(|&(c, _)| c).collect())
        .unwrap_or_default();
    writeln!(
        page.md,
        "| shape | run | {} | fitted order |\n|---|---|{}---|",
        cells
            .iter()
            .map(|c| format!("{c} cells"))
            .collect::<Vec<_>>()
            .join(" | "),
        "---|".repeat(cells.len())
    )
    .ok();
    let mut chart = empty_chart(
        "Column: stress error against cells",
        "cells along the height",
        "stress error",
        true,
    );
    for shape in &shapes {
        for (label, problem, mass) in kinds {
            let e = errors(ok, shape, problem, mass);
            if e.is_empty() {
                continue;
            }
            let points: Vec<(f64, f64)> = e.iter().map(|&(c, v)| (1.0 / c as f64, v)).collect();
            writeln!(
                page.md,
                "| {shape} | {label} | {} | {} |",
                e.iter()
                    .map(|(_, v)| format!("{v:.2e}"))
                    .collect::<Vec<_>>()
                    .join(" | "),
                fmt_order(&points)
            )
            .ok();
            chart.series.push(series(
                format!("{shape}, {label}"),
                e.iter().map(|&(c, v)| (c as f64, v)).collect(),
            ));
        }
    }
    page.md.push('\n');
    page.embed(&chart, "column")?;
    writeln!(
        page.md,
        "\nBilinear functions do not converge on the column (the cell-crossing error of their \
         discontinuous gradients); GIMP and the B-splines do, until the quasi-static increments' quadrature \
         at particles moved off their reference positions stops the quadratic B-splines near 1e-3 \
         (docs/verification.md).\n"
    )
    .ok();
    Ok(())
}
