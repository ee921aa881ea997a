//! What a run will cost, estimated before it starts, against limits a user can raise.
//!
//! A scene file can ask for more than a machine has: a 10⁴ × 10⁴ grid with 32 × 32 particles
//! per cell, an end time of 10¹⁵ at a stable step of 10⁻⁶, a snapshot every 10⁻³⁰⁰ s. `mpm
//! check` and `mpm run` (and [`prepare_run`] in the library) estimate memory, steps and output
//! from the scene and the stable step of its initial state, and refuse a run above
//! [`Limits::default`] with an error naming the scene key that drives the cost, the estimate
//! and the limit. `--allow-large` ([`Limits::raised`]) lifts the limits.
//!
//! The estimates (documented in docs/reliability.md) are deliberately simple:
//!
//! ```text
//! particles   = Σ_bodies  (area of the body ∩ grid) / (hx hy) · ppc²       (rectangles, disks)
//!             + Σ_files   file bytes / 24                                   (CSV rows of about 24 bytes)
//! memory      = 800 B · particles + 200 B · nodes  (+ 600 B · nodes for a non-lumped mass)
//! steps       = ⌈end time / Δt⌉ for a fixed Δt (it stays fixed; only the last step may be
//!               shorter); for a CFL step (the CFL number × the stable step at t = 0), steps
//!               that also land on every snapshot time: about end time / Δt + one shortened
//!               step per snapshot interval
//! output      = snapshots · 490 B · particles + steps · 600 B (report rows)
//! snapshots   = end time / snapshot interval + 2
//! ```
//!
//! 800 B per particle is the measured peak of a quadratic-B-spline run with its stable-step
//! estimate (docs/performance.md); 490 B per particle the size of a `.vtp` snapshot with its
//! twelve arrays (40 components) in base64 (486 B measured on the two disks).

use std::fmt;

use crate::error::{MpmError, Result};
use crate::mass::MassScheme;
use crate::scene::{Geometry, Scene, SceneWarning};
use crate::simulation::Simulation;

/// Peak bytes per particle of a run (measured, quadratic B-splines, with the stable-step
/// estimate).
pub const BYTES_PER_PARTICLE: f64 = 800.0;
/// Bytes per grid node of the lumped-mass engine.
pub const BYTES_PER_NODE: f64 = 200.0;
/// Extra bytes per grid node of a consistent, blended, series or conjugate-gradient mass.
pub const BYTES_PER_NODE_CONSISTENT: f64 = 600.0;
/// Extra bytes per grid node of the Newmark integrator: the tangent, the Newton matrix and its
/// sparse LU (measured: 2,060–2,100 on the two disks at 200² and 400² cells, either mass).
pub const BYTES_PER_NODE_NEWTON: f64 = 2500.0;
/// Bytes per particle of one `.vtp` snapshot.
pub const SNAPSHOT_BYTES_PER_PARTICLE: f64 = 490.0;
/// Bytes per row of `report.csv`.
pub const REPORT_BYTES_PER_STEP: f64 = 600.0;
/// Bytes per particle row of a CSV particle file, for the estimate of its particle count.
pub const PARTICLE_FILE_BYTES_PER_ROW: f64 = 24.0;

/// What a run may cost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Estimated peak memory, bytes.
    pub memory_bytes: f64,
    /// Estimated output (snapshots and report), bytes.
    pub output_bytes: f64,
    /// Snapshots (each rewrites the `.pvd` list of all before it).
    pub snapshots: f64,
    /// Time steps.
    pub steps: f64,
}

impl Default for Limits {
    /// 8 GiB of memory, 20 GiB of output, 2000 snapshots, 10⁸ steps.
    fn default() -> Self {
        Limits {
            memory_bytes: 8.0 * GIB,
            output_bytes: 20.0 * GIB,
            snapshots: 2000.0,
            steps: 1e8,
        }
    }
}

impl Limits {
    /// No limits (`--allow-large`).
    pub fn raised() -> Limits {
        Limits {
            memory_bytes: f64::INFINITY,
            output_bytes: f64::INFINITY,
            snapshots: f64::INFINITY,
            steps: f64::INFINITY,
        }
    }
}

const GIB: f64 = 1024.0 * 1024.0 * 1024.0;

/// A run's estimated cost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Particles (exact once built).
    pub particles: f64,
    /// Grid nodes.
    pub nodes: f64,
    /// Peak memory, bytes.
    pub memory_bytes: f64,
    /// Snapshots.
    pub snapshots: f64,
    /// Time steps, when the step is known: as `mpm run` takes them ([`run_steps`]).
    pub steps: Option<f64>,
    /// Of `steps`, those shorter than Δt (to land on a snapshot time or on the end).
    pub shortened_steps: Option<f64>,
    /// Output bytes (snapshots, and the report when the steps are known).
    pub output_bytes: f64,
}

impl fmt::Display for Estimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "estimated cost: {} particles, {} nodes, memory {}, {} snapshots",
            count(self.particles),
            count(self.nodes),
            bytes(self.memory_bytes),
            count(self.snapshots)
        )?;
        if let Some(steps) = self.steps {
            write!(f, ", {} steps", count(steps))?;
            if let Some(shortened) = self.shortened_steps.filter(|&s| s > 0.0) {
                write!(
                    f,
                    " ({} of them shortened to land on snapshot times or the end)",
                    count(shortened)
                )?;
            }
        }
        write!(f, ", output {}", bytes(self.output_bytes))
    }
}

/// A count for people: `416`, `1.05e6`.
fn count(x: f64) -> String {
    if x < 1e5 {
        format!("{x:.0}")
    } else {
        format!("{x:.3e}")
    }
}

/// A byte count for people: `12.5 MiB` ([`crate::numbers::bytes`]).
fn bytes(b: f64) -> String {
    crate::numbers::bytes(b)
}

/// The memory this process can still have, in bytes, and where the bound comes from: the
/// least of the machine's available memory (`MemAvailable` of `/proc/meminfo`) and the room
/// left under the process's address-space and data-size limits (`ulimit -v`, `ulimit -d`:
/// `/proc/self/limits` less `VmSize` and `VmData` of `/proc/self/status`). `None` where none
/// of these is known (not Linux).
pub fn available_memory() -> Option<(f64, String)> {
    let kib = |text: &str, key: &str| -> Option<f64> {
        let line = text.lines().find(|l| l.starts_with(key))?;
        line[key.len()..]
            .split_whitespace()
            .next()?
            .parse::<f64>()
            .ok()
            .map(|k| 1024.0 * k)
    };
    let mut bound: Option<(f64, String)> = None;
    let mut least = |bytes: f64, from: String| {
        if bound.as_ref().is_none_or(|(b, _)| bytes < *b) {
            bound = Some((bytes.max(0.0), from));
        }
    };
    if let Ok(meminfo) = std::fs::read_to_string("/proc/meminfo") {
        if let Some(b) = kib(&meminfo, "MemAvailable:") {
            least(b, "the memory available on this machine".into());
        }
    }
    let limits = std::fs::read_to_string("/proc/self/limits").unwrap_or_default();
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    for (limit, used, name) in [
        ("Max address space", "VmSize:", "the address-space limit (ulimit -v)"),
        ("Max data size", "VmData:", "the data-size limit (ulimit -d)"),
    ] {
        let soft = limits
            .lines()
            .find(|l| l.starts_with(limit))
            .and_then(|l| l[limit.len()..].split_whitespace().next().map(str::to_string));
        if let Some(Ok(max)) = soft.map(|v| v.parse::<f64>()) {
            let used = kib(&status, used).unwrap_or(0.0);
            least(
                max - used,
                format!("{name} of {} less the {} in use", bytes(max), bytes(used)),
            );
        }
    }
    bound
}

/// Refuses an allocation of about `needed` bytes that this process cannot have
/// ([`available_memory`]) before it is made (an allocation that fails aborts the process: a
/// notebook's kernel, a worker):
///
/// ```text
/// needed > min(MemAvailable, limit_as − VmSize, limit_data − VmData)  →  MpmError::OutOfMemory
/// ```
///
/// `what` names the input that asked. Nothing is refused where the bound is not known.
///
/// # Errors
/// [`MpmError::OutOfMemory`] with the bytes needed and available.
pub fn ensure_memory(needed: f64, what: impl FnOnce() -> String) -> Result<()> {
    match available_memory() {
        Some((available, source_of_bound)) if needed > available => Err(MpmError::OutOfMemory {
            what: what(),
            needed,
            available,
            source_of_bound,
        }),
        _ => Ok(()),
    }
}

/// The estimate from the scene alone (no particle generated, no file read beyond its size):
/// particles, nodes, memory, snapshots, and the steps when `time.dt` is fixed.
pub fn estimate_scene(scene: &Scene) -> Estimate {
    let g = &scene.grid;
    let nodes = (g.cells[0] as f64 + 1.0) * (g.cells[1] as f64 + 1.0);
    let [hx, hy] = g.cell_size;
    let bounds = [
        g.origin[0],
        g.origin[0] + g.cells[0] as f64 * hx,
        g.origin[1],
        g.origin[1] + g.cells[1] as f64 * hy,
    ];
    let clip = |lo: f64, hi: f64, a: f64, b: f64| (hi.min(b) - lo.max(a)).max(0.0);
    let mut particles = 0.0;
    for (k, body) in scene.bodies.iter().enumerate() {
        let ppc = (body.particles_per_cell as f64).powi(2);
        particles += match &body.geometry {
            // Only a path that passes the scene's checks is looked at (the build refuses the
            // others, naming them).
            Geometry::File(_) => match scene.particle_file_path(k) {
                Ok(Some(path)) => {
                    std::fs::metadata(&path).map_or(0.0, |m| m.len() as f64) / PARTICLE_FILE_BYTES_PER_ROW
                }
                _ => 0.0,
            },
            // The box clipped to the grid, or the shape's area where smaller.
            geometry => geometry.bounding_box().map_or(0.0, |(lo, hi)| {
                let square = clip(lo[0], hi[0], bounds[0], bounds[1]) * clip(lo[1], hi[1], bounds[2], bounds[3]);
                square.min(geometry.area().unwrap_or(f64::INFINITY)) / (hx * hy) * ppc
            }),
        };
    }
    let consistent = [scene.schemes.mass.velocity, scene.schemes.mass.acceleration]
        .iter()
        .any(MassScheme::needs_consistent_matrix);
    let memory_bytes = BYTES_PER_PARTICLE * particles
        + BYTES_PER_NODE * nodes
        + if consistent {
            BYTES_PER_NODE_CONSISTENT * nodes
        } else {
            0.0
        }
        + match scene.schemes.integrator {
            crate::simulation::Integrator::Newmark(_) | crate::simulation::Integrator::QuasiStatic(_) => {
                BYTES_PER_NODE_NEWTON * nodes
            }
            crate::simulation::Integrator::Explicit => 0.0,
        };
    let end = scene.time.end;
    let snapshots = end / scene.snapshot_interval() + 2.0;
    // A fixed step stays fixed: no landing on snapshot times (crate::run::SnapshotClock).
    let counted = scene.time.dt.map(|dt| run_steps(end, dt, None));
    let steps = counted.map(|c| c.0);
    Estimate {
        particles,
        nodes,
        memory_bytes,
        snapshots,
        steps,
        shortened_steps: counted.map(|c| c.1),
        output_bytes: output_bytes(particles, snapshots, steps),
    }
}

/// Most steps [`run_steps`] counts one by one; above, it gives the upper bound.
const MAX_COUNTED_STEPS: f64 = 1e7;

/// The steps of a run from 0 to `end` at a step of at most `dt`, as `mpm run` takes them, and
/// how many of them are shorter than `dt`.
///
/// With `landing = None` (a fixed step, which stays fixed) every step is `dt` but the last,
/// which may be shortened to end at `end`: ⌈end / Δt⌉ steps. With `landing = Some(interval)`
/// (a CFL step) the steps also land on every snapshot time (multiples of `interval`), so each
/// interval ends with a shortened step unless `dt` divides it, and a run takes up to one step
/// per snapshot more than `end / dt`.
///
/// Counted with the run's own arithmetic (the same sums, the same tolerance of 10⁻¹² for
/// having reached a time) up to `MAX_COUNTED_STEPS`; above, the upper bound
/// (`⌈end / Δt⌉ + ⌈end / interval⌉` when landing).
pub fn run_steps(end: f64, dt: f64, landing: Option<f64>) -> (f64, f64) {
    if !(dt > 0.0 && end.is_finite() && landing.is_none_or(|i| i > 0.0)) {
        return (f64::INFINITY, 0.0);
    }
    let intervals = landing.map_or(0.0, |interval| (end / interval).ceil());
    if end / dt + intervals > MAX_COUNTED_STEPS {
        return ((end / dt).ceil() + intervals, intervals.max(1.0));
    }
    let (mut time, mut next) = (0.0_f64, landing.unwrap_or(f64::INFINITY));
    let (mut steps, mut shortened) = (0.0, 0.0);
    while time < end * (1.0 - 1e-12) {
        let target = next.min(end);
        let room = target - time;
        // (Not a step short of `dt` by rounding only.)
        if room < dt * (1.0 - 1e-9) {
            shortened += 1.0;
        }
        time += dt.min(room);
        steps += 1.0;
        if let Some(interval) = landing {
            if time >= next * (1.0 - 1e-12) {
                next += interval;
            }
        }
    }
    (steps, shortened)
}

fn output_bytes(particles: f64, snapshots: f64, steps: Option<f64>) -> f64 {
    snapshots * SNAPSHOT_BYTES_PER_PARTICLE * particles + steps.unwrap_or(0.0) * REPORT_BYTES_PER_STEP
}

/// `estimate` against `limits`, naming the scene key that drives what is over.
///
/// # Errors
/// [`MpmError::InvalidScene`] naming the key (`grid.cells` or `bodies` for memory,
/// `output.snapshot_interval` for snapshots, `time.end` for steps and output), the estimate and
/// the limit, and saying how to raise it.
pub fn check(estimate: &Estimate, limits: &Limits, scene: &Scene) -> Result<()> {
    let raise = "check the scene, or raise the limit with --allow-large (docs/reliability.md)";
    let over = |key: String, what: String| -> Result<()> { Err(MpmError::InvalidScene { key, reason: what }) };
    if estimate.memory_bytes > limits.memory_bytes {
        let key = if BYTES_PER_NODE * estimate.nodes > BYTES_PER_PARTICLE * estimate.particles {
            "grid.cells".to_string()
        } else {
            "bodies".to_string()
        };
        return over(
            key,
            format!(
                "the run would need about {} of memory ({} particles, {} nodes), more than the limit of {}; {raise}",
                bytes(estimate.memory_bytes),
                count(estimate.particles),
                count(estimate.nodes),
                bytes(limits.memory_bytes)
            ),
        );
    }
    // Whatever the limits (also with --allow-large): what this process cannot have.
    ensure_memory(estimate.memory_bytes, || {
        format!(
            "the scene ({} particles, {} nodes)",
            count(estimate.particles),
            count(estimate.nodes)
        )
    })?;
    if estimate.snapshots > limits.snapshots {
        return over(
            "output.snapshot_interval".into(),
            format!(
                "{} gives {} snapshots over time.end = {}, more than the limit of {}; {raise}",
                scene.snapshot_interval(),
                count(estimate.snapshots),
                scene.time.end,
                count(limits.snapshots)
            ),
        );
    }
    if let Some(steps) = estimate.steps {
        if steps > limits.steps {
            return over(
                "time.end".into(),
                format!(
                    "{} at the time step of the scene takes about {} steps, more than the limit of {}; {raise}",
                    scene.time.end,
                    count(steps),
                    count(limits.steps)
                ),
            );
        }
    }
    if estimate.output_bytes > limits.output_bytes {
        return over(
            "time.end".into(),
            format!(
                "{} would write about {} of snapshots and report, more than the limit of {}; {raise}",
                scene.time.end,
                bytes(estimate.output_bytes),
                bytes(limits.output_bytes)
            ),
        );
    }
    Ok(())
}

/// The scene's warnings ([`Scene::warnings`], which builds its particles) when its estimate
/// is within `limits`; none above them, where the run is refused before any particle is made.
pub fn scene_warnings(scene: &Scene, limits: &Limits) -> Vec<SceneWarning> {
    if check(&estimate_scene(scene), limits, scene).is_err() {
        return Vec::new();
    }
    scene.warnings()
}

/// Everything `mpm run` checks before its first step, in the order it checks them, and the
/// simulation it would run: the scene estimate against `limits`, the build (particles, options,
/// the stable time step), then the steps and output with the particle count and stable step of
/// the built simulation. `mpm check` calls exactly this.
///
/// # Errors
/// The errors of [`check`] and [`Scene::build`], with the scene file and line of their key
/// ([`Scene::locate`]).
pub fn prepare_run(scene: &Scene, limits: &Limits) -> Result<(Simulation, Estimate)> {
    let mut estimate = estimate_scene(scene);
    check(&estimate, limits, scene).map_err(|e| scene.locate(e))?;
    let sim = scene.build()?;
    estimate.particles = sim.particles().len() as f64;
    let end = scene.time.end;
    let (dt, landing) = match (scene.time.dt, scene.time.cfl) {
        (Some(dt), _) => (dt, None),
        (None, cfl) => (
            cfl.unwrap_or(0.5) * sim.stable_time_step(),
            Some(scene.snapshot_interval()),
        ),
    };
    let counted = (dt > 0.0).then(|| run_steps(end, dt, landing));
    estimate.steps = counted.map(|c| c.0);
    estimate.shortened_steps = counted.map(|c| c.1);
    estimate.output_bytes = output_bytes(estimate.particles, estimate.snapshots, estimate.steps);
    check(&estimate, limits, scene).map_err(|e| scene.locate(e))?;
    Ok((sim, estimate))
}
