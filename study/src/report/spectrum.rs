//! The sections of the parts past the first mode: the dispersion curves, the wave fronts and
//! the time order of the update schemes.

use std::fmt::Write as _;

use super::{empty_chart, fmt_order, mass_label, series, Finished, Page};
use crate::plot::{Series, SeriesStyle};
use crate::verification::fitted_order;
use sparse_mpm::error::Result;

/// The dispersion section: a table of `c_h/c` at four wavenumbers for every shape and mass
/// pair, and one chart per shape of `c_h/c` against θ.
pub(super) fn write_dispersion(ok: &[Finished], page: &mut Page) -> Result<()> {
    writeln!(
        page.md,
        "## Dispersion over the whole spectrum\n\nThe wave speed `c_h/c` of a Fourier mode against \
         θ = kh on a uniform periodic bar with 2 particles per cell, from the symbols of \
         `M_a⁻¹ K M_v⁻¹ M` (`verification::dispersion`, `mpm dispersion`). Below 1 the discrete waves \
         are slow, above 1 fast; the vibrating bar's period error is `c/c_h − 1` at its own θ.\n\n\
         | shape | mass | θ = π/4 | π/2 | 3π/4 | π |\n|---|---|---|---|---|---|"
    )
    .ok();
    let mut shapes: Vec<String> = Vec::new();
    for (r, o) in ok {
        let m = |n: &str| o.metric(n).map_or("–".into(), |v| format!("{v:.4}"));
        writeln!(
            page.md,
            "| {} | {} | {} | {} | {} | {} |",
            r.choices.shape,
            mass_label(r),
            m("c_ratio_pi_4"),
            m("c_ratio_pi_2"),
            m("c_ratio_3pi_4"),
            m("c_ratio_pi")
        )
        .ok();
        let name = r.choices.shape.to_string();
        if !shapes.contains(&name) {
            shapes.push(name);
        }
    }
    page.md.push('\n');
    for shape in shapes {
        let mut chart = empty_chart(
            &format!("Dispersion, {shape}, 2 particles per cell"),
            "theta = k h",
            "c_h / c",
            false,
        );
        for (r, o) in ok.iter().filter(|(r, _)| r.choices.shape.to_string() == shape) {
            if let Some(h) = o.histories.iter().find(|h| h.name == "c_ratio") {
                let points = h
                    .time
                    .iter()
                    .copied()
                    .zip(h.value.iter().copied())
                    .filter(|p| p.1.is_finite())
                    .collect();
                chart.series.push(Series {
                    label: mass_label(r),
                    points,
                    style: SeriesStyle::LineAndMarkers,
                });
            }
        }
        chart.series.push(Series {
            label: "exact".into(),
            points: vec![(0.0, 1.0), (std::f64::consts::PI, 1.0)],
            style: SeriesStyle::Dashed,
        });
        page.embed(&chart, &format!("dispersion_{}", shape.replace(':', "_")))?;
        page.md.push('\n');
    }
    writeln!(
        page.md,
        "With bilinear functions the lumped curve lies below 1 and the consistent one above 1 over the \
         whole spectrum, and the mixed pairs between them; the B-splines' lumped masses are much slower \
         at short wavelengths and their consistent masses close to exact (docs/mass.md).\n"
    )
    .ok();
    Ok(())
}

/// The waves section: a table of the front metrics per wave and mass pair, and the profiles of
/// the step and the pulse near the front, one series per mass pair.
pub(super) fn write_waves(all: &[Finished], page: &mut Page) -> Result<()> {
    let (impulse, ok): (Vec<Finished>, Vec<Finished>) = all.iter().partition(|(_, o)| o.problem == "impulse_bar");
    let ok = &ok[..];
    let finest_cells = ok.iter().map(|(r, _)| r.cells).max().unwrap_or(0);
    let finest: Vec<Finished> = ok.iter().filter(|(r, _)| r.cells == finest_cells).copied().collect();
    writeln!(
        page.md,
        "## Wave fronts against d'Alembert\n\nA right-going step and a square pulse (width L/10) in a \
         free bar (bilinear functions, 2 × 2 particles per cell, FLIP, Courant number 0.5), read when \
         d'Alembert's front has travelled half the bar (`verification::wave`). Arrival: the step's \
         integral front or the pulse's centroid against d'Alembert's, in cells; front: where `v` \
         crosses `v₀/2`; ahead and behind: the largest deviation from d'Alembert more than two cells \
         ahead of the front and behind the rear edge, over v₀; stress: the RMS stress error near the \
         front over `ρ c v₀`. On {finest_cells} cells:\n\n\
         | wave | mass | arrival (cells) | front (cells) | ahead | behind | overshoot | stress |\n\
         |---|---|---|---|---|---|---|---|"
    )
    .ok();
    for (r, o) in &finest {
        let m = |n: &str| o.metric(n).map_or("–".into(), |v| format!("{v:+.3}"));
        let a = |n: &str| o.metric(n).map_or("–".into(), |v| format!("{v:.3}"));
        writeln!(
            page.md,
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            o.problem.trim_start_matches("wave_"),
            mass_label(r),
            m("arrival_error"),
            m("front_error"),
            a("precursor"),
            a("trailing"),
            m("overshoot"),
            a("stress_error")
        )
        .ok();
    }
    page.md.push('\n');
    refinement(ok, page)?;
    for problem in ["wave_step", "wave_pulse"] {
        let runs: Vec<&Finished> = finest.iter().filter(|(_, o)| o.problem == problem).collect();
        let Some((_, first)) = runs.first() else { continue };
        let h = first.cell_size;
        // the window: 20 cells (at most L/8) behind the rear edge to 20 cells ahead of the front
        let exact = first.histories.iter().find(|h| h.name == "velocity_exact");
        let (lo, hi) = exact.map_or((0.0, 1.0), |e| {
            let inside: Vec<f64> = e
                .time
                .iter()
                .zip(&e.value)
                .filter(|(_, v)| **v > 0.5)
                .map(|(x, _)| *x)
                .collect();
            let front = inside.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let rear = if problem == "wave_step" {
                front
            } else {
                inside.iter().copied().fold(f64::INFINITY, f64::min)
            };
            let length = first.cells as f64 * h;
            (rear - (20.0 * h).min(0.125 * length), front + 20.0 * h)
        });
        let window = |hist: &crate::verification::History| -> Vec<(f64, f64)> {
            hist.time
                .iter()
                .copied()
                .zip(hist.value.iter().copied())
                .filter(|(x, _)| *x >= lo && *x <= hi)
                .collect()
        };
        let mut chart = empty_chart(
            &format!(
                "{} near the front",
                if problem == "wave_step" {
                    "Velocity step"
                } else {
                    "Square pulse"
                }
            ),
            "x",
            "v / v0",
            false,
        );
        for (r, o) in &runs {
            if let Some(p) = o.histories.iter().find(|h| h.name == "velocity_profile") {
                chart.series.push(series(mass_label(r), window(p)));
            }
        }
        if let Some(e) = exact {
            chart.series.push(Series {
                label: "d'Alembert".into(),
                points: window(e),
                style: SeriesStyle::Dashed,
            });
        }
        page.embed(&chart, problem)?;
        page.md.push('\n');
    }
    writeln!(
        page.md,
        "Every pair delivers the wave on time by momentum; the half-amplitude front is moved by \
         dispersion, behind the exact front for the slow lumped and mixed masses, ahead of it for the \
         fast consistent one, whose short waves ring ahead as precursors while the lumped mass's trail \
         behind (docs/verification.md, \"Wave fronts\").\n"
    )
    .ok();
    write_impulse(&impulse, page)
}

/// The impulse-loaded bar: per mass pair the displacement error on each grid with its fitted
/// order and the finest grid's end error, fixed-end stress and energy error; the end's
/// displacement against time on the finest grid; the error against the cell size.
fn write_impulse(ok: &[Finished], page: &mut Page) -> Result<()> {
    if ok.is_empty() {
        return Ok(());
    }
    let finest_cells = ok.iter().map(|(r, _)| r.cells).max().unwrap_or(0);
    writeln!(
        page.md,
        "### The impulse-loaded bar\n\nA bar fixed at `x = 0`, pushed at its free end by a pressure \
         pulse `p₀ sin²(πt/T)` of duration `T = L/(2c)`, run for two round trips (`4L/c`) against \
         d'Alembert's solution with images (`verification::impulse`; bilinear functions, 2 × 2 \
         particles per cell, FLIP, Courant number 0.5). Displacement error: the largest over time of \
         the RMS error over the incident pulse's displacement `U`; on the finest grid ({finest_cells} \
         cells) the loaded end's largest error over `U`, the largest stress next to the fixed end \
         over `2p₀` (exactly 1: the reflection doubles the pulse) and the energy against the load's \
         work.\n\n\
         | mass | displacement error | order | end error | fixed-end stress / 2p₀ | energy error |\n\
         |---|---|---|---|---|---|"
    )
    .ok();
    let mut errors = empty_chart(
        "Impulse-loaded bar: displacement error against cell size",
        "cell size h",
        "max_t RMS |u - u_exact| / U",
        true,
    );
    let mut history = empty_chart(
        &format!("Impulse-loaded bar: the loaded end on {finest_cells} cells"),
        "t",
        "u_end / U",
        false,
    );
    let mut seen: Vec<String> = Vec::new();
    for (r, _) in ok {
        let label = mass_label(r);
        if seen.contains(&label) {
            continue;
        }
        seen.push(label.clone());
        let runs: Vec<&Finished> = ok.iter().filter(|(q, _)| mass_label(q) == label).collect();
        let points: Vec<(f64, f64)> = runs
            .iter()
            .filter_map(|(_, o)| Some((o.cell_size, o.metric("displacement_error")?)))
            .collect();
        let finest = runs.iter().find(|(q, _)| q.cells == finest_cells).map(|(_, o)| o);
        let at = |name: &str, f: fn(f64) -> String| finest.and_then(|o| o.metric(name)).map_or("–".into(), f);
        writeln!(
            page.md,
            "| {label} | {} | {} | {} | {} | {} |",
            points
                .iter()
                .map(|p| format!("{:.2e}", p.1))
                .collect::<Vec<_>>()
                .join(", "),
            fmt_order(&points),
            at("end_error", |v| format!("{v:.2e}")),
            at("fixed_end_stress", |v| format!("{v:.4}")),
            at("energy_error", |v| format!("{v:+.1e}")),
        )
        .ok();
        if let Some(end) = finest.and_then(|o| o.history("end_displacement")) {
            history.series.push(series(label.clone(), zip(end)));
        }
        errors.series.push(series(label, points));
    }
    if let Some(exact) = ok
        .iter()
        .find(|(q, _)| q.cells == finest_cells)
        .and_then(|(_, o)| o.history("end_displacement_exact"))
    {
        history.series.push(Series {
            label: "d'Alembert".into(),
            points: zip(exact),
            style: SeriesStyle::Dashed,
        });
    }
    page.md.push('\n');
    page.embed(&history, "impulse_end")?;
    page.md.push('\n');
    page.embed(&errors, "impulse_error")?;
    writeln!(
        page.md,
        "\nThe load is a body force on the particles at the loaded end, half a particle spacing inside \
         the bar, as an MPM code loads a free surface; with bilinear functions the error still falls \
         at about second order (docs/verification.md, \"The impulse-loaded bar\").\n"
    )
    .ok();
    Ok(())
}

/// A history's `(time, value)` pairs.
fn zip(h: &crate::verification::History) -> Vec<(f64, f64)> {
    h.time.iter().copied().zip(h.value.iter().copied()).collect()
}

/// Under refinement: the stress error and the half-amplitude front against the cell size, one
/// row per wave and mass pair, and the chart of the stress error.
fn refinement(ok: &[Finished], page: &mut Page) -> Result<()> {
    let cells: Vec<usize> = {
        let mut c: Vec<usize> = ok.iter().map(|(r, _)| r.cells).collect();
        c.sort_unstable();
        c.dedup();
        c
    };
    if cells.len() < 2 {
        return Ok(());
    }
    writeln!(
        page.md,
        "Under refinement ({} cells): the stress error with its fitted order, and the half-amplitude \
         front in cells, which dispersion moves by about `(c t/h)^{{1/3}}` cells.\n\n\
         | wave | mass | stress error | order | front (cells) |\n|---|---|---|---|---|",
        cells.iter().map(|c| c.to_string()).collect::<Vec<_>>().join(", ")
    )
    .ok();
    let mut chart = empty_chart(
        "Wave fronts: stress error against cell size",
        "cell size h",
        "RMS stress error / (rho c v0)",
        true,
    );
    let mut seen: Vec<(String, String)> = Vec::new();
    for (r, o) in ok {
        let key = (o.problem.clone(), mass_label(r));
        if seen.contains(&key) {
            continue;
        }
        seen.push(key.clone());
        let runs: Vec<&Finished> = ok
            .iter()
            .filter(|(q, p)| p.problem == key.0 && mass_label(q) == key.1)
            .collect();
        let points: Vec<(f64, f64)> = runs
            .iter()
            .filter_map(|(_, p)| Some((p.cell_size, p.metric("stress_error")?)))
            .collect();
        let fronts: Vec<String> = runs
            .iter()
            .filter_map(|(_, p)| p.metric("front_error"))
            .map(|f| format!("{f:+.2}"))
            .collect();
        writeln!(
            page.md,
            "| {} | {} | {} | {} | {} |",
            key.0.trim_start_matches("wave_"),
            key.1,
            points
                .iter()
                .map(|p| format!("{:.3}", p.1))
                .collect::<Vec<_>>()
                .join(", "),
            fmt_order(&points),
            fronts.join(", ")
        )
        .ok();
        chart.series.push(series(
            format!("{}, {}", key.0.trim_start_matches("wave_"), key.1),
            points,
        ));
    }
    page.md.push('\n');
    page.embed(&chart, "wave_stress_error")?;
    page.md.push('\n');
    Ok(())
}

/// The time-order section: the single point's velocity error against Δt per update scheme,
/// the fitted orders, and the chart.
pub(super) fn write_time_order(ok: &[Finished], page: &mut Page) -> Result<()> {
    writeln!(
        page.md,
        "## Time order of the update schemes\n\nThe single material point (v₀ = 10⁻³, lumped mass, \
         FLIP) at Δt = 4e-3 and halvings: the largest velocity error over v₀ against Δt.\n\n\
         | update | errors (largest Δt first) | fitted order |\n|---|---|---|"
    )
    .ok();
    let mut chart = empty_chart(
        "Single point: velocity error against time step",
        "dt",
        "max |v - v_exact| / v0",
        true,
    );
    for update in ["Usf", "Usl", "Musl"] {
        let points: Vec<(f64, f64)> = ok
            .iter()
            .filter(|(r, _)| format!("{:?}", r.choices.update) == update)
            .filter_map(|(_, o)| Some((o.metric("dt")?, o.metric("velocity_error")?)))
            .collect();
        if points.is_empty() {
            continue;
        }
        let errors: Vec<String> = points.iter().map(|p| format!("{:.3e}", p.1)).collect();
        writeln!(
            page.md,
            "| {} | {} | {} |",
            update.to_uppercase(),
            errors.join(", "),
            fmt_order(&points)
        )
        .ok();
        chart.series.push(series(update.to_uppercase(), points));
    }
    page.md.push('\n');
    page.embed(&chart, "time_order")?;
    let orders: Vec<f64> = chart.series.iter().filter_map(|s| fitted_order(&s.points)).collect();
    writeln!(
        page.md,
        "\nEvery scheme is first order at the report times (fitted orders {}): the update is the \
         symplectic Euler method, whose velocity belongs half a step back (docs/verification.md, \
         \"The time order\").\n",
        orders.iter().map(|o| format!("{o:.2}")).collect::<Vec<_>>().join(", ")
    )
    .ok();
    Ok(())
}
