//! The speeds the stable step reads besides the frequency estimate: the largest particle speed,
//! tangent P-wave speed, load and prescribed wall speed ([`Speeds`]), each measured from the
//! state or the setup.

use super::Setup;
use crate::particles::Particles;

/// The largest particle speed and tangent P-wave speed of a state.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Speeds {
    /// `max_p |v_p|`.
    pub(super) particle: f64,
    /// `max_p √(C11_p V_p / m_p)`.
    pub(super) wave: f64,
    /// `max_p |g + b_p|`, gravity and the particle's body force ([`largest_load`]).
    pub(super) load: f64,
    /// The largest prescribed grid speed ([`prescribed_speed`]): a wall that moves drags the
    /// particles beside it at its speed from the first step on.
    pub(super) wall: f64,
}

/// The largest speed the boundary conditions prescribe, over the prescribed components:
///
/// ```text
/// v_wall = |(max_{x prescribed} |v̄_x|, max_{y prescribed} |v̄_y|)|
/// ```
pub(super) fn prescribed_speed(prescribed: &crate::boundary::Prescribed) -> f64 {
    let largest = |k: usize| prescribed.values[k].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    largest(0).hypot(largest(1))
}

/// The largest acceleration the loads give a particle, gravity `g` and its body force `b_p`:
///
/// ```text
/// a_max = max_p |g + b_p|
/// ```
pub(super) fn largest_load(gravity: [f64; 2], p: &Particles) -> f64 {
    (0..p.len())
        .map(|k| (gravity[0] + p.bx[k]).hypot(gravity[1] + p.by[k]))
        .fold(0.0, f64::max)
}

/// A particle's tangent P-wave speed `√(C11 / ρ)`, `ρ = m / V` (0 for a non-positive modulus).
#[inline]
pub(super) fn wave_speed(c11: f64, volume: f64, mass: f64) -> f64 {
    (c11 * volume / mass).max(0.0).sqrt()
}

/// The largest particle speed and tangent P-wave speed `√(C11_p / ρ_p)`, `ρ_p = m_p / V_p`,
/// over the particles, by a pass over them (the time loop keeps them up to date as it goes).
pub(super) fn measure_speeds(setup: &Setup, p: &Particles) -> Speeds {
    let mut speeds = Speeds::default();
    let prepared: Vec<_> = setup.bodies.iter().map(|b| b.material.prepared()).collect();
    for k in 0..p.len() {
        let f = [p.fxx[k], p.fxy[k], p.fyx[k], p.fyy[k]];
        let c11 = prepared[p.body[k]].tangent(f)[0];
        speeds.wave = speeds.wave.max(wave_speed(c11, p.volume[k], p.mass[k]));
        speeds.particle = speeds.particle.max((p.vx[k] * p.vx[k] + p.vy[k] * p.vy[k]).sqrt());
    }
    speeds
}
