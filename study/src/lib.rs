//! # sparse-mpm-study
//!
//! The mass study of [`sparse_mpm`]: the verification problems with known answers
//! ([`verification`]), the worked course problem ([`homework`]), and `mpm study`, which runs the
//! problems over a matrix of
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
//! | `stabilization` | spinning disk, strip projection, thin cantilevers, two disks | stabilisation of the consistent mass | (tables) |
//! | `implicit` | bar, cantilever, two disks | explicit or Newmark (1×–10× the explicit step) × lumped, consistent | bar period error against Δt with the discrete Newmark theory; (tables) |
#![deny(missing_docs)]

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::verification::bar::{Bar, Ends};
use crate::verification::collapse::Collapse;
use crate::verification::column::Column;
use crate::verification::impulse::ImpulseBar;
use crate::verification::manufactured::{self, GeneralisedVortex};
use crate::verification::wave::Wave;
use crate::verification::{cantilever, disks, rotation, single_point, Choices, Outcome};
use sparse_mpm::damping::{Damping, DampingModel};
use sparse_mpm::error::{MpmError, Result};
use sparse_mpm::mass::{MassOptions, MassScheme, SingularityPolicy, Stabilization};
use sparse_mpm::shape::ShapeFunction;
use sparse_mpm::simulation::{Transfer, UpdateScheme};

pub mod homework;
pub mod plot;
mod remedies;
mod report;
mod runs_csv;
mod shard;
mod spec_checks;
mod spectrum;
pub mod verification;
mod whole;

pub use shard::{
    merge_study, plan_study, read_plan, run_share, MergeSummary, PlannedRun, Share, ShareSummary, StudyPlan,
};

pub use whole::run_study;
use whole::write_study;

mod block;

/// The step of the implicit part's Newmark runs, in explicit stable steps at `t = 0`.
pub(crate) const IMPLICIT_STEP: f64 = 5.0;

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
    /// The consistent mass's stabilisations on rotation, thin bodies and impact.
    Stabilization,
    /// The discrete dispersion relation over the whole spectrum for each shape and mass pair.
    Dispersion,
    /// A step and a pulse in a long bar against d'Alembert for each mass pair.
    Waves,
    /// The single material point under a sequence of time steps for each update scheme.
    TimeOrder,
    /// Explicit against implicit (Newmark) integration with each mass: bar period against Δt and
    /// h, cantilever, two disks.
    Implicit,
    /// The elastic column under its own weight: the stress error against `1/h` per kernel,
    /// quasi-static at small and large strain, and relaxed dynamically (explicit with damping)
    /// with the lumped and the consistent mass.
    Column,
    /// The granular column collapse: run-out, final height, time to rest, dissipation and the
    /// stress at rest against the aspect ratio for each mass, with the experimental laws.
    Collapse,
}

impl Part {
    /// Every part, in report order.
    pub const ALL: [Part; 14] = [
        Part::Dispersion,
        Part::Frequency,
        Part::BarEnergy,
        Part::Convergence,
        Part::Energy,
        Part::TimeStep,
        Part::Cantilever,
        Part::Column,
        Part::Collapse,
        Part::SinglePoint,
        Part::TimeOrder,
        Part::Waves,
        Part::Stabilization,
        Part::Implicit,
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
            Part::Stabilization => "stabilization",
            Part::Dispersion => "dispersion",
            Part::Waves => "waves",
            Part::TimeOrder => "time_order",
            Part::Implicit => "implicit",
            Part::Column => "column",
            Part::Collapse => "collapse",
        }
    }
}

/// The smallest Courant number a [`StudySpec`] takes (`cfl`): a study's runs take about
/// `1/cfl` times their steps, so that 10⁻³⁰ (accepted before) planned runs that would never
/// end; at 0.01 the study takes 20 times the steps of the default 0.2.
pub const MIN_STUDY_CFL: f64 = 0.01;

/// The most values of one list of a [`StudySpec`] (masses, shapes, cell counts …): a study's
/// runs grow as the product of its lists.
pub const MAX_LIST_VALUES: usize = 64;

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
    /// Stabilisations of the consistent mass compared by the stabilisation part.
    pub stabilizations: Vec<Stabilization>,
    /// Cells across the spinning disk's unit square (stabilisation part).
    pub rotation_cells: usize,
    /// Cells along the bar of the waves part (the profiles are plotted on the finest).
    pub wave_cells: Vec<usize>,
    /// Cells along the impulse-loaded bar of the waves part.
    pub impulse_cells: Vec<usize>,
    /// Time steps of the time-order part (`Δt = 4e-3 / 2^k`, `k` below this).
    pub time_steps: usize,
    /// Cells along the height of the column.
    pub column_cells: Vec<usize>,
    /// Aspect ratios `H₀/L₀` of the granular collapse.
    pub collapse_aspects: Vec<f64>,
    /// Cells across the collapsing column's width `L₀`.
    pub collapse_cells: usize,
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
            shapes: sparse_mpm::shape::FAMILIES.to_vec(),
            update: UpdateScheme::Musl,
            cfl: 0.2,
            bar_cells: vec![8, 16, 32, 64, 128],
            vortex_cells: vec![16, 32, 64, 128],
            disks_cells: 40,
            cantilever_cells: vec![8, 16, 32],
            particles_per_cell: vec![1, 2, 3, 4],
            stabilizations: remedies::default_stabilizations(),
            rotation_cells: 20,
            wave_cells: vec![100, 200, 400],
            impulse_cells: vec![25, 50, 100],
            time_steps: 4,
            column_cells: vec![8, 16, 32, 64],
            collapse_aspects: vec![0.5, 1.0, 2.0, 3.0],
            collapse_cells: 30,
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
            rotation_cells: 10,
            stabilizations: vec![Stabilization::default()],
            wave_cells: vec![50, 100],
            impulse_cells: vec![25, 50],
            time_steps: 3,
            column_cells: vec![8, 16],
            collapse_aspects: vec![0.5],
            collapse_cells: 8,
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

    fn choices(&self, mass: MassOptions) -> Choices {
        Choices {
            mass,
            update: self.update,
            cfl: self.cfl,
            ..Choices::default()
        }
    }

    /// The runs the spec asks for, as (part, problem, choices, cells), part by part in the
    /// spec's order.
    fn plan(&self) -> Vec<Planned> {
        self.parts.iter().flat_map(|&part| self.plan_part(part)).collect()
    }

    /// The runs of one part.
    fn plan_part(&self, part: Part) -> Vec<Planned> {
        let runs = match part {
            Part::Frequency => self.plan_frequency(),
            Part::BarEnergy => self.plan_bar_energy(),
            Part::Convergence => self.plan_convergence(),
            Part::Energy => self.plan_energy(),
            Part::TimeStep => self.plan_time_step(),
            Part::Cantilever => self.plan_cantilever(),
            Part::Column => self.plan_column(),
            Part::Collapse => self.plan_collapse(),
            Part::SinglePoint => Self::plan_single_point(),
            Part::Stabilization => self.plan_stabilization(),
            Part::Dispersion => self.plan_dispersion(),
            Part::Waves => self.plan_waves(),
            Part::TimeOrder => self.plan_time_order(),
            Part::Implicit => self.plan_implicit(),
        };
        runs.into_iter()
            .map(|(problem, choices, cells)| Planned {
                part,
                problem,
                choices,
                cells,
            })
            .collect()
    }

    /// The frequency part: the bar for every mass pair on every bar grid with bilinear
    /// functions, and with every other shape of the spec on the two finest bar grids of at most
    /// 64 cells ([`StudySpec::kernel_bar_cells`]).
    fn plan_frequency(&self) -> Vec<(Problem, Choices, usize)> {
        let mut runs = Vec::new();
        for &mass in &self.masses {
            for &c in &self.bar_cells {
                runs.push((Problem::BarFixedFixed, self.choices(mass), c));
            }
        }
        for &shape in self.shapes.iter().filter(|&&s| s != ShapeFunction::Linear) {
            for &mass in &self.masses {
                for c in self.kernel_bar_cells() {
                    let choices = Choices {
                        shape,
                        ..self.choices(mass)
                    };
                    runs.push((Problem::BarFixedFixed, choices, c));
                }
            }
        }
        runs
    }

    /// The bar grids of the other kernels: the two finest of `bar_cells` with at most 64 cells
    /// (the coarsest two when none is that small).
    pub(crate) fn kernel_bar_cells(&self) -> Vec<usize> {
        let mut cells: Vec<usize> = self.bar_cells.clone();
        cells.sort_unstable();
        cells.dedup();
        let small: Vec<usize> = cells.iter().copied().filter(|&c| c <= 64).collect();
        let pick = if small.len() >= 2 { small } else { cells };
        pick[pick.len().saturating_sub(2)..].to_vec()
    }

    /// The bar-energy part: the bar on the middle bar grid under PIC, FLIP and FMPM with the
    /// lumped mass, PIC and FLIP with the consistent one.
    fn plan_bar_energy(&self) -> Vec<(Problem, Choices, usize)> {
        let c = self.bar_cells.get(self.bar_cells.len() / 2).copied().unwrap_or(16);
        [
            (MassScheme::Lumped, Transfer::Pic),
            (MassScheme::Lumped, Transfer::Flip),
            (MassScheme::Lumped, Transfer::Fmpm { k: 8 }),
            (MassScheme::Consistent, Transfer::Pic),
            (MassScheme::Consistent, Transfer::Flip),
        ]
        .into_iter()
        .map(|(scheme, transfer)| (Problem::BarFixedFixed, self.transfer_choices(scheme, transfer), c))
        .collect()
    }

    /// The convergence part: the vortex for every shape, with the lumped and the consistent
    /// mass, on every vortex grid.
    fn plan_convergence(&self) -> Vec<(Problem, Choices, usize)> {
        let mut runs = Vec::new();
        for &shape in &self.shapes {
            for scheme in [MassScheme::Lumped, MassScheme::Consistent] {
                for &c in &self.vortex_cells {
                    let choices = Choices {
                        shape,
                        ..self.choices(MassOptions::both(scheme))
                    };
                    runs.push((Problem::Vortex, choices, c));
                }
            }
        }
        runs
    }

    /// The energy part: the two disks under FLIP and PIC with each mass, and FMPM with the
    /// lumped mass.
    fn plan_energy(&self) -> Vec<(Problem, Choices, usize)> {
        [
            (MassScheme::Lumped, Transfer::Flip),
            (MassScheme::Consistent, Transfer::Flip),
            (MassScheme::Lumped, Transfer::Pic),
            (MassScheme::Consistent, Transfer::Pic),
            (MassScheme::Lumped, Transfer::Fmpm { k: 8 }),
        ]
        .into_iter()
        .map(|(scheme, transfer)| {
            (
                Problem::TwoDisks,
                self.transfer_choices(scheme, transfer),
                self.disks_cells,
            )
        })
        .collect()
    }

    /// The time-step part: the block (12 × 12 grid) for every particle count.
    fn plan_time_step(&self) -> Vec<(Problem, Choices, usize)> {
        self.particles_per_cell
            .iter()
            .map(|&n| {
                let choices = Choices {
                    particles_per_cell: n,
                    ..self.choices(MassOptions::both(MassScheme::Lumped))
                };
                (Problem::Block, choices, 12)
            })
            .collect()
    }

    /// The cantilever part: quadratic B-splines with the lumped and the consistent mass on
    /// every cantilever grid.
    /// The implicit part: with the lumped and the consistent mass, the bar explicit and with
    /// Newmark at 5× the explicit stable step on every bar grid of at most 64 cells, and at
    /// 1×, 2×, 5× and 10× on the finest of them; the cantilever (quadratic B-splines, the middle
    /// grid) and the two disks explicit and at 5×.
    fn plan_implicit(&self) -> Vec<(Problem, Choices, usize)> {
        let mut runs = Vec::new();
        let bars: Vec<usize> = self.bar_cells.iter().copied().filter(|&c| c <= 64).collect();
        let finest = bars.iter().copied().max();
        for scheme in [MassScheme::Lumped, MassScheme::Consistent] {
            let base = self.choices(MassOptions::both(scheme));
            let at = |factor: Option<f64>| Choices {
                implicit_step: factor,
                ..base
            };
            for &c in &bars {
                runs.push((Problem::BarFixedFixed, at(None), c));
                runs.push((Problem::BarFixedFixed, at(Some(IMPLICIT_STEP)), c));
            }
            if let Some(c) = finest {
                for factor in [1.0, 2.0, 10.0] {
                    runs.push((Problem::BarFixedFixed, at(Some(factor)), c));
                }
            }
            let quadratic = |factor| Choices {
                shape: ShapeFunction::QuadraticBSpline,
                ..at(factor)
            };
            if let Some(&c) = self.cantilever_cells.get(self.cantilever_cells.len() / 2) {
                runs.push((Problem::Cantilever, quadratic(None), c));
                runs.push((Problem::Cantilever, quadratic(Some(IMPLICIT_STEP)), c));
            }
            runs.push((Problem::TwoDisks, at(None), self.disks_cells));
            runs.push((Problem::TwoDisks, at(Some(IMPLICIT_STEP)), self.disks_cells));
        }
        runs
    }

    fn plan_cantilever(&self) -> Vec<(Problem, Choices, usize)> {
        // Quadratic B-splines: bilinear functions lock in bending, and the deflection then
        // grows with refinement long before it converges.
        let mut runs = Vec::new();
        for scheme in [MassScheme::Lumped, MassScheme::Consistent] {
            for &c in &self.cantilever_cells {
                let choices = Choices {
                    shape: ShapeFunction::QuadraticBSpline,
                    ..self.choices(MassOptions::both(scheme))
                };
                runs.push((Problem::Cantilever, choices, c));
            }
        }
        runs
    }

    /// The column part: every shape quasi-static at small and large strain (the mass does not
    /// enter), and relaxed dynamically at small strain with the lumped and the consistent mass
    /// (FLIP, the spec's update and Courant number), on each of the column's grids.
    fn plan_column(&self) -> Vec<(Problem, Choices, usize)> {
        let mut runs = Vec::new();
        for &shape in &self.shapes {
            for &c in &self.column_cells {
                let lumped = Choices {
                    shape,
                    ..self.choices(MassOptions::both(MassScheme::Lumped))
                };
                runs.push((Problem::ColumnSmallStrain, lumped, c));
                runs.push((Problem::ColumnLargeStrain, lumped, c));
                for scheme in [MassScheme::Lumped, MassScheme::Consistent] {
                    let choices = Choices {
                        shape,
                        mass: MassOptions {
                            singularity: SingularityPolicy::FallbackToLumped,
                            ..MassOptions::both(scheme)
                        },
                        ..lumped
                    };
                    runs.push((Problem::ColumnRelaxed, choices, c));
                }
            }
        }
        runs
    }

    /// The collapse part: every aspect ratio with each of the spec's mass pairs, quadratic
    /// B-splines, MUSL, Courant number 0.4: APIC where the velocity projection is lumped (the
    /// transfer of granular flows: they come to rest), FLIP where it is not (APIC's affine
    /// momentum belongs to the lumped projection), and FLIP with the lumped mass beside them.
    fn plan_collapse(&self) -> Vec<(Problem, Choices, usize)> {
        let mut runs = Vec::new();
        let lumped = MassOptions::both(MassScheme::Lumped);
        let mut pairs: Vec<(MassOptions, Transfer)> = Vec::new();
        for &mass in &self.masses {
            let transfer = if mass.velocity == MassScheme::Lumped {
                Transfer::Apic
            } else {
                Transfer::Flip
            };
            let mass = MassOptions {
                singularity: SingularityPolicy::FallbackToLumped,
                ..mass
            };
            pairs.push((mass, transfer));
        }
        if pairs.iter().any(|&(_, t)| t == Transfer::Flip) {
            pairs.push((lumped, Transfer::Flip));
        }
        for &a in &self.collapse_aspects {
            for &(mass, transfer) in &pairs {
                let choices = Choices {
                    shape: ShapeFunction::QuadraticBSpline,
                    transfer,
                    mass,
                    cfl: 0.4,
                    ..self.choices(mass)
                };
                let aspect = (a * 1000.0).round() as u32;
                runs.push((Problem::Collapse(aspect), choices, self.collapse_cells));
            }
        }
        runs
    }

    /// The single-point part: the default choices under USF, USL and MUSL (the spec's update
    /// and Courant number do not apply).
    fn plan_single_point() -> Vec<(Problem, Choices, usize)> {
        [UpdateScheme::Usf, UpdateScheme::Usl, UpdateScheme::Musl]
            .into_iter()
            .map(|update| {
                let choices = Choices {
                    update,
                    ..Choices::default()
                };
                (Problem::SinglePoint, choices, 1)
            })
            .collect()
    }

    /// The spec's choices with both solves of `scheme` and `transfer`.
    fn transfer_choices(&self, scheme: MassScheme, transfer: Transfer) -> Choices {
        Choices {
            transfer,
            ..self.choices(MassOptions::both(scheme))
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
enum Problem {
    BarFixedFixed,
    Vortex,
    TwoDisks,
    Block,
    Cantilever,
    SinglePoint,
    SpinningDisk,
    StripProjection,
    Dispersion,
    WaveStep,
    WavePulse,
    ImpulseBar,
    SinglePointStep,
    ColumnSmallStrain,
    ColumnLargeStrain,
    ColumnRelaxed,
    /// The granular collapse at the aspect ratio in thousandths.
    Collapse(u32),
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
pub(crate) fn small_bar() -> Bar {
    Bar {
        amplitude: 1e-3,
        ..Bar::new(Ends::FixedFixed)
    }
}

/// The vortex of the convergence part: the published ring with the smooth profile
/// `(1 − ξ²)³` at amplitude 0.05.
fn vortex() -> GeneralisedVortex {
    GeneralisedVortex::smooth(0.05)
}

impl Planned {
    fn run(&self) -> Result<Outcome> {
        match self.problem {
            Problem::BarFixedFixed => small_bar().run(self.cells, &self.choices),
            Problem::Vortex => manufactured::run(&vortex(), self.cells, &self.choices),
            Problem::TwoDisks => disks::run(self.cells, &self.choices),
            Problem::Block => block::block_time_steps(self.choices.particles_per_cell),
            Problem::Cantilever => cantilever::run(self.cells, &self.choices),
            Problem::SinglePoint => single_point::run(0.01, &self.choices),
            Problem::SpinningDisk => rotation::spinning_disk(self.cells, &self.choices),
            Problem::StripProjection => rotation::strip_projection_error(&self.choices),
            Problem::Dispersion => spectrum::dispersion_run(&self.choices),
            Problem::WaveStep => Wave::step().run(self.cells, &self.choices),
            Problem::WavePulse => Wave::pulse(0.1).run(self.cells, &self.choices),
            Problem::ImpulseBar => ImpulseBar::default().run(self.cells, &self.choices),
            Problem::SinglePointStep => spectrum::time_order_run(self.cells, &self.choices),
            Problem::ColumnSmallStrain => Column::SMALL_STRAIN.run(self.cells, &self.choices),
            Problem::ColumnLargeStrain => {
                let mut outcome = Column::LARGE_STRAIN.run(self.cells, &self.choices)?;
                outcome.problem = "column_large_strain".into();
                Ok(outcome)
            }
            Problem::Collapse(aspect) => Collapse::new(f64::from(aspect) / 1000.0).run(self.cells, &self.choices),
            Problem::ColumnRelaxed => {
                let damping = Damping {
                    model: DampingModel::Local,
                    alpha: 0.8,
                    settled: sparse_mpm::damping::DEFAULT_SETTLED,
                };
                // The weight applied over two periods of the first mode.
                let ramp = Some(2.0 * Column::SMALL_STRAIN.period());
                Ok(Column::SMALL_STRAIN
                    .relax(self.cells, &self.choices, damping, ramp, 200.0)?
                    .1)
            }
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
