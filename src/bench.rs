//! `mpm bench`: the benchmark problem the fastest CPU MPM codes publish figures for, run by this
//! library's engine, timed over whole explicit steps.
//!
//! The problem (the same as the Warp, Taichi and NumPy/SciPy scripts it is compared with, see
//! docs/performance.md): the unit square with `n_grid = round(√N)` cells per side; `N` particles
//! uniformly at random in `[0.25, 0.75]²` (about 4 per cell there), in random memory order, each
//! with volume `(h/2)²` and density 1; initial velocity `(0, −1)`; gravity 9.8 downwards; slip
//! walls holding the 3 outermost node lines of every side; neo-Hookean (plane strain) with
//! `E = 400`, `ν = 0.2`; fixed `Δt = 2·10⁻⁴ · 128 / n_grid`. A configuration whose stable step
//! is shorter than that (the consistent mass: its highest frequency is about √3 times the
//! lumped mass's with linear shape functions) runs at [`BENCH_COURANT`] of the stable step the
//! time loop reports instead, re-estimated as in any run ([`BenchRow::dt`] is its first step).
//!
//! Timing: particle-steps per second (`N × steps / seconds`) over the timed steps of each
//! repetition. Set-up — building the simulation (which assembles the operators and estimates
//! the stable step) and one untimed warm-up step that grows every buffer to size — is excluded,
//! as the peers exclude theirs.
//!
//! Memory: the peak resident set size of the process during the set-up and the timed steps,
//! less the resident size before the set-up, per particle (Linux; `None` elsewhere). The peak is
//! reset before each configuration (`/proc/self/clear_refs`).

use std::time::Instant;

use crate::boundary::{BoundaryCondition, Condition, Edge};
use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::mass::{MassOptions, MassScheme, Stabilization};
use crate::material::{Material, NeoHookean};
use crate::particles::Particles;
use crate::shape::ShapeFunction;
use crate::simulation::{
    Body, EstimateCounts, Integrator, Options, Profile, Simulation, TimeStep, Transfer, UpdateScheme,
    DEFAULT_STABILITY_INTERVAL,
};

/// Young's modulus of the benchmark material.
pub const YOUNGS_MODULUS: f64 = 400.0;
/// Poisson's ratio of the benchmark material.
pub const POISSON_RATIO: f64 = 0.2;
/// Density of the benchmark material.
pub const DENSITY: f64 = 1.0;
/// Gravity (downwards).
pub const GRAVITY: f64 = 9.8;
/// Node lines held by the slip walls on every side.
pub const WALL_LAYERS: usize = 3;
/// The particle counts the peers report.
pub const PEER_SIZES: [usize; 4] = [8192, 65536, 262144, 1048576];

/// One configuration of the benchmark.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchSpec {
    /// Shape-function family.
    pub shape: ShapeFunction,
    /// Mass scheme of both solves.
    pub mass: MassScheme,
    /// Stabilisation of the consistent mass (schemes other than lumped).
    pub stabilization: Stabilization,
    /// Velocity transfer.
    pub transfer: Transfer,
    /// Update scheme.
    pub update: UpdateScheme,
    /// Particle counts to run.
    pub particles: Vec<usize>,
    /// Worker threads (1: serial).
    pub threads: usize,
    /// Timed steps per repetition (`None`: the peers' rule, `max(20, min(2000, 2·10⁷ / N))`).
    pub steps: Option<usize>,
    /// Repetitions (at least 1; the median is reported).
    pub reps: usize,
    /// Seed of the particle positions.
    pub seed: u64,
    /// Time the phases of the timed steps ([`Simulation::set_profiling`]).
    pub profile: bool,
    /// A fixed time step instead of the problem's (`None`: the peers' step, or a fraction of
    /// the stable step where that is shorter).
    pub dt: Option<f64>,
    /// Run at this Courant number of the stable step the time loop reports, whatever the
    /// mass (re-estimated as in any run), instead of the peers' step: so that masses are
    /// compared at their own safe steps (`dt` wins where both are given).
    pub cfl: Option<f64>,
    /// The time integrator: explicit (the update scheme, a stable-step limit), or Newmark's
    /// rule with Newton iterations, which has no stable step and takes the fixed step (`dt`,
    /// or the peers' step).
    pub integrator: Integrator,
}

impl Default for BenchSpec {
    fn default() -> Self {
        BenchSpec {
            shape: ShapeFunction::QuadraticBSpline,
            mass: MassScheme::Lumped,
            stabilization: Stabilization::default(),
            transfer: Transfer::Apic,
            update: UpdateScheme::Usl,
            particles: PEER_SIZES.to_vec(),
            threads: 1,
            steps: None,
            reps: 5,
            seed: 1,
            profile: false,
            dt: None,
            cfl: None,
            integrator: Integrator::Explicit,
        }
    }
}

/// The timed steps of one particle count: the peers' rule `max(20, min(2000, 2·10⁷ / N))`.
pub fn default_steps(particles: usize) -> usize {
    (20_000_000 / particles.max(1)).clamp(20, 2000)
}

/// The figures of one particle count.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchRow {
    /// Particles.
    pub particles: usize,
    /// Cells per side.
    pub n_grid: usize,
    /// Timed steps per repetition.
    pub steps: usize,
    /// The time step of the first step (the fixed step, or the first Courant step).
    pub dt: f64,
    /// The shortest and the longest timed step over every repetition.
    pub dt_range: [f64; 2],
    /// Wall seconds of the timed steps of each repetition.
    pub seconds: Vec<f64>,
    /// Wall seconds of the first set-up (build and warm-up step).
    pub setup_seconds: f64,
    /// Peak resident bytes per particle over set-up and steps (Linux only).
    pub peak_bytes_per_particle: Option<f64>,
    /// Phase times summed over every repetition's timed steps, when profiled.
    pub profile: Option<Profile>,
    /// Frequency estimates made during the timed steps of every repetition, and the Lanczos or
    /// LOBPCG steps they took in all ([`crate::stiffness::FrequencyEstimate::lanczos_steps`]).
    pub estimates: [usize; 2],
    /// The estimates and guards of the stable step over the timed steps of every repetition
    /// ([`Simulation::estimate_counts`]).
    pub counts: EstimateCounts,
    /// Simulated time of the timed steps of each repetition.
    pub simulated: Vec<f64>,
}

impl BenchRow {
    /// Particle-steps per second of each repetition, ascending.
    pub fn rates(&self) -> Vec<f64> {
        let mut r: Vec<f64> = self
            .seconds
            .iter()
            .map(|s| (self.particles * self.steps) as f64 / s)
            .collect();
        r.sort_by(f64::total_cmp);
        r
    }

    /// `[min, median, max]` particle-steps per second.
    pub fn rate_summary(&self) -> [f64; 3] {
        let r = self.rates();
        [r[0], median(&r), r[r.len() - 1]]
    }

    /// The median over repetitions of the wall seconds per simulated second (what a run to a
    /// given time costs), `seconds / simulated time` of each repetition.
    pub fn seconds_per_simulated_second(&self) -> f64 {
        let mut r: Vec<f64> = self
            .seconds
            .iter()
            .zip(&self.simulated)
            .map(|(s, t)| if *t > 0.0 { s / t } else { f64::INFINITY })
            .collect();
        r.sort_by(f64::total_cmp);
        median(&r)
    }

    /// The median wall seconds per timed step over repetitions.
    pub fn seconds_per_step(&self) -> f64 {
        let mut r: Vec<f64> = self.seconds.iter().map(|s| s / self.steps.max(1) as f64).collect();
        r.sort_by(f64::total_cmp);
        median(&r)
    }
}

fn median(sorted: &[f64]) -> f64 {
    let n = sorted.len();
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
    }
}

/// A deterministic generator of uniform numbers in [0, 1) (SplitMix64).
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Courant number of the schemes whose stable step is below the peers' step: they run at this
/// fraction of the stable step the time loop reports, re-estimated as it is in any run (every
/// [`DEFAULT_STABILITY_INTERVAL`] steps and whenever the active nodes change,
/// [`Simulation::stable_time_step`]), so the timed steps include those estimates.
pub const BENCH_COURANT: f64 = 0.9;

/// The benchmark problem with `n` particles under `spec`'s schemes, at time 0: the peers' fixed
/// step, or, where the stable step is shorter (the consistent mass: its highest frequency is
/// about √3 times the lumped mass's with linear shape functions), [`BENCH_COURANT`] times the
/// stable step.
///
/// The peers' step is taken unchecked, as the peers take it, and the frozen-configuration
/// stable step does not see every instability: with linear shape functions and the lumped
/// mass (APIC, PIC or FLIP, USL) the random block inverts a particle after about 100 steps at
/// 16,384 particles at the peers' step, and after 865 steps at half of it (docs/performance.md).
///
/// # Errors
/// [`MpmError::InvalidParameter`] for fewer than 16 particles; the errors of
/// [`Simulation::new`].
pub fn problem(n: usize, spec: &BenchSpec) -> Result<Simulation> {
    if let Some(dt) = spec.dt {
        return build(n, spec, dt);
    }
    let peers_dt = peers_time_step(n);
    if spec.integrator != Integrator::Explicit {
        return build(n, spec, peers_dt);
    }
    if let Some(number) = spec.cfl {
        return falling_block(n, spec, TimeStep::Cfl { number }, DEFAULT_STABILITY_INTERVAL);
    }
    let sim = build(n, spec, peers_dt)?;
    let stable = sim.stable_time_step();
    if stable >= peers_dt || !stable.is_finite() {
        return Ok(sim);
    }
    // Built again (not cloned before), so that the peak memory is one simulation's.
    drop(sim);
    let courant = TimeStep::Cfl { number: BENCH_COURANT };
    falling_block(n, spec, courant, DEFAULT_STABILITY_INTERVAL)
}

/// Cells per side for `n` particles.
fn cells_per_side(n: usize) -> usize {
    ((n as f64).sqrt().round() as usize).max(2 * WALL_LAYERS + 4)
}

/// The peers' fixed step, `2·10⁻⁴ · 128 / n_grid`.
pub fn peers_time_step(n: usize) -> f64 {
    2e-4 * 128.0 / cells_per_side(n) as f64
}

/// The problem with the fixed step `dt`.
fn build(n: usize, spec: &BenchSpec, dt: f64) -> Result<Simulation> {
    // The peers take the fixed step without a check; the estimate at the build is kept
    // (set-up), none during the timed steps.
    falling_block(n, spec, TimeStep::Fixed { dt }, 0)
}

/// The benchmark's falling block with `n` particles under `spec`'s schemes and the step rule
/// `time_step`, re-estimating the stable step every `stability_interval` steps (a fixed step
/// above the stable step is allowed, as the peers take it unchecked).
///
/// # Errors
/// [`MpmError::InvalidParameter`] for fewer than 16 particles; the errors of
/// [`Simulation::new`].
pub fn falling_block(n: usize, spec: &BenchSpec, time_step: TimeStep, stability_interval: usize) -> Result<Simulation> {
    if n < 16 {
        return Err(MpmError::InvalidParameter {
            name: "particles",
            value: n as f64,
            reason: "the benchmark needs at least 16 particles",
        });
    }
    let n_grid = cells_per_side(n);
    let h = 1.0 / n_grid as f64;
    let grid = Grid::new([0.0, 0.0], [h, h], [n_grid, n_grid])?;
    let mut rng = SplitMix(spec.seed);
    let (mut x, mut y) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for _ in 0..n {
        x.push(0.25 + 0.5 * rng.next());
        y.push(0.25 + 0.5 * rng.next());
    }
    let volume = 0.25 * h * h;
    let mut particles = Particles::new(x, y, vec![DENSITY * volume; n], vec![volume; n])?;
    particles.vy.iter_mut().for_each(|v| *v = -1.0);
    let bodies = vec![Body {
        name: "block".into(),
        material: Material::NeoHookean(NeoHookean {
            youngs_modulus: YOUNGS_MODULUS,
            poisson_ratio: POISSON_RATIO,
        }),
    }];
    let boundaries = [Edge::Left, Edge::Right, Edge::Bottom, Edge::Top]
        .into_iter()
        .map(|edge| BoundaryCondition {
            layers: Some(WALL_LAYERS),
            ..BoundaryCondition::edge(edge, Condition::Slip)
        })
        .collect();
    let options = Options {
        shape: spec.shape,
        update: spec.update,
        transfer: spec.transfer,
        mass: MassOptions {
            stabilization: spec.stabilization,
            ..MassOptions::both(spec.mass)
        },
        time_step,
        allow_unstable_time_step: true,
        stability_interval,
        threads: spec.threads,
        gravity: [0.0, -GRAVITY],
        boundaries,
        integrator: spec.integrator,
        ..Options::default()
    };
    Simulation::new(grid, particles, bodies, options)
}

/// Runs `spec`, calling `observe` after each particle count.
///
/// # Errors
/// [`MpmError::InvalidParameter`] for no repetitions or no particle counts; the errors of
/// [`problem`] and of the steps.
pub fn run(spec: &BenchSpec, mut observe: impl FnMut(&BenchRow)) -> Result<Vec<BenchRow>> {
    if spec.reps == 0 {
        return Err(MpmError::InvalidParameter {
            name: "reps",
            value: 0.0,
            reason: "at least one repetition is needed",
        });
    }
    if spec.particles.is_empty() {
        return Err(MpmError::InvalidParameter {
            name: "particles",
            value: 0.0,
            reason: "give at least one particle count",
        });
    }
    let mut rows = Vec::new();
    for &n in &spec.particles {
        let steps = spec.steps.unwrap_or_else(|| default_steps(n));
        memory::reset_peak();
        let before = memory::resident_bytes();
        let mut seconds = Vec::with_capacity(spec.reps);
        let mut setup_seconds = 0.0;
        let (mut n_grid, mut dt) = (0, 0.0);
        let mut dt_range = [f64::INFINITY, 0.0f64];
        let mut profile = spec.profile.then(Profile::default);
        let mut estimates = [0, 0];
        let mut counts = EstimateCounts::default();
        let mut simulated = Vec::with_capacity(spec.reps);
        for rep in 0..spec.reps {
            let start = Instant::now();
            let mut sim = problem(n, spec)?;
            let warm_up = sim.step()?;
            if rep == 0 {
                setup_seconds = start.elapsed().as_secs_f64();
                n_grid = sim.grid().cells()[0];
                dt = warm_up.dt;
            }
            sim.set_profiling(spec.profile);
            let (before_counts, before_time) = (sim.estimate_counts(), sim.time());
            let start = Instant::now();
            for _ in 0..steps {
                let before = sim.steps();
                let report = sim.step()?;
                if let Some((e, _)) = sim.frequency_estimate().filter(|&(_, at)| at == before) {
                    estimates[0] += 1;
                    estimates[1] += e.lanczos_steps;
                }
                dt_range[0] = dt_range[0].min(report.dt);
                dt_range[1] = dt_range[1].max(report.dt);
            }
            seconds.push(start.elapsed().as_secs_f64());
            simulated.push(sim.time() - before_time);
            let now = sim.estimate_counts();
            counts.estimates += now.estimates - before_counts.estimates;
            counts.estimate_steps += now.estimate_steps - before_counts.estimate_steps;
            counts.guards += now.guards - before_counts.guards;
            counts.guard_steps += now.guard_steps - before_counts.guard_steps;
            counts.raised += now.raised - before_counts.raised;
            if let (Some(total), Some(p)) = (&mut profile, sim.profile()) {
                total.merge(p);
            }
        }
        let peak = memory::peak_bytes();
        let row = BenchRow {
            particles: n,
            n_grid,
            steps,
            dt,
            dt_range,
            seconds,
            setup_seconds,
            peak_bytes_per_particle: match (peak, before) {
                (Some(p), Some(b)) => Some(p.saturating_sub(b) as f64 / n as f64),
                _ => None,
            },
            profile,
            estimates,
            counts,
            simulated,
        };
        observe(&row);
        rows.push(row);
    }
    Ok(rows)
}

/// Resident memory of this process, from `/proc/self` (Linux).
pub mod memory {
    /// A field of `/proc/self/status` in bytes (`VmRSS`, `VmHWM` …).
    fn status_bytes(field: &str) -> Option<u64> {
        let text = std::fs::read_to_string("/proc/self/status").ok()?;
        let line = text.lines().find(|l| l.starts_with(field))?;
        let kib: u64 = line[field.len()..]
            .trim_start_matches(':')
            .trim()
            .trim_end_matches("kB")
            .trim()
            .parse()
            .ok()?;
        Some(kib * 1024)
    }

    /// Resident set size now.
    pub fn resident_bytes() -> Option<u64> {
        status_bytes("VmRSS")
    }

    /// Peak resident set size since the process started or the last [`reset_peak`].
    pub fn peak_bytes() -> Option<u64> {
        status_bytes("VmHWM")
    }

    /// Resets the peak to the current resident size (writes 5 to `/proc/self/clear_refs`);
    /// does nothing where that is not possible.
    pub fn reset_peak() {
        let _ = std::fs::write("/proc/self/clear_refs", "5");
    }
}
