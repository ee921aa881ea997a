//! The time-step part: the stable step of each mass and `λ_min(M_L⁻¹M)` against particles per
//! cell.

use std::fmt::Write as _;

use super::{empty_chart, series, Finished, Page};
use crate::plot::Chart;
use sparse_mpm::error::Result;

/// Writes the time-step section: the problem, a table of stable steps and `λ_min` per
/// particle count, the plots of both, and where the consistent mass is singular.
pub(super) fn write(ok: &[Finished], page: &mut Page) -> Result<()> {
    writeln!(
        page.md,
        "## Stable step and conditioning against particles per cell\n\nAn 8 × 8-cell block at rest \
         (E = 1000, ν = 0.3, plane strain), FLIP: the stable step of the update with each mass \
         (the estimate of docs/mass.md, in units of h/c) and `λ_min(M_L⁻¹M)` of the plain consistent \
         mass (0: singular).\n"
    )
    .ok();
    let (chart, lambda) = charts(ok);
    table(ok, page.md);
    page.md.push('\n');
    page.embed(&chart, "time_step")?;
    page.md.push('\n');
    page.embed(&lambda, "lambda_min")?;
    conclusion(ok, page.md);
    Ok(())
}

/// The stable steps (lumped and consistent) and `λ_min(M_L⁻¹M)` against particles per cell
/// (per axis), as two charts.
fn charts(ok: &[Finished]) -> (Chart, Chart) {
    let metric = |name: &str| -> Vec<(f64, f64)> {
        ok.iter()
            .map(|(r, o)| (r.choices.particles_per_cell as f64, o.metric(name).unwrap_or(f64::NAN)))
            .collect()
    };
    let x_label = "particles per cell (per axis)";
    let mut chart = empty_chart(
        "Stable step against particles per cell",
        x_label,
        "stable step (h/c)",
        false,
    );
    chart.series = vec![
        series("lumped".into(), metric("stable_step_lumped")),
        series("consistent".into(), metric("stable_step_consistent")),
    ];
    let mut lambda = empty_chart(
        "Smallest eigenvalue of M_L^-1 M against particles per cell",
        x_label,
        "lambda_min(M_L^-1 M)",
        false,
    );
    lambda.series = vec![series("plain consistent mass".into(), metric("lambda_min"))];
    (chart, lambda)
}

/// Writes the table: one row per particle count, its stable steps and `λ_min` ("singular"
/// where the consistent mass is).
fn table(ok: &[Finished], md: &mut String) {
    writeln!(
        md,
        "| particles per cell | stable step, lumped | stable step, consistent | λ_min(M_L⁻¹M) |"
    )
    .ok();
    writeln!(md, "|---|---|---|---|").ok();
    for (r, o) in ok {
        let m = |n: &str| {
            o.metric(n).map_or("–".into(), |v| {
                if v.is_nan() {
                    "singular".into()
                } else {
                    format!("{v:.3}")
                }
            })
        };
        writeln!(
            md,
            "| {} × {} | {} | {} | {} |",
            r.choices.particles_per_cell,
            r.choices.particles_per_cell,
            m("stable_step_lumped"),
            m("stable_step_consistent"),
            m("lambda_min")
        )
        .ok();
    }
}

/// Where the consistent mass is singular, and elsewhere its stable step as a fraction of the
/// lumped one.
fn conclusion(ok: &[Finished], md: &mut String) {
    let singular: Vec<String> = ok
        .iter()
        .filter(|(_, o)| o.metric("stable_step_consistent").is_some_and(f64::is_nan))
        .map(|(r, _)| format!("{0} × {0}", r.choices.particles_per_cell))
        .collect();
    let ratios: Vec<String> = ok
        .iter()
        .filter_map(|(r, o)| {
            let (l, c) = (o.metric("stable_step_lumped")?, o.metric("stable_step_consistent")?);
            c.is_finite()
                .then(|| format!("{:.2} at {1} × {1}", c / l, r.choices.particles_per_cell))
        })
        .collect();
    writeln!(
        md,
        "\nThe consistent mass is singular with {} particles per cell; elsewhere its stable step is a \
         fraction of the lumped one: {}.\n",
        if singular.is_empty() {
            "no tested number of".to_string()
        } else {
            singular.join(", ")
        },
        ratios.join(", ")
    )
    .ok();
}
