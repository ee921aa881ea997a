//! Contact in the explicit step ([`crate::contact`]): one grid field per body, from the
//! operators restricted to its particles, `N_b = N diag(1_b)`, and the bodies' fields corrected
//! where they meet.
//!
//! A body's fields are the step's own kernels run with the other bodies' particles weightless:
//! the particles' mass and volume are swapped for `1_b ∘ m` and `1_b ∘ V` for the time of the
//! call ([`with_body`]), so that `p2g` gives `m_b`, `q_b`, `f_b`, the grid mass gives `M_b`,
//! and the internal force `G_b (V σ)`, each with the same operations as without contact. The
//! grid-to-particle pass and the velocity gradient read each particle's own body's field.

mod correct;
mod solve;

use super::phases::{extend, project_velocity, solve_acceleration, update_grid_velocity, update_stress};
use super::plan::StepPlan;
use super::stability::{estimate_by, Estimator, Stability, Tracking};
use super::walls;
use super::{Cache, Options, Scratch, Setup, State};
use crate::boundary::FrictionWall;
use crate::contact::{Contact, Separation};
use crate::error::Result;
use crate::fields::VectorField;
use crate::grid::Grid;
use crate::kernels::{self, GridState, P2gTerms, Stress};
use crate::mass::{GridMass, MassOptions, SolveOutcome, SolveReport};
use crate::operators::{Operator, Operators};
use crate::particles::Particles;
use crate::shape::ShapeFunction;
use correct::{Context, Decide, Stage, Tally, Touching};

/// One body's grid: its mass (lumped, and the scheme's), its fields, and its volume gradient
/// `g_b = G_b V`.
#[derive(Debug)]
pub(super) struct Layer {
    pub(super) mass: GridMass,
    pub(super) nodes: GridState,
    gradient: VectorField,
    /// `x̄_b = N_b (m ∘ x) / N_b m`, the mass centre of the body's particles as each node sees
    /// them (the separation test).
    centre: VectorField,
    /// `N_b m` unfolded (the centre's weights).
    weight: Vec<f64>,
}

impl Layer {
    fn new(grid: &Grid) -> Layer {
        Layer {
            mass: GridMass::default(),
            nodes: GridState::new(grid),
            gradient: VectorField::zeros(grid.num_nodes()),
            centre: VectorField::zeros(grid.num_nodes()),
            weight: vec![0.0; grid.num_nodes()],
        }
    }
}

/// The bodies' grids, and what the contact did in the last step.
#[derive(Debug, Default)]
pub(super) struct Layers {
    pub(super) bodies: Vec<Layer>,
    /// `1_b ∘ m` and `1_b ∘ V` of the body in hand ([`with_body`]).
    masks: [Vec<f64>; 2],
    /// The normal contact force of the last step: the force stage's normal impulses over `Δt`,
    /// summed over the corrected pairs and nodes.
    pub(super) force: f64,
    /// The pairs the momentum stage and the force stage found in contact at each node.
    touching: [Vec<Touching>; 2],
}

/// Runs `f` on the particles with every body but `b` weightless (mass and volume 0), so that
/// every product with `N`, `Gx`, `Gy` is one with `N_b`, `G_b`; the particles are as they were
/// afterwards.
fn with_body<T>(p: &mut Particles, b: usize, masks: &mut [Vec<f64>; 2], f: impl FnOnce(&Particles) -> T) -> T {
    mask(p, b, masks);
    let out = f(p);
    unmask(p, masks);
    out
}

/// [`with_body`] on the whole state.
fn with_body_mut<T>(state: &mut State, b: usize, masks: &mut [Vec<f64>; 2], f: impl FnOnce(&State) -> T) -> T {
    mask(&mut state.particles, b, masks);
    let out = f(state);
    unmask(&mut state.particles, masks);
    out
}

/// `m ← 1_b ∘ m`, `V ← 1_b ∘ V`, the particles' own arrays kept in `masks`.
fn mask(p: &mut Particles, b: usize, masks: &mut [Vec<f64>; 2]) {
    let [m, v] = masks;
    let own = |k: usize, x: f64| if p.body[k] == b { x } else { 0.0 };
    m.clear();
    m.extend(p.mass.iter().enumerate().map(|(k, &x)| own(k, x)));
    v.clear();
    v.extend(p.volume.iter().enumerate().map(|(k, &x)| own(k, x)));
    std::mem::swap(&mut p.mass, m);
    std::mem::swap(&mut p.volume, v);
}

/// The particles' own mass and volume back from `masks` ([`mask`]).
fn unmask(p: &mut Particles, masks: &mut [Vec<f64>; 2]) {
    let [m, v] = masks;
    std::mem::swap(&mut p.mass, m);
    std::mem::swap(&mut p.volume, v);
}

/// (2)–(5) and the grid mass of every body, after the operators' assembly.
pub(super) fn prepare_layers(setup: &Setup, plan: &StepPlan, state: &mut State, cache: &mut Cache) -> Result<()> {
    let (grid, workers) = (&setup.grid, &setup.workers);
    let (mirror, slip) = (&setup.prescribed.mirror, &setup.prescribed.slip);
    let Cache {
        ops,
        layers,
        component_ops,
        ..
    } = cache;
    let Layers { bodies, masks, .. } = layers;
    bodies.resize_with(setup.bodies.len(), || Layer::new(grid));
    // Each body's own mass, stabilised as the contact options say.
    let contact = setup.contact.as_ref().expect("contact phases run with contact");
    let own = MassOptions {
        stabilization: contact.stabilization,
        ..plan.mass
    };
    let terms = P2gTerms {
        apic: plan.apic,
        gravity: plan.gravity,
        stress: if plan.stress_first {
            Stress::Omit
        } else {
            Stress::Include
        },
    };
    for (b, layer) in bodies.iter_mut().enumerate() {
        with_body(&mut state.particles, b, masks, |p| {
            let Layer {
                mass,
                nodes,
                gradient,
                centre,
                weight,
            } = layer;
            mass.lumped_mut().resize(ops.num_nodes(), 0.0);
            let writes = kernels::NodeWrites {
                fields: true,
                boxed: false,
            };
            kernels::p2g_with(ops, p, terms, mass.lumped_mut(), nodes, workers, writes);
            mirror.fold_lumped(grid, p, ops, mass.lumped_mut());
            walls::fold_lumped(slip, grid, mass.lumped_mut());
            walls::fold(slip, grid, &mut nodes.momentum);
            walls::fold(slip, grid, &mut nodes.force);
            ops.scatter(Operator::Gx, [&p.volume], [&mut gradient.x]);
            ops.scatter(Operator::Gy, [&p.volume], [&mut gradient.y]);
            ops.scatter(Operator::N, [&p.mass], [&mut weight[..]]);
            ops.scatter_scaled(Operator::N, Some(&p.mass), [&p.x, &p.y], [&mut centre.x, &mut centre.y]);
            for i in ops.node_span() {
                if weight[i] > 0.0 {
                    centre.x[i] /= weight[i];
                    centre.y[i] /= weight[i];
                }
            }
            super::phases::prepare_mass(setup, plan, &own, ops, component_ops, p, mass)
        })?;
    }
    Ok(())
}

/// The share of a body's own stable step below which it replaces the shared field's
/// ([`bound_by_bodies`]).
const OWN_STEP_SHARE: f64 = 0.9;

/// The stable step of the shared field's estimate `shared`, or of one body's own grid where
/// that is below [`OWN_STEP_SHARE`] of it: a body much lighter or stiffer than the bodies it
/// shares nodes with, whose mass the shared field's hides (one disk with a density of 1e-9
/// inverted in its first step). Each body's estimate is the shared one's, made with its own
/// grid mass and its particles alone; the shared estimate is kept otherwise, so that bodies
/// apart run as without contact.
pub(super) fn bound_by_bodies(
    setup: &Setup,
    options: &Options,
    state: &mut State,
    cache: &mut Cache,
    tracking: &mut Tracking,
    shared: Stability,
) -> Result<Stability> {
    let contact = setup.contact.as_ref().expect("contact phases run with contact");
    let mut out = shared;
    let mut layers = std::mem::take(&mut cache.layers);
    let mut result = Ok(());
    for (b, layer) in layers.bodies.iter_mut().enumerate() {
        if contact.rigid_velocity(b).is_some() {
            continue;
        }
        std::mem::swap(&mut cache.mass, &mut layer.mass);
        let own = with_body_mut(state, b, &mut layers.masks, |state| {
            estimate_by(setup, options, state, cache, Estimator::Cheapest, tracking)
        });
        std::mem::swap(&mut cache.mass, &mut layer.mass);
        match own {
            Ok(own) if own.wave_step < OWN_STEP_SHARE * out.wave_step => out = own,
            Ok(_) => {}
            Err(e) => {
                result = Err(e);
                break;
            }
        }
    }
    cache.layers = layers;
    result.map(|()| out)
}

/// (6)–(8b) of every body, with the contact corrections of the momentum stage (after (6)) and
/// of the force stage (after (8)); USF's stress update between. The centre-of-mass velocities
/// go into the shared fields (what the report and [`Simulation::grid_velocity`] read).
///
/// [`Simulation::grid_velocity`]: super::Simulation::grid_velocity
pub(super) fn grid_phases(
    setup: &Setup,
    options: &Options,
    state: &mut State,
    cache: &mut Cache,
    scratch: &mut Scratch,
    dt: f64,
) -> Result<[SolveReport; 2]> {
    let contact = setup.contact.as_ref().expect("contact phases run with contact");
    let (grid, prescribed) = (&setup.grid, &setup.prescribed);
    let Cache { ops, layers, nodes, .. } = cache;
    let Layers {
        bodies,
        force,
        touching,
        ..
    } = layers;
    let mut solves = [Vec::new(), Vec::new()];
    for layer in bodies.iter_mut() {
        let (mass, fields) = (&mut layer.mass, &mut layer.nodes);
        solves[0].push(project_velocity(
            setup,
            ops,
            mass,
            &fields.momentum,
            &mut fields.projected,
        )?);
        walls::unfold(&prescribed.slip, grid, &mut [&mut fields.projected]);
    }
    // The momentum stage, in place (as NairnMPM does): FLIP's increment Nᵀ(w − v) carries
    // the force stage's correction; the momentum stage's reaches the positions and the strain.
    let [momentum_stage, force_stage] = touching;
    let decide = Decide::Approach(momentum_stage);
    correct_stage(contact, setup, ops, bodies, Stage::Momentum, decide)?.add_to(state);
    for layer in bodies.iter_mut() {
        let (mass, fields) = (&mut layer.mass, &mut layer.nodes);
        // The mirrored node lines beyond a slip wall take the corrected interior's image, as the
        // updated field does in (8b): a ghost left as it was gives FLIP an increment w − v there
        // that the interior never had (at a corner of a mirrored wall and a wall with friction
        // it fed a particle's velocity into the floor, step after step).
        walls::unfold(&prescribed.slip, grid, &mut [&mut fields.projected]);
        if let Some(damping) = options.damping {
            let power = damping.apply(&mut fields.force, &fields.projected, mass.lumped(), mass.is_active());
            state.relaxation.damping_work -= dt * power;
        }
        solves[1].push(solve_acceleration(
            prescribed,
            ops,
            mass,
            &fields.force,
            &mut fields.acceleration,
        )?);
        walls::unfold(&prescribed.slip, grid, &mut [&mut fields.acceleration]);
        let (v, a) = (&fields.projected, &fields.acceleration);
        update_grid_velocity(prescribed, mass.is_active(), v, a, dt, &mut fields.updated);
    }
    let decide = Decide::Approach(force_stage);
    let stage = correct_stage(contact, setup, ops, bodies, Stage::Force, decide)?;
    stage.add_to(state);
    *force = stage.normal_impulse / dt;
    for layer in bodies.iter_mut() {
        layer.mass.set_velocity_warm_start(&layer.nodes.updated);
    }
    extend_each(ops, prescribed, bodies, |n| &mut n.updated, scratch);
    centre_of_mass(bodies, nodes);
    Ok(solves.map(|s| combined(&s)))
}

/// MUSL's (11)–(13) with one field per body: each body's momentum re-projected from its
/// particles' new velocities, corrected where the bodies meet, and each particle strained by
/// its own body's velocity.
#[allow(clippy::too_many_arguments)]
pub(super) fn reproject_and_update_stress(
    setup: &Setup,
    plan: &StepPlan,
    state: &mut State,
    ops: &Operators,
    layers: &mut Layers,
    scratch: &mut Scratch,
    dt: f64,
) -> Result<()> {
    let contact = setup.contact.as_ref().expect("contact phases run with contact");
    let (grid, prescribed, workers) = (&setup.grid, &setup.prescribed, &setup.workers);
    let Layers {
        bodies,
        masks,
        touching,
        ..
    } = layers;
    for (b, layer) in bodies.iter_mut().enumerate() {
        let (mass, fields) = (&mut layer.mass, &mut layer.nodes);
        with_body(&mut state.particles, b, masks, |p| {
            kernels::reproject_momentum(ops, p, plan.apic, fields, workers); // (11)
        });
        walls::fold(&prescribed.slip, grid, &mut fields.momentum);
        project_velocity(setup, ops, mass, &fields.momentum, &mut fields.projected)?;
        walls::unfold(&prescribed.slip, grid, &mut [&mut fields.projected]);
    }
    // Where the force stage found contact (the particles moved with those corrections); the
    // particles' velocities are not changed here, so what this removes is not counted.
    let decide = Decide::Known(&touching[1]);
    correct_stage(contact, setup, ops, bodies, Stage::Strain, decide)?;
    extend_each(ops, prescribed, bodies, |n| &mut n.projected, scratch);
    layered_gradient(setup, ops, bodies, &state.particles, |n| &n.projected, scratch);
    update_stress(setup, state, scratch, dt)
}

/// (8b) in the field `field` of every body, each with its own active set.
fn extend_each(
    ops: &Operators,
    prescribed: &crate::boundary::Prescribed,
    bodies: &mut [Layer],
    field: impl Fn(&mut GridState) -> &mut VectorField,
    scratch: &mut Scratch,
) {
    for layer in bodies.iter_mut() {
        let active = layer.mass.is_active();
        extend(ops, prescribed, active, field(&mut layer.nodes), &mut scratch.extension);
    }
}

/// The packed velocities of every body for the grid-to-particle pass, and the values per body.
pub(super) fn pack(ops: &Operators, cache_layers: &Layers, rule: &kernels::G2pRule, packed: &mut Vec<f64>) -> usize {
    let grids: Vec<&GridState> = cache_layers.bodies.iter().map(|l| &l.nodes).collect();
    kernels::pack_layers(ops, &grids, rule, packed)
}

/// `L_p = [Gxᵀ u_b, Gyᵀ u_b]_p` with `u_b` the field `field` of particle `p`'s body, into the
/// particle scratch.
fn layered_gradient(
    setup: &Setup,
    ops: &Operators,
    bodies: &[Layer],
    p: &Particles,
    field: impl Fn(&GridState) -> &VectorField,
    scratch: &mut Scratch,
) {
    let fields: Vec<&VectorField> = bodies.iter().map(|l| field(&l.nodes)).collect();
    let l = &mut scratch.particle.velocity_gradient;
    kernels::velocity_gradient_layered(ops, &fields, &p.body, l, &setup.workers);
}

/// The nodes whose kernel support crosses the line of `wall` (those a body there meets it at),
/// the wall's own line and the lines beyond it included, line by line, over the wall's range
/// along it; with each, the
/// coordinate along the wall's axis of the mass centre of the half-space beyond the wall as the
/// node sees it (the wall's `x̄` in the separation test, [`crate::contact::Separation`]).
pub(super) fn wall_nodes(grid: &Grid, shape: ShapeFunction, wall: &FrictionWall) -> Vec<(usize, f64)> {
    let counts = grid.nodes_per_axis();
    let (h, origin) = (grid.cell_size()[wall.axis], grid.origin()[wall.axis]);
    let reach = shape.support() as f64 / 2.0;
    // Node lines within `reach` cells of the wall, on both sides (strictly inside the reach).
    let centre = (wall.at - origin) / h;
    let first = (centre - reach).floor().max(0.0) as usize;
    let last = ((centre + reach).ceil() as usize).min(counts[wall.axis] - 1);
    let mut out = Vec::new();
    for j in (first..=last).filter(|&j| ((j as f64) - centre).abs() < reach) {
        // The node's offset from the wall into the domain, in cells; the half-space beyond the
        // wall is the kernel's part from `−reach` to `−inside` (inward coordinate).
        let inside = (centre - j as f64) * wall.outward;
        let (weight, moment) = kernel_moments(shape, -reach, -inside);
        let node_at = origin + j as f64 * h;
        // Inward coordinate `s` is `−outward` along the axis.
        let wall_centre = node_at - wall.outward * h * moment / weight.max(f64::MIN_POSITIVE);
        let (along_origin, along_h) = (grid.origin()[1 - wall.axis], grid.cell_size()[1 - wall.axis]);
        let in_range = |k: usize| {
            wall.range.is_none_or(|[from, to]| {
                let c = along_origin + k as f64 * along_h;
                let tol = 1e-9 * along_h;
                c >= from - tol && c <= to + tol
            })
        };
        for k in (0..counts[1 - wall.axis]).filter(|&k| in_range(k)) {
            let node = if wall.axis == 0 {
                grid.node_index(j, k)
            } else {
                grid.node_index(k, j)
            };
            out.push((node, wall_centre));
        }
    }
    out
}

/// `(∫ N(s) ds, ∫ s N(s) ds)` over `s` in `[from, to]` (in cells from the node), `N` the 1D
/// kernel of `shape`, by the midpoint rule on 4096 points per cell.
pub(super) fn kernel_moments(shape: ShapeFunction, from: f64, to: f64) -> (f64, f64) {
    const CELLS: usize = 16;
    let Ok(grid) = Grid::new([0.0, 0.0], [1.0, 1.0], [CELLS, CELLS]) else {
        return (0.0, 0.0);
    };
    let node = CELLS / 2;
    let steps = ((to - from).max(0.0) * 4096.0).ceil() as usize;
    let ds = (to - from) / steps.max(1) as f64;
    let (mut w, mut m) = (0.0, 0.0);
    for k in 0..steps {
        let s = from + (k as f64 + 0.5) * ds;
        let Some(a) = shape.axis_weights(&grid, 0, node as f64 + s) else {
            continue;
        };
        if let Some(value) = (node.checked_sub(a.first)).filter(|&i| i < a.len).map(|i| a.value[i]) {
            w += value * ds;
            m += s * value * ds;
        }
    }
    (w, m)
}

/// The separation cutoff `c` of `contact` with `shape` ([`crate::contact::Separation`]), in
/// cells (infinite without the test).
pub(super) fn separation_cutoff(contact: &Contact, shape: ShapeFunction) -> f64 {
    match contact.separation {
        Separation::Off => f64::INFINITY,
        Separation::Cutoff(c) => c,
        Separation::Kernel => {
            let reach = shape.support() as f64 / 2.0;
            let (w, m) = kernel_moments(shape, 0.0, reach);
            1.2 * 2.0 * m / w
        }
    }
}

/// The contact corrections of `stage` of the pairs `decide` selects: node by node where every
/// body's mass of the stage's solve is lumped ([`correct::correct`]), through the bodies'
/// masses otherwise ([`solve::correct_through_mass`]).
fn correct_stage(
    contact: &Contact,
    setup: &Setup,
    ops: &Operators,
    bodies: &mut [Layer],
    stage: Stage,
    decide: Decide,
) -> Result<Tally> {
    let rigid = (0..bodies.len()).map(|b| contact.rigid_velocity(b)).collect();
    let cx = Context {
        contact,
        setup,
        rigid,
        stage,
    };
    if bodies.iter().all(|l| l.mass.scheme(stage.role()).is_lumped()) {
        Ok(correct::correct(&cx, bodies, ops.node_span(), decide))
    } else {
        solve::correct_through_mass(&cx, ops, bodies, ops.node_span(), decide)
    }
}

/// The centre-of-mass velocities `Σ_b m_b u_b / Σ_b m_b` of the bodies' projected and updated
/// fields into the shared ones (a body's own where it is alone; body 0's where none has mass).
fn centre_of_mass(bodies: &[Layer], nodes: &mut GridState) {
    let n = nodes.updated.len();
    for (pick, out) in [
        (0, &mut nodes.projected as &mut VectorField),
        (1, &mut nodes.updated as &mut VectorField),
    ] {
        fn field(l: &Layer, pick: usize) -> &VectorField {
            if pick == 0 {
                &l.nodes.projected
            } else {
                &l.nodes.updated
            }
        }
        let field = |l| field(l, pick);
        for i in 0..n {
            let mut with_mass = bodies.iter().filter(|l| l.mass.lumped()[i] > 0.0);
            let (x, y) = match (with_mass.next(), with_mass.next()) {
                (Some(l), None) => (field(l).x[i], field(l).y[i]),
                (None, _) => (field(&bodies[0]).x[i], field(&bodies[0]).y[i]),
                (Some(_), Some(_)) => {
                    let (mut m, mut px, mut py) = (0.0, 0.0, 0.0);
                    for l in bodies {
                        let w = l.mass.lumped()[i];
                        m += w;
                        px += w * field(l).x[i];
                        py += w * field(l).y[i];
                    }
                    (px / m, py / m)
                }
            };
            out.x[i] = x;
            out.y[i] = y;
        }
    }
}

/// One report of the bodies' solves: their iterations summed, the largest residual, the first
/// outcome other than solved.
fn combined(reports: &[SolveReport]) -> SolveReport {
    let mut out = reports[0].clone();
    out.iterations = reports.iter().map(|r| r.iterations).sum();
    out.relative_residual = reports.iter().map(|r| r.relative_residual).fold(0.0, f64::max);
    out.outcome = reports
        .iter()
        .map(|r| r.outcome.clone())
        .find(|o| *o != SolveOutcome::Solved)
        .unwrap_or(SolveOutcome::Solved);
    out
}
