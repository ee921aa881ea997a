//! The implicit part: explicit against Newmark integration with the lumped and the consistent
//! mass, on the bar (period error against h and Δt, with the discrete Newmark theory), the
//! cantilever and the two disks.

use std::fmt::Write as _;

use super::{empty_chart, mass_label, series, Finished, Page};
use crate::plot::{Series, SeriesStyle};
use crate::verification::bar::newmark_period;
use sparse_mpm::error::Result;

/// The space-discrete bar's period error in closed form ([`crate::verification::bar::Bar::discrete_period`])
/// for run `r` (bilinear functions; the consistent mass in both solves or the lumped mass with
/// FLIP), and the one Newmark's rule at the run's step turns it into
/// (`T_Δt = π Δt / arctan(π Δt / T_h)`).
fn theory(r: &Finished) -> (Option<f64>, Option<f64>) {
    let bar = crate::small_bar();
    let consistent = match mass_label(r.0).as_str() {
        "consistent" => true,
        "lumped" => false,
        _ => return (None, None),
    };
    let linear = r.0.choices.shape == sparse_mpm::shape::ShapeFunction::Linear;
    let t = bar.period();
    let Some(t_h) = bar
        .discrete_period(r.0.cells, r.0.choices.particles_per_cell, consistent)
        .filter(|_| linear)
    else {
        return (None, None);
    };
    let newmark = r.1.metric("dt").filter(|_| r.0.choices.implicit_step.is_some());
    (Some(t_h / t - 1.0), newmark.map(|dt| newmark_period(t_h, dt) / t - 1.0))
}

fn fmt(v: Option<f64>) -> String {
    v.map_or("–".into(), |v| format!("{v:+.2e}"))
}

/// Writes the section.
pub(super) fn write(ok: &[Finished], page: &mut Page) -> Result<()> {
    writeln!(
        page.md,
        "## Explicit against implicit integration\n\nNewmark's average-acceleration rule (β = ¼, γ = ½) \
         with Newton iterations on the grid (docs/implicit.md) at multiples of the explicit stable step at \
         t = 0, against the explicit update at the study's Courant number, with the lumped and the consistent \
         mass (FLIP). Without a stable-step limit the consistent mass costs only its solves; the \
         comparison of the masses becomes one of accuracy.\n"
    )
    .ok();
    let bars: Vec<&Finished> = ok.iter().filter(|(_, o)| o.problem.starts_with("bar")).collect();
    let explicit_of = |i: &Finished| -> Option<&Finished> {
        bars.iter().copied().find(|e| {
            e.0.choices.implicit_step.is_none() && e.0.cells == i.0.cells && mass_label(e.0) == mass_label(i.0)
        })
    };
    // Period error against h at 5×.
    writeln!(
        page.md,
        "The bar (both ends fixed), period error against the grid; Newmark at 5 × the explicit stable step. \
         *closed form*: the space-discrete bar's period (`Bar::discrete_period`: the particles' consistent mass, \
         or the lumped mass with FLIP's `M_L⁻¹M` hand-back) and the discrete Newmark period \
         `π Δt / arctan(π Δt / T_h)` it gives.\n\n\
         | mass | cells | explicit | closed form, space | Newmark 5× | closed form, Newmark |\n|---|---|---|---|---|---|"
    )
    .ok();
    for i in bars
        .iter()
        .filter(|(r, _)| r.choices.implicit_step == Some(super::super::IMPLICIT_STEP))
    {
        let e = explicit_of(i);
        let (space, newmark) = theory(i);
        writeln!(
            page.md,
            "| {} | {} | {} | {} | {} | {} |",
            mass_label(i.0),
            i.0.cells,
            fmt(e.and_then(|e| e.1.metric("period_error"))),
            fmt(space),
            fmt(i.1.metric("period_error")),
            fmt(newmark),
        )
        .ok();
    }
    // Period error against Δt on the finest grid.
    let finest = bars
        .iter()
        .filter(|(r, _)| r.choices.implicit_step == Some(1.0))
        .map(|(r, _)| r.cells)
        .max();
    let mut chart = empty_chart(
        "Bar period error against the Newmark step",
        "time step / explicit stable step",
        "period error",
        false,
    );
    if let Some(cells) = finest {
        writeln!(
            page.md,
            "\nThe same bar on {cells} cells, period error against the step:\n\n\
             | mass | Δt / Δt_stable | measured | closed form |\n|---|---|---|---|"
        )
        .ok();
        for mass in ["lumped", "consistent"] {
            let mut runs: Vec<&&Finished> = bars
                .iter()
                .filter(|(r, _)| r.cells == cells && r.choices.implicit_step.is_some() && mass_label(r) == mass)
                .collect();
            runs.sort_by(|a, b| {
                a.0.choices
                    .implicit_step
                    .partial_cmp(&b.0.choices.implicit_step)
                    .unwrap()
            });
            let (mut measured, mut predicted) = (Vec::new(), Vec::new());
            for i in runs {
                let factor = i.0.choices.implicit_step.unwrap_or(f64::NAN);
                let th = theory(i).1;
                let m = i.1.metric("period_error");
                writeln!(page.md, "| {mass} | {factor} | {} | {} |", fmt(m), fmt(th)).ok();
                if let (Some(m), Some(th)) = (m, th) {
                    measured.push((factor, m));
                    predicted.push((factor, th));
                }
            }
            chart.series.push(Series {
                style: SeriesStyle::Markers,
                ..series(format!("{mass}, measured"), measured)
            });
            chart.series.push(Series {
                style: SeriesStyle::Dashed,
                ..series(format!("{mass}, closed form"), predicted)
            });
        }
        page.md.push('\n');
        page.embed(&chart, "implicit_bar_period")?;
    }
    // The cantilever and the two disks.
    writeln!(
        page.md,
        "\nThe cantilever (quadratic B-splines) and the two disks, explicit and at 5 × the explicit stable step \
         (the wall time per unit of simulated time is in runs.csv, `wall_per_simulated_time_seconds`):\n\n\
         | problem | mass | integrator | steps | tip deflection | energy change | transfers' loss |\n\
         |---|---|---|---|---|---|---|"
    )
    .ok();
    for (r, o) in ok.iter().filter(|(_, o)| !o.problem.starts_with("bar")) {
        let integrator = r
            .choices
            .implicit_step
            .map_or("explicit".to_string(), |f| format!("Newmark {f}×"));
        let m = |name: &str| o.metric(name).map_or("–".into(), |v| format!("{v:.4}"));
        writeln!(
            page.md,
            "| {} | {} | {integrator} | {} | {} | {} | {} |",
            o.problem,
            mass_label(r),
            o.steps,
            m("tip_deflection"),
            m("energy_change"),
            m("transfer_loss")
        )
        .ok();
    }
    page.md.push('\n');
    Ok(())
}
