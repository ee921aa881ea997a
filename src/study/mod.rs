//! `mpm study`: the verification problems ([`crate::verification`]) run over a matrix of
//! choices, written to a folder as a CSV of every run, PNG plots and a Markdown report that
//! embeds them and states what they show (docs/verification.md).
//!
//! A study is a [`StudySpec`] (TOML, every key optional) made of parts:
//!
//! | part | problem | varies | plots |
//! |---|---|---|---|
//! | `frequency` | bar, both ends fixed, small amplitude | mass pair × cells | period error against cells, fitted orders |
//! | `bar_energy` | the same bar | mass × transfer (PIC, FLIP, FMPM) | total energy against time |
//! | `convergence` | generalised vortex (manufactured) | shape × mass × cells | displacement error against cell size, fitted orders; cost per step against error |
//! | `energy` | two elastic disks | mass × transfer | total energy against time |
//! | `time_step` | a filled block | particles per cell | stable step and `λ_min(M_L⁻¹M)` against particles per cell |
//! | `cantilever` | cantilever under gravity | mass × cells | tip deflection against time; Richardson extrapolation |
//! | `single_point` | one material point | update scheme | (a table) |

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::mass::{MassDiagnostics, MassOptions, MassScheme};
use crate::material::{LinearElastic, Material, PlaneCondition};
use crate::operators::Operators;
use crate::particles::{lattice, Particles};
use crate::shape::ShapeFunction;
use crate::simulation::{Body, Options, Simulation, TimeStep, Transfer, UpdateScheme};
use crate::verification::bar::{Bar, Ends};
use crate::verification::manufactured::{self, GeneralisedVortex};
use crate::verification::{cantilever, disks, fitted_order, single_point, Choices, Outcome};

pub mod plot;

use plot::{Chart, Series, SeriesStyle};

/// One part of a study.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Part {
    /// Bar period error against cells for each mass pair.
    Frequency,
    /// Bar energy under PIC, FLIP and FMPM.
    BarEnergy,
    /// Vortex displacement error against cell size for each shape and mass.
    Convergence,
    /// Two-disk energy histories.
    Energy,
    /// Stable step and `λ_min(M_L⁻¹M)` against particles per cell.
    TimeStep,
    /// Cantilever refinement with Richardson extrapolation.
    Cantilever,
    /// The single material point under each update scheme.
    SinglePoint,
}

impl Part {
    /// Every part, in report order.
    pub const ALL: [Part; 7] = [
        Part::Frequency,
        Part::BarEnergy,
        Part::Convergence,
        Part::Energy,
        Part::TimeStep,
        Part::Cantilever,
        Part::SinglePoint,
    ];

    /// The part's name as spelled in a spec (`"frequency"` …).
    pub fn name(&self) -> &'static str {
        match self {
            Part::Frequency => "frequency",
            Part::BarEnergy => "bar_energy",
            Part::Convergence => "convergence",
            Part::Energy => "energy",
            Part::TimeStep => "time_step",
            Part::Cantilever => "cantilever",
            Part::SinglePoint => "single_point",
        }
    }
}

/// What a study runs. Every field has a default; a TOML file names only what it changes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StudySpec {
    /// The parts to run, in report order.
    pub parts: Vec<Part>,
    /// Mass pairs (velocity and acceleration solve) compared.
    pub masses: Vec<MassOptions>,
    /// Shape functions of the convergence part.
    pub shapes: Vec<ShapeFunction>,
    /// Update scheme of every run but the single point's.
    pub update: UpdateScheme,
    /// Courant number (fraction of each scheme's stable step).
    pub cfl: f64,
    /// Cells along the bar.
    pub bar_cells: Vec<usize>,
    /// Cells across the vortex's domain.
    pub vortex_cells: Vec<usize>,
    /// Cells per side of the two-disk domain.
    pub disks_cells: usize,
    /// Cells along the cantilever (three, each twice the last, for the extrapolation).
    pub cantilever_cells: Vec<usize>,
    /// Particles per cell (per axis) of the time-step part.
    pub particles_per_cell: Vec<usize>,
}

impl Default for StudySpec {
    fn default() -> Self {
        let pair = |velocity, acceleration| MassOptions {
            velocity,
            acceleration,
            ..MassOptions::both(MassScheme::Lumped)
        };
        let (l, c) = (MassScheme::Lumped, MassScheme::Consistent);
        StudySpec {
            parts: Part::ALL.to_vec(),
            masses: vec![
                pair(l, l),
                pair(c, c),
                pair(l, c),
                pair(c, l),
                MassOptions::both(MassScheme::Blended { gamma: 13.0 / 18.0 }),
            ],
            shapes: vec![
                ShapeFunction::Linear,
                ShapeFunction::Gimp { half_width: 0.25 },
                ShapeFunction::QuadraticBSpline,
                ShapeFunction::CubicBSpline,
            ],
            update: UpdateScheme::Musl,
            cfl: 0.2,
            bar_cells: vec![8, 16, 32, 64, 128],
            vortex_cells: vec![16, 32, 64, 128],
            disks_cells: 40,
            cantilever_cells: vec![8, 16, 32],
            particles_per_cell: vec![1, 2, 3, 4],
        }
    }
}

impl StudySpec {
    /// A small study (a few seconds) with the same parts, for trying the command out and for
    /// tests.
    pub fn quick() -> StudySpec {
        StudySpec {
            masses: StudySpec::default().masses[..2].to_vec(),
            shapes: vec![ShapeFunction::Linear, ShapeFunction::QuadraticBSpline],
            bar_cells: vec![8, 16, 32],
            vortex_cells: vec![8, 16, 32],
            disks_cells: 10,
            cantilever_cells: vec![4, 8, 16],
            particles_per_cell: vec![1, 2, 3],
            ..StudySpec::default()
        }
    }

    /// Reads a spec from TOML (unknown keys are errors).
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] naming the key, or [`MpmError::Io`].
    pub fn from_toml_str(text: &str) -> Result<StudySpec> {
        let spec: StudySpec = toml::from_str(text).map_err(|e| MpmError::InvalidScene {
            key: "study".into(),
            reason: e.to_string(),
        })?;
        spec.validate()?;
        Ok(spec)
    }

    fn validate(&self) -> Result<()> {
        let bad = |key: &str, reason: &str| {
            Err(MpmError::InvalidScene {
                key: key.into(),
                reason: reason.into(),
            })
        };
        if !(self.cfl > 0.0 && self.cfl <= 1.0) {
            return bad("cfl", "the Courant number must lie in (0, 1]");
        }
        for (key, cells) in [
            ("bar_cells", &self.bar_cells),
            ("vortex_cells", &self.vortex_cells),
            ("cantilever_cells", &self.cantilever_cells),
        ] {
            if cells.iter().any(|&c| c == 0 || c > 4096) {
                return bad(key, "cell counts must lie between 1 and 4096");
            }
        }
        if self.disks_cells == 0 || self.disks_cells > 4096 {
            return bad("disks_cells", "must lie between 1 and 4096");
        }
        if self.particles_per_cell.iter().any(|&n| n == 0 || n > 8) {
            return bad("particles_per_cell", "must lie between 1 and 8");
        }
        Ok(())
    }

    fn choices(&self, mass: MassOptions) -> Choices {
        Choices {
            mass,
            update: self.update,
            cfl: self.cfl,
            ..Choices::default()
        }
    }

    /// The runs the spec asks for, as (part, problem, choices, cells).
    fn plan(&self) -> Vec<Planned> {
        let mut plan = Vec::new();
        let mut add = |part, problem, choices, cells| {
            plan.push(Planned {
                part,
                problem,
                choices,
                cells,
            })
        };
        for &part in &self.parts {
            match part {
                Part::Frequency => {
                    for &mass in &self.masses {
                        for &c in &self.bar_cells {
                            add(part, Problem::BarFixedFixed, self.choices(mass), c);
                        }
                    }
                }
                Part::BarEnergy => {
                    let c = self.bar_cells.get(self.bar_cells.len() / 2).copied().unwrap_or(16);
                    for (scheme, transfer) in [
                        (MassScheme::Lumped, Transfer::Pic),
                        (MassScheme::Lumped, Transfer::Flip),
                        (MassScheme::Lumped, Transfer::Fmpm { k: 8 }),
                        (MassScheme::Consistent, Transfer::Pic),
                        (MassScheme::Consistent, Transfer::Flip),
                    ] {
                        let choices = Choices {
                            transfer,
                            ..self.choices(MassOptions::both(scheme))
                        };
                        add(part, Problem::BarFixedFixed, choices, c);
                    }
                }
                Part::Convergence => {
                    for &shape in &self.shapes {
                        for scheme in [MassScheme::Lumped, MassScheme::Consistent] {
                            for &c in &self.vortex_cells {
                                let choices = Choices {
                                    shape,
                                    ..self.choices(MassOptions::both(scheme))
                                };
                                add(part, Problem::Vortex, choices, c);
                            }
                        }
                    }
                }
                Part::Energy => {
                    for (scheme, transfer) in [
                        (MassScheme::Lumped, Transfer::Flip),
                        (MassScheme::Consistent, Transfer::Flip),
                        (MassScheme::Lumped, Transfer::Pic),
                        (MassScheme::Consistent, Transfer::Pic),
                        (MassScheme::Lumped, Transfer::Fmpm { k: 8 }),
                    ] {
                        let choices = Choices {
                            transfer,
                            ..self.choices(MassOptions::both(scheme))
                        };
                        add(part, Problem::TwoDisks, choices, self.disks_cells);
                    }
                }
                Part::TimeStep => {
                    for &n in &self.particles_per_cell {
                        let choices = Choices {
                            particles_per_cell: n,
                            ..self.choices(MassOptions::both(MassScheme::Lumped))
                        };
                        add(part, Problem::Block, choices, 12);
                    }
                }
                Part::Cantilever => {
                    // Quadratic B-splines: bilinear functions lock in bending, and the deflection
                    // then grows with refinement long before it converges.
                    for scheme in [MassScheme::Lumped, MassScheme::Consistent] {
                        for &c in &self.cantilever_cells {
                            let choices = Choices {
                                shape: ShapeFunction::QuadraticBSpline,
                                ..self.choices(MassOptions::both(scheme))
                            };
                            add(part, Problem::Cantilever, choices, c);
                        }
                    }
                }
                Part::SinglePoint => {
                    for update in [UpdateScheme::Usf, UpdateScheme::Usl, UpdateScheme::Musl] {
                        let choices = Choices {
                            update,
                            ..Choices::default()
                        };
                        add(part, Problem::SinglePoint, choices, 1);
                    }
                }
            }
        }
        plan
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Problem {
    BarFixedFixed,
    Vortex,
    TwoDisks,
    Block,
    Cantilever,
    SinglePoint,
}

#[derive(Debug, Clone, Copy)]
struct Planned {
    part: Part,
    problem: Problem,
    choices: Choices,
    cells: usize,
}

/// The bar of the frequency and energy parts: the published bar at amplitude 1e-3, so that the
/// particles stay within a fraction of a cell of their start.
fn small_bar() -> Bar {
    Bar {
        amplitude: 1e-3,
        ..Bar::new(Ends::FixedFixed)
    }
}

/// The vortex of the convergence part: the published ring at amplitude 0.05.
fn vortex() -> GeneralisedVortex {
    GeneralisedVortex {
        amplitude: 0.05,
        ..GeneralisedVortex::default()
    }
}

/// The time-step part's block: 8 × 8 cells filled with `n × n` particles per cell in a 12 × 12
/// grid (h = 1, E = 1000, ν = 0.3 plane strain, ρ = 1), at rest. Metrics: `stable_step_lumped`,
/// `stable_step_consistent` (FLIP, in units of h/c; NaN when the consistent mass is singular)
/// and `lambda_min` (`λ_min(M_L⁻¹M)`, Lanczos).
fn block_time_steps(n: usize) -> Result<Outcome> {
    let grid = Grid::new([0.0, 0.0], [1.0, 1.0], [12, 12])?;
    let (x, y, volume) = lattice(&grid, n, |px, py| {
        (2.0..10.0).contains(&px) && (2.0..10.0).contains(&py)
    });
    let count = x.len();
    let particles = Particles::new(x, y, vec![volume; count], vec![volume; count])?;
    let material = LinearElastic::new(1000.0, 0.3, PlaneCondition::Strain)?;
    let c = material.wave_speed(1.0);
    let stable = |scheme| -> f64 {
        let options = Options {
            mass: MassOptions::both(scheme),
            time_step: TimeStep::Cfl { number: 1.0 },
            ..Options::default()
        };
        let bodies = vec![Body {
            name: "block".into(),
            material: Material::LinearElastic(material),
        }];
        Simulation::new(grid.clone(), particles.clone(), bodies, options).map_or(f64::NAN, |s| s.stable_time_step() * c)
    };
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &particles)?;
    let diagnostics = MassDiagnostics::compute(&ops, &particles.mass, &MassOptions::plain(MassScheme::Consistent))?;
    Ok(Outcome {
        problem: "block".into(),
        cells: 8,
        cell_size: 1.0,
        metrics: vec![
            ("stable_step_lumped".into(), stable(MassScheme::Lumped)),
            ("stable_step_consistent".into(), stable(MassScheme::Consistent)),
            ("lambda_min".into(), diagnostics.lambda_min_estimate),
        ],
        histories: Vec::new(),
        steps: 0,
        seconds: 0.0,
    })
}

impl Planned {
    fn run(&self) -> Result<Outcome> {
        match self.problem {
            Problem::BarFixedFixed => small_bar().run(self.cells, &self.choices),
            Problem::Vortex => manufactured::run(&vortex(), self.cells, &self.choices),
            Problem::TwoDisks => disks::run(self.cells, &self.choices),
            Problem::Block => block_time_steps(self.choices.particles_per_cell),
            Problem::Cantilever => cantilever::run(self.cells, &self.choices),
            Problem::SinglePoint => single_point::run(0.01, &self.choices),
        }
    }

    fn describe(&self) -> String {
        format!(
            "{} / {:?} / {} / {} cells",
            self.part.name(),
            self.problem,
            self.choices.label(),
            self.cells
        )
    }
}

/// One finished run of a study.
#[derive(Debug, Clone)]
pub struct StudyRun {
    /// The part it belongs to.
    pub part: Part,
    /// Its choices.
    pub choices: Choices,
    /// Cells.
    pub cells: usize,
    /// What it measured, or why it failed.
    pub outcome: std::result::Result<Outcome, String>,
}

/// Where a study is: runs done out of the total, and the one starting.
#[derive(Debug, Clone)]
pub struct StudyProgress {
    /// Runs finished.
    pub done: usize,
    /// Runs in all.
    pub total: usize,
    /// The run starting now.
    pub current: String,
}

/// What a study wrote.
#[derive(Debug, Clone)]
pub struct StudySummary {
    /// Every run.
    pub runs: Vec<StudyRun>,
    /// `report.md`.
    pub report: PathBuf,
    /// `runs.csv`.
    pub csv: PathBuf,
    /// The PNG plots.
    pub plots: Vec<PathBuf>,
}

/// Runs `spec`, writing `runs.csv`, the PNG plots and `report.md` into `out` (created if
/// needed). A run that fails (for example a singular consistent mass with one particle per
/// cell) is recorded with its error and left out of the plots; the study goes on.
///
/// # Errors
/// [`MpmError::Io`] when the folder or a file cannot be written; [`MpmError::InvalidScene`]
/// for an invalid spec.
pub fn run_study(spec: &StudySpec, out: &Path, mut progress: impl FnMut(&StudyProgress)) -> Result<StudySummary> {
    spec.validate()?;
    std::fs::create_dir_all(out).map_err(|source| MpmError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    let plan = spec.plan();
    let mut runs = Vec::with_capacity(plan.len());
    for (k, planned) in plan.iter().enumerate() {
        progress(&StudyProgress {
            done: k,
            total: plan.len(),
            current: planned.describe(),
        });
        runs.push(StudyRun {
            part: planned.part,
            choices: planned.choices,
            cells: planned.cells,
            outcome: planned.run().map_err(|e| e.to_string()),
        });
    }
    progress(&StudyProgress {
        done: plan.len(),
        total: plan.len(),
        current: String::new(),
    });
    let csv = out.join("runs.csv");
    write_runs_csv(&runs, &csv)?;
    let mut plots = Vec::new();
    let mut report = String::new();
    writeln!(report, "# Consistent against lumped mass: a study\n").ok();
    writeln!(
        report,
        "Written by `mpm study`. Every run is a row of [`runs.csv`](runs.csv); the problems, references \
         and tolerances are in docs/verification.md. Courant number {} of each scheme's stable step, {} \
         update unless a part says otherwise; runs that failed are listed at the end.\n",
        spec.cfl,
        format!("{:?}", spec.update).to_uppercase()
    )
    .ok();
    for &part in &spec.parts {
        let of_part: Vec<&StudyRun> = runs.iter().filter(|r| r.part == part).collect();
        section(part, &of_part, out, &mut report, &mut plots)?;
    }
    let failures: Vec<&StudyRun> = runs.iter().filter(|r| r.outcome.is_err()).collect();
    if !failures.is_empty() {
        writeln!(report, "## Runs that failed\n").ok();
        for r in failures {
            writeln!(
                report,
                "- {} / {} / {} cells: {}",
                r.part.name(),
                r.choices.label(),
                r.cells,
                r.outcome.as_ref().err().map_or("", |e| e.as_str())
            )
            .ok();
        }
    }
    let report_path = out.join("report.md");
    std::fs::write(&report_path, report).map_err(|source| MpmError::Io {
        path: report_path.clone(),
        source,
    })?;
    Ok(StudySummary {
        runs,
        report: report_path,
        csv,
        plots,
    })
}

/// `runs.csv`: one row per run, the choices, then every metric any run measured.
fn write_runs_csv(runs: &[StudyRun], path: &Path) -> Result<()> {
    let names: BTreeSet<&str> = runs
        .iter()
        .filter_map(|r| r.outcome.as_ref().ok())
        .flat_map(|o| o.metrics.iter().map(|(n, _)| n.as_str()))
        .collect();
    let io = |e: csv::Error| MpmError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    };
    let mut w = csv::Writer::from_path(path).map_err(io)?;
    let mut header = vec![
        "part",
        "problem",
        "label",
        "shape",
        "update",
        "transfer",
        "velocity_mass",
        "acceleration_mass",
        "particles_per_cell",
        "cfl",
        "cells",
        "cell_size",
        "steps",
        "seconds",
        "ms_per_step",
        "error",
    ];
    header.extend(names.iter());
    w.write_record(&header).map_err(io)?;
    for r in runs {
        let c = &r.choices;
        let mut row = vec![
            r.part.name().to_string(),
            r.outcome.as_ref().map_or(String::new(), |o| o.problem.clone()),
            c.label(),
            c.shape.name().to_string(),
            format!("{:?}", c.update).to_lowercase(),
            format!("{:?}", c.transfer).to_lowercase(),
            c.mass.velocity.label(),
            c.mass.acceleration.label(),
            c.particles_per_cell.to_string(),
            c.cfl.to_string(),
            r.cells.to_string(),
        ];
        match &r.outcome {
            Ok(o) => {
                row.push(o.cell_size.to_string());
                row.push(o.steps.to_string());
                row.push(o.seconds.to_string());
                row.push(if o.steps > 0 {
                    (1e3 * o.seconds / o.steps as f64).to_string()
                } else {
                    String::new()
                });
                row.push(String::new());
                for n in &names {
                    row.push(o.metric(n).map_or(String::new(), |v| v.to_string()));
                }
            }
            Err(e) => {
                row.extend([String::new(), String::new(), String::new(), String::new(), e.clone()]);
                row.extend(names.iter().map(|_| String::new()));
            }
        }
        w.write_record(&row).map_err(io)?;
    }
    w.flush().map_err(|source| MpmError::Io {
        path: path.to_path_buf(),
        source,
    })
}

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

fn section(part: Part, runs: &[&StudyRun], out: &Path, md: &mut String, plots: &mut Vec<PathBuf>) -> Result<()> {
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
