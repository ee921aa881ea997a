//! The benchmark problem the fastest CPU MPM codes publish figures for (timed by `mpm bench`),
//! as a [`Simulation`] of this library.
//!
//! The problem (the same as the Warp, Taichi and NumPy/SciPy scripts it is compared with, see
//! docs/performance.md): the unit square with `n_grid = round(√N)` cells per side; `N` particles
//! uniformly at random in `[0.25, 0.75]²` (about 4 per cell there), in random memory order, each
//! with volume `(h/2)²` and density 1; initial velocity `(0, −1)`; gravity 9.8 downwards; slip
//! walls holding the 3 outermost node lines of every side; neo-Hookean (plane strain) with
//! `E = 400`, `ν = 0.2`; fixed `Δt = 2·10⁻⁴ · 128 / n_grid`. A configuration whose stable step
//! is shorter than that (the consistent mass: its highest frequency is about √3 times the
//! lumped mass's with linear shape functions) runs at [`BENCH_COURANT`] of the stable step the
//! time loop reports instead, re-estimated as in any run.
//!
//! [`BenchSpec`] also carries what the timing harness reads (particle counts, steps,
//! repetitions, profiling), so that one value describes a benchmark configuration.

use crate::boundary::{BoundaryCondition, Condition, Edge, WallRule};
use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::mass::{MassOptions, MassScheme, Stabilization};
use crate::material::{Material, NeoHookean};
use crate::particles::Particles;
use crate::shape::ShapeFunction;
use crate::simulation::{
    Body, Integrator, Options, Simulation, TimeStep, Transfer, UpdateScheme, DEFAULT_STABILITY_INTERVAL,
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
    /// The explicit step's fused pass ([`Options::fused_passes`]; `false` by default).
    pub fused_passes: bool,
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
            fused_passes: false,
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
            // Held, as the peers clamp their boundary cells (not the mirror rule a slip edge
            // takes by default with GIMP and B-splines).
            wall: Some(WallRule::Held),
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
        fused_passes: spec.fused_passes,
        gravity: [0.0, -GRAVITY],
        boundaries,
        integrator: spec.integrator,
        ..Options::default()
    };
    Simulation::new(grid, particles, bodies, options)
}
