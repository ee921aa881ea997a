//! The frequency part: the bar's period error against resolution for each mass pair.

use std::fmt::Write as _;

use super::{by_label, cells_header, empty_chart, fmt_order, header_rule, mass_label, series, Finished, Groups, Page};
use crate::plot::Chart;
use crate::small_bar;
use sparse_mpm::error::Result;
use sparse_mpm::mass::MassScheme;
use sparse_mpm::shape::ShapeFunction;

/// The finest run of one mass pair: its mass label, cells and signed period error.
type Finest = (String, f64, f64);

/// Writes the frequency section: the problem, a table of period errors with fitted orders,
/// the plot of `|period error|` against cells, and what the finest grid shows.
pub(super) fn write(ok: &[Finished], page: &mut Page) -> Result<()> {
    intro(page.md);
    let (linear, others): (Vec<Finished>, Vec<Finished>) =
        ok.iter().partition(|(r, _)| r.choices.shape == ShapeFunction::Linear);
    let groups = by_label(&linear);
    let mut chart = empty_chart(
        "Bar period error against resolution",
        "cells along the bar",
        "|period error|",
        true,
    );
    let finest = table(&groups, page.md, &mut chart);
    page.md.push('\n');
    page.embed(&chart, "frequency_error")?;
    conclusion(&finest, page.md);
    kernels(&others, page.md);
    Ok(())
}

/// The interior period-error coefficient `c` in `c θ²/96` of a kernel and mass pair (quarter
/// points, docs/mass.md), where a closed form is known.
fn coefficient(shape: ShapeFunction, velocity: MassScheme, acceleration: MassScheme) -> Option<f64> {
    let lumped = |m: MassScheme| m == MassScheme::Lumped;
    let consistent = |m: MassScheme| m == MassScheme::Consistent;
    let [l, c] = shape.interior_period_error()?;
    if lumped(velocity) && lumped(acceleration) {
        Some(l)
    } else if consistent(velocity) && consistent(acceleration) {
        Some(c)
    } else {
        None
    }
}

/// The table of the other kernels: period error on the two grids, the spatial error (the
/// explicit update's removed) and its order, and the interior theory where known.
fn kernels(others: &[Finished], md: &mut String) {
    let groups = by_label(others);
    if groups.is_empty() {
        return;
    }
    let cells: Vec<usize> = groups[0].1.iter().map(|(r, _)| r.cells).collect();
    let columns: Vec<String> = cells.iter().map(|c| format!("{c} cells")).collect();
    writeln!(
        md,
        "The other kernels on {} cells (mirrored walls, the default for fixed edges of GIMP and the \
         B-splines): period error, the spatial period error (the explicit update's error removed, \
         `Bar::spatial_period`) with its order, and the interior theory `c θ²/96` where docs/mass.md \
         gives it.\n\n| shape | masses | {} | spatial, finest | spatial order | theory, finest |\n|---|---|{}---|---|---|",
        cells.iter().map(|c| c.to_string()).collect::<Vec<_>>().join(" and "),
        columns.join(" | "),
        "---|".repeat(cells.len())
    )
    .ok();
    for (_, g) in &groups {
        let r0 = g[0].0;
        let total: Vec<String> = g
            .iter()
            .map(|(_, o)| {
                o.metric("period_error")
                    .map_or("–".into(), |e| format!("{:+.4}%", 100.0 * e))
            })
            .collect();
        let spatial: Vec<(f64, f64)> = g
            .iter()
            .map(|(r, o)| (r.cells as f64, o.metric("spatial_period_error").unwrap_or(f64::NAN)))
            .collect();
        let order = match spatial.as_slice() {
            [.., a, b] => format!("{:.2}", (a.1.abs() / b.1.abs()).log2() / (b.0 / a.0).log2()),
            _ => "–".into(),
        };
        let finest = spatial.last().copied().unwrap_or((f64::NAN, f64::NAN));
        let theory = coefficient(r0.choices.shape, r0.choices.mass.velocity, r0.choices.mass.acceleration).map_or(
            "–".to_string(),
            |c| {
                let theta = small_bar().wavenumber() * small_bar().length / finest.0;
                format!("{:+.5}%", 100.0 * c * theta * theta / 96.0)
            },
        );
        writeln!(
            md,
            "| {} | {} | {} | {:+.5}% | {order} | {theory} |",
            r0.choices.shape,
            mass_label(r0),
            total.join(" | "),
            100.0 * finest.1
        )
        .ok();
    }
    md.push('\n');
}

/// The section's heading and the problem it solves, with the theory's error terms.
fn intro(md: &mut String) {
    writeln!(
        md,
        "## Frequency error: the vibrating bar\n\nThe bar with both ends fixed (E = 100, ρ = 1, L = 25, \
         first mode, period {}), amplitude 1e-3, two periods, bilinear functions (the other kernels \
         below), FLIP. The period \
         is measured from the zero crossings of the centre-of-mass velocity. Theory for particles at \
         the quarter points (docs/mass.md): lumped `+13θ²/96`, consistent `−5θ²/96`, mixed pairs \
         `+θ²/24`, the blend γ = 13/18 zero at order θ².\n",
        small_bar().period()
    )
    .ok();
}

/// Writes the table of period errors (one row per mass pair, one column per grid, the fitted
/// order last), adds one series per mass pair to `chart`, and returns each pair's finest run.
fn table(groups: &Groups, md: &mut String, chart: &mut Chart) -> Vec<Finest> {
    writeln!(
        md,
        "| masses (velocity/acceleration) | {} | fitted order |",
        cells_header(groups)
    )
    .ok();
    writeln!(md, "{}", header_rule(groups, 1)).ok();
    let mut finest = Vec::new();
    for (_, g) in groups {
        let points: Vec<(f64, f64)> = g
            .iter()
            .map(|(r, o)| (r.cells as f64, o.metric("period_error").unwrap_or(f64::NAN)))
            .collect();
        let magnitudes: Vec<(f64, f64)> = points.iter().map(|&(c, e)| (1.0 / c, e.abs())).collect();
        let order = fmt_order(&magnitudes);
        let mass = mass_label(g[0].0);
        writeln!(
            md,
            "| {mass} | {} | {order} |",
            points
                .iter()
                .map(|(_, e)| format!("{:+.4}%", 100.0 * e))
                .collect::<Vec<_>>()
                .join(" | ")
        )
        .ok();
        if let Some(&(c, e)) = points.last() {
            finest.push((mass.clone(), c, e));
        }
        chart.series.push(series(
            format!("{mass} (order {order})"),
            points.iter().map(|&(c, e)| (c, e.abs())).collect(),
        ));
    }
    finest
}

/// What the finest grid shows: the lumped against the consistent error, and each mass
/// pair's sign of the error.
fn conclusion(finest: &[Finest], md: &mut String) {
    let find = |m: &str| finest.iter().find(|f| f.0 == m);
    if let (Some(l), Some(c)) = (find("lumped"), find("consistent")) {
        writeln!(
            md,
            "\nAt {} cells the {} mass errs by {:+.4}% and the {} mass by {:+.4}% (a ratio of {:.1}); \
             the fitted orders are in the table, and the mixed pairs and the blend, where run, sit \
             between or below them.",
            l.1,
            l.0,
            100.0 * l.2,
            c.0,
            100.0 * c.2,
            (l.2 / c.2).abs()
        )
        .ok();
    }
    let signs: Vec<String> = finest
        .iter()
        .map(|f| format!("{} {}", f.0, if f.2 > 0.0 { "lengthens" } else { "shortens" }))
        .collect();
    writeln!(md, "Sign of the error: {}.", signs.join(", ")).ok();
    md.push('\n');
}
