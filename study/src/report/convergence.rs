//! The convergence part: the manufactured vortex's displacement error against cell size, and
//! the cost of each scheme against its error.

use std::fmt::Write as _;

use super::{by_label, cells_header, empty_chart, fmt_order, header_rule, mass_label, series, Finished, Groups, Page};
use crate::plot::Chart;
use sparse_mpm::error::Result;
use sparse_mpm::mass::MassScheme;

/// The metric the part plots: the largest RMS displacement error over the amplitude.
const ERROR: &str = "displacement_error_l2";

/// Writes the convergence section: the problem, a table of errors with fitted orders, the
/// plots of error against cell size and of cost against error, and what the consistent mass
/// cost.
pub(super) fn write(ok: &[Finished], page: &mut Page) -> Result<()> {
    writeln!(
        page.md,
        "## Convergence: the generalised vortex\n\nThe manufactured vortex with the smooth profile \
         `g = (1 − ξ²)³` (ring 0.75 < R < 1.25, E = 1000, ν = 0.3, ρ₀ = 1000, amplitude 0.05, to the \
         time of the largest shear) with its body force; unlike the published `(1 − ξ²)²` its shear \
         stress's gradient vanishes at the free surfaces, which leaves no first-order boundary error \
         (docs/verification.md). Error: the largest over time of the volume-weighted RMS particle \
         displacement error, over the amplitude. Local orders between successive grids, then the \
         order fitted to all.\n"
    )
    .ok();
    let groups = by_label(ok);
    let mut chart = empty_chart(
        "Vortex: displacement error against cell size",
        "cell size h",
        "RMS displacement error / amplitude",
        true,
    );
    let mut cost = empty_chart(
        "Cost against error (vortex)",
        "RMS displacement error / amplitude",
        "wall time per step (ms)",
        true,
    );
    table(&groups, page.md, &mut chart, &mut cost);
    page.md.push('\n');
    page.embed(&chart, "convergence")?;
    page.md.push('\n');
    page.embed(&cost, "cost")?;
    writeln!(
        page.md,
        "\nEach line of the cost plot runs from the coarsest grid (right) to the finest (left): a scheme \
         further down and left buys accuracy for less time per step.{}\n",
        consistent_cost(ok)
    )
    .ok();
    Ok(())
}

/// Writes the table of errors (one row per shape and mass, one column per grid, the fitted
/// order last) and adds each row's series to `chart` (error against cell size) and to `cost`
/// (wall time per step against error).
fn table(groups: &Groups, md: &mut String, chart: &mut Chart, cost: &mut Chart) {
    writeln!(
        md,
        "| shape, mass | {} | local orders | fitted order |",
        cells_header(groups)
    )
    .ok();
    writeln!(md, "{}", header_rule(groups, 2)).ok();
    for (_, g) in groups {
        let points: Vec<(f64, f64)> = g
            .iter()
            .map(|(_, o)| (o.cell_size, o.metric(ERROR).unwrap_or(f64::NAN)))
            .collect();
        let label = format!("{}, {}", g[0].0.choices.shape.name(), mass_label(g[0].0));
        let order = fmt_order(&points);
        let local: Vec<String> = points
            .windows(2)
            .map(|w| {
                let o = (w[0].1 / w[1].1).ln() / (w[0].0 / w[1].0).ln();
                if o.is_finite() {
                    format!("{o:.2}")
                } else {
                    "–".into()
                }
            })
            .collect();
        writeln!(
            md,
            "| {label} | {} | {} | {order} |",
            points
                .iter()
                .map(|(_, e)| format!("{e:.2e}"))
                .collect::<Vec<_>>()
                .join(" | "),
            local.join(", ")
        )
        .ok();
        chart.series.push(series(format!("{label} ({order})"), points.clone()));
        cost.series.push(series(label, cost_points(g)));
    }
}

/// `(error, wall time per step in ms)` of each run of one scheme.
fn cost_points(runs: &[Finished]) -> Vec<(f64, f64)> {
    runs.iter()
        .map(|(_, o)| {
            (
                o.metric(ERROR).unwrap_or(f64::NAN),
                1e3 * o.seconds / o.steps.max(1) as f64,
            )
        })
        .collect()
}

/// What the consistent mass cost against the lumped one in the same (shape, cells) runs.
fn consistent_cost(runs: &[Finished]) -> String {
    let mut steps = Vec::new();
    for (r, o) in runs
        .iter()
        .filter(|(r, _)| r.choices.mass.acceleration == MassScheme::Consistent)
    {
        let twin = runs.iter().find(|(q, _)| {
            q.choices.mass.acceleration == MassScheme::Lumped
                && q.choices.shape == r.choices.shape
                && q.cells == r.cells
        });
        if let Some((_, l)) = twin {
            steps.push(o.steps as f64 / l.steps.max(1) as f64);
        }
    }
    if steps.is_empty() {
        return String::new();
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    format!(
        " The consistent mass took {:.1} times as many steps as the lumped mass on the same grids (its \
         stable step is shorter). The wall times are in cost.png and the `*_seconds` columns of runs.csv \
         (`wall_per_step_seconds`); being measured, they differ from one execution of the study to the next, \
         and are the only figures that do.",
        mean(&steps)
    )
}
