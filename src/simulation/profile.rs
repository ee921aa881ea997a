//! Where a step's time goes: wall seconds per phase, summed over the steps taken while
//! profiling is on ([`Simulation::set_profiling`](super::Simulation::set_profiling)).
//!
//! The clock is read twice per phase (tens of nanoseconds); with profiling off nothing is read.

use std::time::Instant;

use super::Simulation;

/// A phase of the step, in the order a step runs them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Counting sort of the particles by cell (every `sort_interval` steps).
    Sort,
    /// (1) `Operators::reassemble`.
    Assemble,
    /// (2)–(5) `kernels::p2g`.
    P2g,
    /// (2) active set, `1/m_L`, and the consistent mass when a scheme needs it.
    Mass,
    /// The stable step: the frequency estimate when due, and the current stable step.
    StableStep,
    /// (6) velocity projection.
    Project,
    /// USF only: (11)–(13) before the acceleration, then (5) again.
    StressFirst,
    /// (7) acceleration solve.
    Accelerate,
    /// (8) updated grid velocity.
    GridVelocity,
    /// (6)–(8) in one pass over the grid, with the lumped mass in both solves.
    LumpedGrid,
    /// (8b) velocities of massless support nodes.
    Extend,
    /// XPIC / FMPM series velocity.
    Series,
    /// (9)–(11) `kernels::g2p` (USL: with (12)–(13), (9) and the report's particle sums; the
    /// fused pass also the next step's (1)–(5) scatter, leaving (2)–(5) its node pass).
    G2p,
    /// USL, MUSL: (11) (MUSL's re-projection) and (12)–(13).
    Stress,
    /// (9) applying the position increments.
    Move,
    /// The step report's sums.
    Report,
}

impl Phase {
    /// Every phase, in step order.
    pub const ALL: [Phase; 16] = [
        Phase::Sort,
        Phase::Assemble,
        Phase::P2g,
        Phase::Mass,
        Phase::StableStep,
        Phase::Project,
        Phase::StressFirst,
        Phase::Accelerate,
        Phase::GridVelocity,
        Phase::LumpedGrid,
        Phase::Extend,
        Phase::Series,
        Phase::G2p,
        Phase::Stress,
        Phase::Move,
        Phase::Report,
    ];

    /// A label with the phase's equations (docs/formulation.md).
    pub fn label(&self) -> &'static str {
        match self {
            Phase::Sort => "sort particles by cell",
            Phase::Assemble => "(1) assemble N, Gx, Gy",
            Phase::P2g => "(2)-(5) p2g: mass, momentum, forces",
            Phase::Mass => "(2) active set, 1/m_L, consistent mass",
            Phase::StableStep => "stable step (estimate when due)",
            Phase::Project => "(6) velocity projection",
            Phase::StressFirst => "USF: (11)-(13), (5)",
            Phase::Accelerate => "(7) acceleration",
            Phase::GridVelocity => "(8) updated grid velocity",
            Phase::LumpedGrid => "(6)-(8) lumped grid pass",
            Phase::Extend => "(8b) massless support nodes",
            Phase::Series => "XPIC/FMPM series",
            Phase::G2p => "(9)-(11) g2p (USL: (12)-(13), move, sums; fused: next (1)-(5))",
            Phase::Stress => "(11)-(13) stress and volume",
            Phase::Move => "(9) move particles",
            Phase::Report => "step report",
        }
    }

    fn index(self) -> usize {
        Phase::ALL.iter().position(|p| *p == self).unwrap_or(0)
    }
}

/// Wall seconds per phase, summed over the profiled steps.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Profile {
    seconds: [f64; Phase::ALL.len()],
    steps: usize,
}

impl Profile {
    /// Seconds spent in `phase`.
    pub fn seconds(&self, phase: Phase) -> f64 {
        self.seconds[phase.index()]
    }

    /// Seconds over all phases.
    pub fn total(&self) -> f64 {
        self.seconds.iter().sum()
    }

    /// Steps profiled.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Every phase that took any time, with its seconds, in step order.
    pub fn rows(&self) -> Vec<(Phase, f64)> {
        Phase::ALL
            .into_iter()
            .map(|p| (p, self.seconds(p)))
            .filter(|(_, s)| *s > 0.0)
            .collect()
    }

    /// Adds `other` to this profile.
    pub fn merge(&mut self, other: &Profile) {
        for (a, b) in self.seconds.iter_mut().zip(&other.seconds) {
            *a += b;
        }
        self.steps += other.steps;
    }
}

impl Simulation {
    /// Starts (`true`, from zero) or stops (`false`) timing the phases of each step.
    pub fn set_profiling(&mut self, on: bool) {
        self.profile = on.then(Profile::default);
    }

    /// The phase times since profiling was switched on.
    pub fn profile(&self) -> Option<&Profile> {
        self.profile.as_ref()
    }
}

/// Runs `f` as `phase`, timing it into `profile` when profiling is on.
pub(super) fn timed<T>(profile: &mut Option<Profile>, phase: Phase, f: impl FnOnce() -> T) -> T {
    if profile.is_none() {
        return f();
    }
    let start = Instant::now();
    let result = f();
    if let Some(p) = profile {
        p.seconds[phase.index()] += start.elapsed().as_secs_f64();
    }
    result
}

impl Profile {
    /// Counts a profiled step.
    pub(super) fn count_step(&mut self) {
        self.steps += 1;
    }
}
