//! What one step did: [`StepReport`], and its CSV columns.

use super::{Cache, Scratch, Setup, State};
use crate::error::{MpmError, Result};
use crate::kernels::{ParticleSums, SumInput, SumPartials};
use crate::mass::{SolveOutcome, SolveReport};
use crate::parallel::Workers;
use crate::particles::Particles;

/// What one step did and the state after it: data, not log lines.
#[derive(Debug, Clone, PartialEq)]
pub struct StepReport {
    /// Steps completed (1 after the first step).
    pub step: usize,
    /// Time at the end of the step.
    pub time: f64,
    /// Step length used.
    pub dt: f64,
    /// The stable step at the start of the step ([`Simulation::stable_time_step`](super::Simulation::stable_time_step)).
    pub stable_time_step: f64,
    /// `½ Σ_p m_p |v_p|²` after the step.
    pub kinetic_energy: f64,
    /// `½ Σ_I m_L,I |w_I|²`: grid kinetic energy of the updated grid velocity, lumped mass.
    pub grid_kinetic_energy_lumped: f64,
    /// `½ wᵀ M w = ½ Σ_p m_p |(Nᵀ w)_p|²`: the same with the consistent mass.
    pub grid_kinetic_energy_consistent: f64,
    /// `Σ_p` strain energy of each particle's material after the step.
    pub strain_energy: f64,
    /// `K_p − ½ Σ_p m_p |Nᵀv|²` at this step: the particles' kinetic energy that the projected
    /// grid velocity `v` does not carry (measured at the particles, so it is never negative
    /// with the consistent velocity mass).
    pub particle_grid_gap: f64,
    /// Kinetic energy lost in the transfers back to the particles, summed over the steps so
    /// far: `Σ [K_p,before + (½ Σ m_p |Nᵀw|² − ½ Σ m_p |Nᵀv|²) − K_p,after]`, what the particles'
    /// kinetic energy changed by less than the grid's (PIC loses the whole gap; FLIP with the
    /// consistent velocity mass nothing).
    pub transfer_loss: f64,
    /// Potential of the body forces `−Σ_p m_p (b_p + g) · x_p` after the step.
    pub potential_energy: f64,
    /// `kinetic + strain + potential`.
    pub total_energy: f64,
    /// `Σ_p m_p v_p` after the step.
    pub momentum: [f64; 2],
    /// `Σ_p m_p (x_p × v_p)` after the step (the APIC affine part is not included).
    pub angular_momentum: f64,
    /// `Σ_I x_I × q_I`: angular momentum of the grid momentum of this step's (3), which APIC
    /// conserves exactly.
    pub grid_angular_momentum: f64,
    /// `Σ_p m_p`.
    pub mass: f64,
    /// `max_p |v_p|` after the step.
    pub max_speed: f64,
    /// What the velocity projection did.
    pub velocity_solve: SolveReport,
    /// What the acceleration solve did.
    pub acceleration_solve: SolveReport,
    /// Energy the damping has removed so far ([`crate::damping`]; 0 undamped): the energy
    /// balance of a damped run is `total_energy + damping_work`, constant up to the transfers'
    /// and the integrator's share.
    pub damping_work: f64,
    /// The normal contact force between bodies in the step ([`crate::contact`]): the normal
    /// impulses of the force stage's corrections over `Δt`, summed over the nodes and pairs
    /// (0 without contact).
    pub contact_force: f64,
    /// The work of friction between bodies so far, `Σ −Δp'_t · (w'_a − w'_b)` over the steps
    /// ([`crate::contact`]): the energy balance of a frictional run is `total_energy +
    /// friction_dissipation`, constant up to the transfers' share and the normal corrections'
    /// (an inelastic collision at each node where the bodies meet).
    pub friction_dissipation: f64,
    /// The plastic dissipation so far, `Σ_steps Σ_p V₀_p τ_p : Δεᵖ_p`: the plastic work of the
    /// return maps of elastoplastic bodies ([`crate::material::hencky`]; 0 for elastic
    /// bodies). The energy balance of a plastic run is `total_energy +
    /// plastic_dissipation (+ friction_dissipation + damping_work)`, constant up to the
    /// transfers' share.
    pub plastic_dissipation: f64,
    /// Whether a damped run has settled: the kinetic energy of the motion that moves the
    /// particles, `½ Σ_p m_p |(Nᵀ w)_p|²`, at most
    /// [`Damping::settled`](crate::damping::Damping::settled) times its largest so far (always
    /// false undamped). Not the particles' own: FLIP keeps particle velocities the grid does not
    /// see, which no damping of the grid force reaches, and which move no particle.
    pub settled: bool,
}

impl StepReport {
    /// Column names of [`StepReport::values`], for a CSV header.
    pub const COLUMNS: [&'static str; 30] = [
        "step",
        "time",
        "dt",
        "stable_time_step",
        "kinetic_energy",
        "grid_kinetic_energy_lumped",
        "grid_kinetic_energy_consistent",
        "strain_energy",
        "particle_grid_gap",
        "transfer_loss",
        "potential_energy",
        "total_energy",
        "momentum_x",
        "momentum_y",
        "angular_momentum",
        "grid_angular_momentum",
        "mass",
        "max_speed",
        "velocity_outcome",
        "velocity_iterations",
        "velocity_residual",
        "acceleration_outcome",
        "acceleration_iterations",
        "acceleration_residual",
        "velocity_fallback_node",
        "damping_work",
        "settled",
        "contact_force",
        "friction_dissipation",
        "plastic_dissipation",
    ];

    /// The report as numbers, in the order of [`StepReport::COLUMNS`]. Outcomes are coded
    /// 0 = solved, 1 = fell back to lumped, 2 = regularized; the fallback node is −1 when none.
    pub fn values(&self) -> [f64; 30] {
        let code = |r: &SolveReport| match r.outcome {
            SolveOutcome::Solved => 0.0,
            SolveOutcome::FellBackToLumped { .. } => 1.0,
            SolveOutcome::Regularized { .. } => 2.0,
        };
        let node = match self.velocity_solve.outcome {
            SolveOutcome::FellBackToLumped { node: Some(n), .. } | SolveOutcome::Regularized { node: Some(n), .. } => {
                n as f64
            }
            _ => -1.0,
        };
        [
            self.step as f64,
            self.time,
            self.dt,
            self.stable_time_step,
            self.kinetic_energy,
            self.grid_kinetic_energy_lumped,
            self.grid_kinetic_energy_consistent,
            self.strain_energy,
            self.particle_grid_gap,
            self.transfer_loss,
            self.potential_energy,
            self.total_energy,
            self.momentum[0],
            self.momentum[1],
            self.angular_momentum,
            self.grid_angular_momentum,
            self.mass,
            self.max_speed,
            code(&self.velocity_solve),
            self.velocity_solve.iterations as f64,
            self.velocity_solve.relative_residual,
            code(&self.acceleration_solve),
            self.acceleration_solve.iterations as f64,
            self.acceleration_solve.relative_residual,
            node,
            self.damping_work,
            f64::from(u8::from(self.settled)),
            self.contact_force,
            self.friction_dissipation,
            self.plastic_dissipation,
        ]
    }
}

/// What the step just taken was: its length, the stable step it was checked against, and the
/// velocity and acceleration solves' reports.
pub(super) struct StepTaken {
    pub(super) dt: f64,
    pub(super) stable_time_step: f64,
    pub(super) solves: [SolveReport; 2],
    /// Gravity in the step (the potential energy's).
    pub(super) gravity: [f64; 2],
}

/// The report of the step just taken: energies, momenta and mass summed over the particles and
/// the grid, after checking every particle velocity is finite.
pub(super) fn report(
    setup: &Setup,
    state: &State,
    cache: &Cache,
    scratch: &mut Scratch,
    taken: StepTaken,
) -> Result<StepReport> {
    let (mass, nodes) = (&cache.mass, &cache.nodes);
    let StepTaken {
        dt,
        stable_time_step,
        solves,
        gravity,
    } = taken;
    let p = &state.particles;
    let t = match scratch.sums.take() {
        Some(sums) => sums,
        None => particle_sums(&setup.workers, p, gravity, &mut scratch.report_blocks),
    };
    if let Some(k) = t.non_finite {
        return Err(MpmError::NonFinite {
            step: state.steps,
            stage: "particle velocity",
            particle: k,
            id: p.id[k],
            value: [p.vx[k], p.vy[k]],
        });
    }
    let ParticleSums {
        kinetic: ke,
        potential,
        angular: ang,
        mass: total_mass,
        max_speed,
        momentum: [px, py],
        ..
    } = t;
    let (m_l, w) = (mass.lumped(), &nodes.updated);
    // The nodes the step's p2g wrote (the operators may have moved on since: the fused pass).
    let span = super::phases::massive_span(setup, &cache.ops, Some(nodes));
    // In fixed blocks of nodes, added in order; in each block eight partial sums (node i into
    // partial i mod 8), added in order. Blocks outside the span hold no mass: 0. (Within the
    // span, skipping the columns outside p2g's ran no faster: runs of a few kilobytes.)
    setup.workers.blocks(m_l.len(), &mut scratch.grid_blocks, |range| {
        if range.end <= span.start || range.start >= span.end {
            return 0.0;
        }
        let mut partial = [0.0; 8];
        for i in range {
            partial[i % 8] += 0.5 * m_l[i] * (w.x[i] * w.x[i] + w.y[i] * w.y[i]);
        }
        partial.iter().sum::<f64>()
    });
    let ke_l: f64 = scratch.grid_blocks.iter().sum();
    let kinetic = &scratch.particle.kinetic;
    let [velocity_solve, acceleration_solve] = solves;
    Ok(StepReport {
        step: state.steps,
        time: state.time,
        dt,
        stable_time_step,
        kinetic_energy: ke,
        particle_grid_gap: kinetic.before - kinetic.projected,
        transfer_loss: state.transfer_loss,
        grid_kinetic_energy_lumped: ke_l,
        grid_kinetic_energy_consistent: kinetic.updated,
        strain_energy: state.strain_energy,
        potential_energy: potential,
        total_energy: ke + state.strain_energy + potential,
        momentum: [px, py],
        angular_momentum: ang,
        grid_angular_momentum: nodes.angular_momentum,
        mass: total_mass,
        max_speed,
        velocity_solve,
        acceleration_solve,
        damping_work: state.relaxation.damping_work,
        contact_force: cache.layers.force,
        friction_dissipation: state.relaxation.friction_dissipation,
        plastic_dissipation: state.relaxation.plastic_dissipation,
        settled: false,
    })
}

/// The particles' sums for the report, in fixed blocks of particles so that they do not depend
/// on the threads (`blocks` is work space).
fn particle_sums(workers: &Workers, p: &Particles, gravity: [f64; 2], blocks: &mut Vec<SumPartials>) -> ParticleSums {
    workers.blocks(p.len(), blocks, |range| {
        let mut s = SumPartials::default();
        let first = range.start;
        for k in range {
            let sum = SumInput {
                x: [p.x[k], p.y[k]],
                v: [p.vx[k], p.vy[k]],
                m: p.mass[k],
                b: [p.bx[k], p.by[k]],
            };
            s.add(k - first, k, sum, gravity);
        }
        s
    });
    ParticleSums::total(blocks.iter().copied())
}
