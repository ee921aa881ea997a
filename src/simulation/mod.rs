//! The explicit time loop: update schemes, transfers, boundary conditions, time-step control and
//! per-step reports, on the sparse operators N, Gx, Gy.
//!
//! Every choice is an independent axis of [`Options`]: the shape function
//! ([`ShapeFunction`]), the update scheme ([`UpdateScheme`]), the particle velocity transfer
//! ([`Transfer`]), the mass treatment of each solve ([`MassOptions`](crate::mass::MassOptions)), the position rule
//! ([`PositionUpdate`]), the time step ([`TimeStep`]), gravity and the boundary conditions
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
//! (9)  v_pic = Nᵀ w,   Δv = Nᵀ (w − v)      (the change of the grid velocity; XPIC, FMPM: below)
//!      PIC:  v_p ← v_pic          FLIP: v_p ← v_p + Δv        blend α: α (v_p + Δv) + (1 − α) v_pic
//!      APIC: v_p ← v_pic,  B_p ← Σ_I N_I w_I (x_I − x_p)ᵀ;  in (3) C_p = B_p D_p⁻¹ at the new position
//! (10) x_p ← x_p + Δt v_pic     (or the trapezoidal rule (Δt/2)(v_p_old + v_pic))
//! (11) USL:  L = [Gxᵀ w, Gyᵀ w]
//!      MUSL: q' = N (m ∘ v_p) [+ APIC term],  v' = Π M_v⁻¹ q',  L = [Gxᵀ v', Gyᵀ v']
//! (12) F ← (I + Δt L) F,   V ← V det(I + Δt L),   σ ← material(σ, L, F)
//! ```
//!
//! ## Allocation
//! With lumped mass for both solves a step allocates nothing after the first: the operators are
//! reassembled into their buffers and every grid and particle work array is kept in the
//! simulation. Consistent, blended, series and iterative schemes go through
//! [`GridMass`], which reuses its factorization buffers but allocates its vectors.

mod options;
mod report;

pub use options::{Body, Options, TimeStep, Transfer, UpdateScheme, DEFAULT_STABILITY_INTERVAL};
pub use report::StepReport;

use crate::boundary::{self, Prescribed};
use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::mass::{GridMass, MassScheme, Role, SolveOutcome, SolveReport};
use crate::operators::{Operator, Operators};
use crate::particles::Particles;
use crate::shape::ShapeFunction;
use crate::step::PositionUpdate;
use crate::stiffness::{self, FrequencyEstimate};
use crate::transfer::{extend_to_inactive_nodes, series_velocity_into, ExtensionScratch, SeriesScratch, VectorField};

/// Work arrays kept from step to step.
#[derive(Debug, Default)]
struct Work {
    // Grid (one entry per node).
    m: Vec<f64>,
    q: VectorField,
    f: VectorField,
    v: VectorField,
    v_series: VectorField,
    series: SeriesScratch,
    a: VectorField,
    w: VectorField,
    active: Vec<bool>,
    node_x: Vec<f64>,
    node_y: Vec<f64>,
    extension: ExtensionScratch,
    prescribed: VectorField,
    // Particles.
    displacement: VectorField,
    l: [Vec<f64>; 4],
    // Sorting.
    keys: Vec<usize>,
    counts: Vec<usize>,
    order: Vec<usize>,
    scratch: Vec<f64>,
    scratch_index: Vec<usize>,
    grid_angular_momentum: f64,
    strain_energy: f64,
    inv_m: Vec<f64>,
    /// This step's kinetic energies: particles before, `½ Σ m_p |Nᵀv|²`, `½ Σ m_p |Nᵀw|²`.
    kinetic_before: f64,
    kinetic_projected: f64,
    kinetic_updated: f64,
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
    work: Work,
}

/// The stable step found by the last frequency estimate.
#[derive(Debug, Clone, Copy)]
struct Stability {
    /// [`stiffness::mpm_critical_time_step`] at that estimate.
    wave_step: f64,
    /// Largest tangent P-wave speed over the particles then.
    wave_speed: f64,
    /// Steps completed when it was made.
    at_step: usize,
    estimate: FrequencyEstimate,
}

impl Simulation {
    /// A simulation of `particles` (each with `particles.body[p]` an index into `bodies`) on
    /// `grid` with `options`, at time 0.
    ///
    /// # Errors
    /// The errors of [`Particles::validate`], [`Material::validate`](crate::material::Material::validate),
    /// [`ShapeFunction::validate`] and [`boundary::resolve`]; [`MpmError::InvalidScene`] for a
    /// particle naming a body that does not exist, a non-positive or non-finite fixed step or
    /// Courant number, an invalid blend weight or a non-finite gravity;
    /// [`MpmError::ParticleOutsideGrid`] / [`MpmError::SupportOutsideGrid`] for particles
    /// outside the region the shape function allows.
    pub fn new(grid: Grid, particles: Particles, bodies: Vec<Body>, options: Options) -> Result<Simulation> {
        particles.validate()?;
        options.shape.validate()?;
        options.mass.velocity.validate()?;
        options.mass.acceleration.validate()?;
        for body in &bodies {
            body.material.validate()?;
        }
        if let Some(p) = (0..particles.len()).find(|&p| particles.body[p] >= bodies.len()) {
            return Err(MpmError::InvalidScene {
                key: "bodies".into(),
                reason: format!(
                    "particle {p} belongs to body {} but there are {} bodies",
                    particles.body[p],
                    bodies.len()
                ),
            });
        }
        match options.time_step {
            TimeStep::Fixed { dt } if !(dt.is_finite() && dt > 0.0) => {
                return Err(MpmError::InvalidScene {
                    key: "time.dt".into(),
                    reason: format!("{dt} is not a positive finite time step"),
                })
            }
            TimeStep::Cfl { number } if !(number > 0.0 && number <= 1.0) => {
                return Err(MpmError::InvalidScene {
                    key: "time.cfl".into(),
                    reason: format!("{number}: the Courant number must lie in (0, 1]"),
                })
            }
            _ => {}
        }
        if let Transfer::Blend { flip } = options.transfer {
            if !(0.0..=1.0).contains(&flip) {
                return Err(MpmError::InvalidScene {
                    key: "schemes.transfer.blend.flip".into(),
                    reason: format!("{flip}: the FLIP weight must lie in [0, 1]"),
                });
            }
        }
        if let Some(k) = options.transfer.series_terms() {
            let name = if matches!(options.transfer, Transfer::Xpic { .. }) {
                "xpic"
            } else {
                "fmpm"
            };
            if k == 0 {
                return Err(MpmError::InvalidScene {
                    key: format!("schemes.transfer.{name}.k"),
                    reason: "the series needs at least one term (k = 1 is PIC)".into(),
                });
            }
            if options.mass.velocity != MassScheme::Lumped || options.mass.acceleration != MassScheme::Lumped {
                return Err(MpmError::InvalidScene {
                    key: "schemes.mass".into(),
                    reason: format!(
                        "{} is defined on the lumped mass (its series is the full-mass correction); set both \
                         solves to \"lumped\"",
                        name.to_uppercase()
                    ),
                });
            }
        }
        if !options.gravity.iter().all(|g| g.is_finite()) {
            return Err(MpmError::InvalidScene {
                key: "gravity".into(),
                reason: format!("{:?} must be finite", options.gravity),
            });
        }
        let prescribed = boundary::resolve(&grid, options.shape, &options.boundaries)?;
        // Reference density of each body: the largest m / V₀ among its particles.
        let mut density = vec![0.0f64; bodies.len()];
        for p in 0..particles.len() {
            let j = particles.fxx[p] * particles.fyy[p] - particles.fxy[p] * particles.fyx[p];
            let rho0 = particles.mass[p] / (particles.volume[p] / j);
            density[particles.body[p]] = density[particles.body[p]].max(rho0);
        }
        let mut ops = Operators::default();
        ops.reassemble(&grid, options.shape, &particles.x, &particles.y)?;
        let n = grid.num_nodes();
        let mut work = Work {
            node_x: grid.node_x(),
            node_y: grid.node_y(),
            prescribed: VectorField {
                x: prescribed
                    .vx
                    .iter()
                    .map(|v| if v.is_nan() { 0.0 } else { *v })
                    .collect(),
                y: prescribed
                    .vy
                    .iter()
                    .map(|v| if v.is_nan() { 0.0 } else { *v })
                    .collect(),
            },
            ..Work::default()
        };
        work.m.resize(n, 0.0);
        work.inv_m.resize(n, 0.0);
        work.extension = ExtensionScratch::new(n);
        work.active.resize(n, false);
        for field in [
            &mut work.q,
            &mut work.f,
            &mut work.v,
            &mut work.v_series,
            &mut work.a,
            &mut work.w,
        ] {
            *field = VectorField::zeros(n);
        }
        let [cx, cy] = grid.cells();
        work.counts.resize(cx * cy + 1, 0);
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
            work,
        };
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
        &self.work.m
    }
    /// The updated grid velocity `w` of the last step.
    pub fn grid_velocity(&self) -> &VectorField {
        &self.work.w
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

    /// The stable time step for the current state:
    ///
    /// ```text
    /// Δt_stable = 1 / (1/Δt_wave + max_p |v_p| / min(hx, hy)),
    /// Δt_wave = TIME_STEP_SAFETY · √(2 (1 + α))/ω_max · min(1, c_est / c_now)
    /// ```
    ///
    /// `ω²_max` is the largest squared frequency of the update with this simulation's masses
    /// ([`stiffness::mpm_max_frequency_squared`]: `λ_max(M_a⁻¹ K M_v⁻¹ M)` from the current
    /// operators, tangent stiffness and masses, by Lanczos), estimated when the simulation is
    /// made and again every [`Options::stability_interval`] steps; between estimates the step
    /// shrinks if the largest tangent P-wave speed `c = √(C11/ρ)` over the particles rises above
    /// its value at the estimate. `α` is the transfer's [`Transfer::flip_weight`] (FLIP is stable
    /// up to `2/ω_max`, PIC-type updates up to `√2/ω_max`). The particle-speed term keeps particles
    /// from crossing more than a cell per step.
    pub fn stable_time_step(&self) -> f64 {
        let Some(s) = self.stability else {
            return f64::INFINITY;
        };
        let p = &self.particles;
        let max_speed = (0..p.len())
            .map(|k| (p.vx[k] * p.vx[k] + p.vy[k] * p.vy[k]).sqrt())
            .fold(0.0, f64::max);
        let c_now = self.max_wave_speed();
        let wave = if c_now > s.wave_speed {
            s.wave_step * s.wave_speed / c_now
        } else {
            s.wave_step
        };
        let [hx, hy] = self.grid.cell_size();
        1.0 / (1.0 / wave + max_speed / hx.min(hy))
    }

    /// The last frequency estimate behind [`Simulation::stable_time_step`] and the number of
    /// steps completed when it was made.
    pub fn frequency_estimate(&self) -> Option<(FrequencyEstimate, usize)> {
        self.stability.map(|s| (s.estimate, s.at_step))
    }

    /// Largest tangent P-wave speed `√(C11_p / ρ_p)` over the particles, `ρ_p = m_p / V_p`.
    fn max_wave_speed(&self) -> f64 {
        let p = &self.particles;
        (0..p.len())
            .map(|k| {
                let f = [p.fxx[k], p.fxy[k], p.fyx[k], p.fyy[k]];
                let c11 = self.bodies[p.body[k]].material.tangent(f)[0];
                (c11 * p.volume[k] / p.mass[k]).max(0.0).sqrt()
            })
            .fold(0.0, f64::max)
    }

    /// Estimates `ω²_max` of the update with the grid prepared for the current configuration
    /// ((1)–(5) and the mass) and keeps it.
    fn estimate_stability(&mut self) -> Result<()> {
        let (ops, p, w) = (&self.ops, &self.particles, &self.work);
        let n = ops.num_nodes();
        let tangent: Vec<[f64; 3]> = (0..p.len())
            .map(|k| {
                let f = [p.fxx[k], p.fxy[k], p.fyx[k], p.fyy[k]];
                self.bodies[p.body[k]].material.tangent(f)
            })
            .collect();
        let mut free: Vec<bool> = w.active.iter().chain(&w.active).copied().collect();
        let c = &self.prescribed.constraints;
        c.fixed_x.iter().for_each(|&i| free[i] = false);
        c.fixed_y.iter().for_each(|&i| free[n + i] = false);
        let free = &free;
        let grid_mass = &self.grid_mass;
        let transfer = self.options.transfer;
        let inverse = |role: Role| {
            let scheme = match role {
                Role::Velocity => self.options.mass.velocity,
                Role::Acceleration => self.options.mass.acceleration,
            };
            move |r: &VectorField| -> Result<VectorField> {
                if scheme != MassScheme::Lumped {
                    return grid_mass.solve(role, r, None, ops).map(|(u, _)| u);
                }
                let mut u = VectorField::zeros(n);
                for i in 0..n {
                    u.x[i] = if free[i] { r.x[i] * w.inv_m[i] } else { 0.0 };
                    u.y[i] = if free[n + i] { r.y[i] * w.inv_m[i] } else { 0.0 };
                }
                if let Transfer::Fmpm { k } = transfer {
                    // FMPM's particle velocity and stress update read M_k⁻¹ M_L of the lumped
                    // velocity: the series is the mass of both halves of the update.
                    let constrain = |v: &mut VectorField| {
                        for i in 0..n {
                            v.x[i] = if free[i] { v.x[i] } else { 0.0 };
                            v.y[i] = if free[n + i] { v.y[i] } else { 0.0 };
                        }
                    };
                    let mut out = VectorField::default();
                    let mut scratch = SeriesScratch::default();
                    series_velocity_into(ops, &p.mass, &w.inv_m, k, &constrain, &u, &mut out, &mut scratch);
                    return Ok(out);
                }
                Ok(u)
            }
        };
        let mut velocity = inverse(Role::Velocity);
        let mut acceleration = inverse(Role::Acceleration);
        let same = self.options.mass.velocity == self.options.mass.acceleration;
        let estimate = stiffness::mpm_max_frequency_squared(
            ops,
            &p.mass,
            &p.volume,
            &tangent,
            free,
            &mut velocity,
            if same { None } else { Some(&mut acceleration) },
        )?;
        let wave_speed = self.max_wave_speed();

        self.stability = Some(Stability {
            wave_step: stiffness::mpm_critical_time_step(&estimate, self.options.transfer.flip_weight()),
            wave_speed,
            at_step: self.steps,
            estimate,
        });
        Ok(())
    }

    /// The step to take now: the fixed one (refused above the stable step unless allowed) or
    /// the Courant number times the stable step.
    fn next_time_step(&self, stable: f64) -> Result<f64> {
        match self.options.time_step {
            TimeStep::Cfl { number } => {
                if stable.is_finite() {
                    Ok(number * stable)
                } else {
                    Err(MpmError::Unstable {
                        step: self.steps,
                        reason: "no stiffness or particle speed to set a CFL time step (no particles?)".into(),
                    })
                }
            }
            TimeStep::Fixed { dt } => {
                if dt > stable && !self.options.allow_unstable_time_step {
                    let m = &self.options.mass;
                    Err(MpmError::TimeStepAboveStable {
                        step: self.steps,
                        dt,
                        stable,
                        masses: if m.velocity == m.acceleration {
                            m.velocity.label()
                        } else {
                            format!("{} / {}", m.velocity.label(), m.acceleration.label())
                        },
                    })
                } else {
                    Ok(dt)
                }
            }
        }
    }

    /// Advances one step (see the [module docs](self)) and reports it.
    ///
    /// # Errors
    /// [`MpmError::TimeStepAboveStable`] for a fixed step above the stable step;
    /// [`MpmError::Unstable`] for an inverted particle (`det F ≤ 0`) or a non-finite velocity;
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
            return Err(MpmError::Unstable {
                step: self.steps,
                reason: format!("an earlier step failed ({reason}); the state is not usable"),
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
            self.sort_particles();
        }
        let shape = self.options.shape;
        self.ops
            .reassemble(&self.grid, shape, &self.particles.x, &self.particles.y)?; //         (1)
        self.particle_to_grid(self.options.update != UpdateScheme::Usf); //                (2)–(5)
        self.prepare_mass()?;
        let due = match self.stability {
            None => true,
            Some(s) => {
                let interval = self.options.stability_interval;
                interval > 0 && self.steps >= s.at_step + interval
            }
        };
        if due {
            self.estimate_stability()?;
        }
        Ok(())
    }

    fn phases(&mut self, max_dt: f64) -> Result<StepReport> {
        self.prepare_grid()?;
        let stable = self.stable_time_step();
        let dt = self.next_time_step(stable)?.min(max_dt);
        let usf = self.options.update == UpdateScheme::Usf;
        let velocity_solve = self.project_velocity()?; //                                   (6)
        if usf {
            let field = self.stress_velocity(GridField::Projected);
            self.extend_to_inactive_nodes(field);
            self.velocity_gradient(field);
            self.update_stress(dt)?;
            self.internal_force();
        }
        let acceleration_solve = self.solve_acceleration()?; //                             (7)
        self.update_grid_velocity(dt); //                                                   (8)
        self.extend_to_inactive_nodes(GridField::Updated);
        self.series_particle_velocity(); //                                          XPIC, FMPM
        self.grid_to_particle(dt, self.options.update == UpdateScheme::Usl); //             (9)–(11)
        match self.options.update {
            UpdateScheme::Usl => self.update_stress(dt)?, //                                (12)
            UpdateScheme::Musl => {
                self.reproject(); //                                                        (11)
                self.project_velocity()?;
                let field = self.stress_velocity(GridField::Projected);
                self.extend_to_inactive_nodes(field);
                self.velocity_gradient(field);
                self.update_stress(dt)?; //                                                 (12)
            }
            UpdateScheme::Usf => {}
        }
        self.move_particles(); //                                                           (10)
        self.time += dt;
        self.steps += 1;
        let mut report = self.report(dt, stable, velocity_solve, acceleration_solve)?;
        let w = &self.work;
        self.transfer_loss += w.kinetic_before + (w.kinetic_updated - w.kinetic_projected) - report.kinetic_energy;
        report.transfer_loss = self.transfer_loss;
        Ok(report)
    }

    /// Counting sort of the particles by cell index (row-major), allocation-free.
    fn sort_particles(&mut self) {
        let (grid, p, w) = (&self.grid, &mut self.particles, &mut self.work);
        let np = p.len();
        let [cx, cy] = grid.cells();
        w.keys.resize(np, 0);
        w.order.resize(np, 0);
        w.counts.iter_mut().for_each(|c| *c = 0);
        for k in 0..np {
            let key = grid.cell_of(p.x[k], p.y[k]).map_or(cx * cy, |(i, j)| j * cx + i);
            w.keys[k] = key.min(cx * cy);
            w.counts[w.keys[k]] += 1;
        }
        let mut start = 0;
        for c in w.counts.iter_mut() {
            let n = *c;
            *c = start;
            start += n;
        }
        for k in 0..np {
            let key = w.keys[k];
            w.order[w.counts[key]] = k;
            w.counts[key] += 1;
        }
        p.permute(&w.order, &mut w.scratch, &mut w.scratch_index);
    }

    /// (2)–(5) in one pass over the shared pattern of N, Gx, Gy:
    ///
    /// ```text
    /// m_L = N m,   q = N (m ∘ v) [+ APIC: Σ_p N_Ip m_p B_p D_p⁻¹ (x_I − x_p)],
    /// f = N (m ∘ b) + m_L g − [Gx (V∘σxx) + Gy (V∘σxy); Gx (V∘σxy) + Gy (V∘σyy)]
    /// ```
    fn particle_to_grid(&mut self, with_internal: bool) {
        let (ops, p, w) = (&self.ops, &self.particles, &mut self.work);
        let apic = self.options.transfer == Transfer::Apic;
        let inertia = apic.then(|| ApicInertia::of(self.options.shape, &self.grid));
        let [gx, gy] = self.options.gravity;
        w.m.iter_mut().for_each(|v| *v = 0.0);
        for field in [&mut w.q, &mut w.f] {
            field.x.iter_mut().for_each(|v| *v = 0.0);
            field.y.iter_mut().for_each(|v| *v = 0.0);
        }
        let (cp, ri) = (ops.col_offsets(), ops.row_indices());
        let (nv, gxv, gyv) = (
            ops.values(Operator::N),
            ops.values(Operator::Gx),
            ops.values(Operator::Gy),
        );
        let internal = if with_internal { 1.0 } else { 0.0 };
        for k in 0..p.len() {
            let m = p.mass[k];
            let (mvx, mvy) = (m * p.vx[k], m * p.vy[k]);
            let (mbx, mby) = (m * p.bx[k], m * p.by[k]);
            let v = internal * p.volume[k];
            let (vsxx, vsyy, vsxy) = (v * p.sxx[k], v * p.syy[k], v * p.sxy[k]);
            let affine = apic_affine(p, k, &w.node_x, &w.node_y, ops, inertia);
            for e in cp[k]..cp[k + 1] {
                let (i, n) = (ri[e], nv[e]);
                w.m[i] += n * m;
                let [ax, ay] = affine.velocity(i, &w.node_x, &w.node_y, n);
                w.q.x[i] += n * mvx + m * ax;
                w.q.y[i] += n * mvy + m * ay;
                w.f.x[i] += n * mbx - (gxv[e] * vsxx + gyv[e] * vsxy);
                w.f.y[i] += n * mby - (gxv[e] * vsxy + gyv[e] * vsyy);
            }
        }
        let mut ang = 0.0;
        for i in 0..w.m.len() {
            w.f.x[i] += w.m[i] * gx;
            w.f.y[i] += w.m[i] * gy;
            ang += w.node_x[i] * w.q.y[i] - w.node_y[i] * w.q.x[i];
        }
        w.grid_angular_momentum = ang;
    }

    /// (5) alone, added to `f` (USF recomputes it after the stress update).
    fn internal_force(&mut self) {
        let (ops, p, w) = (&self.ops, &self.particles, &mut self.work);
        let (cp, ri) = (ops.col_offsets(), ops.row_indices());
        let (gxv, gyv) = (ops.values(Operator::Gx), ops.values(Operator::Gy));
        for k in 0..p.len() {
            let v = p.volume[k];
            let (sxx, syy, sxy) = (v * p.sxx[k], v * p.syy[k], v * p.sxy[k]);
            for e in cp[k]..cp[k + 1] {
                let i = ri[e];
                w.f.x[i] -= gxv[e] * sxx + gyv[e] * sxy;
                w.f.y[i] -= gxv[e] * sxy + gyv[e] * syy;
            }
        }
    }

    /// Active nodes, and the consistent mass and its factorizations when a scheme needs them.
    fn prepare_mass(&mut self) -> Result<()> {
        let w = &mut self.work;
        let max = w.m.iter().cloned().fold(0.0, f64::max);
        let threshold = self.options.mass.active_tolerance * max;
        for i in 0..w.m.len() {
            w.active[i] = w.m[i] > threshold && w.m[i] > 0.0;
            w.inv_m[i] = if w.active[i] { 1.0 / w.m[i] } else { 0.0 };
        }
        if self.uses_grid_mass() {
            self.grid_mass.update(
                &self.ops,
                &self.particles.mass,
                &self.options.mass,
                &self.prescribed.constraints,
            )?;
        }
        Ok(())
    }

    fn uses_grid_mass(&self) -> bool {
        let m = &self.options.mass;
        m.velocity != MassScheme::Lumped || m.acceleration != MassScheme::Lumped
    }

    /// (6) `v = Π M_v⁻¹ q` into `work.v`.
    fn project_velocity(&mut self) -> Result<SolveReport> {
        let w = &mut self.work;
        let report = if self.options.mass.velocity == MassScheme::Lumped {
            divide_by_lumped(&w.inv_m, &w.q, &mut w.v)
        } else {
            let (v, report) = self
                .grid_mass
                .solve(Role::Velocity, &w.q, Some(&w.prescribed), &self.ops)?;
            w.v = v;
            report
        };
        self.prescribed.apply_velocity(&mut w.v.x, &mut w.v.y);
        Ok(report)
    }

    /// (7) `a = Π₀ M_a⁻¹ f` into `work.a`.
    fn solve_acceleration(&mut self) -> Result<SolveReport> {
        let w = &mut self.work;
        let report = if self.options.mass.acceleration == MassScheme::Lumped {
            divide_by_lumped(&w.inv_m, &w.f, &mut w.a)
        } else {
            let (a, report) = self.grid_mass.solve(Role::Acceleration, &w.f, None, &self.ops)?;
            w.a = a;
            report
        };
        self.prescribed.zero(&mut w.a.x, &mut w.a.y);
        Ok(report)
    }

    /// (8) `w = Π (v + Δt a)` on active nodes, 0 elsewhere.
    fn update_grid_velocity(&mut self, dt: f64) {
        let w = &mut self.work;
        for i in 0..w.m.len() {
            let s = if w.active[i] { 1.0 } else { 0.0 };
            w.w.x[i] = s * (w.v.x[i] + dt * w.a.x[i]);
            w.w.y[i] = s * (w.v.y[i] + dt * w.a.y[i]);
        }
        self.prescribed.apply_velocity(&mut w.w.x, &mut w.w.y);
    }

    /// The grid velocity the stress update reads, given the one the update scheme projects:
    /// FMPM(k) passes it through its series first (into `work.v_series`).
    fn stress_velocity(&mut self, field: GridField) -> GridField {
        let Transfer::Fmpm { k } = self.options.transfer else {
            return field;
        };
        let w = &mut self.work;
        let source = match field {
            GridField::Projected => &w.v,
            GridField::Updated => &w.w,
            GridField::Series => return field,
        };
        let prescribed = &self.prescribed;
        let constrain = |u: &mut VectorField| prescribed.zero(&mut u.x, &mut u.y);
        series_velocity_into(
            &self.ops,
            &self.particles.mass,
            &w.inv_m,
            k,
            &constrain,
            source,
            &mut w.v_series,
            &mut w.series,
        );
        GridField::Series
    }

    /// XPIC(k) and FMPM(k), once per step before the particle update: the grid velocity the new
    /// particle velocities interpolate, into `work.v_series`,
    ///
    /// ```text
    /// XPIC(k):  v* = Σ_{ℓ<k} (I − M_L⁻¹M)^ℓ v + (w − v)      (v: this step's projected velocity)
    /// FMPM(k):  v* = Σ_{ℓ<k} (I − M_L⁻¹M)^ℓ w                 (w: the updated velocity)
    /// ```
    ///
    /// each increment with its prescribed components zeroed ([`series_velocity_into`]).
    fn series_particle_velocity(&mut self) {
        match self.options.transfer {
            Transfer::Fmpm { .. } => {
                self.stress_velocity(GridField::Updated);
            }
            Transfer::Xpic { k } => {
                let w = &mut self.work;
                let prescribed = &self.prescribed;
                let constrain = |u: &mut VectorField| prescribed.zero(&mut u.x, &mut u.y);
                let m = &self.particles.mass;
                series_velocity_into(
                    &self.ops,
                    m,
                    &w.inv_m,
                    k,
                    &constrain,
                    &w.v,
                    &mut w.v_series,
                    &mut w.series,
                );
                for i in 0..w.w.len() {
                    w.v_series.x[i] += w.w.x[i] - w.v.x[i];
                    w.v_series.y[i] += w.w.y[i] - w.v.y[i];
                }
            }
            _ => return,
        }
        self.extend_to_inactive_nodes(GridField::Series);
    }

    /// Gives the inactive nodes inside some particle's support the mean interpolated velocity of
    /// those particles (see [`crate::transfer::extend_to_massless_nodes`]), in the grid velocity
    /// `field`; prescribed components keep their values.
    fn extend_to_inactive_nodes(&mut self, field: GridField) {
        let w = &mut self.work;
        let u = match field {
            GridField::Projected => &mut w.v,
            GridField::Updated => &mut w.w,
            GridField::Series => &mut w.v_series,
        };
        if extend_to_inactive_nodes(&self.ops, &w.active, u, &mut w.extension) {
            self.prescribed.apply_velocity(&mut u.x, &mut u.y);
        }
    }

    /// `L = [Gxᵀ u, Gyᵀ u]` at every particle into `work.l`, for the grid velocity `field`.
    fn velocity_gradient(&mut self, field: GridField) {
        let (ops, w) = (&self.ops, &mut self.work);
        let np = ops.num_particles();
        for l in w.l.iter_mut() {
            l.resize(np, 0.0);
        }
        let u = match field {
            GridField::Projected => &w.v,
            GridField::Updated => &w.w,
            GridField::Series => &w.v_series,
        };
        let (cp, ri) = (ops.col_offsets(), ops.row_indices());
        let (gxv, gyv) = (ops.values(Operator::Gx), ops.values(Operator::Gy));
        for k in 0..np {
            let mut l = [0.0; 4];
            for e in cp[k]..cp[k + 1] {
                let (ux, uy) = (u.x[ri[e]], u.y[ri[e]]);
                l[0] += gxv[e] * ux;
                l[1] += gyv[e] * ux;
                l[2] += gxv[e] * uy;
                l[3] += gyv[e] * uy;
            }
            for c in 0..4 {
                w.l[c][k] = l[c];
            }
        }
    }

    /// (9)–(11) in one pass over N, Gx, Gy: particle velocities (and APIC `C`), the position
    /// increments (applied by [`Simulation::move_particles`]) and, when `with_gradient`,
    /// `L = [Gxᵀ u, Gyᵀ u]` with `u` the velocity the stress update reads (`w`, or FMPM's `v*`).
    ///
    /// FLIP's increment is `Nᵀ (w − v)`, the change of the grid velocity with the boundary
    /// conditions applied to both (`Δt Nᵀ a` when they are constant), for every mass scheme
    /// (docs/formulation.md).
    fn grid_to_particle(&mut self, dt: f64, with_gradient: bool) {
        let (ops, p, w) = (&self.ops, &mut self.particles, &mut self.work);
        let np = p.len();
        w.displacement.x.resize(np, 0.0);
        w.displacement.y.resize(np, 0.0);
        for l in w.l.iter_mut() {
            l.resize(np, 0.0);
        }
        let (cp, ri) = (ops.col_offsets(), ops.row_indices());
        let (nv, gxv, gyv) = (
            ops.values(Operator::N),
            ops.values(Operator::Gx),
            ops.values(Operator::Gy),
        );
        let transfer = self.options.transfer;
        let trapezoidal = self.options.position_update == PositionUpdate::Trapezoidal;
        // Linear kernels keep C_p = Σ_I w_I ∇N_Iᵀ itself (see `apic_affine`).
        let linear_apic = transfer == Transfer::Apic && self.options.shape == ShapeFunction::Linear;
        let need_l = with_gradient || linear_apic;
        // The field the new velocity interpolates, the reference of increments (the projected v)
        // and the field of the stress update's gradient.
        let series = transfer.series_terms().is_some();
        let target = if series { &w.v_series } else { &w.w };
        let reference = &w.v;
        let gradient = if matches!(transfer, Transfer::Fmpm { .. }) {
            &w.v_series
        } else {
            &w.w
        };
        let (mut kinetic_before, mut kinetic_projected, mut kinetic_updated) = (0.0, 0.0, 0.0);
        for k in 0..np {
            let (mut vx, mut vy, mut tx, mut ty, mut rx, mut ry) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
            let mut l = [0.0; 4];
            let mut lw = [0.0; 4];
            let mut b = [0.0; 4];
            for e in cp[k]..cp[k + 1] {
                let (i, n) = (ri[e], nv[e]);
                let (wx, wy) = (w.w.x[i], w.w.y[i]);
                vx += n * wx;
                vy += n * wy;
                tx += n * target.x[i];
                ty += n * target.y[i];
                rx += n * reference.x[i];
                ry += n * reference.y[i];
                if need_l {
                    let (gx, gy) = (gradient.x[i], gradient.y[i]);
                    l[0] += gxv[e] * gx;
                    l[1] += gyv[e] * gx;
                    l[2] += gxv[e] * gy;
                    l[3] += gyv[e] * gy;
                }
                if transfer == Transfer::Apic {
                    lw[0] += gxv[e] * wx;
                    lw[1] += gyv[e] * wx;
                    lw[2] += gxv[e] * wy;
                    lw[3] += gyv[e] * wy;
                    let (dx, dy) = (w.node_x[i] - p.x[k], w.node_y[i] - p.y[k]);
                    b[0] += n * wx * dx;
                    b[1] += n * wx * dy;
                    b[2] += n * wy * dx;
                    b[3] += n * wy * dy;
                }
            }
            if with_gradient {
                for c in 0..4 {
                    w.l[c][k] = l[c];
                }
            }
            let (old_x, old_y) = (p.vx[k], p.vy[k]);
            let half_m = 0.5 * p.mass[k];
            kinetic_before += half_m * (old_x * old_x + old_y * old_y);
            kinetic_projected += half_m * (rx * rx + ry * ry);
            kinetic_updated += half_m * (vx * vx + vy * vy);
            let (dvx, dvy) = (vx - rx, vy - ry);
            let (new_x, new_y) = match transfer {
                Transfer::Pic | Transfer::Apic => (vx, vy),
                Transfer::Xpic { .. } | Transfer::Fmpm { .. } => (tx, ty),
                Transfer::Flip => (old_x + dvx, old_y + dvy),
                Transfer::Blend { flip } => (
                    flip * (old_x + dvx) + (1.0 - flip) * vx,
                    flip * (old_y + dvy) + (1.0 - flip) * vy,
                ),
            };
            p.vx[k] = new_x;
            p.vy[k] = new_y;
            if transfer == Transfer::Apic {
                let b = if linear_apic { lw } else { b };
                p.affine_xx[k] = b[0];
                p.affine_xy[k] = b[1];
                p.affine_yx[k] = b[2];
                p.affine_yy[k] = b[3];
            }
            let (ux, uy) = match transfer {
                // Nairn: x += Δt (Nᵀ v + ½ (v_p,new − v_p,old)).
                Transfer::Xpic { .. } => (rx + 0.5 * (new_x - old_x), ry + 0.5 * (new_y - old_y)),
                Transfer::Fmpm { .. } => (0.5 * (old_x + new_x), 0.5 * (old_y + new_y)),
                _ if trapezoidal => (0.5 * (old_x + vx), 0.5 * (old_y + vy)),
                _ => (vx, vy),
            };
            w.displacement.x[k] = dt * ux;
            w.displacement.y[k] = dt * uy;
        }
        w.kinetic_before = kinetic_before;
        w.kinetic_projected = kinetic_projected;
        w.kinetic_updated = kinetic_updated;
    }

    /// MUSL's re-projection `q' = N (m ∘ v_p) [+ APIC term]` with the operators and positions of
    /// the start of the step (particles move after it).
    fn reproject(&mut self) {
        let (ops, p, w) = (&self.ops, &self.particles, &mut self.work);
        let apic = self.options.transfer == Transfer::Apic;
        w.q.x.iter_mut().for_each(|v| *v = 0.0);
        w.q.y.iter_mut().for_each(|v| *v = 0.0);
        let inertia = apic.then(|| ApicInertia::of(self.options.shape, &self.grid));
        let (cp, ri, nv) = (ops.col_offsets(), ops.row_indices(), ops.values(Operator::N));
        for k in 0..p.len() {
            let m = p.mass[k];
            let affine = apic_affine(p, k, &w.node_x, &w.node_y, ops, inertia);
            for e in cp[k]..cp[k + 1] {
                let (i, n) = (ri[e], nv[e]);
                let [ax, ay] = affine.velocity(i, &w.node_x, &w.node_y, n);
                w.q.x[i] += n * m * p.vx[k] + m * ax;
                w.q.y[i] += n * m * p.vy[k] + m * ay;
            }
        }
    }

    /// (10) `x_p ← x_p + Δt v̂_p` with the displacement stored by the grid-to-particle pass.
    fn move_particles(&mut self) {
        let (p, d) = (&mut self.particles, &self.work.displacement);
        for k in 0..p.len() {
            p.x[k] += d.x[k];
            p.y[k] += d.y[k];
        }
    }

    /// (12) `F ← (I + Δt L) F`, `V ← V det(I + Δt L)`, `σ ← material(σ, L, F)`.
    fn update_stress(&mut self, dt: f64) -> Result<()> {
        let (p, w) = (&mut self.particles, &mut self.work);
        let mut energy = 0.0;
        for k in 0..p.len() {
            let l = [w.l[0][k], w.l[1][k], w.l[2][k], w.l[3][k]];
            let g = [1.0 + dt * l[0], dt * l[1], dt * l[2], 1.0 + dt * l[3]];
            let j_inc = g[0] * g[3] - g[1] * g[2];
            let f = [
                g[0] * p.fxx[k] + g[1] * p.fyx[k],
                g[0] * p.fxy[k] + g[1] * p.fyy[k],
                g[2] * p.fxx[k] + g[3] * p.fyx[k],
                g[2] * p.fxy[k] + g[3] * p.fyy[k],
            ];
            let j = f[0] * f[3] - f[1] * f[2];
            if !(j_inc > 0.0 && j > 0.0 && j.is_finite()) {
                return Err(MpmError::Unstable {
                    step: self.steps,
                    reason: format!(
                        "particle {} (id {}, body `{}`) inverted: det(I + Δt L) = {j_inc:e}, det F = {j:e}; reduce \
                         the time step (Courant number) or check the material and loads",
                        k, p.id[k], self.bodies[p.body[k]].name
                    ),
                });
            }
            let material = &self.bodies[p.body[k]].material;
            let volume = p.volume[k] * j_inc;
            let (s, e) = material.update([p.sxx[k], p.syy[k], p.sxy[k]], l, f, dt, volume);
            energy += e;
            p.fxx[k] = f[0];
            p.fxy[k] = f[1];
            p.fyx[k] = f[2];
            p.fyy[k] = f[3];
            p.volume[k] = volume;
            p.sxx[k] = s[0];
            p.syy[k] = s[1];
            p.sxy[k] = s[2];
        }
        w.strain_energy = energy;
        Ok(())
    }

    fn report(
        &self,
        dt: f64,
        stable_time_step: f64,
        velocity_solve: SolveReport,
        acceleration_solve: SolveReport,
    ) -> Result<StepReport> {
        let (p, w) = (&self.particles, &self.work);
        let [gx, gy] = self.options.gravity;
        let strain = w.strain_energy;
        let (mut ke, mut potential, mut ang, mut mass, mut max_speed) = (0.0, 0.0, 0.0, 0.0, 0.0f64);
        let (mut px, mut py) = (0.0, 0.0);
        for k in 0..p.len() {
            let m = p.mass[k];
            let (vx, vy) = (p.vx[k], p.vy[k]);
            let speed = (vx * vx + vy * vy).sqrt();
            if !speed.is_finite() {
                return Err(MpmError::Unstable {
                    step: self.steps,
                    reason: format!(
                        "particle {k} (id {}) has a non-finite velocity ({vx}, {vy}); reduce the time step",
                        p.id[k]
                    ),
                });
            }
            max_speed = max_speed.max(speed);
            mass += m;
            ke += 0.5 * m * (vx * vx + vy * vy);
            px += m * vx;
            py += m * vy;
            ang += m * (p.x[k] * vy - p.y[k] * vx);
            potential -= m * ((p.bx[k] + gx) * p.x[k] + (p.by[k] + gy) * p.y[k]);
        }
        let ke_l: f64 = (0..w.m.len())
            .map(|i| 0.5 * w.m[i] * (w.w.x[i].powi(2) + w.w.y[i].powi(2)))
            .sum();
        Ok(StepReport {
            step: self.steps,
            time: self.time,
            dt,
            stable_time_step,
            kinetic_energy: ke,
            particle_grid_gap: w.kinetic_before - w.kinetic_projected,
            transfer_loss: self.transfer_loss,
            grid_kinetic_energy_lumped: ke_l,
            grid_kinetic_energy_consistent: w.kinetic_updated,
            strain_energy: strain,
            potential_energy: potential,
            total_energy: ke + strain + potential,
            momentum: [px, py],
            angular_momentum: ang,
            grid_angular_momentum: w.grid_angular_momentum,
            mass,
            max_speed,
            velocity_solve,
            acceleration_solve,
        })
    }
}

/// The lumped solve `u_I = r_I / m_L,I` on active nodes, 0 elsewhere, into `u` (`inv_m` holds
/// `1 / m_L,I` on active nodes and 0 elsewhere); its report.
fn divide_by_lumped(inv_m: &[f64], r: &VectorField, u: &mut VectorField) -> SolveReport {
    for i in 0..inv_m.len() {
        u.x[i] = r.x[i] * inv_m[i];
        u.y[i] = r.y[i] * inv_m[i];
    }
    SolveReport {
        scheme: MassScheme::Lumped,
        outcome: SolveOutcome::Solved,
        iterations: 0,
        relative_residual: 0.0,
    }
}

/// Which grid velocity a phase reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum GridField {
    /// `v`: projected from the particles (6).
    Projected,
    /// `w`: updated (8).
    Updated,
    /// `v*`: XPIC's or FMPM's series velocity.
    Series,
}

/// How a kernel's APIC inertia `D_p` is obtained.
#[derive(Clone, Copy)]
enum ApicInertia {
    /// Linear kernels: the particle stores `C_p` itself.
    StoredC,
    /// B-splines: `D_p = diag(dxx, dyy)`, the same for every particle.
    Constant([f64; 2]),
    /// GIMP: summed over the particle's column.
    Column,
}

impl ApicInertia {
    fn of(shape: ShapeFunction, grid: &Grid) -> ApicInertia {
        let [hx, hy] = grid.cell_size();
        match shape {
            ShapeFunction::Linear => ApicInertia::StoredC,
            ShapeFunction::QuadraticBSpline => ApicInertia::Constant([hx * hx / 4.0, hy * hy / 4.0]),
            ShapeFunction::CubicBSpline => ApicInertia::Constant([hx * hx / 3.0, hy * hy / 3.0]),
            ShapeFunction::Gimp { .. } => ApicInertia::Column,
        }
    }
}

/// The APIC affine velocity of one particle at the nodes of its column.
enum Affine {
    /// Not APIC.
    None,
    /// `C_p` and the particle's position: the affine velocity at node I is `C_p (x_I − x_p)`.
    Matrix([f64; 4], [f64; 2]),
}

impl Affine {
    /// The affine momentum per unit particle mass at node `i` with weight `n`:
    /// `m_p⁻¹ × N_I m_p C_p (x_I − x_p)`.
    #[inline]
    fn velocity(&self, i: usize, node_x: &[f64], node_y: &[f64], n: f64) -> [f64; 2] {
        match *self {
            Affine::None => [0.0, 0.0],
            Affine::Matrix(c, [x, y]) => {
                let (dx, dy) = (node_x[i] - x, node_y[i] - y);
                [n * (c[0] * dx + c[1] * dy), n * (c[2] * dx + c[3] * dy)]
            }
        }
    }
}

/// Particle `k`'s APIC affine velocity matrix at its current position: `C_p = B_p D_p⁻¹` with
/// `D_p = diag(Σ_I N_I dx², Σ_I N_I dy²)` (the off-diagonal part vanishes for tensor-product
/// kernels; `h²/4` for quadratic and `h²/3` for cubic B-splines, summed over the column for
/// GIMP). Linear kernels store `C_p = Σ_I w_I ∇N_Iᵀ` itself (their `D_p` vanishes on grid
/// lines; `∇N_I = D_p⁻¹ N_I (x_I − x_p)` at the old position).
fn apic_affine(
    p: &Particles,
    k: usize,
    node_x: &[f64],
    node_y: &[f64],
    ops: &Operators,
    kind: Option<ApicInertia>,
) -> Affine {
    let Some(kind) = kind else {
        return Affine::None;
    };
    let b = [p.affine_xx[k], p.affine_xy[k], p.affine_yx[k], p.affine_yy[k]];
    let position = [p.x[k], p.y[k]];
    match kind {
        ApicInertia::StoredC => return Affine::Matrix(b, position),
        ApicInertia::Constant([dxx, dyy]) => {
            return Affine::Matrix([b[0] / dxx, b[1] / dyy, b[2] / dxx, b[3] / dyy], position)
        }
        ApicInertia::Column => {}
    }
    let (cp, ri, nv) = (ops.col_offsets(), ops.row_indices(), ops.values(Operator::N));
    let (mut dxx, mut dyy) = (0.0, 0.0);
    for e in cp[k]..cp[k + 1] {
        let (dx, dy) = (node_x[ri[e]] - p.x[k], node_y[ri[e]] - p.y[k]);
        dxx += nv[e] * dx * dx;
        dyy += nv[e] * dy * dy;
    }
    // D_p > 0 for GIMP and B-splines: their weights always spread over more than one node.
    Affine::Matrix([b[0] / dxx, b[1] / dyy, b[2] / dxx, b[3] / dyy], [p.x[k], p.y[k]])
}
