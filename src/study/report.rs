//! The Markdown report of a study: one section per part, with the plots it embeds and the
//! tables and fitted orders that state what they show.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::plot::{self, Chart, Series, SeriesStyle};
use super::{small_bar, Part, StudyRun};
use crate::error::{MpmError, Result};
use crate::mass::MassScheme;
use crate::simulation::UpdateScheme;
use crate::verification::{cantilever, fitted_order, Outcome};

/// Writes `chart` as `out/name.png`, records it, and returns the Markdown that embeds it.
fn save(chart: &Chart, out: &Path, name: &str, plots: &mut Vec<PathBuf>) -> Result<String> {
    let path = out.join(format!("{name}.png"));
    plot::write_png(chart, &path, 900, 600).map_err(|e| MpmError::Io {
        path: path.clone(),
        source: std::io::Error::other(e.to_string()),
    })?;
    plots.push(path);
    Ok(format!("![{}]({name}.png)\n", chart.title))
}

fn ok_runs<'a>(runs: &[&'a StudyRun]) -> Vec<(&'a StudyRun, &'a Outcome)> {
    runs.iter()
        .filter_map(|r| r.outcome.as_ref().ok().map(|o| (*r, o)))
        .collect()
}

/// Runs grouped by their choices' label, in first-seen order.
fn by_label<'a>(runs: &[(&'a StudyRun, &'a Outcome)]) -> Vec<(String, Vec<(&'a StudyRun, &'a Outcome)>)> {
    let mut groups: Vec<(String, Vec<_>)> = Vec::new();
    for &(r, o) in runs {
        let label = r.choices.label();
        match groups.iter_mut().find(|(l, _)| *l == label) {
            Some((_, g)) => g.push((r, o)),
            None => groups.push((label, vec![(r, o)])),
        }
    }
    groups
}

fn series(label: String, points: Vec<(f64, f64)>) -> Series {
    Series {
        label,
        points,
        style: SeriesStyle::LineAndMarkers,
    }
}

fn fmt_order(points: &[(f64, f64)]) -> String {
    fitted_order(points).map_or("–".into(), |p| format!("{p:.2}"))
}

pub(super) fn section(
    part: Part,
    runs: &[&StudyRun],
    out: &Path,
    md: &mut String,
    plots: &mut Vec<PathBuf>,
) -> Result<()> {
    let ok = ok_runs(runs);
    match part {
        Part::Frequency => {
            let bar = small_bar();
            writeln!(
                md,
                "## Frequency error: the vibrating bar\n\nThe bar with both ends fixed (E = 100, ρ = 1, L = 25, \
                 first mode, period {}), amplitude 1e-3, two periods, bilinear functions, FLIP. The period \
                 is measured from the zero crossings of the centre-of-mass velocity. Theory for particles at \
                 the quarter points (docs/mass.md): lumped `+13θ²/96`, consistent `−5θ²/96`, mixed pairs \
                 `+θ²/24`, the blend γ = 13/18 zero at order θ².\n",
                bar.period()
            )
            .ok();
            let groups = by_label(&ok);
            let mut chart = Chart {
                title: "Bar period error against resolution".into(),
                x_label: "cells along the bar".into(),
                y_label: "|period error|".into(),
                log_x: true,
                log_y: true,
                series: Vec::new(),
            };
            writeln!(
                md,
                "| masses (velocity/acceleration) | {} | fitted order |",
                cells_header(&groups)
            )
            .ok();
            writeln!(
                md,
                "|---|{}---|",
                "---|".repeat(groups.first().map_or(0, |g| g.1.len()))
            )
            .ok();
            let mut finest = Vec::new();
            for (label, g) in &groups {
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
                let _ = label;
            }
            md.push('\n');
            md.push_str(&save(&chart, out, "frequency_error", plots)?);
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
        Part::BarEnergy => {
            writeln!(
                md,
                "## Energy of the bar under PIC, FLIP and FMPM\n\nThe same bar on {} cells; total energy over \
                 its initial value. Energy lost by the end: {}.\n",
                ok.first().map_or(0, |(r, _)| r.cells),
                losses(&ok)
            )
            .ok();
            md.push_str(&energy_section(
                &ok,
                "bar_energy",
                "Bar: total energy",
                out,
                plots,
                md_table_drift,
            )?);
        }
        Part::Convergence => {
            writeln!(
                md,
                "## Convergence: the generalised vortex\n\nThe manufactured vortex (ring 0.75 < R < 1.25, \
                 E = 1000, ν = 0.3, ρ₀ = 1000, amplitude 0.05, to the time of the largest shear) with its body \
                 force. Error: the largest over time of the volume-weighted RMS particle displacement error, \
                 over the amplitude.\n"
            )
            .ok();
            let groups = by_label(&ok);
            let mut chart = Chart {
                title: "Vortex: displacement error against cell size".into(),
                x_label: "cell size h".into(),
                y_label: "RMS displacement error / amplitude".into(),
                log_x: true,
                log_y: true,
                series: Vec::new(),
            };
            let mut cost = Chart {
                title: "Cost against error (vortex)".into(),
                x_label: "RMS displacement error / amplitude".into(),
                y_label: "wall time per step (ms)".into(),
                log_x: true,
                log_y: true,
                series: Vec::new(),
            };
            writeln!(md, "| shape, mass | {} | fitted order |", cells_header(&groups)).ok();
            writeln!(
                md,
                "|---|{}---|",
                "---|".repeat(groups.first().map_or(0, |g| g.1.len()))
            )
            .ok();
            for (_, g) in &groups {
                let points: Vec<(f64, f64)> = g
                    .iter()
                    .map(|(_, o)| (o.cell_size, o.metric("displacement_error_l2").unwrap_or(f64::NAN)))
                    .collect();
                let label = format!("{}, {}", g[0].0.choices.shape.name(), mass_label(g[0].0));
                let order = fmt_order(&points);
                writeln!(
                    md,
                    "| {label} | {} | {order} |",
                    points
                        .iter()
                        .map(|(_, e)| format!("{e:.2e}"))
                        .collect::<Vec<_>>()
                        .join(" | ")
                )
                .ok();
                chart.series.push(series(format!("{label} ({order})"), points.clone()));
                cost.series.push(series(
                    label,
                    g.iter()
                        .map(|(_, o)| {
                            (
                                o.metric("displacement_error_l2").unwrap_or(f64::NAN),
                                1e3 * o.seconds / o.steps.max(1) as f64,
                            )
                        })
                        .collect(),
                ));
            }
            md.push('\n');
            md.push_str(&save(&chart, out, "convergence", plots)?);
            md.push('\n');
            md.push_str(&save(&cost, out, "cost", plots)?);
            writeln!(
                md,
                "\nEach line of the cost plot runs from the coarsest grid (right) to the finest (left): a scheme \
                 further down and left buys accuracy for less time per step.{}\n",
                consistent_cost(&ok)
            )
            .ok();
        }
        Part::Energy => {
            writeln!(
                md,
                "## Energy: two elastic disks in impact\n\nThe shipped two-disk scene ({} cells per side). No \
                 exact solution: the total energy should stay at its initial value; the transfers' own \
                 dissipation shows. Energy lost by the end: {}. (FLIP schemes dip during the impact and \
                 recover; docs/verification.md explains the dip.)\n",
                ok.first().map_or(0, |(r, _)| r.cells),
                losses(&ok)
            )
            .ok();
            md.push_str(&energy_section(
                &ok,
                "two_disks_energy",
                "Two disks: total energy",
                out,
                plots,
                md_table_drift,
            )?);
        }
        Part::TimeStep => {
            writeln!(
                md,
                "## Stable step and conditioning against particles per cell\n\nAn 8 × 8-cell block at rest \
                 (E = 1000, ν = 0.3, plane strain), FLIP: the stable step of the update with each mass \
                 (the estimate of docs/mass.md, in units of h/c) and `λ_min(M_L⁻¹M)` of the plain consistent \
                 mass (0: singular).\n"
            )
            .ok();
            let n_of = |r: &StudyRun| r.choices.particles_per_cell as f64;
            let metric = |name: &str| -> Vec<(f64, f64)> {
                ok.iter()
                    .map(|(r, o)| (n_of(r), o.metric(name).unwrap_or(f64::NAN)))
                    .collect()
            };
            let chart = Chart {
                title: "Stable step against particles per cell".into(),
                x_label: "particles per cell (per axis)".into(),
                y_label: "stable step (h/c)".into(),
                log_x: false,
                log_y: false,
                series: vec![
                    series("lumped".into(), metric("stable_step_lumped")),
                    series("consistent".into(), metric("stable_step_consistent")),
                ],
            };
            let lambda = Chart {
                title: "Smallest eigenvalue of M_L^-1 M against particles per cell".into(),
                x_label: "particles per cell (per axis)".into(),
                y_label: "lambda_min(M_L^-1 M)".into(),
                log_x: false,
                log_y: false,
                series: vec![series("plain consistent mass".into(), metric("lambda_min"))],
            };
            writeln!(
                md,
                "| particles per cell | stable step, lumped | stable step, consistent | λ_min(M_L⁻¹M) |"
            )
            .ok();
            writeln!(md, "|---|---|---|---|").ok();
            for (r, o) in &ok {
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
            md.push('\n');
            md.push_str(&save(&chart, out, "time_step", plots)?);
            md.push('\n');
            md.push_str(&save(&lambda, out, "lambda_min", plots)?);
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
        Part::Cantilever => {
            writeln!(
                md,
                "## The cantilever: a refinement study\n\nThe shipped cantilever (4 × 1 neo-Hookean beam under \
                 gravity, released at rest) on three grids, each twice as fine, with quadratic B-splines \
                 (bilinear functions lock in bending). No closed form: the largest tip deflection is \
                 extrapolated (Richardson) from the three where the differences shrink.\n"
            )
            .ok();
            let groups = by_label(&ok);
            writeln!(
                md,
                "| mass | {} | extrapolated | observed order |",
                cells_header(&groups)
            )
            .ok();
            writeln!(
                md,
                "|---|{}---|---|",
                "---|".repeat(groups.first().map_or(0, |g| g.1.len()))
            )
            .ok();
            let mut chart = Chart {
                title: "Cantilever: tip deflection".into(),
                x_label: "time".into(),
                y_label: "downward tip displacement".into(),
                log_x: false,
                log_y: false,
                series: Vec::new(),
            };
            for (_, g) in &groups {
                let values: Vec<f64> = g
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
                    mass_label(g[0].0),
                    values.iter().map(|v| format!("{v:.4}")).collect::<Vec<_>>().join(" | ")
                )
                .ok();
                if let Some((r, o)) = g.last() {
                    if let Some(h) = o.history("tip_deflection") {
                        chart.series.push(series(
                            format!("{}, {} cells", mass_label(r), r.cells),
                            h.time.iter().copied().zip(h.value.iter().copied()).collect(),
                        ));
                    }
                }
            }
            md.push('\n');
            md.push_str(&save(&chart, out, "cantilever", plots)?);
            md.push('\n');
        }
        Part::SinglePoint => {
            writeln!(
                md,
                "## The single material point\n\nOne particle in one bilinear cell (v₀ = 0.01, Δt = 0.001, to \
                 t = 2), lumped mass, FLIP, against `v = v₀ cos 2πt`, `x = x₀ exp((v₀/2π) sin 2πt)`.\n\n\
                 | update | max \\|v − v_exact\\| / v₀ | max \\|x − x_exact\\| / amplitude | energy drift |\n|---|---|---|---|"
            )
            .ok();
            for (r, o) in &ok {
                let m = |n: &str| o.metric(n).map_or("–".into(), |v| format!("{v:.2e}"));
                writeln!(
                    md,
                    "| {:?} | {} | {} | {} |",
                    r.choices.update,
                    m("velocity_error"),
                    m("position_error"),
                    m("energy_drift")
                )
                .ok();
            }
            let drift = |u: UpdateScheme| {
                ok.iter()
                    .find(|(r, _)| r.choices.update == u)
                    .and_then(|(_, o)| o.metric("energy_drift"))
                    .unwrap_or(f64::NAN)
            };
            let (usf, usl) = (drift(UpdateScheme::Usf), drift(UpdateScheme::Usl));
            if usl > 5.0 * usf {
                writeln!(
                    md,
                    "\nUSL's energy drift ({:.2}%) is {:.0} times USF's ({:.2}%): one order of the updates nearly \
                     conserves this problem's energy and the other dissipates it, as Bardenhagen (2002) found.\n",
                    100.0 * usl,
                    usl / usf,
                    100.0 * usf
                )
                .ok();
            }
        }
    }
    Ok(())
}

/// "PIC, lumped 85.4%, FLIP, lumped 0.52%, …": the energy each run lost by its end.
fn losses(runs: &[(&StudyRun, &Outcome)]) -> String {
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

/// What the consistent mass cost against the lumped one in the same (shape, cells) runs.
fn consistent_cost(runs: &[(&StudyRun, &Outcome)]) -> String {
    let mut steps = Vec::new();
    let mut time = Vec::new();
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
            time.push(o.seconds / l.seconds.max(1e-12));
        }
    }
    if steps.is_empty() {
        return String::new();
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    format!(
        " The consistent mass took {:.1} times as many steps as the lumped mass on the same grids (its \
         stable step is shorter) and {:.1} times the wall time.",
        mean(&steps),
        mean(&time)
    )
}

/// The masses of a run: one label when both solves use the same scheme.
fn mass_label(r: &StudyRun) -> String {
    let m = &r.choices.mass;
    if m.velocity == m.acceleration {
        m.velocity.label()
    } else {
        format!("{} / {}", m.velocity.label(), m.acceleration.label())
    }
}

fn cells_header(groups: &[(String, Vec<(&StudyRun, &Outcome)>)]) -> String {
    groups
        .first()
        .map(|(_, g)| {
            g.iter()
                .map(|(r, _)| format!("{} cells", r.cells))
                .collect::<Vec<_>>()
                .join(" | ")
        })
        .unwrap_or_default()
}

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

/// A chart of total energy over its initial value against time, one series per run, and a table.
fn energy_section(
    runs: &[(&StudyRun, &Outcome)],
    name: &str,
    title: &str,
    out: &Path,
    plots: &mut Vec<PathBuf>,
    table: fn(&[(String, &Outcome)]) -> String,
) -> Result<String> {
    let mut chart = Chart {
        title: title.into(),
        x_label: "time".into(),
        y_label: "E(t) / E(0)".into(),
        log_x: false,
        log_y: false,
        series: Vec::new(),
    };
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
    let mut md = table(&rows);
    md.push('\n');
    md.push_str(&save(&chart, out, name, plots)?);
    md.push('\n');
    Ok(md)
}
