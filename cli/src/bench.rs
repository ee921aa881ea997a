//! `mpm bench`: the benchmark problem ([`sparse_mpm::bench`]) timed over whole explicit steps.
//!
//! Timing: particle-steps per second (`N × steps / seconds`) over the timed steps of each
//! repetition. Set-up — building the simulation (which assembles the operators and estimates
//! the stable step) and one untimed warm-up step that grows every buffer to size — is excluded,
//! as the peers exclude theirs.
//!
//! Memory: the peak resident set size of the process during the set-up and the timed steps,
//! less the resident size before the set-up, per particle (Linux; `None` elsewhere). The peak is
//! reset before each configuration (`/proc/self/clear_refs`).

use std::time::Instant;

use sparse_mpm::bench::{problem, BenchSpec};
use sparse_mpm::error::{MpmError, Result};
use sparse_mpm::simulation::{EstimateCounts, Profile};

/// The timed steps of one particle count: the peers' rule `max(20, min(2000, 2·10⁷ / N))`.
pub fn default_steps(particles: usize) -> usize {
    (20_000_000 / particles.max(1)).clamp(20, 2000)
}

/// The figures of one particle count.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchRow {
    /// Particles.
    pub particles: usize,
    /// Cells per side.
    pub n_grid: usize,
    /// Timed steps per repetition.
    pub steps: usize,
    /// The time step of the first step (the fixed step, or the first Courant step).
    pub dt: f64,
    /// The shortest and the longest timed step over every repetition.
    pub dt_range: [f64; 2],
    /// Wall seconds of the timed steps of each repetition.
    pub seconds: Vec<f64>,
    /// Wall seconds of the first set-up (build and warm-up step).
    pub setup_seconds: f64,
    /// Peak resident bytes per particle over set-up and steps (Linux only).
    pub peak_bytes_per_particle: Option<f64>,
    /// Phase times summed over every repetition's timed steps, when profiled.
    pub profile: Option<Profile>,
    /// Frequency estimates made during the timed steps of every repetition, and the Lanczos or
    /// LOBPCG steps they took in all ([`sparse_mpm::stiffness::FrequencyEstimate::lanczos_steps`]).
    pub estimates: [usize; 2],
    /// The estimates and guards of the stable step over the timed steps of every repetition
    /// ([`sparse_mpm::simulation::Simulation::estimate_counts`]).
    pub counts: EstimateCounts,
    /// Simulated time of the timed steps of each repetition.
    pub simulated: Vec<f64>,
}

impl BenchRow {
    /// Particle-steps per second of each repetition, ascending.
    pub fn rates(&self) -> Vec<f64> {
        let mut r: Vec<f64> = self
            .seconds
            .iter()
            .map(|s| (self.particles * self.steps) as f64 / s)
            .collect();
        r.sort_by(f64::total_cmp);
        r
    }

    /// `[min, median, max]` particle-steps per second.
    pub fn rate_summary(&self) -> [f64; 3] {
        let r = self.rates();
        [r[0], median(&r), r[r.len() - 1]]
    }

    /// The median over repetitions of the wall seconds per simulated second (what a run to a
    /// given time costs), `seconds / simulated time` of each repetition.
    pub fn seconds_per_simulated_second(&self) -> f64 {
        let mut r: Vec<f64> = self
            .seconds
            .iter()
            .zip(&self.simulated)
            .map(|(s, t)| if *t > 0.0 { s / t } else { f64::INFINITY })
            .collect();
        r.sort_by(f64::total_cmp);
        median(&r)
    }

    /// The median wall seconds per timed step over repetitions.
    pub fn seconds_per_step(&self) -> f64 {
        let mut r: Vec<f64> = self.seconds.iter().map(|s| s / self.steps.max(1) as f64).collect();
        r.sort_by(f64::total_cmp);
        median(&r)
    }
}

fn median(sorted: &[f64]) -> f64 {
    let n = sorted.len();
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
    }
}

/// Runs `spec`, calling `observe` after each particle count.
///
/// # Errors
/// [`MpmError::InvalidParameter`] for no repetitions or no particle counts; the errors of
/// [`problem`] and of the steps.
pub fn run(spec: &BenchSpec, mut observe: impl FnMut(&BenchRow)) -> Result<Vec<BenchRow>> {
    if spec.reps == 0 {
        return Err(MpmError::InvalidParameter {
            name: "reps",
            value: 0.0,
            reason: "at least one repetition is needed",
        });
    }
    if spec.particles.is_empty() {
        return Err(MpmError::InvalidParameter {
            name: "particles",
            value: 0.0,
            reason: "give at least one particle count",
        });
    }
    let mut rows = Vec::new();
    for &n in &spec.particles {
        let steps = spec.steps.unwrap_or_else(|| default_steps(n));
        memory::reset_peak();
        let before = memory::resident_bytes();
        let mut seconds = Vec::with_capacity(spec.reps);
        let mut setup_seconds = 0.0;
        let (mut n_grid, mut dt) = (0, 0.0);
        let mut dt_range = [f64::INFINITY, 0.0f64];
        let mut profile = spec.profile.then(Profile::default);
        let mut estimates = [0, 0];
        let mut counts = EstimateCounts::default();
        let mut simulated = Vec::with_capacity(spec.reps);
        for rep in 0..spec.reps {
            let start = Instant::now();
            let mut sim = problem(n, spec)?;
            let warm_up = sim.step()?;
            if rep == 0 {
                setup_seconds = start.elapsed().as_secs_f64();
                n_grid = sim.grid().cells()[0];
                dt = warm_up.dt;
            }
            sim.set_profiling(spec.profile);
            let (before_counts, before_time) = (sim.estimate_counts(), sim.time());
            let start = Instant::now();
            for _ in 0..steps {
                let before = sim.steps();
                let report = sim.step()?;
                if let Some((e, _)) = sim.frequency_estimate().filter(|&(_, at)| at == before) {
                    estimates[0] += 1;
                    estimates[1] += e.lanczos_steps;
                }
                dt_range[0] = dt_range[0].min(report.dt);
                dt_range[1] = dt_range[1].max(report.dt);
            }
            seconds.push(start.elapsed().as_secs_f64());
            simulated.push(sim.time() - before_time);
            let now = sim.estimate_counts();
            counts.estimates += now.estimates - before_counts.estimates;
            counts.estimate_steps += now.estimate_steps - before_counts.estimate_steps;
            counts.guards += now.guards - before_counts.guards;
            counts.guard_steps += now.guard_steps - before_counts.guard_steps;
            counts.raised += now.raised - before_counts.raised;
            if let (Some(total), Some(p)) = (&mut profile, sim.profile()) {
                total.merge(p);
            }
        }
        let peak = memory::peak_bytes();
        let row = BenchRow {
            particles: n,
            n_grid,
            steps,
            dt,
            dt_range,
            seconds,
            setup_seconds,
            peak_bytes_per_particle: match (peak, before) {
                (Some(p), Some(b)) => Some(p.saturating_sub(b) as f64 / n as f64),
                _ => None,
            },
            profile,
            estimates,
            counts,
            simulated,
        };
        observe(&row);
        rows.push(row);
    }
    Ok(rows)
}

/// Resident memory of this process, from `/proc/self` (Linux).
pub mod memory {
    /// A field of `/proc/self/status` in bytes (`VmRSS`, `VmHWM` …).
    fn status_bytes(field: &str) -> Option<u64> {
        let text = std::fs::read_to_string("/proc/self/status").ok()?;
        let line = text.lines().find(|l| l.starts_with(field))?;
        let kib: u64 = line[field.len()..]
            .trim_start_matches(':')
            .trim()
            .trim_end_matches("kB")
            .trim()
            .parse()
            .ok()?;
        Some(kib * 1024)
    }

    /// Resident set size now.
    pub fn resident_bytes() -> Option<u64> {
        status_bytes("VmRSS")
    }

    /// Peak resident set size since the process started or the last [`reset_peak`].
    pub fn peak_bytes() -> Option<u64> {
        status_bytes("VmHWM")
    }

    /// Resets the peak to the current resident size (writes 5 to `/proc/self/clear_refs`);
    /// does nothing where that is not possible.
    pub fn reset_peak() {
        let _ = std::fs::write("/proc/self/clear_refs", "5");
    }
}
