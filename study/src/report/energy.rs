//! The energy parts: the bar under PIC, FLIP and FMPM, and the two elastic disks in impact.

use std::fmt::Write as _;

use super::{empty_chart, mass_label, series, Finished, Page};
use crate::verification::Outcome;
use sparse_mpm::error::Result;

/// Writes the bar-energy section: the problem, the energy each run lost, the table of energy
/// drifts and the plot of total energy against time.
pub(super) fn write_bar(ok: &[Finished], page: &mut Page) -> Result<()> {
    writeln!(
        page.md,
        "## Energy of the bar under PIC, FLIP and FMPM\n\nThe same bar on {} cells; total energy over \
         its initial value. Energy lost by the end: {}.\n",
        ok.first().map_or(0, |(r, _)| r.cells),
        losses(ok)
    )
    .ok();
    energy_section(ok, "bar_energy", "Bar: total energy", page)
}

/// Writes the two-disk section: the problem, the energy each run lost, the table of energy
/// drifts and the plot of total energy against time.
pub(super) fn write_two_disks(ok: &[Finished], page: &mut Page) -> Result<()> {
    writeln!(
        page.md,
        "## Energy: two elastic disks in impact\n\nThe two-disk scene of scenes/two_disks.toml (20 cells \
         per side as shipped) on {} cells per side. No \
         exact solution: the total energy should stay at its initial value; the transfers' own \
         dissipation shows. Energy lost by the end: {}. (FLIP schemes dip during the impact and \
         recover; docs/verification.md explains the dip.)\n",
        ok.first().map_or(0, |(r, _)| r.cells),
        losses(ok)
    )
    .ok();
    energy_section(ok, "two_disks_energy", "Two disks: total energy", page)
}

/// "PIC, lumped 85.4%, FLIP, lumped 0.52%, …": the energy each run lost by its end.
fn losses(runs: &[Finished]) -> String {
    runs.iter()
        .map(|(r, o)| {
            let c = &r.choices;
            let transfer = c.label().split(", ").nth(2).unwrap_or("").to_string();
            let loss = -o.metric("energy_change").unwrap_or(f64::NAN);
            // No "-0.00%" for a loss that rounds to zero.
            let loss = if (100.0 * loss).abs() < 0.005 { 0.0 } else { loss };
            format!("{transfer} with {} mass {:.2}%", mass_label(r), 100.0 * loss)
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The table of energy drifts: one row per run, labelled.
fn md_table_drift(rows: &[(String, &Outcome)]) -> String {
    let mut md = String::from(
        "| scheme | largest \\|E − E₀\\|/E₀ | E_end/E₀ − 1 | lost in the transfers |\n|---|---|---|---|\n",
    );
    for (label, o) in rows {
        let m = |n: &str, sign: bool| {
            o.metric(n).map_or("–".into(), |v| {
                if sign {
                    format!("{:+.2}%", 100.0 * v)
                } else {
                    format!("{:.2}%", 100.0 * v)
                }
            })
        };
        md.push_str(&format!(
            "| {label} | {} | {} | {} |\n",
            m("energy_drift", false),
            m("energy_change", true),
            m("transfer_loss", false)
        ));
    }
    md
}

/// Writes the table of energy drifts and a chart of total energy over its initial value
/// against time (one series per run) as `name.png`.
fn energy_section(runs: &[Finished], name: &str, title: &str, page: &mut Page) -> Result<()> {
    let mut chart = empty_chart(title, "time", "E(t) / E(0)", false);
    let mut rows = Vec::new();
    for (r, o) in runs {
        let label = r.choices.label();
        if let Some(h) = o.history("total_energy") {
            let e0 = h.value.first().copied().unwrap_or(1.0);
            chart.series.push(series(
                label.clone(),
                h.time.iter().zip(&h.value).map(|(&t, &e)| (t, e / e0)).collect(),
            ));
        }
        rows.push((label, *o));
    }
    page.md.push_str(&md_table_drift(&rows));
    page.md.push('\n');
    page.embed(&chart, name)?;
    page.md.push('\n');
    Ok(())
}
