//! The one constructor of a [`Simulation`]: [`Simulation::new`] (time 0) and a checkpoint's
//! restore (a saved state) both go through [`Simulation::build`], which validates the parts,
//! resolves the boundary conditions, starts the workers and assembles the operators.

use super::plan::StepPlan;
use super::stability::Speeds;
use super::{Body, Cache, Options, Scratch, Setup, Simulation, State};
use crate::boundary::{self, Prescribed};
use crate::error::{MpmError, Result};
use crate::fields::VectorField;
use crate::grid::Grid;
use crate::kernels::GridState;
use crate::mass::GridMass;
use crate::operators::Operators;
use crate::parallel::Workers;
use crate::particles::Particles;

/// What a simulation continues from instead of time 0: a checkpoint's saved state.
pub(super) struct Resume {
    /// Each body's reference density (from the initial state, not recomputable).
    pub(super) density: Vec<f64>,
    /// Time, steps, failure, energies, speeds and stable-step estimate (particles aside).
    pub(super) state: State,
    /// `m_L` of the last step.
    pub(super) lumped: Vec<f64>,
    /// `w` of the last step.
    pub(super) updated: VectorField,
    /// The conjugate gradient's warm-start vectors.
    pub(super) warm_start: [Vec<f64>; 4],
    /// The top mode the stable-step guards track (empty, or two values per node).
    pub(super) frequency_mode: Vec<f64>,
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
    /// outside the region the shape function allows; [`MpmError::TimeStepAboveStable`] for a
    /// fixed step above the stable step.
    pub fn new(grid: Grid, particles: Particles, bodies: Vec<Body>, options: Options) -> Result<Simulation> {
        let mut sim = Simulation::build(grid, particles, bodies, options, None)?;
        sim.state.speeds = super::stability::Speeds {
            load: sim.state.speeds.load,
            wall: sim.state.speeds.wall,
            ..super::stability::measure_speeds(&sim.setup, &sim.state.particles)
        };
        // The stable step before the first step, so that a fixed step above it is refused now.
        let plan = StepPlan::of(&sim.setup, &sim.options, sim.state.time);
        let (input, out) = sim.split(&plan);
        super::phases::prepare_grid(input, out)?;
        super::stability::next_time_step(&sim.options, sim.state.steps, sim.stable_time_step())?;
        Ok(sim)
    }

    /// The simulation of these parts, at time 0 or resuming a saved state.
    ///
    /// # Errors
    /// As [`Simulation::new`] (the stable-step check aside), and
    /// [`MpmError::InvalidParameter`] for a saved state whose node fields or densities do not
    /// fit the grid and bodies.
    pub(super) fn build(
        grid: Grid,
        particles: Particles,
        bodies: Vec<Body>,
        options: Options,
        resume: Option<Resume>,
    ) -> Result<Simulation> {
        validate_parts(&particles, &bodies, &options)?;
        let prescribed = boundary::resolve(&grid, options.shape, &options.boundaries)?;
        let contact = effective_contact(&options, &prescribed, bodies.len())?;
        let workers = Workers::new(options.threads)?;
        let mut ops = Operators::default();
        ops.reassemble_with(&grid, options.shape, &particles.x, &particles.y, &workers)?;
        prescribed
            .mirror
            .fold(&grid, options.shape, &particles.x, &particles.y, &mut ops);
        let mut nodes = GridState::new(&grid);
        let mut mass = GridMass::default();
        // Zeroed pages: the time loop writes the particles' span only.
        *mass.lumped_mut() = vec![0.0; grid.num_nodes()];
        let mut frequency_mode = Vec::new();
        let (density, mut state) = match resume {
            None => {
                let mut particles = particles;
                let materials: Vec<_> = bodies.iter().map(|b| b.material.prepared()).collect();
                super::plastic::initial_state(&mut particles, &materials)?;
                (reference_densities(&particles, bodies.len()), State::start(particles))
            }
            Some(saved) => {
                check_saved(&saved, grid.num_nodes(), bodies.len())?;
                mass.set_lumped(saved.lumped);
                mass.set_warm_start(saved.warm_start);
                nodes.updated = saved.updated;
                frequency_mode = saved.frequency_mode;
                (
                    saved.density,
                    State {
                        particles,
                        ..saved.state
                    },
                )
            }
        };
        // Not saved in a checkpoint: they follow from the options and the particles.
        state.speeds.load = super::stability::largest_load(options.gravity, &state.particles);
        state.speeds.wall = super::stability::prescribed_speed(&prescribed);
        let wall_nodes = (prescribed.friction.iter())
            .map(|wall| super::contact::wall_nodes(&grid, options.shape, wall))
            .collect();
        let separation = contact
            .as_ref()
            .map_or(f64::INFINITY, |c| super::contact::separation_cutoff(c, options.shape));
        let setup = Setup {
            contact,
            wall_nodes,
            separation,
            materials: bodies.iter().map(|b| b.material.prepared()).collect(),
            prescribed_velocity: std::sync::OnceLock::new(),
            grid,
            bodies,
            density,
            prescribed,
            workers,
        };
        let mut scratch = Scratch::for_grid(&setup.grid);
        scratch.tracking.mode = frequency_mode;
        Ok(Simulation {
            scratch,
            setup,
            options,
            state,
            cache: Cache {
                ops,
                mass,
                nodes,
                component_ops: Default::default(),
                layers: Default::default(),
                zero_body_force: None,
            },
            profile: None,
        })
    }
}

impl State {
    /// The state at time 0 of `particles`.
    fn start(particles: Particles) -> State {
        State {
            particles,
            time: 0.0,
            steps: 0,
            failed: None,
            transfer_loss: 0.0,
            relaxation: Default::default(),
            strain_energy: 0.0,
            speeds: Speeds::default(),
            stability: None,
        }
    }
}

/// The contact the step makes: the options', or, for slip walls with friction, contact with no
/// pair of bodies (one body; the walls meet it through the contact correction).
///
/// # Errors
/// [`MpmError::InvalidOption`] (`boundaries`) for walls with friction in a simulation of several
/// bodies without contact (each body needs a field of its own), and the errors of
/// [`Options::validate`] for contact's schemes.
fn effective_contact(
    options: &Options,
    prescribed: &boundary::Prescribed,
    bodies: usize,
) -> Result<Option<crate::contact::Contact>> {
    if options.contact.is_some() || prescribed.friction.is_empty() {
        return Ok(options.contact.clone());
    }
    if bodies > 1 {
        let k = prescribed.friction[0].condition;
        return Err(MpmError::InvalidOption {
            option: "boundaries",
            reason: format!(
                "boundaries[{k}].friction with {bodies} bodies and no contact: a wall with friction meets each body \
                 in a velocity field of its own; add a [contact] table (friction = 0 between the bodies, say)"
            ),
        });
    }
    let contact = crate::contact::Contact::default();
    options.validate_contact_schemes()?;
    Ok(Some(contact))
}

/// The checks of every part before anything is built from them.
fn validate_parts(particles: &Particles, bodies: &[Body], options: &Options) -> Result<()> {
    particles.validate()?;
    options.validate()?;
    if let Some(contact) = &options.contact {
        contact.validate(bodies.len())?;
    }
    for body in bodies {
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
    Ok(())
}

/// A saved state's node fields and densities against the grid and the bodies.
fn check_saved(saved: &Resume, num_nodes: usize, num_bodies: usize) -> Result<()> {
    let fields = [
        ("lumped mass", saved.lumped.len()),
        ("grid velocity x", saved.updated.x.len()),
        ("grid velocity y", saved.updated.y.len()),
    ];
    let warm = saved
        .warm_start
        .iter()
        .map(|w| ("warm start", w.len()))
        .filter(|&(_, len)| len != 0);
    let mode = (!saved.frequency_mode.is_empty()).then_some(("stable-step mode", saved.frequency_mode.len() / 2));
    if saved.frequency_mode.len() % 2 == 1 {
        return Err(MpmError::InvalidParameter {
            name: "stable-step mode",
            value: saved.frequency_mode.len() as f64,
            reason: "values for a grid of another node count",
        });
    }
    for (name, len) in fields.into_iter().chain(warm).chain(mode) {
        if len != num_nodes {
            return Err(MpmError::InvalidParameter {
                name,
                value: len as f64,
                reason: "values for a grid of another node count",
            });
        }
    }
    if saved.density.len() != num_bodies {
        return Err(MpmError::InvalidParameter {
            name: "reference densities",
            value: saved.density.len() as f64,
            reason: "densities for another number of bodies",
        });
    }
    Ok(())
}

/// Reference density of each body: the largest `m / V₀` among its particles
/// (`V₀ = V / det F`).
fn reference_densities(particles: &Particles, num_bodies: usize) -> Vec<f64> {
    let p = particles;
    let mut density = vec![0.0f64; num_bodies];
    for k in 0..p.len() {
        let j = p.fxx[k] * p.fyy[k] - p.fxy[k] * p.fyx[k];
        let rho0 = p.mass[k] / (p.volume[k] / j);
        density[p.body[k]] = density[p.body[k]].max(rho0);
    }
    density
}

/// The prescribed velocities as a grid field, 0 where free.
pub(super) fn prescribed_velocity_field(prescribed: &Prescribed, n: usize) -> VectorField {
    let mut field = VectorField::zeros(n);
    prescribed.apply_velocity(&mut field.x, &mut field.y);
    field
}
