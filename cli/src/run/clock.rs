//! When a run writes its snapshots and how its steps meet them.
//!
//! A **fixed** time step stays fixed: every step is `dt` except the last, which may be shorter
//! to end at the end time; a snapshot is written after the step that reaches or passes its
//! time, and records the time reached (as other MPM codes do). A **CFL** step, which changes
//! from step to step anyway, is shortened to land on every snapshot time, so the snapshots of
//! a CFL run fall on the multiples of the interval.

use sparse_mpm::simulation::{Options, TimeStep};

/// Relative tolerance for having reached a time (rounding of the summed steps).
const REACHED: f64 = 1e-12;

/// Above this many intervals, the next snapshot time is computed, not summed.
const SUMMED_INTERVALS: f64 = 1e7;

/// The snapshot times of a run and the longest step that keeps to them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SnapshotClock {
    interval: f64,
    next: f64,
    land: bool,
}

impl SnapshotClock {
    /// Snapshots every `interval` (> 0), the next one due at `next`; the steps land on them when
    /// `land` is set.
    pub fn new(interval: f64, next: f64, land: bool) -> Self {
        SnapshotClock { interval, next, land }
    }

    /// The clock of a run with `options`' time step: landing on the snapshot times for a CFL
    /// step, keeping a fixed step fixed.
    pub fn for_options(options: &Options, interval: f64, next: f64) -> Self {
        Self::new(interval, next, Self::lands(options))
    }

    /// Whether the steps of a run with `options` are shortened to land on snapshot times (a
    /// CFL step) or kept as they are (a fixed step).
    pub fn lands(options: &Options) -> bool {
        matches!(options.time_step, TimeStep::Cfl { .. })
    }

    /// The clock of a simulation at `time` whose snapshots come every `interval`: the next one
    /// is the first multiple of `interval` after `time`, found by summing `interval` as the
    /// run does (the same bits as the uninterrupted run).
    pub fn after(time: f64, interval: f64, land: bool) -> Self {
        let mut clock = Self::new(interval, interval, land);
        clock.pass(time);
        clock
    }

    /// The time of the next snapshot.
    pub fn next(&self) -> f64 {
        self.next
    }

    /// The snapshot interval.
    pub fn interval(&self) -> f64 {
        self.interval
    }

    /// Whether the steps land on snapshot times.
    pub fn landing(&self) -> bool {
        self.land
    }

    /// The longest step from `time` towards `end`: `end − time`, or up to the next snapshot
    /// time `min(t_next, end) − time` when the steps land on snapshot times.
    pub fn max_step(&self, time: f64, end: f64) -> f64 {
        let target = if self.land { self.next.min(end) } else { end };
        target - time
    }

    /// Whether a snapshot is due at `time` (the step reached or passed the next snapshot time,
    /// `time ≥ t_next (1 − 10⁻¹²)`); if so the next snapshot time moves past `time` (a step longer
    /// than the interval writes one snapshot, not one per interval passed).
    pub fn due(&mut self, time: f64) -> bool {
        if !self.reached(time) {
            return false;
        }
        self.pass(time);
        true
    }

    fn reached(&self, time: f64) -> bool {
        time >= self.next * (1.0 - REACHED)
    }

    /// Moves the next snapshot time past `time`.
    fn pass(&mut self, time: f64) {
        if !(self.interval > 0.0 && time.is_finite()) {
            return;
        }
        if (time - self.next) / self.interval > SUMMED_INTERVALS {
            self.next = ((time / self.interval).floor() + 1.0) * self.interval;
        }
        while self.reached(time) {
            self.next += self.interval;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fixed_step_is_capped_only_by_the_end() {
        let clock = SnapshotClock::new(0.05, 0.05, false);
        assert_eq!(clock.max_step(0.0, 1.0), 1.0);
        let landing = SnapshotClock::new(0.05, 0.05, true);
        assert_eq!(landing.max_step(0.0, 1.0), 0.05);
        assert_eq!(landing.max_step(0.0, 0.01), 0.01);
    }

    #[test]
    fn a_long_step_writes_one_snapshot_and_moves_past_its_time() {
        let mut clock = SnapshotClock::new(0.1, 0.1, false);
        assert!(!clock.due(0.05));
        assert!(clock.due(0.35));
        assert!((clock.next() - 0.4).abs() < 1e-12);
        assert!(!clock.due(0.39));
        assert!(clock.due(0.4 * (1.0 - 1e-14)));
    }

    #[test]
    fn after_sums_like_the_run_and_computes_far_times() {
        let clock = SnapshotClock::after(0.3, 0.1, true);
        let mut summed = 0.1;
        while 0.3 >= summed * (1.0 - REACHED) {
            summed += 0.1;
        }
        assert_eq!(clock.next(), summed);
        let far = SnapshotClock::after(1e9, 1e-3, false);
        assert!(far.next() > 1e9 && far.next() <= 1e9 + 2e-3);
    }
}
