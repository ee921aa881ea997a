//! The collapse part: the granular column collapse against the aspect ratio for each mass and
//! transfer, with the experimental laws of Lube et al. (2005).

use std::fmt::Write as _;

use super::{by_label, empty_chart, series, Finished, Page};
use crate::plot::{Series, SeriesStyle};
use crate::verification::collapse::{from_band, height_law, runout_law, Collapse};
use sparse_mpm::error::Result;

/// Writes the collapse section: the set-up, one table row per run, and the plots of the
/// run-out and the final height against `a` with the laws.
pub(super) fn write(ok: &[Finished], page: &mut Page) -> Result<()> {
    let c = Collapse::new(1.0);
    writeln!(
        page.md,
        "## The granular column collapse\n\nA column of cohesionless Drucker–Prager material (φ = {}°, ψ = 0, \
         E = {:e} Pa, ν = {}, ρ = {}) of width L₀ = {} m and height a L₀, against a smooth back wall on a \
         rough (fixed) floor, released at rest with its geostatic stress; quadratic B-splines, MUSL, 2 × 2 \
         particles per cell, Courant number 0.4, run for {} √(H₀/g). Run-out (L∞ − L₀)/L₀ with the front \
         the toe of the contiguous deposit (the first column of cells from the wall that holds no particle); H∞ the deposit's height at the back wall; at rest when \
         the grid's kinetic energy stays below 10⁻³ of its peak; dissipated: plastic dissipation over the \
         potential energy released; energy error: the largest excursion of kinetic + strain + potential + \
         plastic dissipation + transfer loss, over the energy released; stress deviation: RMS of σ_yy \
         against the weight of the deposit above each particle, over ρ g H₀. The law: Lube et al. (2005), \
         1.2 a for a ≤ 1.8 and 1.9 a^(2/3) for a ≥ 2.8 (between them, the band they span); H∞/L₀ = a \
         for a ≤ 1.15, a^(2/5) beyond (docs/verification.md). The cost is the number of steps; the wall \
         times are in runs.csv (`wall_seconds`, `wall_per_step_seconds`), being measured they differ from one \
         execution of the study to the next.\n",
        c.friction_angle, c.youngs_modulus, c.poisson_ratio, c.density, c.width, c.duration
    )
    .ok();
    writeln!(
        page.md,
        "| run | a | run-out | law | off the law | H∞/L₀ | law | at rest (√(H₀/g)) | dissipated | energy error | \
         stress deviation | steps |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
    )
    .ok();
    let groups = by_label(ok);
    let mut runout = empty_chart(
        "Collapse: run-out against the aspect ratio",
        "a = H0/L0",
        "(L - L0)/L0",
        true,
    );
    let mut height = empty_chart(
        "Collapse: final height against the aspect ratio",
        "a = H0/L0",
        "H/L0",
        true,
    );
    let mut aspects: Vec<f64> = Vec::new();
    for (label, runs) in &groups {
        let mut points = Vec::new();
        let mut heights = Vec::new();
        for (_, o) in runs {
            let m = |n: &str| o.metric(n).unwrap_or(f64::NAN);
            let a = m("aspect");
            aspects.push(a);
            let band = runout_law(a);
            let law = if band.0 == band.1 {
                format!("{:.2}", band.0)
            } else {
                format!("{:.2}–{:.2}", band.0, band.1)
            };
            writeln!(
                page.md,
                "| {label} | {a} | {:.2} | {law} | {:+.0}% | {:.2} | {:.2} | {:.1} | {:.3} | {:.1e} | {:.3} | {} |",
                m("runout"),
                100.0 * from_band(m("runout"), band),
                m("final_height"),
                height_law(a),
                m("stop_time"),
                m("dissipated"),
                m("energy_error"),
                m("stress_deviation"),
                o.steps
            )
            .ok();
            points.push((a, m("runout")));
            heights.push((a, m("final_height")));
        }
        runout.series.push(series(label.clone(), points));
        height.series.push(series(label.clone(), heights));
    }
    aspects.sort_by(f64::total_cmp);
    aspects.dedup();
    if let (Some(&lo), Some(&hi)) = (aspects.first(), aspects.last()) {
        let curve = |f: &dyn Fn(f64) -> f64| -> Vec<(f64, f64)> {
            (0..=40)
                .map(|k| lo * (hi / lo).powf(f64::from(k) / 40.0))
                .map(|a| (a, f(a)))
                .collect()
        };
        for (label, f) in [
            ("Lube et al. 2005: 1.2 a", &(|a: f64| 1.2 * a) as &dyn Fn(f64) -> f64),
            ("Lube et al. 2005: 1.9 a^(2/3)", &|a: f64| 1.9 * a.powf(2.0 / 3.0)),
        ] {
            runout.series.push(Series {
                label: label.into(),
                points: curve(f),
                style: SeriesStyle::Dashed,
            });
        }
        height.series.push(Series {
            label: "Lube et al. 2005".into(),
            points: curve(&height_law),
            style: SeriesStyle::Dashed,
        });
    }
    page.md.push('\n');
    page.embed(&runout, "collapse_runout")?;
    page.md.push('\n');
    page.embed(&height, "collapse_height")?;
    page.md.push('\n');
    // The deposits of the tallest column, one line per run.
    if let Some(&tallest) = aspects.last() {
        let mut profiles = empty_chart(
            &format!("Collapse: deposits at a = {tallest}"),
            "x/L0",
            "height/L0",
            false,
        );
        for (label, runs) in &groups {
            for (_, o) in runs.iter().filter(|(_, o)| o.metric("aspect") == Some(tallest)) {
                if let Some(p) = o.history("profile") {
                    profiles.series.push(series(
                        label.clone(),
                        p.time.iter().copied().zip(p.value.iter().copied()).collect(),
                    ));
                }
            }
        }
        page.embed(&profiles, "collapse_profiles")?;
        page.md.push('\n');
    }
    Ok(())
}
