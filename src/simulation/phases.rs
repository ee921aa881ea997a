//! The step of the time loop, as the numbered lines of the [module docs](super): each phase
//! takes what it reads by `&` and what it writes by `&mut`.

use super::plan::StepPlan;
use super::profile::{timed, Phase};
use super::report::StepTaken;
use super::series::{with_series_operator, SeriesTransfer};
use super::{stability, walls, Body, Cache, Options, Scratch, Setup, Simulation, State, StepReport};
use crate::boundary::Prescribed;
use crate::error::{MpmError, Result};
use crate::fields::VectorField;
use crate::kernels::{
    self, extend_to_inactive_nodes, ApicInertia, ExtensionScratch, Fused, G2pRule, GridField, GridState, P2gTerms,
    ParticleSums, Stress, StressInput, StressOutput, StressPartials, StressSums,
};
use crate::mass::{series_velocity_into, GridMass, MassOptions, MassScheme, Role, SolveReport};
use crate::operators::Operators;
use crate::particles::Particles;
use crate::schemes::StressFrom;

impl Simulation {
    /// One step no longer than `max_dt`: the lines of the [module docs](super) in order.
    pub(super) fn phases(&mut self, max_dt: f64) -> Result<StepReport> {
        match self.options.integrator {
            super::Integrator::Newmark(newmark) => return self.newmark_phases(newmark, max_dt),
            super::Integrator::QuasiStatic(q) => return self.quasi_static_phases(q, max_dt),
            super::Integrator::Explicit => {}
        }
        let plan = StepPlan::of(&self.setup, &self.options, self.state.time);
        let (input, mut out) = self.split(&plan);
        prepare_grid(input, out.reborrow())?; // (1)–(5), mass
        let (setup, state) = (input.setup, &*out.state);
        let stable = timed(out.profile, Phase::StableStep, || {
            stability::stable_time_step(&setup.grid, state)
        });
        let dt = stability::next_time_step(input.options, out.state.steps, stable)?.min(max_dt);
        let solves = if input.setup.contact.is_some() {
            let (state, cache, scratch, _) = out.reborrow().into_parts();
            super::contact::grid_phases(input.setup, input.options, state, cache, scratch, dt)?
        } else {
            grid_phases(input, out.reborrow(), dt)?
        }; // (6)–(8b), XPIC/FMPM
        particle_phases(input, out.reborrow(), dt)?; // (9)–(13)
        finish_step(input, out, dt, stable, solves)
    }

    /// The simulation split into what the stages of a step read (with the step's `plan`) and
    /// what they write.
    pub(super) fn split<'a>(&'a mut self, plan: &'a StepPlan) -> (StepInput<'a>, StepOutput<'a>) {
        let Simulation {
            setup,
            options,
            state,
            cache,
            scratch,
            profile,
        } = self;
        (
            StepInput { setup, options, plan },
            StepOutput {
                state,
                cache,
                scratch,
                profile,
            },
        )
    }
}

/// What the stages of a step read: the setup, the options and the step's plan.
#[derive(Clone, Copy)]
pub(super) struct StepInput<'a> {
    pub(super) setup: &'a Setup,
    pub(super) options: &'a Options,
    pub(super) plan: &'a StepPlan,
}

/// What the stages of a step write: the state, the cache, the work arrays and the profile.
pub(super) struct StepOutput<'a> {
    pub(super) state: &'a mut State,
    pub(super) cache: &'a mut Cache,
    pub(super) scratch: &'a mut Scratch,
    pub(super) profile: &'a mut Option<super::profile::Profile>,
}

/// [`StepOutput`]'s parts, each on its own.
type Parts<'a> = (
    &'a mut State,
    &'a mut Cache,
    &'a mut Scratch,
    &'a mut Option<super::profile::Profile>,
);

impl<'a> StepOutput<'a> {
    /// The parts, each on its own.
    pub(super) fn into_parts(self) -> Parts<'a> {
        (self.state, self.cache, self.scratch, self.profile)
    }

    /// The same parts, borrowed again for one stage.
    pub(super) fn reborrow(&mut self) -> StepOutput<'_> {
        StepOutput {
            state: self.state,
            cache: self.cache,
            scratch: self.scratch,
            profile: self.profile,
        }
    }
}

/// (1)–(5) and the grid mass for the current particle configuration (re-sorting the
/// particles first when due), and the stable-step estimate when due.
pub(super) fn prepare_grid(input: StepInput, out: StepOutput) -> Result<()> {
    let StepInput { setup, options, plan } = input;
    let (state, cache, scratch, profile) = out.into_parts();
    let (grid, workers) = (&setup.grid, &setup.workers);
    let interval = options.sort_interval;
    let sorts = interval > 0 && state.steps.is_multiple_of(interval);
    // The last step's fused pass assembled (1) and scattered (2)–(5) already (never before a
    // sort: see particle_phases).
    let prepared = cache.nodes.next_ready() && !sorts;
    if !prepared {
        cache.nodes.discard_next();
    }
    if sorts {
        timed(profile, Phase::Sort, || {
            // The operators' coordinate array, which the assembly below rewrites, lends its
            // memory as the sort's work array.
            let work = cache.ops.reassembly_scratch();
            super::sort::sort_particles(grid, options.shape, &mut state.particles, &mut scratch.sorting, work)
        });
    }
    let p = &state.particles;
    let (mirror, slip) = (&setup.prescribed.mirror, &setup.prescribed.slip);
    if !prepared {
        timed(profile, Phase::Assemble, || {
            cache.ops.reassemble_with(grid, options.shape, &p.x, &p.y, workers)?;
            mirror.fold(grid, options.shape, &p.x, &p.y, &mut cache.ops); // mirrored walls
            Ok::<_, MpmError>(())
        })?; // (1)
    }
    let stress = if plan.stress_first {
        Stress::Omit
    } else {
        Stress::Include
    };
    let (ops, mass, nodes, each) = (&cache.ops, &mut cache.mass, &mut cache.nodes, &mut cache.component_ops);
    let mass = &mut *mass;
    let writes = kernels::NodeWrites {
        fields: !plan.lumped_grid_pass,
        boxed: !folds_mass(setup),
    };
    timed(profile, Phase::P2g, || {
        let terms = P2gTerms {
            apic: plan.apic,
            gravity: plan.gravity,
            stress,
        };
        if prepared {
            kernels::p2g_prepared(ops, plan.gravity, mass.lumped_mut(), nodes, workers, writes);
        } else {
            kernels::p2g_with(ops, p, terms, mass.lumped_mut(), nodes, workers, writes);
        }
        mirror.fold_lumped(grid, p, ops, mass.lumped_mut());
        walls::fold_lumped(slip, grid, mass.lumped_mut());
        walls::fold(slip, grid, &mut nodes.momentum);
        walls::fold(slip, grid, &mut nodes.force);
    }); // (2)–(5)
    timed(profile, Phase::Mass, || {
        if !slip.is_empty() && !lumped_only(plan) {
            walls::component_operators(slip, grid, options.shape, p, ops, each);
        }
        prepare_mass(setup, plan, &plan.mass, ops, each, p, mass)
    })?;
    if setup.contact.is_some() {
        timed(profile, Phase::Mass, || {
            super::contact::prepare_layers(setup, plan, state, cache)
        })?;
    }
    // (The implicit integrator has no stable step to estimate.)
    let explicit = options.integrator == super::Integrator::Explicit;
    let due = stability::estimate_due(options, state, &cache.mass);
    if explicit && due != stability::Due::Nothing {
        let tracking = &mut scratch.tracking;
        let mut estimate = timed(profile, Phase::StableStep, || {
            stability::estimate(setup, options, state, cache, due, tracking)
        })?;
        // A nearly singular mass: the singularity policy for this step, and the stable
        // step of what it put in place.
        if let Some(s) = tracking.nearly_singular.take() {
            cache.mass.substitute_nearly_singular(s.node, s.ratio, &cache.ops)?;
            estimate = timed(profile, Phase::StableStep, || {
                stability::estimate(setup, options, state, cache, stability::Due::Estimate, tracking)
            })?;
            tracking.nearly_singular = None;
        }
        if setup.contact.is_some() && due == stability::Due::Estimate {
            estimate = timed(profile, Phase::StableStep, || {
                super::contact::bound_by_bodies(setup, options, state, cache, tracking, estimate)
            })?;
        }
        state.stability = Some(estimate);
    }
    Ok(())
}

/// Whether both solves take the lumped mass.
fn lumped_only(plan: &StepPlan) -> bool {
    plan.mass.velocity == MassScheme::Lumped && plan.mass.acceleration == MassScheme::Lumped
}

/// The nodes that may carry grid mass: the operators' span ([`Operators::node_span`]; with
/// `written`, the span its last p2g wrote in place of the operators'), or every node when walls
/// fold mass across them (mirrored or slip walls).
pub(super) fn massive_span(setup: &Setup, ops: &Operators, written: Option<&GridState>) -> std::ops::Range<usize> {
    match written {
        _ if folds_mass(setup) => 0..ops.num_nodes(),
        Some(grid) => grid.span.clone(),
        None => ops.node_span(),
    }
}

/// Whether walls fold mass across the operators' span (mirrored or slip walls).
fn folds_mass(setup: &Setup) -> bool {
    let prescribed = &setup.prescribed;
    !(prescribed.mirror.is_empty() && prescribed.slip.is_empty())
}

/// The grid mass of the particles `p` (whose `m_L` p2g left in `mass`) with the mass options
/// `choice` (the step's, or a body's own under contact): one matrix per component from the
/// folded operators `each` when slip walls are mirrored (simulation/walls.rs), one matrix
/// otherwise.
pub(super) fn prepare_mass(
    setup: &Setup,
    plan: &StepPlan,
    choice: &MassOptions,
    ops: &Operators,
    each: &[Operators; 2],
    p: &Particles,
    mass: &mut GridMass,
) -> Result<()> {
    let (slip, workers) = (&setup.prescribed.slip, &setup.workers);
    let constraints = &setup.prescribed.constraints;
    // (The whole span: skipping the columns outside p2g's ran no faster.)
    let span = massive_span(setup, ops, None);
    if slip.is_empty() || lumped_only(plan) {
        return mass.prepare_with(ops, &p.mass, choice, constraints, span, workers);
    }
    let [x, y] = each;
    mass.prepare_components([x, y], &p.mass, choice, constraints, span, workers)
}

/// (6)–(8b) and XPIC/FMPM's series velocity (USF: the stress update after (6)); the
/// reports of the velocity and acceleration solves.
fn grid_phases(input: StepInput, out: StepOutput, dt: f64) -> Result<[SolveReport; 2]> {
    let StepInput { setup, options, plan } = input;
    let (state, Cache { ops, mass, nodes, .. }, scratch, profile) = out.into_parts();
    let series = plan.series;
    let prescribed = &setup.prescribed;
    if plan.lumped_grid_pass {
        let (inverse, gravity, active) = (mass.inverse_lumped(), plan.gravity, mass.is_active());
        timed(profile, Phase::LumpedGrid, || {
            let workers = &setup.workers;
            kernels::update_lumped_grid(nodes, inverse, active, gravity, dt, prescribed, workers)
        }); // (6)–(8)
        timed(profile, Phase::Extend, || {
            if !mass.supports_all_active(ops)
                && extend(ops, prescribed, active, &mut nodes.updated, &mut scratch.extension)
            {
                // The w the grid-to-particle pass reads follows.
                nodes.refresh_lumped_w();
            }
        }); // (8b)
        return Ok([
            mass.lumped_report(Role::Velocity),
            mass.lumped_report(Role::Acceleration),
        ]);
    }
    let velocity_solve = timed(profile, Phase::Project, || {
        project_velocity(setup, ops, mass, &nodes.momentum, &mut nodes.projected)
    })?; // (6)
    walls::unfold(&prescribed.slip, &setup.grid, &mut [&mut nodes.projected]);
    if plan.stress_first {
        timed(profile, Phase::StressFirst, || {
            let m = &state.particles.mass;
            stress_gradient(setup, ops, mass, m, series, nodes, scratch);
            update_stress(setup, state, scratch, dt)?;
            let p = &state.particles;
            kernels::add_internal_force(ops, &p.volume, &p.sxx, &p.syy, &p.sxy, &mut nodes.force);
            walls::fold(&prescribed.slip, &setup.grid, &mut nodes.force);
            Ok::<_, MpmError>(())
        })?; // USF: (11)–(13), (5)
    }
    if let Some(damping) = options.damping {
        // Dynamic relaxation: the force damped against the projected velocity.
        let power = damping.apply(&mut nodes.force, &nodes.projected, mass.lumped(), mass.is_active());
        state.relaxation.damping_work -= dt * power;
    }
    let acceleration_solve = timed(profile, Phase::Accelerate, || {
        solve_acceleration(prescribed, ops, mass, &nodes.force, &mut nodes.acceleration)
    })?; // (7)
    walls::unfold(&prescribed.slip, &setup.grid, &mut [&mut nodes.acceleration]);
    let (v, a) = (&nodes.projected, &nodes.acceleration);
    timed(profile, Phase::GridVelocity, || {
        update_grid_velocity(prescribed, mass.is_active(), v, a, dt, &mut nodes.updated)
    }); // (8)
        // The next projection is w but for the particles' motion (FLIP: N m (v_p + Nᵀ(w − v)) =
        // M w at fixed operators; PIC and APIC alike): its conjugate gradient starts there.
    mass.set_velocity_warm_start(&nodes.updated);
    let active = mass.is_active();
    timed(profile, Phase::Extend, || {
        extend(ops, prescribed, active, &mut nodes.updated, &mut scratch.extension)
    }); // (8b)
    if let Some(series) = series {
        timed(profile, Phase::Series, || {
            series_velocity(series, setup, ops, mass, &state.particles, nodes, scratch)
        }); // XPIC, FMPM
    }
    Ok([velocity_solve, acceleration_solve])
}

/// (9)–(13): the grid-to-particle pass, the stress update of USL and MUSL, the positions.
/// USL updates the stress in the pass itself, and USL and USF move the particles there (and
/// sum them for the report), from the same per-particle code as the passes of their own.
pub(super) fn particle_phases(input: StepInput, out: StepOutput, dt: f64) -> Result<()> {
    let StepInput { setup, options, plan } = input;
    let (state, cache, scratch, profile) = out.into_parts();
    let Cache {
        ops,
        mass,
        nodes,
        layers,
        zero_body_force,
        ..
    } = cache;
    let p = &state.particles;
    // (+0 exactly: a −0 would give other zeros' signs than the zeros standing in for it.)
    let zero_body_force = *zero_body_force.get_or_insert_with(|| p.bx.iter().chain(&p.by).all(|b| b.to_bits() == 0));
    let (series, stress_last) = (plan.series, plan.stress_last);
    let rule = G2pRule {
        transfer: plan.transfer,
        position: options.position_update,
        inertia: ApicInertia::of(options.shape, &setup.grid),
        gradient: plan.motion.or_else(|| {
            (stress_last == Some(StressFrom::Updated)).then(|| SeriesTransfer::stress_field(series, GridField::Updated))
        }),
        motion: plan.motion,
    };
    // Elastoplastic bodies take the update that carries their state, after the pass.
    let plastic = setup.is_plastic();
    let fused = Fused {
        stress: (stress_last == Some(StressFrom::Updated) && !plastic).then_some(&setup.materials[..]),
        moves: (stress_last != Some(StressFrom::Reprojected)).then_some(plan.gravity),
        zero_body_force,
    };
    let next = super::fused::next_terms(input, state.steps, ops, &fused);
    let (p, workers) = (&mut state.particles, &setup.workers);
    let mut blocks = std::mem::take(&mut scratch.g2p_blocks);
    let mut packed = std::mem::take(&mut scratch.packed);
    let by_grid_pass = plan.lumped_grid_pass;
    timed(profile, Phase::G2p, || {
        let Some(terms) = next else { return };
        let (packed, particle) = (&mut packed, &mut scratch.particle);
        let pass = super::fused::FusedPass {
            rule: &rule,
            fused: &fused,
            by_grid_pass,
            dt,
            terms,
        };
        pass.run(setup, options, ops, nodes, p, particle, packed, &mut blocks);
    }); // (9)–(13) and the next step's (1)–(5)
    timed(profile, Phase::G2p, || {
        if next.is_some() {
            return;
        }
        // The lumped grid pass left [w, v] in p2g's accumulator; otherwise pack them.
        let velocities = if by_grid_pass {
            nodes.lumped_velocities()
        } else if setup.contact.is_some() {
            let layer = super::contact::pack(ops, layers, &rule, &mut packed);
            kernels::Packed {
                values: &packed,
                stride: rule.packed_width(),
                layer,
            }
        } else {
            kernels::pack_velocities(ops, nodes, &rule, &mut packed);
            kernels::Packed {
                values: &packed,
                stride: rule.packed_width(),
                layer: 0,
            }
        };
        kernels::g2p_packed(
            ops,
            velocities,
            &rule,
            dt,
            &fused,
            p,
            &mut scratch.particle,
            workers,
            &mut blocks,
        )
    }); // (9)–(11), USL: (12)–(13), USL and USF: (9)
    scratch.packed = packed;
    scratch.particle.kinetic = kernels::KineticEnergies::total(&blocks);
    scratch.sums = fused.moves.map(|_| ParticleSums::total(blocks.iter().map(|b| b.sums)));
    if fused.stress.is_some() {
        let stress = StressSums::total(blocks.iter().map(|b| b.stress));
        scratch.g2p_blocks = blocks;
        keep_stress(&setup.bodies, state, stress)?;
    } else {
        scratch.g2p_blocks = blocks;
    }
    if stress_last == Some(StressFrom::Updated) && plastic {
        timed(profile, Phase::Stress, || update_stress(setup, state, scratch, dt))?;
        // (12)–(13)
    }
    if stress_last == Some(StressFrom::Reprojected) && setup.contact.is_some() {
        timed(profile, Phase::Stress, || {
            super::contact::reproject_and_update_stress(setup, plan, state, ops, layers, scratch, dt)
        })?; // (11)–(13)
        timed(profile, Phase::Move, || {
            move_particles(&scratch.particle.displacement, &mut state.particles)
        }); // (9)
    } else if stress_last == Some(StressFrom::Reprojected) {
        timed(profile, Phase::Stress, || {
            kernels::reproject_momentum(ops, &state.particles, plan.apic, nodes, workers); // (11)
            walls::fold(&setup.prescribed.slip, &setup.grid, &mut nodes.momentum);
            project_velocity(setup, ops, mass, &nodes.momentum, &mut nodes.projected)?;
            let m = &state.particles.mass;
            stress_gradient(setup, ops, mass, m, series, nodes, scratch);
            update_stress(setup, state, scratch, dt)
        })?; // (11)–(13)
        timed(profile, Phase::Move, || {
            move_particles(&scratch.particle.displacement, &mut state.particles)
        }); // (9)
    }
    Ok(())
}

/// The end of a step: time and step count advanced, the report, what the state keeps of it.
pub(super) fn finish_step(
    input: StepInput,
    out: StepOutput,
    dt: f64,
    stable: f64,
    solves: [SolveReport; 2],
) -> Result<StepReport> {
    let StepInput { setup, options, plan } = input;
    let (state, cache, scratch, profile) = out.into_parts();
    state.time += dt;
    state.steps += 1;
    let mut report = timed(profile, Phase::Report, || {
        let taken = StepTaken {
            dt,
            stable_time_step: stable,
            solves,
            gravity: plan.gravity,
        };
        super::report::report(setup, state, cache, scratch, taken)
    })?;
    state.keep(&report, &scratch.particle.kinetic);
    if let Some(damping) = options.damping {
        // The kinetic energy of the motion that moves the particles, ½ Σ m_p |Nᵀw|²: FLIP
        // keeps particle velocities the grid does not see, which no grid force reaches, and a
        // consistent mass may hold a velocity at fringe nodes that no particle follows.
        let kinetic = report.grid_kinetic_energy_consistent;
        let peak = &mut state.relaxation.peak_kinetic;
        *peak = peak.max(kinetic);
        report.settled = *peak > 0.0 && kinetic <= damping.settled * *peak;
    }
    stability::travel(state, dt, setup.grid.cell_size());
    report.transfer_loss = state.transfer_loss;
    if let Some(p) = profile {
        p.count_step();
    }
    Ok(report)
}

impl State {
    /// What the state keeps of the step just reported: the largest speed (the next stable step
    /// reads it) and the kinetic energy the transfers back to the particles lost.
    fn keep(&mut self, report: &StepReport, k: &kernels::KineticEnergies) {
        self.speeds.particle = report.max_speed;
        self.transfer_loss += k.before + (k.updated - k.projected) - report.kinetic_energy;
    }
}

/// XPIC(k), FMPM(k): the series velocity `v*` into the series field, extended to the massless
/// support nodes (8b).
fn series_velocity(
    series: SeriesTransfer,
    setup: &Setup,
    ops: &Operators,
    mass: &GridMass,
    p: &Particles,
    nodes: &mut GridState,
    scratch: &mut Scratch,
) {
    let prescribed = &setup.prescribed;
    let (v, w, out) = (&nodes.projected, &nodes.updated, &mut nodes.series);
    with_series_operator(ops, &p.mass, mass, prescribed, |op| {
        series.particle_velocity(op, v, w, out, &mut scratch.series);
    });
    extend(
        ops,
        prescribed,
        mass.is_active(),
        &mut nodes.series,
        &mut scratch.extension,
    );
}

/// (6) `v = Π M_v⁻¹ q`.
pub(super) fn project_velocity(
    setup: &Setup,
    ops: &Operators,
    mass: &mut GridMass,
    q: &VectorField,
    v: &mut VectorField,
) -> Result<SolveReport> {
    let prescribed = setup
        .prescribed_velocity
        .get_or_init(|| super::build::prescribed_velocity_field(&setup.prescribed, setup.grid.num_nodes()));
    let report = mass.solve_warm_into(Role::Velocity, q, Some(prescribed), ops, v)?;
    setup.prescribed.apply_velocity(&mut v.x, &mut v.y);
    Ok(report)
}

/// (7) `a = Π₀ M_a⁻¹ f`.
pub(super) fn solve_acceleration(
    prescribed: &Prescribed,
    ops: &Operators,
    mass: &mut GridMass,
    f: &VectorField,
    a: &mut VectorField,
) -> Result<SolveReport> {
    let report = mass.solve_warm_into(Role::Acceleration, f, None, ops, a)?;
    prescribed.zero(&mut a.x, &mut a.y);
    Ok(report)
}

/// (8) `w = Π (v + Δt a)` on active nodes, 0 elsewhere.
pub(super) fn update_grid_velocity(
    prescribed: &Prescribed,
    is_active: &[bool],
    v: &VectorField,
    a: &VectorField,
    dt: f64,
    w: &mut VectorField,
) {
    for i in 0..is_active.len() {
        let s = if is_active[i] { 1.0 } else { 0.0 };
        w.x[i] = s * (v.x[i] + dt * a.x[i]);
        w.y[i] = s * (v.y[i] + dt * a.y[i]);
    }
    prescribed.apply_velocity(&mut w.x, &mut w.y);
}

/// (8b) in the grid velocity `u`; prescribed components keep their values. Whether any node
/// changed.
pub(super) fn extend(
    ops: &Operators,
    prescribed: &Prescribed,
    is_active: &[bool],
    u: &mut VectorField,
    scratch: &mut ExtensionScratch,
) -> bool {
    let changed = extend_to_inactive_nodes(ops, is_active, u, scratch);
    if changed {
        prescribed.apply_velocity(&mut u.x, &mut u.y);
    }
    // The ghosts of slip walls take their mirrors' values (simulation/walls.rs).
    if let Some(grid) = ops.grid().filter(|_| !prescribed.slip.is_empty()) {
        walls::unfold(&prescribed.slip, grid, &mut [u]);
    }
    changed
}

/// (11) `L = [Gxᵀ u, Gyᵀ u]` into the particle scratch, for the grid velocity the stress update
/// of USF reads: the projected velocity (6) itself, or under FMPM(k) its series (into the
/// series field); extended to the massless support nodes first (8b). Returns the field read.
fn stress_gradient(
    setup: &Setup,
    ops: &Operators,
    mass: &GridMass,
    m: &[f64],
    series: Option<SeriesTransfer>,
    nodes: &mut GridState,
    scratch: &mut Scratch,
) -> GridField {
    let field = GridField::Projected;
    let prescribed = &setup.prescribed;
    let read = SeriesTransfer::stress_field(series, field);
    if let Some(k) = series.and_then(SeriesTransfer::stress_terms) {
        let (u, out) = nodes.source_and_series(field);
        with_series_operator(ops, m, mass, prescribed, |op| {
            series_velocity_into(op, k, u, out, &mut scratch.series);
        });
    }
    extend(
        ops,
        prescribed,
        mass.is_active(),
        nodes.field_mut(read),
        &mut scratch.extension,
    );
    kernels::velocity_gradient_into(
        ops,
        nodes.field(read),
        &mut scratch.particle.velocity_gradient,
        &setup.workers,
    );
    read
}

/// (9) `x_p ← x_p + Δx_p` with the increments of the grid-to-particle pass.
fn move_particles(d: &VectorField, p: &mut Particles) {
    for k in 0..p.len() {
        p.x[k] += d.x[k];
        p.y[k] += d.y[k];
    }
}

/// (12) `F ← (I + Δt L) F`, `σ ← material(σ, L, F)`; (13) `V ← V det(I + Δt L)`, with the
/// velocity gradient `L` of the particle scratch; the strain energy and the wave speed into
/// `state`.
pub(super) fn update_stress(setup: &Setup, state: &mut State, scratch: &mut Scratch, dt: f64) -> Result<()> {
    if setup.is_plastic() {
        return super::plastic::update_stress(setup, state, scratch, dt);
    }
    let (l, blocks) = (&scratch.particle.velocity_gradient, &mut scratch.stress_blocks);
    let p = &mut state.particles;
    let input = StressInput {
        materials: &setup.materials[..],
        body: &p.body[..],
        mass: &p.mass[..],
        dt,
    };
    let out = StressOutput {
        f: [&mut p.fxx[..], &mut p.fxy[..], &mut p.fyx[..], &mut p.fyy[..]],
        sigma: [&mut p.sxx[..], &mut p.syy[..], &mut p.sxy[..]],
        volume: &mut p.volume[..],
    };
    setup.workers.split_blocks(out, blocks, |first, mut out| {
        let mut sums = StressPartials::default();
        for j in 0..out.volume.len() {
            let k = first + j;
            let l = [l[0][k], l[1][k], l[2][k], l[3][k]];
            kernels::update_stress::<f64>(&input, l, k, j, &mut out, &mut sums);
        }
        sums
    });
    let stress = StressSums::total(blocks.iter().copied());
    keep_stress(&setup.bodies, state, stress)
}

/// What the state keeps of a stress update: its strain energy and wave speed; the error of
/// the first particle it inverted.
pub(super) fn keep_stress(bodies: &[Body], state: &mut State, stress: StressSums) -> Result<()> {
    if let Some((k, det_increment, det_f)) = stress.inverted {
        return Err(inversion(bodies, state, k, det_increment, det_f));
    }
    state.strain_energy = stress.energy;
    // max √x = √(max x): one square root instead of one per particle.
    state.speeds.wave = stability::wave_speed(stress.wave_squared, 1.0, 1.0);
    Ok(())
}

/// The error of particle `k` inverted at this step.
fn inversion(bodies: &[Body], state: &State, k: usize, det_increment: f64, det_f: f64) -> MpmError {
    let p = &state.particles;
    MpmError::InvertedParticle {
        step: state.steps,
        particle: k,
        id: p.id[k],
        body: bodies[p.body[k]].name.clone(),
        det_increment,
        det_f,
    }
}
