//! The explicit time loop: update schemes, transfers, boundary conditions, time-step control and
//! per-step reports, on the sparse operators N, Gx, Gy.
//!
//! Every choice is an independent axis of [`Options`]: the shape function
//! ([`ShapeFunction`](crate::ShapeFunction)), the update scheme ([`UpdateScheme`]), the particle velocity transfer
//! ([`Transfer`]), the mass treatment of each solve ([`MassOptions`](crate::mass::MassOptions)), the position rule
//! ([`PositionUpdate`](crate::step::PositionUpdate)), the time step ([`TimeStep`]), gravity and the boundary conditions
//! ([`BoundaryCondition`](crate::boundary::BoundaryCondition)). Particles belong to bodies, each with its own [`Material`](crate::material::Material); bodies
//! meet through the shared grid (no contact algorithm: the grid velocity is single-valued).
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
//! ## Allocation
//! With lumped mass for both solves a step allocates nothing after the first: the operators are
//! reassembled into their buffers and every grid and particle work array is kept in the
//! simulation. Consistent, blended, series and iterative schemes go through
//! [`GridMass`], which reuses its factorization buffers but allocates its vectors.

mod checkpoint;
mod options;
mod profile;
mod report;
mod stability;

pub use checkpoint::CHECKPOINT_FORMAT_VERSION;
pub use options::{Body, Options, TimeStep, Transfer, UpdateScheme, DEFAULT_STABILITY_INTERVAL};
pub use profile::{Phase, Profile};
pub use report::StepReport;
use stability::Stability;

use crate::boundary::{self, Prescribed};
use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::kernels::{
    self, extend_to_inactive_nodes, ApicInertia, ExtensionScratch, G2pRule, GridField, GridState, ParticleScratch,
    Stress,
};
use crate::mass::{series_velocity_into, GridMass, Role, SeriesScratch, SolveReport};
use crate::material::Prepared;
use crate::operators::Operators;
use crate::parallel::Workers;
use crate::particles::Particles;
use crate::transfer::{deformation_increment, VectorField};

/// Work arrays of the phases that are not grid or particle fields, kept between steps.
#[derive(Debug, Default)]
struct Scratch {
    extension: ExtensionScratch,
    series: SeriesScratch,
    sorting: Sorting,
    stress_blocks: Vec<StressBlock>,
    report_blocks: Vec<report::Sums>,
}

/// What one block of particles of the stress update returns: its strain energy, the largest
/// `C11 V / m`, and the first inverted particle (index, `det(I + Δt L)`, `det F`).
#[derive(Debug, Clone, Copy, Default)]
struct StressBlock {
    energy: f64,
    wave_squared: f64,
    inverted: Option<(usize, f64, f64)>,
}

impl Scratch {
    /// Work arrays sized for `grid`.
    fn for_grid(grid: &Grid) -> Scratch {
        let [cx, cy] = grid.cells();
        Scratch {
            extension: ExtensionScratch::new(grid.num_nodes()),
            sorting: Sorting {
                counts: vec![0; cx * cy + 1],
                ..Sorting::default()
            },
            ..Scratch::default()
        }
    }
}

/// The prescribed velocities as a grid field, 0 where free.
fn prescribed_velocity_field(prescribed: &Prescribed) -> VectorField {
    let zero_free = |v: &[f64]| v.iter().map(|v| if v.is_nan() { 0.0 } else { *v }).collect();
    VectorField {
        x: zero_free(&prescribed.vx),
        y: zero_free(&prescribed.vy),
    }
}

/// The counting sort's arrays.
#[derive(Debug, Default)]
struct Sorting {
    keys: Vec<usize>,
    counts: Vec<usize>,
    order: Vec<usize>,
    values: Vec<f64>,
    indices: Vec<usize>,
}

/// A running simulation: grid, particles, bodies, options and everything kept between steps.
#[derive(Debug)]
pub struct Simulation {
    grid: Grid,
    particles: Particles,
    bodies: Vec<Body>,
    options: Options,
    prescribed: Prescribed,
    density: Vec<f64>,
    ops: Operators,
    grid_mass: GridMass,
    time: f64,
    steps: usize,
    failed: Option<String>,
    stability: Option<Stability>,
    transfer_loss: f64,
    /// Grid fields of the step.
    nodes: GridState,
    /// Per-particle fields of the step.
    particle_scratch: ParticleScratch,
    /// The prescribed velocities as a grid field (0 where free).
    prescribed_velocity: VectorField,
    /// Strain energy after the last stress update.
    strain_energy: f64,
    scratch: Scratch,
    /// Phase times, when profiling.
    profile: Option<Profile>,
    /// Largest particle speed and tangent wave speed of the current state, kept by the stress
    /// update and the report so that the stable step needs no pass of its own.
    speeds: stability::Speeds,
    /// Each body's material constants, computed once.
    materials: Vec<Prepared>,
    /// The worker threads ([`Options::threads`]).
    workers: Workers,
}

impl Simulation {
    /// A simulation of `particles` (each with `particles.body[p]` an index into `bodies`) on
    /// `grid` with `options`, at time 0.
    ///
    /// # Errors
    /// The errors of [`Particles::validate`], [`Material::validate`](crate::material::Material::validate),
    /// [`Options::validate`] and [`boundary::resolve`]; [`MpmError::InvalidParticleValue`] for a
    /// particle naming a body that does not exist;
    /// [`MpmError::ParticleOutsideGrid`] / [`MpmError::SupportOutsideGrid`] for particles
    /// outside the region the shape function allows.
    pub fn new(grid: Grid, particles: Particles, bodies: Vec<Body>, options: Options) -> Result<Simulation> {
        particles.validate()?;
        options.validate()?;
        for body in &bodies {
            body.material.validate()?;
        }
        if let Some(p) = (0..particles.len()).find(|&p| particles.body[p] >= bodies.len()) {
            return Err(MpmError::InvalidParticleValue {
                particle: p,
                field: "body",
                value: particles.body[p] as f64,
                reason: "names a body that does not exist (the simulation's bodies are numbered from 0)",
            });
        }
        let prescribed = boundary::resolve(&grid, options.shape, &options.boundaries)?;
        let workers = Workers::new(options.threads)?;
        // Reference density of each body: the largest m / V₀ among its particles.
        let mut density = vec![0.0f64; bodies.len()];
        for p in 0..particles.len() {
            let j = particles.fxx[p] * particles.fyy[p] - particles.fxy[p] * particles.fyx[p];
            let rho0 = particles.mass[p] / (particles.volume[p] / j);
            density[particles.body[p]] = density[particles.body[p]].max(rho0);
        }
        let mut ops = Operators::default();
        ops.reassemble(&grid, options.shape, &particles.x, &particles.y)?;
        let prescribed_velocity = prescribed_velocity_field(&prescribed);
        let scratch = Scratch::for_grid(&grid);
        let nodes = GridState::new(&grid);
        let mut sim = Simulation {
            grid,
            particles,
            bodies,
            options,
            prescribed,
            density,
            ops,
            grid_mass: GridMass::default(),
            time: 0.0,
            steps: 0,
            failed: None,
            stability: None,
            transfer_loss: 0.0,
            nodes,
            particle_scratch: ParticleScratch::default(),
            prescribed_velocity,
            strain_energy: 0.0,
            scratch,
            profile: None,
            speeds: stability::Speeds::default(),
            materials: Vec::new(),
            workers,
        };
        sim.materials = sim.bodies.iter().map(|b| b.material.prepared()).collect();
        sim.speeds = sim.measure_speeds();
        // The stable step before the first step, so that a fixed step above it is refused now.
        sim.prepare_grid()?;
        sim.next_time_step(sim.stable_time_step())?;
        Ok(sim)
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }
    /// The particles' current state.
    pub fn particles(&self) -> &Particles {
        &self.particles
    }
    /// The bodies.
    pub fn bodies(&self) -> &[Body] {
        &self.bodies
    }
    /// The options.
    pub fn options(&self) -> &Options {
        &self.options
    }
    /// The resolved boundary conditions.
    pub fn prescribed(&self) -> &Prescribed {
        &self.prescribed
    }
    /// Current time.
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Steps taken.
    pub fn steps(&self) -> usize {
        self.steps
    }
    /// The operators N, Gx, Gy of the last step (of the initial configuration before the first).
    pub fn operators(&self) -> &Operators {
        &self.ops
    }
    /// Lumped grid mass `m_L` of the last step.
    pub fn lumped_mass(&self) -> &[f64] {
        &self.nodes.mass
    }
    /// The updated grid velocity `w` of the last step.
    pub fn grid_velocity(&self) -> &VectorField {
        &self.nodes.updated
    }
    /// Sets every particle's body force per unit mass (besides gravity) to `b(id, x_p)`, with
    /// `id` the particle's permanent id and `x_p` its current position. For a time-dependent load,
    /// such as a manufactured solution's, call it before each step with the time in `b`.
    pub fn set_body_force(&mut self, mut b: impl FnMut(usize, [f64; 2]) -> [f64; 2]) {
        let p = &mut self.particles;
        for k in 0..p.len() {
            [p.bx[k], p.by[k]] = b(p.id[k], [p.x[k], p.y[k]]);
        }
    }

    /// Reference density of each body (largest `m_p / V₀_p` of its particles).
    pub fn body_densities(&self) -> &[f64] {
        &self.density
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
        while self.time < end_time * (1.0 - 1e-12) {
            let report = self.step_capped(end_time - self.time)?;
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

    /// A step no longer than `max_dt`; an error in it leaves the state unusable.
    fn advance(&mut self, max_dt: f64) -> Result<StepReport> {
        if let Some(reason) = &self.failed {
            return Err(MpmError::EarlierFailure {
                step: self.steps,
                cause: reason.clone(),
            });
        }
        let result = self.phases(max_dt);
        if let Err(e) = &result {
            self.failed = Some(e.to_string());
        }
        result
    }

    /// (1)–(5) and the grid mass for the current particle configuration (re-sorting the
    /// particles first when due), and the stable-step estimate when due.
    fn prepare_grid(&mut self) -> Result<()> {
        let interval = self.options.sort_interval;
        if interval > 0 && self.steps.is_multiple_of(interval) {
            self.timed(Phase::Sort, Self::sort_particles);
        }
        self.timed(Phase::Assemble, |s| {
            let p = &s.particles;
            s.ops.reassemble_with(&s.grid, s.options.shape, &p.x, &p.y, &s.workers)
        })?; // (1)
        let stress = if self.options.update == UpdateScheme::Usf {
            Stress::Omit
        } else {
            Stress::Include
        };
        let apic = self.apic();
        self.timed(Phase::P2g, |s| {
            kernels::p2g(
                &s.ops,
                &s.particles,
                apic,
                s.options.gravity,
                stress,
                &mut s.nodes,
                &s.workers,
            )
        }); // (2)–(5)
        self.timed(Phase::Mass, Self::prepare_mass)?;
        let due = match self.stability {
            None => true,
            Some(s) => {
                let interval = self.options.stability_interval;
                interval > 0 && self.steps >= s.at_step + interval
            }
        };
        if due {
            self.timed(Phase::StableStep, Self::estimate_stability)?;
        }
        Ok(())
    }

    fn phases(&mut self, max_dt: f64) -> Result<StepReport> {
        self.prepare_grid()?; // (1)–(5), mass
        let stable = self.timed(Phase::StableStep, |s| s.stable_time_step());
        let dt = self.next_time_step(stable)?.min(max_dt);
        let velocity_solve = self.timed(Phase::Project, Self::project_velocity)?; // (6)
        if self.options.update == UpdateScheme::Usf {
            self.timed(Phase::StressFirst, |s| s.update_stress_first(dt))?; // USF: (11)–(13), (5)
        }
        let acceleration_solve = self.timed(Phase::Accelerate, Self::solve_acceleration)?; // (7)
        self.timed(Phase::GridVelocity, |s| s.update_grid_velocity(dt)); // (8)
        self.timed(Phase::Extend, |s| s.extend_to_inactive_nodes(GridField::Updated)); // (8b)
        self.timed(Phase::Series, Self::series_particle_velocity); // XPIC, FMPM
        self.timed(Phase::G2p, |s| s.grid_to_particles(dt)); // (9)–(11)
        match self.options.update {
            UpdateScheme::Usl => self.timed(Phase::Stress, |s| s.update_stress(dt))?, // (12)–(13)
            UpdateScheme::Musl => self.timed(Phase::Stress, |s| s.update_stress_reprojected(dt))?, // (11)–(13)
            UpdateScheme::Usf => {}
        }
        self.timed(Phase::Move, Self::move_particles); // (9)
        self.time += dt;
        self.steps += 1;
        let mut report = self.timed(Phase::Report, |s| {
            s.report(dt, stable, velocity_solve, acceleration_solve)
        })?;
        self.speeds.particle = report.max_speed;
        let k = &self.particle_scratch.kinetic;
        self.transfer_loss += k.before + (k.updated - k.projected) - report.kinetic_energy;
        report.transfer_loss = self.transfer_loss;
        self.count_profiled_step();
        Ok(report)
    }

    /// The APIC inertia of the shape functions, when the transfer is APIC.
    /// USF: (11)–(13) from the projected velocity `v` of (6), then (5) again with the new
    /// stress.
    fn update_stress_first(&mut self, dt: f64) -> Result<()> {
        let field = self.stress_velocity(GridField::Projected);
        self.gradient_of(field);
        self.update_stress(dt)?;
        let p = &self.particles;
        kernels::add_internal_force(&self.ops, &p.volume, &p.sxx, &p.syy, &p.sxy, &mut self.nodes.force);
        Ok(())
    }

    /// (9)–(11) in one pass: new particle velocities, position increments and (USL) the velocity
    /// gradient of the updated grid velocity.
    fn grid_to_particles(&mut self, dt: f64) {
        let rule = G2pRule {
            transfer: self.options.transfer,
            position: self.options.position_update,
            inertia: ApicInertia::of(self.options.shape, &self.grid),
            gradient: (self.options.update == UpdateScheme::Usl).then(|| self.stress_field(GridField::Updated)),
        };
        kernels::g2p(
            &self.ops,
            &self.nodes,
            &rule,
            dt,
            &mut self.particles,
            &mut self.particle_scratch,
            &self.workers,
        );
    }

    /// MUSL: (11) `q' = N (m ∘ v_p)` (APIC term included), `v' = Π M_v⁻¹ q'`,
    /// `L = [Gxᵀ v', Gyᵀ v']`, then (12)–(13).
    fn update_stress_reprojected(&mut self, dt: f64) -> Result<()> {
        kernels::reproject_momentum(&self.ops, &self.particles, self.apic(), &mut self.nodes, &self.workers);
        self.project_velocity()?;
        let field = self.stress_velocity(GridField::Projected);
        self.gradient_of(field);
        self.update_stress(dt)
    }

    fn apic(&self) -> Option<ApicInertia> {
        (self.options.transfer == Transfer::Apic).then(|| ApicInertia::of(self.options.shape, &self.grid))
    }

    /// Counting sort of the particles by cell index (row-major), allocation-free.
    fn sort_particles(&mut self) {
        let (grid, p, s) = (&self.grid, &mut self.particles, &mut self.scratch.sorting);
        let np = p.len();
        let [cx, cy] = grid.cells();
        s.keys.resize(np, 0);
        s.order.resize(np, 0);
        s.counts.iter_mut().for_each(|c| *c = 0);
        for k in 0..np {
            let key = grid.cell_of(p.x[k], p.y[k]).map_or(cx * cy, |(i, j)| j * cx + i);
            s.keys[k] = key.min(cx * cy);
            s.counts[s.keys[k]] += 1;
        }
        let mut start = 0;
        for c in s.counts.iter_mut() {
            let n = *c;
            *c = start;
            start += n;
        }
        for k in 0..np {
            let key = s.keys[k];
            s.order[s.counts[key]] = k;
            s.counts[key] += 1;
        }
        p.permute(&s.order, &mut s.values, &mut s.indices);
    }

    /// The active nodes (the one active set of every solve) and `1/m_L`; the consistent mass
    /// and its factorizations when a scheme needs them.
    fn prepare_mass(&mut self) -> Result<()> {
        let g = &mut self.nodes;
        self.grid_mass.lumped_mut().clone_from(&g.mass);
        self.grid_mass.prepare(
            &self.ops,
            &self.particles.mass,
            &self.options.mass,
            &self.prescribed.constraints,
        )?;
        g.active.copy_from_slice(self.grid_mass.is_active());
        g.inverse_mass.copy_from_slice(self.grid_mass.inverse_lumped());
        Ok(())
    }

    /// (6) `v = Π M_v⁻¹ q`.
    fn project_velocity(&mut self) -> Result<SolveReport> {
        let g = &mut self.nodes;
        let report = self.grid_mass.solve_into(
            Role::Velocity,
            &g.momentum,
            Some(&self.prescribed_velocity),
            &self.ops,
            &mut g.projected,
        )?;
        self.prescribed.apply_velocity(&mut g.projected.x, &mut g.projected.y);
        Ok(report)
    }

    /// (7) `a = Π₀ M_a⁻¹ f`.
    fn solve_acceleration(&mut self) -> Result<SolveReport> {
        let g = &mut self.nodes;
        let report = self
            .grid_mass
            .solve_into(Role::Acceleration, &g.force, None, &self.ops, &mut g.acceleration)?;
        self.prescribed.zero(&mut g.acceleration.x, &mut g.acceleration.y);
        Ok(report)
    }

    /// (8) `w = Π (v + Δt a)` on active nodes, 0 elsewhere.
    fn update_grid_velocity(&mut self, dt: f64) {
        let g = &mut self.nodes;
        for i in 0..g.mass.len() {
            let s = if g.active[i] { 1.0 } else { 0.0 };
            g.updated.x[i] = s * (g.projected.x[i] + dt * g.acceleration.x[i]);
            g.updated.y[i] = s * (g.projected.y[i] + dt * g.acceleration.y[i]);
        }
        self.prescribed.apply_velocity(&mut g.updated.x, &mut g.updated.y);
    }

    /// The field the stress update reads when the scheme projects `field`: FMPM(k)'s series
    /// velocity of it (computed by [`Simulation::stress_velocity`]), else `field` itself.
    fn stress_field(&self, field: GridField) -> GridField {
        match self.options.transfer {
            Transfer::Fmpm { .. } => GridField::Series,
            _ => field,
        }
    }

    /// The grid velocity the stress update reads, given the one the update scheme projects:
    /// FMPM(k) passes it through its series first (into the series field).
    fn stress_velocity(&mut self, field: GridField) -> GridField {
        let Transfer::Fmpm { k } = self.options.transfer else {
            return field;
        };
        self.series_of(field, k);
        GridField::Series
    }

    /// `v* = Σ_{ℓ<k} (I − M_L⁻¹M)^ℓ u` of the field `source` into the series field, each increment
    /// with its prescribed components zeroed ([`kernels::series_velocity_into`]).
    fn series_of(&mut self, source: GridField, k: usize) {
        let g = &mut self.nodes;
        let prescribed = &self.prescribed;
        let constrain = |u: &mut VectorField| prescribed.zero(&mut u.x, &mut u.y);
        let u = match source {
            GridField::Projected => &g.projected,
            GridField::Updated => &g.updated,
            GridField::Series => unreachable!("the series is taken of a projected or updated velocity"),
        };
        series_velocity_into(
            &self.ops,
            &self.particles.mass,
            &g.inverse_mass,
            k,
            &constrain,
            u,
            &mut g.series,
            &mut self.scratch.series,
        );
    }

    /// XPIC(k) and FMPM(k), once per step before the particle update: the grid velocity the new
    /// particle velocities interpolate, into the series field,
    ///
    /// ```text
    /// XPIC(k):  v* = Σ_{ℓ<k} (I − M_L⁻¹M)^ℓ v + (w − v)      (v: this step's projected velocity)
    /// FMPM(k):  v* = Σ_{ℓ<k} (I − M_L⁻¹M)^ℓ w                 (w: the updated velocity)
    /// ```
    fn series_particle_velocity(&mut self) {
        match self.options.transfer {
            Transfer::Fmpm { k } => self.series_of(GridField::Updated, k),
            Transfer::Xpic { k } => {
                self.series_of(GridField::Projected, k);
                let g = &mut self.nodes;
                for i in 0..g.updated.len() {
                    g.series.x[i] += g.updated.x[i] - g.projected.x[i];
                    g.series.y[i] += g.updated.y[i] - g.projected.y[i];
                }
            }
            _ => return,
        }
        self.extend_to_inactive_nodes(GridField::Series);
    }

    /// (8b) in the grid velocity `field`; prescribed components keep their values.
    fn extend_to_inactive_nodes(&mut self, field: GridField) {
        let GridState {
            active,
            projected,
            updated,
            series,
            ..
        } = &mut self.nodes;
        let u = match field {
            GridField::Projected => projected,
            GridField::Updated => updated,
            GridField::Series => series,
        };
        if extend_to_inactive_nodes(&self.ops, active, u, &mut self.scratch.extension) {
            self.prescribed.apply_velocity(&mut u.x, &mut u.y);
        }
    }

    /// `L = [Gxᵀ u, Gyᵀ u]` at every particle for the grid velocity `field` (extended to the
    /// massless support nodes first).
    fn gradient_of(&mut self, field: GridField) {
        self.extend_to_inactive_nodes(field);
        let u = self.nodes.field(field);
        kernels::velocity_gradient_into(
            &self.ops,
            u,
            &mut self.particle_scratch.velocity_gradient,
            &self.workers,
        );
    }

    /// (9) `x_p ← x_p + Δx_p` with the increments of the grid-to-particle pass.
    fn move_particles(&mut self) {
        let (p, d) = (&mut self.particles, &self.particle_scratch.displacement);
        for k in 0..p.len() {
            p.x[k] += d.x[k];
            p.y[k] += d.y[k];
        }
    }

    /// (12) `F ← (I + Δt L) F`, `σ ← material(σ, L, F)`; (13) `V ← V det(I + Δt L)`.
    fn update_stress(&mut self, dt: f64) -> Result<()> {
        let p = &mut self.particles;
        let l = &self.particle_scratch.velocity_gradient;
        let (materials, body, mass) = (&self.materials, &p.body, &p.mass);
        let out = (
            [&mut p.fxx[..], &mut p.fxy[..], &mut p.fyx[..], &mut p.fyy[..]],
            ([&mut p.sxx[..], &mut p.syy[..], &mut p.sxy[..]], &mut p.volume[..]),
        );
        let mut blocks = std::mem::take(&mut self.scratch.stress_blocks);
        self.workers.split_blocks(out, &mut blocks, |first, out| {
            let ([fxx, fxy, fyx, fyy], ([sxx, syy, sxy], volumes)) = out;
            let mut block = StressBlock::default();
            for j in 0..fxx.len() {
                let k = first + j;
                let l = [l[0][k], l[1][k], l[2][k], l[3][k]];
                let (g, j_inc) = deformation_increment(l, dt);
                let f = [
                    g[0] * fxx[j] + g[1] * fyx[j],
                    g[0] * fxy[j] + g[1] * fyy[j],
                    g[2] * fxx[j] + g[3] * fyx[j],
                    g[2] * fxy[j] + g[3] * fyy[j],
                ];
                let det_f = f[0] * f[3] - f[1] * f[2];
                if !(j_inc > 0.0 && det_f > 0.0 && det_f.is_finite()) {
                    block.inverted = Some((k, j_inc, det_f));
                    return block;
                }
                let volume = volumes[j] * j_inc;
                let (s, e, c11) = materials[body[k]].update_with_modulus([sxx[j], syy[j], sxy[j]], l, f, dt, volume);
                block.energy += e;
                block.wave_squared = block.wave_squared.max(c11 * volume / mass[k]);
                [fxx[j], fxy[j], fyx[j], fyy[j]] = f;
                volumes[j] = volume;
                [sxx[j], syy[j], sxy[j]] = s;
            }
            block
        });
        let mut energy = 0.0;
        // max √x = √(max x): one square root instead of one per particle.
        let mut wave_squared = 0.0f64;
        let mut inverted = None;
        for b in &blocks {
            energy += b.energy;
            wave_squared = wave_squared.max(b.wave_squared);
            inverted = inverted.or(b.inverted);
        }
        self.scratch.stress_blocks = blocks;
        if let Some((k, det_increment, det_f)) = inverted {
            return Err(MpmError::InvertedParticle {
                step: self.steps,
                particle: k,
                id: p.id[k],
                body: self.bodies[p.body[k]].name.clone(),
                det_increment,
                det_f,
            });
        }
        self.strain_energy = energy;
        self.speeds.wave = stability::wave_speed(wave_squared, 1.0, 1.0);
        Ok(())
    }
}
