//! The library's error type.
//!
//! Every variant carries the data a user needs to act on it: which particle, which node, which
//! field, which value. User data (particle states, grid parameters, files) never causes a panic;
//! it produces one of these. Each variant's message is its `#[error]` attribute;
//! [`MpmError::Io`] gives the underlying I/O error as its source.

use std::path::{Path, PathBuf};

use crate::numbers::human;

/// Everything that can go wrong with user data.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MpmError {
    /// A grid parameter is unusable (non-positive cell size, no cells, non-finite origin …).
    #[error("invalid grid: {reason}")]
    InvalidGrid {
        /// What is wrong, in words.
        reason: String,
    },
    /// Node coordinate vectors do not describe a uniform grid in a supported node order.
    #[error("node coordinates do not form a uniform grid: {reason}")]
    NotAUniformGrid {
        /// What is wrong, naming the offending node (0-based) where there is one.
        reason: String,
    },
    /// Two inputs that must have the same length do not.
    #[error("`{field}` has {found} entries but {expected} are required (one per particle)")]
    LengthMismatch {
        /// The field whose length is wrong.
        field: &'static str,
        /// The length it must have.
        expected: usize,
        /// The length it has.
        found: usize,
    },
    /// A particle's field holds an unusable value (NaN, infinity, non-positive mass …).
    #[error("particle {particle}: `{field}` = {value} is invalid: {reason}")]
    InvalidParticleValue {
        /// 0-based particle index.
        particle: usize,
        /// The field (`"mass"`, `"x"`, `"sigma_xx"` …).
        field: &'static str,
        /// The offending value.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// A particle lies outside the background grid, so it has no shape-function support.
    #[error(
        "particle {particle} at ({}, {}) lies outside the grid [{}, {}] x [{}, {}]",
        .position[0], .position[1], .bounds[0], .bounds[1], .bounds[2], .bounds[3]
    )]
    ParticleOutsideGrid {
        /// 0-based particle index.
        particle: usize,
        /// Particle position.
        position: [f64; 2],
        /// Grid bounds `[x_min, x_max, y_min, y_max]`.
        bounds: [f64; 4],
    },
    /// A particle is inside the grid, but closer to its edge than the shape function's
    /// margin: its support would need nodes outside the grid (see
    /// [`ShapeFunction::margin`](crate::ShapeFunction::margin)).
    #[error(
        "particle {particle} at ({}, {}): the {shape} support needs nodes outside the grid; particles \
         must stay inside [{}, {}] x [{}, {}] (pad the grid by {padding} cell{} on each side)",
        .position[0], .position[1], .allowed[0], .allowed[1], .allowed[2], .allowed[3], plural(*.padding)
    )]
    SupportOutsideGrid {
        /// 0-based particle index.
        particle: usize,
        /// Particle position.
        position: [f64; 2],
        /// The shape-function family ([`ShapeFunction::name`](crate::ShapeFunction::name)).
        shape: &'static str,
        /// Where particles are accepted, `[x_min, x_max, y_min, y_max]`
        /// ([`ShapeFunction::allowed_region`](crate::ShapeFunction::allowed_region)).
        allowed: [f64; 4],
        /// Cells of padding on each side that keep such particles' supports inside
        /// ([`ShapeFunction::recommended_padding`](crate::ShapeFunction::recommended_padding)).
        padding: usize,
    },
    /// A material or step parameter is unusable.
    #[error("parameter `{name}` = {value} is invalid: {reason}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The admissible range, in words.
        reason: &'static str,
    },
    /// A simulation option is unusable or contradicts another one.
    #[error("option `{option}`: {reason}")]
    InvalidOption {
        /// The option's path in [`Options`](crate::simulation::Options): `"time_step.dt"`,
        /// `"time_step.cfl"`, `"transfer.flip"`, `"transfer.k"`, `"transfer"`, `"gravity"` …
        option: &'static str,
        /// What is wrong and what would be accepted.
        reason: String,
    },
    /// The consistent mass matrix restricted to the active nodes is singular (or so close to it
    /// that a solve would return garbage).
    #[error(
        "the consistent mass matrix is singular at node {node} ({}; particles touching it: \
         {particles:?}): {cause}",
        pivot_text(*.relative_pivot)
    )]
    SingularMassMatrix {
        /// The node (grid numbering, 0-based) at which the Cholesky factorization broke down.
        node: usize,
        /// The particles whose shape functions touch that node.
        particles: Vec<usize>,
        /// Pivot found at that node divided by the node's diagonal entry `M_ii`; 0 when the
        /// factorization met a pivot that was zero or negative (faer does not report its value);
        /// NaN when the stable step found the matrix nearly singular
        /// ([`NEARLY_SINGULAR_RATIO`](crate::simulation::NEARLY_SINGULAR_RATIO)).
        relative_pivot: f64,
        /// Why this happens, in words.
        cause: String,
    },
    /// A sparse factorization failed for a reason other than singularity (out of memory …).
    #[error("sparse solver failed: {reason}")]
    Solver {
        /// The solver's message.
        reason: String,
    },
    /// A scene (or simulation setting) is unusable: a key has a wrong value, a required key is
    /// missing, or settings contradict each other.
    #[error("`{key}`: {reason}")]
    InvalidScene {
        /// Where: the key's dotted path (`bodies[1].material`, `time.dt`).
        key: String,
        /// What is wrong and what would be accepted.
        reason: String,
    },
    /// A particle inverted or collapsed: `det(I + Δt L) ≤ 0` or `det F ≤ 0` after the update.
    #[error(
        "step {step}: particle {particle} (id {id}, body `{body}`) inverted: det(I + Δt L) = \
         {}, det F = {}; reduce the time step (Courant number) or check the material \
         and loads",
        human(*.det_increment), human(*.det_f)
    )]
    InvertedParticle {
        /// Step number (from 0) at which it happened.
        step: usize,
        /// 0-based particle index (in the simulation's current order).
        particle: usize,
        /// The particle's stable id.
        id: usize,
        /// Name of the body it belongs to.
        body: String,
        /// Determinant of the increment, `det(I + Δt L)`.
        det_increment: f64,
        /// Determinant of the updated deformation gradient, `det F`.
        det_f: f64,
    },
    /// A quantity became NaN or infinite.
    #[error(
        "step {step}: particle {particle} (id {id}) has a non-finite {stage} ({}, {}); reduce the time step",
        .value[0], .value[1]
    )]
    NonFinite {
        /// Step number (from 0) at which it happened.
        step: usize,
        /// Which quantity, e.g. `"particle velocity"`.
        stage: &'static str,
        /// 0-based particle index (in the simulation's current order).
        particle: usize,
        /// The particle's stable id.
        id: usize,
        /// The offending value (both components of a vector).
        value: [f64; 2],
    },
    /// A CFL time step was asked for but nothing sets a wave speed or particle speed (no
    /// particles, or no stiffness and no motion).
    #[error("step {step}: no stiffness or particle speed to set a CFL time step (no particles?); use a fixed `dt`")]
    NoStableTimeStep {
        /// Step number (from 0) at which it happened.
        step: usize,
    },
    /// A step was asked for after an earlier step failed; the state is not usable.
    #[error("step {step}: an earlier step failed ({cause}); the state is not usable")]
    EarlierFailure {
        /// Step number (from 0) of the refused step.
        step: usize,
        /// The earlier error, as text.
        cause: String,
    },
    /// A fixed time step exceeds the stable step of the update with the chosen masses.
    #[error(
        "step {step}: the fixed time step {} exceeds the stable step {} of the update with \
         {masses} mass (estimated from the operators, material stiffness and masses; {:.1}% over); use a \
         smaller `dt`, a CFL step (`cfl = 0.5`), or set `allow_unstable = true`",
        human(*.dt), human(*.stable), 100.0 * (*.dt / *.stable - 1.0)
    )]
    TimeStepAboveStable {
        /// Step number (from 0) at which the stable step was estimated.
        step: usize,
        /// The fixed step asked for.
        dt: f64,
        /// The stable step estimate (safety factor included).
        stable: f64,
        /// The masses of the velocity and acceleration solves, as labels.
        masses: String,
    },
    /// A checkpoint ([`Simulation::read_checkpoint`](crate::simulation::Simulation::read_checkpoint))
    /// cannot be resumed: not a checkpoint, written in another format version, truncated,
    /// corrupted (its checksum does not match), or holding a state that does not hold together.
    #[error("checkpoint{}: {reason}", in_file(.path.as_deref()))]
    Checkpoint {
        /// The file; `None` for bytes given in memory
        /// ([`Simulation::from_checkpoint_bytes`](crate::simulation::Simulation::from_checkpoint_bytes)).
        path: Option<PathBuf>,
        /// What is wrong, in words.
        reason: String,
    },
    /// The output folder of a run already holds files (`mpm run --overwrite` replaces them).
    #[error(
        "the output folder {path} already holds {count} file(s) ({}{}); use --overwrite to replace an earlier \
         run's output there, or --out to choose another folder",
        .examples.join(", "), if *.count > .examples.len() { ", …" } else { "" }
    )]
    OutputExists {
        /// The folder.
        path: PathBuf,
        /// How many entries it holds.
        count: usize,
        /// A few of their names.
        examples: Vec<String>,
    },
    /// The Newton iteration of an implicit step did not converge.
    #[error(
        "step {step}: the Newton iteration of the implicit step did not converge after {iterations} \
         iteration(s) (relative residual {residual:.3e}): {reason}"
    )]
    NewtonFailed {
        /// The step (counted from 1, as report.csv).
        step: usize,
        /// Newton iterations done.
        iterations: usize,
        /// The last relative residual.
        residual: f64,
        /// What went wrong and what to change.
        reason: String,
    },
    /// An implicit step that cannot be taken as it is: its Newton matrix is singular, or its
    /// converged displacement would carry a particle where the shape functions do not reach.
    /// Nothing of the step is applied.
    #[error("step {step}: the Newmark step cannot be taken: {reason}")]
    StepRejected {
        /// The step (counted from 1, as report.csv).
        step: usize,
        /// Why, and what to change.
        reason: String,
    },
    /// The output folder is in use by another run (it holds the folder's lock).
    #[error(
        "the output folder {path} is in use by another run (mpm run or mpm resume); wait for it to end, or choose \
         another folder with --out"
    )]
    OutputInUse {
        /// The folder.
        path: PathBuf,
    },
    /// `--overwrite` found files a run would write that no earlier run's manifest lists: they
    /// are not the output of a run, and nothing is removed.
    #[error(
        "the output folder {path} holds {} that no earlier run's manifest (manifest.json) lists; --overwrite \
         removes only what a run wrote there, so nothing was removed: move {} away, or choose another folder with \
         --out",
        .names.join(", "), if .names.len() == 1 { "it" } else { "them" }
    )]
    OutputNotOwned {
        /// The folder.
        path: PathBuf,
        /// The names that are not listed (a few).
        names: Vec<String>,
    },
    /// A snapshot (`.vtp`) or time series (`.pvd`) cannot be read
    /// (`sparse_mpm_cli::vtk::read_vtp`, `sparse_mpm_cli::vtk::read_pvd`: the `mpm` program's reader):
    /// not such a file, an encoding this reader does not take, truncated or inconsistent data.
    #[error("{path}: {reason}")]
    Snapshot {
        /// The file.
        path: PathBuf,
        /// What is wrong, in words.
        reason: String,
    },
    /// What an input asks for needs more memory than this process can have
    /// ([`crate::limits::ensure_memory`]): refused before the allocation, which would abort the
    /// process.
    #[error(
        "{what} would need about {} of memory, more than the {} this process can have ({source_of_bound})",
        crate::numbers::bytes(*needed),
        crate::numbers::bytes(*available)
    )]
    OutOfMemory {
        /// What asked, naming the input (a scene key, an argument).
        what: String,
        /// Bytes needed (estimated).
        needed: f64,
        /// Bytes this process can have.
        available: f64,
        /// Where the bound comes from (the machine's available memory, the process's limit).
        source_of_bound: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
}

/// `"s"` for a count other than one.
fn plural(count: usize) -> &'static str {
    if count == 1 {
        ""
    } else {
        "s"
    }
}

/// How a singular mass matrix's pivot reads in its message: its relative value, or that it was
/// not positive.
fn pivot_text(relative_pivot: f64) -> String {
    if relative_pivot.is_nan() {
        "nearly singular, found by the stable step".to_string()
    } else if relative_pivot > 0.0 {
        format!("relative pivot {relative_pivot:.3e}")
    } else {
        "non-positive pivot".to_string()
    }
}

/// `" <file>"` naming a checkpoint's file in its message, nothing for bytes given in memory.
fn in_file(path: Option<&Path>) -> String {
    path.map_or(String::new(), |p| format!(" {}", p.display()))
}

/// Shorthand for results whose error is [`MpmError`].
pub type Result<T> = std::result::Result<T, MpmError>;
