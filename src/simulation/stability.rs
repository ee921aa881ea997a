//! The stable time step: the frequency estimate of the update with the simulation's masses,
//! kept between estimates, and the choice of the next step from it.

use super::series::SeriesTransfer;
use super::{Cache, Options, Setup, Simulation, State, TimeStep};
use crate::error::{MpmError, Result};
use crate::fields::VectorField;
use crate::grid::Grid;
use crate::mass::{series_velocity_into, GridMass, MassScheme, Role, SeriesScratch};
use crate::particles::Particles;
use crate::stiffness::{self, FrequencyEstimate, Inverse};

/// The stable step found by the last frequency estimate.
#[derive(Debug, Clone, Copy)]
pub(super) struct Stability {
    /// [`stiffness::mpm_critical_time_step`] at that estimate.
    pub(super) wave_step: f64,
    /// Largest tangent P-wave speed over the particles then.
    pub(super) wave_speed: f64,
    /// Steps completed when it was made.
    pub(super) at_step: usize,
    pub(super) estimate: FrequencyEstimate,
    /// What the estimate was made for; a change triggers the next ([`estimate_due`]).
    pub(super) basis: Basis,
    /// Steps completed at which the next estimate is due at the latest ([`next_interval`]).
    pub(super) due_at: usize,
}

/// What a frequency estimate depends on beyond the particle positions, compared at every step
/// to decide whether it still holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) struct Basis {
    /// A hash of the active nodes ([`active_fingerprint`]); 0 with the lumped mass in both
    /// solves, whose frequencies do not depend on it.
    pub(super) active: u64,
    /// Whether the velocity and the acceleration solves substituted another mass for their
    /// scheme's ([`GridMass::substitutes`]).
    pub(super) substitutes: [bool; 2],
}

/// The most a re-estimate may raise the stable wave step over the previous estimate's.
///
/// ```text
/// Δt_wave ← min(Δt_wave,new, MAX_STEP_RISE · Δt_wave,previous)
/// ```
///
/// An estimate holds for the configuration it was made at, and the step it sets is taken until
/// the next: a re-estimate that raises the step a lot (measured: series:32 on the two disks,
/// +51% at step 201 and +37% at step 501, a particle inverted at step 543) bets that the
/// frequency stays down until then. Bounding the rise makes the step come back up over several
/// estimates instead; a fall is taken at once.
pub const MAX_STEP_RISE: f64 = 1.1;

/// The relative change of `ω_max` that the schedule of estimates lets pass between two
/// estimates ([`next_interval`]).
pub const FREQUENCY_DRIFT: f64 = 0.02;

/// Steps from an estimate to the next at the latest:
///
/// ```text
/// lumped in both solves:  s = stability_interval
/// otherwise:              s = clamp(⌊FREQUENCY_DRIFT / r⌋, 1, stability_interval),
///                         r = |ln(ω_now / ω_previous)| / (steps between the two estimates)
/// ```
///
/// `r` is the rate at which `ω_max` was last seen to change, so that at that rate it moves by
/// at most [`FREQUENCY_DRIFT`] before it is estimated again. Where the configuration makes the
/// frequency move fast (a particle nearing a grid line in a sparse layout, a near-singular
/// consistent mass) the estimates follow it step by step; where it does not they stay
/// `stability_interval` apart. The first estimate, with no rate yet, schedules the next after
/// at most [`FIRST_INTERVAL`] steps. The lumped mass keeps the fixed interval: its frequencies
/// do not grow where a node's support empties, and estimating it at every step changed nothing
/// measurable (docs/simulation.md).
pub(super) fn next_interval(
    options: &Options,
    previous: Option<&Stability>,
    omega_squared: f64,
    steps: usize,
) -> usize {
    let interval = options.stability_interval.max(1);
    let lumped = options.mass.velocity == MassScheme::Lumped && options.mass.acceleration == MassScheme::Lumped;
    let Some(p) = previous.filter(|_| !lumped) else {
        return if lumped { interval } else { interval.min(FIRST_INTERVAL) };
    };
    let (now, before) = (omega_squared, p.estimate.omega_squared);
    if !(now > 0.0 && before > 0.0) {
        return 1;
    }
    let rate = 0.5 * (now / before).ln().abs() / steps.saturating_sub(p.at_step).max(1) as f64;
    if rate * interval as f64 <= FREQUENCY_DRIFT {
        interval
    } else {
        ((FREQUENCY_DRIFT / rate) as usize).clamp(1, interval)
    }
}

/// Most steps from the first estimate to the second, for masses other than lumped.
pub const FIRST_INTERVAL: usize = 10;

/// The largest particle speed and tangent P-wave speed of a state.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Speeds {
    /// `max_p |v_p|`.
    pub(super) particle: f64,
    /// `max_p √(C11_p V_p / m_p)`.
    pub(super) wave: f64,
}

/// A particle's tangent P-wave speed `√(C11 / ρ)`, `ρ = m / V` (0 for a non-positive modulus).
#[inline]
pub(super) fn wave_speed(c11: f64, volume: f64, mass: f64) -> f64 {
    (c11 * volume / mass).max(0.0).sqrt()
}

impl Simulation {
    /// The stable time step for the current state:
    ///
    /// ```text
    /// Δt_stable = 1 / (1/Δt_wave + max_p |v_p| / min(hx, hy)),
    /// Δt_wave = μ · TIME_STEP_SAFETY · √(2 (1 + α))/ω_max · min(1, c_est / c_now),
    ///           at most MAX_STEP_RISE times the previous estimate's
    /// ```
    ///
    /// with `μ` the [`stiffness::crossing_margin`] (1 but for a FLIP part with linear shape
    /// functions or a truncated-series mass).
    /// `ω²_max` is the largest squared frequency of the update with this simulation's masses
    /// ([`stiffness::mpm_max_frequency_squared`]: `λ_max(M_a⁻¹ K M_v⁻¹ M)` from the current
    /// operators, tangent stiffness and masses, by Lanczos), estimated when the simulation is
    /// made, again at most every [`Options::stability_interval`](super::Options::stability_interval) steps (sooner where it
    /// was last seen to change fast: by at most 2% between estimates at that rate), and at once when a
    /// singularity policy starts or stops substituting a mass or (for masses other than lumped)
    /// the active nodes change; between estimates the step
    /// shrinks if the largest tangent P-wave speed `c = √(C11/ρ)` over the particles rises above
    /// its value at the estimate. `α` is the transfer's [`Transfer::flip_weight`](super::Transfer::flip_weight) (FLIP is stable
    /// up to `2/ω_max`, PIC-type updates up to `√2/ω_max`). The particle-speed term keeps particles
    /// from crossing more than a cell per step.
    pub fn stable_time_step(&self) -> f64 {
        stable_time_step(&self.setup.grid, &self.state)
    }

    /// The last frequency estimate behind [`Simulation::stable_time_step`] and the number of
    /// steps completed when it was made.
    pub fn frequency_estimate(&self) -> Option<(FrequencyEstimate, usize)> {
        self.state.stability.map(|s| (s.estimate, s.at_step))
    }
}

/// [`Simulation::stable_time_step`] of `state` on `grid`.
pub(super) fn stable_time_step(grid: &Grid, state: &State) -> f64 {
    let Some(s) = state.stability else {
        return f64::INFINITY;
    };
    let (max_speed, c_now) = (state.speeds.particle, state.speeds.wave);
    let wave = if c_now > s.wave_speed {
        s.wave_step * s.wave_speed / c_now
    } else {
        s.wave_step
    };
    let [hx, hy] = grid.cell_size();
    1.0 / (1.0 / wave + max_speed / hx.min(hy))
}

/// The largest particle speed and tangent P-wave speed `√(C11_p / ρ_p)`, `ρ_p = m_p / V_p`,
/// over the particles, by a pass over them (the time loop keeps them up to date as it goes).
pub(super) fn measure_speeds(setup: &Setup, p: &Particles) -> Speeds {
    let mut speeds = Speeds::default();
    for k in 0..p.len() {
        let f = [p.fxx[k], p.fxy[k], p.fyx[k], p.fyy[k]];
        let c11 = setup.bodies[p.body[k]].material.tangent(f)[0];
        speeds.wave = speeds.wave.max(wave_speed(c11, p.volume[k], p.mass[k]));
        speeds.particle = speeds.particle.max((p.vx[k] * p.vx[k] + p.vy[k] * p.vy[k]).sqrt());
    }
    speeds
}

/// Whether the stable step is to be estimated at this step: before the first step; then (unless
/// [`Options::stability_interval`] is 0) every `stability_interval` steps, and at once when what
/// the last estimate was made for has changed ([`Basis`]): a solve that substitutes another
/// mass for its scheme's or stops doing so (the singularity policies), and, for every mass but
/// the lumped one in both solves, a change of the active nodes (a node whose support starts or
/// stops being read, where the consistent mass and the series meet their highest frequencies).
/// That holds for the linear-extension penalty too, although it keeps an emptied node's inertia:
/// left out for it, the random block of `tests/stable_step.rs` (256 and 1,024 particles, linear,
/// FLIP, MUSL) inverted a particle at 0.9 of the stable step for 5 of 16 seeds (steps 287–1583,
/// measured), and ran with at most +1.3% energy with it.
pub(super) fn estimate_due(options: &Options, state: &State, mass: &GridMass) -> bool {
    match state.stability {
        None => true,
        Some(s) => {
            let interval = options.stability_interval;
            interval > 0 && (state.steps >= s.due_at || basis(options, mass) != s.basis)
        }
    }
}

/// The [`Basis`] of the grid mass as prepared now.
pub(super) fn basis(options: &Options, mass: &GridMass) -> Basis {
    let lumped = options.mass.velocity == MassScheme::Lumped && options.mass.acceleration == MassScheme::Lumped;
    Basis {
        active: if lumped {
            0
        } else {
            active_fingerprint(mass.is_active())
        },
        substitutes: [mass.substitutes(Role::Velocity), mass.substitutes(Role::Acceleration)],
    }
}

/// A hash of the active set (FNV-1a over the active node numbers and their count):
///
/// ```text
/// h ← (h ⊕ I) · 1099511628211   for each active node I, then for the count
/// ```
pub(super) fn active_fingerprint(is_active: &[bool]) -> u64 {
    const PRIME: u64 = 1_099_511_628_211;
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut count = 0u64;
    for (i, _) in is_active.iter().enumerate().filter(|(_, &a)| a) {
        h = (h ^ i as u64).wrapping_mul(PRIME);
        count += 1;
    }
    (h ^ count).wrapping_mul(PRIME)
}

/// Estimates `ω²_max` of the update with the grid prepared for the current configuration
/// ((1)–(5) and the mass): the masses of both solves as [`crate::mass::GridMass::solve`]
/// applies them, followed by FMPM's series when the transfer is FMPM (its particle velocity and
/// stress update read `M_k⁻¹ M_L` of the lumped velocity: the series is the mass of both halves
/// of the update).
pub(super) fn estimate(setup: &Setup, options: &Options, state: &State, cache: &Cache) -> Result<Stability> {
    estimate_by(setup, options, state, cache, Estimator::Cheapest)
}

/// Which way [`estimate_by`] finds `ω²_max`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Estimator {
    /// The mass bound where [`GridMass::bounding_mass`] allows it, the exact estimate otherwise.
    Cheapest,
    /// Always the exact estimate ([`stiffness::mpm_max_frequency_squared`]).
    #[cfg_attr(not(test), allow(dead_code))]
    Exact,
}

/// [`estimate`] by the given estimator. The mass bound
/// ([`stiffness::mpm_mass_bound_frequency_squared`]) needs no mass solve: where both solves use
/// one [`GridMass::bounding_mass`] (and no FMPM series follows) it replaces the Lanczos
/// iteration on `M_s⁻¹ K M_s⁻¹ M`, whose two mass solves per step cost tens of conjugate-gradient
/// iterations each from a cold start.
pub(super) fn estimate_by(
    setup: &Setup,
    options: &Options,
    state: &State,
    cache: &Cache,
    estimator: Estimator,
) -> Result<Stability> {
    let (ops, p, mass) = (&cache.ops, &state.particles, &cache.mass);
    let n = ops.num_nodes();
    // Each particle's tangent, formed where a product reads it (no per-particle array).
    let tangent_of = |k: usize| {
        let f = [p.fxx[k], p.fxy[k], p.fyx[k], p.fyy[k]];
        setup.bodies[p.body[k]].material.tangent(f)
    };
    let mut free: Vec<bool> = mass.is_active().iter().chain(mass.is_active()).copied().collect();
    let c = &setup.prescribed.constraints;
    c.fixed_x.iter().for_each(|&i| free[i] = false);
    c.fixed_y.iter().for_each(|&i| free[n + i] = false);
    let free = &free;
    let series = SeriesTransfer::of(options.transfer).and_then(SeriesTransfer::stress_terms);
    let inverse = |role: Role| {
        move |r: &VectorField| -> Result<VectorField> {
            let mut u = VectorField::zeros(n);
            mass.solve_for_estimate(role, r, ops, &mut u)?;
            let Some(k) = series else {
                return Ok(u);
            };
            let constrain = |v: &mut VectorField| {
                for i in 0..n {
                    v.x[i] = if free[i] { v.x[i] } else { 0.0 };
                    v.y[i] = if free[n + i] { v.y[i] } else { 0.0 };
                }
            };
            let (mut out, mut scratch) = (VectorField::default(), SeriesScratch::default());
            series_velocity_into(
                ops,
                &p.mass,
                mass.inverse_lumped(),
                k,
                &constrain,
                &u,
                &mut out,
                &mut scratch,
            );
            Ok(out)
        }
    };
    let bound = match (
        mass.bounding_mass(Role::Velocity),
        mass.bounding_mass(Role::Acceleration),
    ) {
        (Some(m), Some(_))
            if estimator == Estimator::Cheapest
                && series.is_none()
                && options.mass.velocity == options.mass.acceleration =>
        {
            Some(m)
        }
        _ => None,
    };
    let mut velocity = inverse(Role::Velocity);
    let mut acceleration = inverse(Role::Acceleration);
    let same = options.mass.velocity == options.mass.acceleration;
    let lumped = options.mass.velocity == MassScheme::Lumped && same && series.is_none();
    let estimate = match bound {
        Some(m) => {
            let tangent: Vec<[f64; 3]> = (0..p.len()).map(tangent_of).collect();
            stiffness::mpm_mass_bound_frequency_squared(ops, &p.volume, &tangent, free, |_, x| m.mul(x), m.diagonal())
        }
        None if lumped => {
            // The lumped solve as a scaling of the free entries (the same bits as the solve).
            let inverse = Inverse::Lumped(mass.inverse_lumped());
            stiffness::max_frequency_squared_with(ops, &p.mass, &p.volume, &tangent_of, free, inverse, None)?
        }
        None => stiffness::max_frequency_squared_with(
            ops,
            &p.mass,
            &p.volume,
            &tangent_of,
            free,
            Inverse::Solve(&mut velocity),
            (!same).then_some(Inverse::Solve(&mut acceleration)),
        )?,
    };
    let alpha = options.transfer.flip_weight();
    let mut wave_step = stiffness::mpm_critical_time_step(&estimate, alpha)
        * stiffness::crossing_margin(options.shape, [options.mass.velocity, options.mass.acceleration], alpha);
    if let Some(previous) = state.stability {
        wave_step = wave_step.min(MAX_STEP_RISE * previous.wave_step);
    }
    let previous = state.stability.as_ref();
    Ok(Stability {
        wave_step,
        wave_speed: state.speeds.wave,
        at_step: state.steps,
        estimate,
        basis: basis(options, mass),
        due_at: state
            .steps
            .saturating_add(next_interval(options, previous, estimate.omega_squared, state.steps)),
    })
}

/// The step to take now: the fixed one (refused above the stable step unless allowed) or the
/// Courant number times the stable step.
pub(super) fn next_time_step(options: &Options, steps: usize, stable: f64) -> Result<f64> {
    match options.time_step {
        TimeStep::Cfl { number } => {
            if stable.is_finite() {
                Ok(number * stable)
            } else {
                Err(MpmError::NoStableTimeStep { step: steps })
            }
        }
        TimeStep::Fixed { dt } => {
            if dt > stable && !options.allow_unstable_time_step {
                let m = &options.mass;
                Err(MpmError::TimeStepAboveStable {
                    step: steps,
                    dt,
                    stable,
                    masses: if m.velocity == m.acceleration {
                        format!("{:#}", m.velocity)
                    } else {
                        format!("{:#} / {:#}", m.velocity, m.acceleration)
                    },
                })
            } else {
                Ok(dt)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::{falling_block, BenchSpec};
    use crate::mass::Stabilization;
    use crate::shape::ShapeFunction;
    use crate::simulation::{TimeStep, Transfer};

    /// The mass bound of `ω²_max` lies above the exact estimate, and close to it, on the
    /// benchmark's random block with the linear-extension penalty, at the start and after the
    /// particles have moved.
    #[test]
    fn the_mass_bound_is_above_the_exact_frequency_and_close_to_it() {
        for shape in [ShapeFunction::Linear, ShapeFunction::QuadraticBSpline] {
            let spec = BenchSpec {
                shape,
                transfer: Transfer::Flip,
                mass: MassScheme::Iterative {
                    tolerance: 1e-10,
                    max_iterations: 2000,
                },
                stabilization: Stabilization::default(),
                ..BenchSpec::default()
            };
            let mut sim = falling_block(1024, &spec, TimeStep::Cfl { number: 0.9 }, 100).unwrap();
            for round in 0..3 {
                let s = &sim;
                let of = |e| {
                    estimate_by(&s.setup, &s.options, &s.state, &s.cache, e)
                        .unwrap()
                        .estimate
                        .omega_squared
                };
                let (bound, exact) = (of(Estimator::Cheapest), of(Estimator::Exact));
                let ratio = bound / exact;
                println!(
                    "{} round {round}: bound {bound:.6e} exact {exact:.6e} ratio {ratio:.4}",
                    shape.name()
                );
                assert!(
                    (1.0 - 2.0 * crate::stiffness::FREQUENCY_TOLERANCE..1.15).contains(&ratio),
                    "{}: bound {bound:e}, exact {exact:e}",
                    shape.name()
                );
                for _ in 0..15 {
                    sim.step().unwrap();
                }
            }
        }
    }
}
