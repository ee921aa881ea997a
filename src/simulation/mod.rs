//! The explicit time loop: update schemes, transfers, boundary conditions, time-step control and
//! per-step reports, on the sparse operators N, Gx, Gy.
//!
//! Every choice is an independent axis of [`Options`]: the shape function
//! ([`ShapeFunction`](crate::ShapeFunction)), the update scheme ([`UpdateScheme`]), the particle velocity transfer
//! ([`Transfer`]), the mass treatment of each solve ([`MassOptions`](crate::mass::MassOptions)), the position rule
//! ([`PositionUpdate`](crate::schemes::PositionUpdate)), the time step ([`TimeStep`]), gravity and the boundary conditions
//! ([`BoundaryCondition`](crate::boundary::BoundaryCondition)). Particles belong to bodies, each with its own [`Material`](crate::material::Material); bodies
//! meet through the shared grid (its velocity single-valued), or with [`Options::contact`]
//! through contact, one grid field per body ([`crate::contact`]).
//!
//! ## One step
//! With `w = v + Δt a` the updated grid velocity and `Π` the prescribed-velocity projection
//! (see [`crate::boundary`]):
//!
//! ```text
//! (1)  N, Gx, Gy at x_p                                   (re-sorted by cell every few steps)
//! (2)  m_L = N m                                          one pass over N, Gx, Gy computes
//! (3)  q   = N (m ∘ v) + N (m ∘ C (x_I − x_p))  [APIC]     (2)–(5) together
//! (4)  f_ext = N (m ∘ b) + m_L g
//! (5)  f_int = −[Gx (V∘σxx) + Gy (V∘σxy); Gx (V∘σxy) + Gy (V∘σyy)]
//! (6)  v = Π M_v⁻¹ q                                      velocity scheme of MassOptions
//!      USF: L = [Gxᵀ v, Gyᵀ v], update F, V, σ, redo (5)
//! (7)  a = Π₀ M_a⁻¹ (f_ext + f_int)                       acceleration scheme; 0 on prescribed dofs
//! (8)  w = Π (v + Δt a);  massless nodes in a particle's support take the particles' mean velocity
//! (9)  x_p ← x_p + Δt v_pic,  v_pic = Nᵀ w   (or the trapezoidal rule (Δt/2)(v_p_old + v_pic);
//!      XPIC, FMPM: below)
//! (10) Δv = Nᵀ (w − v)   (the change of the grid velocity)
//!      PIC:  v_p ← v_pic          FLIP: v_p ← v_p + Δv        blend α: α (v_p + Δv) + (1 − α) v_pic
//!      APIC: v_p ← v_pic,  B_p ← Σ_I N_I w_I (x_I − x_p)ᵀ;  in (3) C_p = B_p D_p⁻¹ at the new position
//! (11) USL:  L = [Gxᵀ w, Gyᵀ w]
//!      MUSL: q' = N (m ∘ v_p) [+ APIC term],  v' = Π M_v⁻¹ q',  L = [Gxᵀ v', Gyᵀ v']
//! (12) F ← (I + Δt L) F,   σ ← material(σ, L, F)
//! (13) V ← V det(I + Δt L)
//! ```
//!
//! [`Simulation::step`] is these lines in this order, one call each: every phase is a function
//! that takes what it reads by `&` and what it writes by `&mut`, so that the data of a step can
//! be followed from the signatures (`phases.rs`). The update scheme decides the order once
//! ([`UpdateScheme::schedule`]); XPIC and FMPM share one interface (`series.rs`).
//!
//! **The fused pass** (opt-in, [`Options::fused_passes`]). Where the particles' stress is final once they have moved (USL updating
//! it in the grid-to-particle pass, or USF before it) and nothing changes the columns between
//! steps (no contact, no mirrored walls, no sort before the next step, the explicit
//! integrator), the grid-to-particle pass of a step also does the next step's (1)–(5) for each
//! batch of particles it has just moved: the next step then starts
//! from the node pass of (2)–(5). The results are the same bits (`tests/fused.rs`); after such
//! a step [`Simulation::operators`] holds the columns of the particles' present positions.
//!
//! ## Parts
//! A simulation is its setup (grid, bodies and materials, boundary conditions, workers: fixed
//! once built), its [`Options`], its state (particles, time, energies, the stable-step estimate:
//! what a checkpoint holds), a cache of what the current configuration makes (operators, grid
//! mass, grid fields of the step) and work arrays.
//!
//! ## Allocation
//! With lumped mass for both solves a step allocates nothing after the first: the operators are
//! reassembled into their buffers and every grid and particle work array is kept in the
//! simulation. Consistent, blended, series and iterative schemes go through
//! [`GridMass`], which reuses its factorization buffers but allocates its vectors.

mod build;
mod checkpoint;
mod contact;
mod fused;
mod motion;
mod near_singular;
mod newmark;
mod options;
mod phases;
mod plan;
mod plastic;
mod profile;
mod quasi_static;
mod report;
mod series;
mod sort;
mod speeds;
mod stability;
mod walls;

pub use checkpoint::{CHECKPOINT_FORMAT_VERSION, MAX_CHECKPOINT_BYTES};
pub use near_singular::NEARLY_SINGULAR_RATIO;
pub use options::{
    Body, Integrator, Newmark, Options, QuasiStatic, TimeStep, Transfer, UpdateScheme, DEFAULT_STABILITY_INTERVAL,
};
pub use profile::{Phase, Profile};
pub use report::StepReport;
pub use stability::{EstimateCounts, BOUND_INTERVAL, ESTIMATE_TRAVEL, GUARD_STEPS, GUARD_STEPS_UNDER_MARGIN};

use crate::boundary::Prescribed;
use crate::error::{MpmError, Result};
use crate::fields::VectorField;
use crate::grid::Grid;
use crate::kernels::{self, ExtensionScratch, GridState, ParticleScratch};
use crate::mass::{GridMass, SeriesScratch};
use crate::material::Prepared;
use crate::operators::Operators;
use crate::parallel::Workers;
use crate::particles::Particles;
use stability::{Speeds, Stability};

/// What a simulation is made of, fixed once it is built.
#[derive(Debug)]
struct Setup {
    grid: Grid,
    bodies: Vec<Body>,
    /// Each body's material constants, computed once.
    materials: Vec<Prepared>,
    /// Reference density of each body (largest `m_p / V₀_p` of its particles).
    density: Vec<f64>,
    /// The resolved boundary conditions.
    prescribed: Prescribed,
    /// The contact the step makes ([`crate::contact`]): [`Options::contact`], or contact with
    /// no pair for slip walls with friction.
    contact: Option<crate::contact::Contact>,
    /// The nodes each slip wall with friction meets the bodies at, with the wall's mass centre
    /// there (`contact::wall_nodes`).
    wall_nodes: Vec<Vec<(usize, f64)>>,
    /// The separation test's cutoff in cells (`crate::contact::Separation`).
    separation: f64,
    /// The prescribed velocities as a grid field (0 where free).
    prescribed_velocity: std::sync::OnceLock<VectorField>,
    /// The worker threads ([`Options::threads`]).
    workers: Workers,
}

impl Setup {
    /// Whether a body is elastoplastic (its particles carry a plastic state).
    fn is_plastic(&self) -> bool {
        self.materials.iter().any(|m| m.plastic().is_some())
    }
}

/// What the time loop advances, and a checkpoint holds.
#[derive(Debug)]
struct State {
    particles: Particles,
    time: f64,
    steps: usize,
    /// The failure of an earlier step, if any: further steps are refused.
    failed: Option<String>,
    /// Kinetic energy lost in the transfers back to the particles so far.
    transfer_loss: f64,
    /// What the damping has done so far ([`crate::damping`]).
    relaxation: Relaxation,
    /// Strain energy after the last stress update.
    strain_energy: f64,
    /// Largest particle speed and tangent wave speed of the current state, kept by the stress
    /// update and the report so that the stable step needs no pass of its own.
    speeds: Speeds,
    /// The last stable-step estimate.
    stability: Option<Stability>,
}

/// The energy accounts a run keeps between steps: what the damping and the contact removed.
#[derive(Debug, Clone, Copy, Default, serde::Serialize, serde::Deserialize)]
struct Relaxation {
    /// Energy the damping removed, `Σ −f_d · v Δt`.
    damping_work: f64,
    /// The work of friction between bodies so far ([`crate::contact`]).
    friction_dissipation: f64,
    /// The plastic dissipation so far ([`StepReport::plastic_dissipation`]).
    plastic_dissipation: f64,
    /// The largest kinetic energy `½ Σ m_p |Nᵀw|²` of the run (the settling is measured
    /// against it).
    peak_kinetic: f64,
}

/// What the current particle configuration makes: rebuilt every step, kept for its buffers
/// and for inspection between steps.
#[derive(Debug)]
struct Cache {
    /// N, Gx, Gy.
    ops: Operators,
    /// Lumped mass, active set, consistent mass and its factorizations.
    mass: GridMass,
    /// Grid fields of the step.
    nodes: GridState,
    /// The operators folded for each velocity component, when slip walls are mirrored and a
    /// consistent mass is assembled from them (simulation/walls.rs).
    component_ops: [Operators; 2],
    /// One grid per body, under contact ([`crate::contact`]; empty without).
    layers: contact::Layers,
    /// Whether every particle's body force is exactly +0, so that the passes need not read it
    /// (the same operations on zeros they would have read): found when first needed after the
    /// body forces were last set.
    zero_body_force: Option<bool>,
}

/// Work arrays of the phases, kept between steps.
#[derive(Debug, Default)]
struct Scratch {
    /// Per-particle fields of the step.
    particle: ParticleScratch,
    extension: ExtensionScratch,
    series: SeriesScratch,
    sorting: sort::Sorting,
    stress_blocks: Vec<kernels::StressPartials>,
    report_blocks: Vec<kernels::SumPartials>,
    /// The grid's kinetic energy per block of nodes, for the report.
    grid_blocks: Vec<f64>,
    /// The top mode the stable-step estimates track, their work arrays and counts.
    tracking: stability::Tracking,
    /// The packed grid velocities the grid-to-particle pass reads.
    packed: Vec<f64>,
    /// What each block of particles of the last grid-to-particle pass returned.
    g2p_blocks: Vec<kernels::G2pBlock>,
    /// The report's particle sums when the grid-to-particle pass moved the particles and took
    /// them (USL, USF); `None` when the report sums them itself.
    sums: Option<kernels::ParticleSums>,
    /// The Newton system's LU of the implicit integrator (its symbolic analysis kept while the
    /// pattern is unchanged).
    newton: crate::implicit::SparseLu,
    /// The relative residuals of the last implicit step's Newton iterates, the first (the
    /// predictor's) included.
    newton_residuals: Vec<f64>,
}

impl Scratch {
    /// Work arrays sized for `grid`.
    fn for_grid(grid: &Grid) -> Scratch {
        Scratch {
            extension: ExtensionScratch::new(grid.num_nodes()),
            sorting: sort::Sorting::for_grid(grid),
            ..Scratch::default()
        }
    }
}

/// A running simulation: its setup, options, state, the cache of the current configuration and
/// work arrays (module docs).
#[derive(Debug)]
pub struct Simulation {
    setup: Setup,
    options: Options,
    state: State,
    cache: Cache,
    scratch: Scratch,
    /// Phase times, when profiling.
    profile: Option<profile::Profile>,
}

impl Simulation {
    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.setup.grid
    }
    /// The particles' current state.
    pub fn particles(&self) -> &Particles {
        &self.state.particles
    }
    /// The bodies.
    pub fn bodies(&self) -> &[Body] {
        &self.setup.bodies
    }
    /// The options.
    pub fn options(&self) -> &Options {
        &self.options
    }

    /// The relative Newton residuals ([`Newmark::tolerance`]) of the last implicit
    /// step's iterates, from the predictor to the converged one (empty for explicit steps).
    pub fn newton_residuals(&self) -> &[f64] {
        &self.scratch.newton_residuals
    }

    /// Symbolic analyses of the implicit integrator's Newton matrix so far (one per distinct
    /// sparsity pattern: reused across a step's iterations and across steps with the same
    /// pattern).
    pub fn newton_symbolic_analyses(&self) -> usize {
        self.scratch.newton.symbolic_analyses()
    }

    /// Integrates the following steps with `integrator` at `time_step` (the explicit update, or
    /// Newmark's rule at a fixed step, [`crate::implicit`]).
    ///
    /// # Errors
    /// The errors of [`Options::validate`] for the changed options (Newmark with a CFL step, with
    /// APIC or a series transfer, parameters out of range); the simulation is unchanged then.
    pub fn set_integrator(&mut self, integrator: Integrator, time_step: TimeStep) -> Result<()> {
        let options = Options {
            integrator,
            time_step,
            ..self.options.clone()
        };
        options.validate()?;
        self.options = options;
        self.cache.nodes.discard_next();
        Ok(())
    }

    /// Runs the following steps on `threads` worker threads (a resumed run on another machine,
    /// say). The results are the same bits for any count.
    ///
    /// # Errors
    /// [`MpmError::InvalidOption`] for 0 or more than [`crate::parallel::MAX_THREADS`] threads,
    /// or when the pool cannot be started; the simulation is unchanged then.
    pub fn set_threads(&mut self, threads: usize) -> Result<()> {
        let options = Options {
            threads,
            ..self.options.clone()
        };
        options.validate()?;
        self.setup.workers = Workers::new(threads).map_err(|e| MpmError::InvalidOption {
            option: "threads",
            reason: e.to_string(),
        })?;
        self.options.threads = threads;
        Ok(())
    }
    /// The resolved boundary conditions.
    pub fn prescribed(&self) -> &Prescribed {
        &self.setup.prescribed
    }
    /// Current time.
    pub fn time(&self) -> f64 {
        self.state.time
    }
    /// Steps taken.
    pub fn steps(&self) -> usize {
        self.state.steps
    }
    /// The operators N, Gx, Gy of the last step (of the initial configuration before the first;
    /// of the particles' present positions after an explicit step whose fused pass prepared
    /// the next step, [`Options::fused_passes`]).
    pub fn operators(&self) -> &Operators {
        &self.cache.ops
    }
    /// The grid mass of the last step: lumped mass, active set, and the consistent mass when a
    /// scheme needs it.
    pub fn grid_mass(&self) -> &GridMass {
        &self.cache.mass
    }
    /// Lumped grid mass `m_L` of the last step.
    pub fn lumped_mass(&self) -> &[f64] {
        self.cache.mass.lumped()
    }
    /// The updated grid velocity `w` of the last step.
    pub fn grid_velocity(&self) -> &VectorField {
        &self.cache.nodes.updated
    }
    /// Sets every particle's body force per unit mass (besides gravity) to `b(id, x_p)`, with
    /// `id` the particle's permanent id and `x_p` its current position. For a time-dependent load,
    /// such as a manufactured solution's, call it before each step with the time in `b`.
    pub fn set_body_force(&mut self, mut b: impl FnMut(usize, [f64; 2]) -> [f64; 2]) {
        self.cache.nodes.discard_next();
        self.cache.zero_body_force = None;
        let p = &mut self.state.particles;
        for k in 0..p.len() {
            [p.bx[k], p.by[k]] = b(p.id[k], [p.x[k], p.y[k]]);
        }
        self.state.speeds.load = stability::largest_load(self.options.gravity, p);
    }

    /// Sets every particle's velocity to `v(id, v_p)` between steps, with `id` the particle's
    /// permanent id and `v_p` its velocity now (an impulse, a restart with other initial
    /// conditions). The next step's CFL term sees the new speeds.
    ///
    /// # Errors
    /// [`MpmError::InvalidParticleValue`] (`vx` or `vy`) naming the first particle given a
    /// value that is not finite; nothing is changed then.
    pub fn set_velocity(&mut self, v: impl FnMut(usize, [f64; 2]) -> [f64; 2]) -> Result<()> {
        let new = self.particle_pairs(v, ["vx", "vy"], |p, k| [p.vx[k], p.vy[k]])?;
        self.cache.nodes.discard_next();
        let p = &mut self.state.particles;
        for (k, [vx, vy]) in new.into_iter().enumerate() {
            (p.vx[k], p.vy[k]) = (vx, vy);
        }
        self.state.speeds.particle = (0..p.len()).map(|k| p.vx[k].hypot(p.vy[k])).fold(0.0, f64::max);
        Ok(())
    }

    /// Sets every particle's Cauchy stress to `s(id, [σxx, σyy, σxy])` between steps (a
    /// prestress, a geostatic state), with `id` the particle's permanent id. The deformation
    /// gradient is left as it is: for the neo-Hookean model, whose stress follows from `F`, the
    /// next stress update replaces the stress set here.
    ///
    /// # Errors
    /// [`MpmError::InvalidParticleValue`] (`sxx`, `syy` or `sxy`) naming the first particle
    /// given a value that is not finite; nothing is changed then.
    pub fn set_stress(&mut self, mut s: impl FnMut(usize, [f64; 3]) -> [f64; 3]) -> Result<()> {
        let p = &self.state.particles;
        let mut new = Vec::with_capacity(p.len());
        for k in 0..p.len() {
            let value = s(p.id[k], [p.sxx[k], p.syy[k], p.sxy[k]]);
            if let Some(c) = value.iter().position(|v| !v.is_finite()) {
                return Err(MpmError::InvalidParticleValue {
                    particle: k,
                    field: ["sxx", "syy", "sxy"][c],
                    value: value[c],
                    reason: "a stress must be finite",
                });
            }
            new.push(value);
        }
        self.cache.nodes.discard_next();
        let p = &mut self.state.particles;
        for (k, [sxx, syy, sxy]) in new.into_iter().enumerate() {
            (p.sxx[k], p.syy[k], p.sxy[k]) = (sxx, syy, sxy);
        }
        Ok(())
    }

    /// `f(id, now)` for every particle, checked finite.
    fn particle_pairs(
        &self,
        mut f: impl FnMut(usize, [f64; 2]) -> [f64; 2],
        fields: [&'static str; 2],
        now: impl Fn(&Particles, usize) -> [f64; 2],
    ) -> Result<Vec<[f64; 2]>> {
        let p = &self.state.particles;
        let mut out = Vec::with_capacity(p.len());
        for k in 0..p.len() {
            let value = f(p.id[k], now(p, k));
            if let Some(c) = value.iter().position(|v| !v.is_finite()) {
                return Err(MpmError::InvalidParticleValue {
                    particle: k,
                    field: fields[c],
                    value: value[c],
                    reason: "a velocity must be finite",
                });
            }
            out.push(value);
        }
        Ok(out)
    }

    /// Reference density of each body (largest `m_p / V₀_p` of its particles).
    pub fn body_densities(&self) -> &[f64] {
        &self.setup.density
    }

    /// Advances one step (see the [module docs](self)) and reports it.
    ///
    /// # Errors
    /// [`MpmError::TimeStepAboveStable`] for a fixed step above the stable step;
    /// [`MpmError::InvertedParticle`] for an inverted particle (`det F ≤ 0`), [`MpmError::NonFinite`]
    /// for a non-finite velocity, [`MpmError::EarlierFailure`] after a failed step;
    /// [`MpmError::ParticleOutsideGrid`] / [`MpmError::SupportOutsideGrid`] when a particle leaves
    /// the region its kernel allows; [`MpmError::SingularMassMatrix`] under
    /// [`crate::mass::SingularityPolicy::Error`]. After an error in the middle of a step the state
    /// is not consistent, and further steps are refused.
    pub fn step(&mut self) -> Result<StepReport> {
        self.advance(f64::INFINITY)
    }

    /// Steps until `end_time` (the last step is shortened to land on it), calling `observe`
    /// after every step; `observe` may stop the run by returning an error.
    ///
    /// # Errors
    /// The errors of [`Simulation::step`] and of `observe`.
    pub fn run_until<F>(&mut self, end_time: f64, mut observe: F) -> Result<()>
    where
        F: FnMut(&Simulation, &StepReport) -> Result<()>,
    {
        while self.state.time < end_time * (1.0 - 1e-12) {
            let report = self.step_capped(end_time - self.state.time)?;
            observe(self, &report)?;
        }
        Ok(())
    }

    /// One step, no longer than `max_dt`.
    ///
    /// # Errors
    /// As [`Simulation::step`].
    pub fn step_capped(&mut self, max_dt: f64) -> Result<StepReport> {
        self.advance(max_dt)
    }

    /// A step no longer than `max_dt`; an error in it leaves the state unusable, but for an
    /// implicit step refused or not converged ([`MpmError::StepRejected`],
    /// [`MpmError::NewtonFailed`]), which changes nothing.
    fn advance(&mut self, max_dt: f64) -> Result<StepReport> {
        if let Some(reason) = &self.state.failed {
            return Err(MpmError::EarlierFailure {
                step: self.state.steps,
                cause: reason.clone(),
            });
        }
        let result = self.phases(max_dt);
        match &result {
            // An implicit step refused or not converged changed no particle: the simulation
            // may go on (with a shorter step, say).
            Err(MpmError::StepRejected { .. } | MpmError::NewtonFailed { .. }) => {}
            Err(e) => self.state.failed = Some(e.to_string()),
            Ok(_) => {}
        }
        result
    }
}
