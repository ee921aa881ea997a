//! The cantilever part: tip deflection on three grids and its Richardson extrapolation.

use std::fmt::Write as _;

use super::{by_label, cells_header, empty_chart, header_rule, mass_label, series, Finished, Page};
use crate::plot::Chart;
use crate::verification::cantilever;
use sparse_mpm::error::Result;

/// Writes the cantilever section: the problem, a table of tip deflections per mass and grid
/// with the extrapolated limit and observed order, and the plot of the finest runs' tip
/// deflection against time.
pub(super) fn write(ok: &[Finished], page: &mut Page) -> Result<()> {
    writeln!(
        page.md,
        "## The cantilever: a refinement study\n\nThe shipped cantilever (4 × 1 neo-Hookean beam under \
         gravity, released at rest) on three grids, each twice as fine, with quadratic B-splines \
         (bilinear functions lock in bending). No closed form: the largest tip deflection is \
         extrapolated (Richardson) from the three where the differences shrink.\n"
    )
    .ok();
    let groups = by_label(ok);
    writeln!(
        page.md,
        "| mass | {} | extrapolated | observed order |",
        cells_header(&groups)
    )
    .ok();
    writeln!(page.md, "{}", header_rule(&groups, 2)).ok();
    let mut chart = empty_chart("Cantilever: tip deflection", "time", "downward tip displacement", false);
    for (_, g) in &groups {
        row(g, page.md);
        add_finest_history(g, &mut chart);
    }
    page.md.push('\n');
    page.embed(&chart, "cantilever")?;
    page.md.push('\n');
    Ok(())
}

/// Writes the table row of one mass: the largest tip deflection on each grid, and the limit
/// and order extrapolated from three grids ("–" otherwise).
fn row(runs: &[Finished], md: &mut String) {
    let values: Vec<f64> = runs
        .iter()
        .map(|(_, o)| o.metric("tip_deflection").unwrap_or(f64::NAN))
        .collect();
    let extrapolated = if values.len() == 3 {
        cantilever::extrapolate([values[0], values[1], values[2]], 2.0)
    } else {
        None
    };
    let (limit, order) = extrapolated.map_or(("–".into(), "–".into()), |(f, p)| {
        (format!("{f:.4}"), format!("{p:.2}"))
    });
    writeln!(
        md,
        "| {} | {} | {limit} | {order} |",
        mass_label(runs[0].0),
        values.iter().map(|v| format!("{v:.4}")).collect::<Vec<_>>().join(" | ")
    )
    .ok();
}

/// Adds the tip deflection against time of the finest of `runs` to `chart`.
fn add_finest_history(runs: &[Finished], chart: &mut Chart) {
    if let Some((r, o)) = runs.last() {
        if let Some(h) = o.history("tip_deflection") {
            chart.series.push(series(
                format!("{}, {} cells", mass_label(r), r.cells),
                h.time.iter().copied().zip(h.value.iter().copied()).collect(),
            ));
        }
    }
}
