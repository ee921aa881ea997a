//! Scene files: a whole simulation described in TOML, read strictly (an unknown key is an
//! error), and the [`Scene`] type a program can build and save the same way.
//!
//! ```toml
//! title = "two elastic disks"
//!
//! [grid]
//! origin = [0.0, 0.0]
//! cell_size = [0.05, 0.05]
//! cells = [20, 20]
//!
//! [schemes]                      # every key optional; defaults shown
//! shape = "linear"               # "quadratic_bspline", "cubic_bspline", { gimp = { half_width = 0.25 } }
//! update = "usl"                 # "usf", "musl"
//! transfer = "flip"              # "pic", "apic", { blend = { flip = 0.95 } }, { fmpm = { k = 8 } }, { xpic = { k = 4 } }
//! position_update = "grid_velocity"   # or "trapezoidal"
//! sort_interval = 50             # re-sort particles by cell every 50 steps (0: never)
//! mass = { velocity = "lumped", acceleration = "lumped", singularity = "error" }
//!                                # stabilization = { partial_lumping = { threshold = 0.5 } } (consistent mass)
//!
//! [time]
//! end = 3.0
//! cfl = 0.5                      # or dt = 1e-3 (checked against the stable estimate)
//! allow_unstable = false
//! stability_interval = 100       # steps between estimates of the stable step
//!
//! [loads]
//! gravity = [0.0, 0.0]
//!
//! [[bodies]]
//! name = "left disk"
//! material = { model = "linear_elastic", youngs_modulus = 1000.0, poisson_ratio = 0.3, plane = "strain" }
//! density = 1000.0
//! particles_per_cell = 2         # per axis
//! velocity = [0.1, 0.1]
//! geometry = { disk = { center = [0.25, 0.25], radius = 0.2 } }
//!
//! [[boundaries]]
//! edge = "bottom"
//! condition = "slip"
//!
//! [output]
//! snapshot_interval = 0.05       # time between particle snapshots (default: end / 50)
//! ```
//!
//! Geometries: `{ rectangle = { min = [x, y], max = [x, y] } }`, `{ disk = { center = [x, y],
//! radius = r } }`, `{ file = "particles.csv" }` (a CSV file with a header naming at least `x`,
//! `y` and `volume`, optionally `vx`, `vy`, `mass` (default `density × volume`), `sxx`, `syy`,
//! `sxy`; lines starting with `#` are comments; a relative path is taken from the scene file's
//! folder). Rectangles and disks are filled with `particles_per_cell²` particles per grid cell,
//! at the centres of a regular sub-lattice of the grid cells, each of volume
//! `hx hy / particles_per_cell²` and mass `density × volume`.
//!
//! ## What a scene file may ask for
//! A scene file is input like any other and is read defensively:
//!
//! - A particle file must lie in the scene file's folder or below it: an absolute path, a path
//!   whose `..` leave the folder, or a symbolic link that leads out of it is refused (a program
//!   that trusts its scenes can set [`Scene::allow_outside_files`]). Only regular files are read
//!   (not devices, pipes or folders), and at most [`MAX_PARTICLE_FILE_BYTES`] of them. An error
//!   about a particle file names its line and column and what is wrong; it shows nothing of a
//!   file whose header is not a particle-file header, and of a particle file at most a short
//!   word of the offending cell.
//! - Every number is checked where it is given, and an error names the key and the value:
//!   NaN and infinities are refused everywhere; accelerations (`loads.gravity`,
//!   `bodies[k].body_force`) are bounded by [`MAX_ACCELERATION`] and speeds (`bodies[k].velocity`,
//!   a particle file's `vx`, `vy`, a boundary's `vx`, `vy`) by [`MAX_SPEED`]; the grid's origin
//!   by [`MAX_ORIGIN_CELLS`] cell sizes.
//! - A boundary's `nodes` list names each node once and is no longer than the grid's node count.

use std::io::Read;
use std::path::{Component, Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::boundary::BoundaryCondition;
use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::mass::{MassOptions, MassScheme, SingularityPolicy, Stabilization};
use crate::material::Material;
use crate::numbers::exact;
use crate::particles::Particles;
use crate::schemes::PositionUpdate;
use crate::shape::ShapeFunction;
use crate::simulation::{Body, Options, Simulation, TimeStep, Transfer, UpdateScheme};

/// A complete simulation description.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// A line describing the scene.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub title: Option<String>,
    /// The background grid.
    pub grid: GridSpec,
    /// Shape function, update scheme, transfer, mass treatment.
    #[serde(default)]
    pub schemes: Schemes,
    /// End time and time-step control.
    pub time: TimeSpec,
    /// Gravity.
    #[serde(default)]
    pub loads: Loads,
    /// The bodies (at least one).
    pub bodies: Vec<BodySpec>,
    /// Nodal boundary conditions.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub boundaries: Vec<BoundaryCondition>,
    /// What to write.
    #[serde(default)]
    pub output: OutputSpec,
    /// The folder relative paths (particle files) are taken from; set by [`Scene::load`]. When
    /// `None`, the current directory.
    #[serde(skip)]
    pub base_dir: Option<PathBuf>,
    /// Read particle files wherever their paths lead (absolute paths, `..` out of
    /// [`Scene::base_dir`], symbolic links out of it). `false` (the default, and what a scene
    /// read from TOML gets; it is not a key of the file): a particle file must lie inside the
    /// scene's folder, so that a scene from elsewhere cannot make the program read, and report
    /// on, files it was not meant to. Only a program that trusts its scenes should set it.
    #[serde(skip)]
    pub allow_outside_files: bool,
}

/// The uniform background grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    /// Lower-left corner.
    #[serde(default)]
    pub origin: [f64; 2],
    /// Cell size `[hx, hy]`.
    pub cell_size: [f64; 2],
    /// Cells along x and y.
    pub cells: [usize; 2],
}

/// The independent algorithmic choices.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Schemes {
    /// Shape-function family.
    pub shape: ShapeFunction,
    /// USF, USL or MUSL.
    pub update: UpdateScheme,
    /// PIC, FLIP, blend or APIC.
    pub transfer: Transfer,
    /// Position update rule.
    pub position_update: PositionUpdate,
    /// Mass schemes of the two solves and the singularity policy.
    pub mass: MassOptions,
    /// Re-sort particles by cell every this many steps (0: never).
    pub sort_interval: usize,
}

impl Default for Schemes {
    fn default() -> Self {
        let o = Options::default();
        Schemes {
            shape: o.shape,
            update: o.update,
            transfer: o.transfer,
            position_update: o.position_update,
            mass: o.mass,
            sort_interval: o.sort_interval,
        }
    }
}

/// End time and time step: exactly one of `dt` and `cfl` (neither: `cfl = 0.5`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeSpec {
    /// End time of the run.
    pub end: f64,
    /// Fixed time step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dt: Option<f64>,
    /// Courant number of a step recomputed every step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cfl: Option<f64>,
    /// Accept a fixed step above the stable estimate.
    #[serde(default)]
    pub allow_unstable: bool,
    /// Re-estimate the stable step every this many steps (default
    /// [`crate::simulation::DEFAULT_STABILITY_INTERVAL`]; 0: only before the first step).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stability_interval: Option<usize>,
}

/// Loads applied to every particle.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Loads {
    /// Gravitational acceleration.
    pub gravity: [f64; 2],
}

/// Where a body's particles are.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Geometry {
    /// The axis-aligned rectangle `[min, max]`.
    Rectangle {
        /// Lower-left corner.
        min: [f64; 2],
        /// Upper-right corner.
        max: [f64; 2],
    },
    /// The disk `|x − center| < radius`.
    Disk {
        /// Centre.
        center: [f64; 2],
        /// Radius.
        radius: f64,
    },
    /// Particles listed in a CSV file (columns `x`, `y`, `volume`, optionally `vx`, `vy`, `mass`,
    /// `sxx`, `syy`, `sxy`).
    File(PathBuf),
}

/// One body of the scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Name (reports, errors).
    pub name: String,
    /// Constitutive model.
    pub material: Material,
    /// Reference density (mass per unit area, unit thickness).
    pub density: f64,
    /// Particles per cell along each axis (rectangles and disks).
    #[serde(default = "default_ppc")]
    pub particles_per_cell: usize,
    /// Initial velocity of every particle (added to a file's `vx`, `vy`).
    #[serde(default)]
    pub velocity: [f64; 2],
    /// Body force per unit mass besides gravity.
    #[serde(default)]
    pub body_force: [f64; 2],
    /// Where the particles are.
    pub geometry: Geometry,
}

/// Largest grid accepted from a scene file (nodes).
pub const MAX_NODES: f64 = 1e8;

/// Largest `particles_per_cell` (per axis) accepted from a scene file.
pub const MAX_PARTICLES_PER_CELL: usize = 32;

/// Largest magnitude of an acceleration accepted from a scene file (`loads.gravity`,
/// `bodies[k].body_force`): 10¹² in the scene's units, some 10¹¹ g in SI units. Above it a run
/// only overflows (a particle's velocity after one step, its travel over the run).
pub const MAX_ACCELERATION: f64 = 1e12;

/// Largest speed accepted from a scene file (`bodies[k].velocity`, the `vx`, `vy` columns of a
/// particle file, a boundary's `vx`, `vy`): 10¹² in the scene's units. The step's reports
/// square speeds, which overflows from about 10¹⁵⁴ on.
pub const MAX_SPEED: f64 = 1e12;

/// How far from zero the grid's origin may lie, in cell sizes of the same axis: 10¹². There a
/// coordinate resolves about 2·10⁻⁴ of a cell; further out, positions within a cell lose their
/// meaning.
pub const MAX_ORIGIN_CELLS: f64 = 1e12;

/// Largest particle file read, in bytes (1 GiB). A larger file is refused from its size before
/// anything is read, and no more than this is ever read from a file that grows or reports a
/// wrong size.
pub const MAX_PARTICLE_FILE_BYTES: u64 = 1 << 30;

fn default_ppc() -> usize {
    2
}

/// What a run writes.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OutputSpec {
    /// Time between particle snapshots (default: a fiftieth of the run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub snapshot_interval: Option<f64>,
}

fn invalid(key: impl Into<String>, reason: impl Into<String>) -> MpmError {
    MpmError::InvalidScene {
        key: key.into(),
        reason: reason.into(),
    }
}

/// `[x, y]` with [`num`].
fn pair(v: [f64; 2]) -> String {
    format!("[{}, {}]", exact(v[0]), exact(v[1]))
}

/// An [`MpmError::InvalidParameter`] of a part of the scene (a material, a mass scheme …)
/// restated at the key `{prefix}.{name}` with its value; other errors at `prefix`.
fn parameter_error(prefix: &str, e: MpmError) -> MpmError {
    match e {
        MpmError::InvalidParameter { name, value, reason } => invalid(
            format!("{prefix}.{name}"),
            format!("{} is invalid: {reason}", exact(value)),
        ),
        e => invalid(prefix, e.to_string()),
    }
}

/// The TOML key of a mass scheme's table (`blended`, `iterative` …), empty for unit variants.
fn mass_scheme_key(scheme: &MassScheme) -> &'static str {
    match scheme {
        MassScheme::Blended { .. } => ".blended",
        MassScheme::TruncatedSeries { .. } => ".truncated_series",
        MassScheme::Iterative { .. } => ".iterative",
        MassScheme::Lumped | MassScheme::Consistent => "",
    }
}

impl Scene {
    /// Parses a scene from TOML text.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] with the parser's message (line, column, the key and what is
    /// wrong: unknown key, missing key, wrong type), then the checks of [`Scene::validate`].
    pub fn from_toml_str(text: &str) -> Result<Scene> {
        let scene: Scene = toml::from_str(text).map_err(|e| {
            let place = e.span().map(|s| {
                let start = s.start.min(text.len());
                let line = text[..start].matches('\n').count() + 1;
                // Name the key written on that line (or the table header) as well.
                let source = text.lines().nth(line - 1).unwrap_or("").trim();
                let key = match source.split_once('=') {
                    Some((k, _)) if !source.starts_with('[') => k.trim(),
                    _ => source,
                };
                if key.is_empty() {
                    format!("line {line}")
                } else {
                    format!("line {line}, {key}")
                }
            });
            invalid(place.unwrap_or_else(|| "scene".into()), e.message().trim().to_string())
        })?;
        scene.validate()?;
        Ok(scene)
    }

    /// Reads a scene file; relative particle-file paths are taken from its folder.
    ///
    /// # Errors
    /// [`MpmError::Io`] naming the file, and the errors of [`Scene::from_toml_str`].
    pub fn load(path: &Path) -> Result<Scene> {
        let text = std::fs::read_to_string(path).map_err(|source| MpmError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let mut scene = Scene::from_toml_str(&text).map_err(|e| match e {
            MpmError::InvalidScene { key, reason } => invalid(format!("{}: {key}", path.display()), reason),
            e => e,
        })?;
        scene.base_dir = path.parent().map(Path::to_path_buf);
        Ok(scene)
    }

    /// The scene as TOML text; [`Scene::from_toml_str`] reads it back to an equal scene.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] when a value has no TOML form (a particle-file path that is
    /// not valid UTF-8).
    pub fn to_toml_string(&self) -> Result<String> {
        toml::to_string(self).map_err(|e| invalid("scene", format!("cannot be written as TOML: {e}")))
    }

    /// Checks what the file format cannot: positive sizes and times, one time-step rule, at
    /// least one body, sensible body parameters, finite and bounded numbers everywhere (see the
    /// [module docs](self)), boundary conditions that fit the grid.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] naming the key (`time.dt`, `bodies[1].density`,
    /// `schemes.mass.pivot_tolerance` …) and its value.
    pub fn validate(&self) -> Result<()> {
        let g = &self.grid;
        for (k, h) in g.cell_size.iter().enumerate() {
            if !(h.is_finite() && *h > 0.0) {
                return Err(invalid(
                    format!("grid.cell_size[{k}]"),
                    format!("{} must be positive and finite", exact(*h)),
                ));
            }
        }
        for (k, o) in g.origin.iter().enumerate() {
            if !o.is_finite() {
                return Err(invalid(
                    format!("grid.origin[{k}]"),
                    format!("{} must be finite", exact(*o)),
                ));
            }
            let h = g.cell_size[k];
            if o.abs() > MAX_ORIGIN_CELLS * h {
                return Err(invalid(
                    format!("grid.origin[{k}]"),
                    format!(
                        "{} is too far from zero for cells of {}: at most {} cell sizes are accepted (further out, \
                         positions within a cell lose their precision)",
                        exact(*o),
                        exact(h),
                        exact(MAX_ORIGIN_CELLS)
                    ),
                ));
            }
        }
        for (k, c) in g.cells.iter().enumerate() {
            if *c == 0 {
                return Err(invalid(
                    format!("grid.cells[{k}]"),
                    "the grid needs at least one cell per axis",
                ));
            }
        }
        let nodes = (g.cells[0] as f64 + 1.0) * (g.cells[1] as f64 + 1.0);
        if nodes > MAX_NODES {
            return Err(invalid(
                "grid.cells",
                format!(
                    "{:?} cells make {nodes:.3e} nodes, more than the {MAX_NODES:.0e} this program accepts \
                     (about 20 values per node are kept)",
                    g.cells
                ),
            ));
        }
        for k in 0..2 {
            let far = g.origin[k] + g.cells[k] as f64 * g.cell_size[k];
            if !far.is_finite() {
                return Err(invalid(
                    format!("grid.cell_size[{k}]"),
                    format!(
                        "{} cells of {} from the origin {} overflow (the far edge is at {})",
                        g.cells[k],
                        exact(g.cell_size[k]),
                        exact(g.origin[k]),
                        exact(far)
                    ),
                ));
            }
        }
        let t = &self.time;
        if !(t.end.is_finite() && t.end > 0.0) {
            return Err(invalid(
                "time.end",
                format!("{} must be positive and finite", exact(t.end)),
            ));
        }
        if t.dt.is_some() && t.cfl.is_some() {
            return Err(invalid("time", "give `dt` or `cfl`, not both"));
        }
        if let Some(s) = self.output.snapshot_interval {
            if !(s.is_finite() && s > 0.0) {
                return Err(invalid(
                    "output.snapshot_interval",
                    format!("{} must be positive and finite", exact(s)),
                ));
            }
        }
        self.check_vector("loads.gravity", self.loads.gravity, MAX_ACCELERATION)?;
        self.validate_schemes()?;
        self.options().validate().map_err(|e| self.scene_error(e))?;
        if self.bodies.is_empty() {
            return Err(invalid("bodies", "the scene needs at least one [[bodies]] entry"));
        }
        for (k, b) in self.bodies.iter().enumerate() {
            self.validate_body(k, b)?;
        }
        let grid = self.grid()?;
        for (k, bc) in self.boundaries.iter().enumerate() {
            bc.validate(k, &grid, self.schemes.shape)?;
            for (name, v) in [("vx", bc.vx), ("vy", bc.vy)] {
                if let Some(v) = v {
                    if v.abs() > MAX_SPEED {
                        return Err(invalid(
                            format!("boundaries[{k}].{name}"),
                            format!(
                                "{} is too large: prescribed speeds of at most {} are accepted",
                                exact(v),
                                exact(MAX_SPEED)
                            ),
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// The shape function, the mass schemes and the mass solves' tolerances and policies, each
    /// at its own key.
    fn validate_schemes(&self) -> Result<()> {
        let s = &self.schemes;
        s.shape
            .validate()
            .map_err(|e| parameter_error(&format!("schemes.shape.{}", s.shape.name()), e))?;
        for (role, scheme) in [("velocity", s.mass.velocity), ("acceleration", s.mass.acceleration)] {
            scheme
                .validate()
                .map_err(|e| parameter_error(&format!("schemes.mass.{role}{}", mass_scheme_key(&scheme)), e))?;
        }
        for (name, value, meaning) in [
            (
                "active_tolerance",
                s.mass.active_tolerance,
                "the relative lumped mass at or below which a node is inactive",
            ),
            (
                "pivot_tolerance",
                s.mass.pivot_tolerance,
                "the scaled Cholesky pivot at or below which the matrix counts as singular",
            ),
        ] {
            if !(0.0..1.0).contains(&value) {
                return Err(invalid(
                    format!("schemes.mass.{name}"),
                    format!("{} must be a number in [0, 1) ({meaning})", exact(value)),
                ));
            }
        }
        if let SingularityPolicy::Regularize { epsilon } = s.mass.singularity {
            if !(epsilon > 0.0 && epsilon <= 1.0) {
                return Err(invalid(
                    "schemes.mass.singularity.regularize.epsilon",
                    format!(
                        "{} must lie in (0, 1] (the weight of the lumped mass in the regularized matrix)",
                        exact(epsilon)
                    ),
                ));
            }
        }
        let stabilization = match s.mass.stabilization {
            Stabilization::None => "schemes.mass.stabilization",
            Stabilization::GhostPenalty { .. } => "schemes.mass.stabilization.ghost_penalty",
            Stabilization::PartialLumping { .. } => "schemes.mass.stabilization.partial_lumping",
        };
        s.mass
            .stabilization
            .validate()
            .map_err(|e| parameter_error(stabilization, e))
    }

    /// One body's density, particle count, material, velocity, body force and geometry.
    fn validate_body(&self, k: usize, b: &BodySpec) -> Result<()> {
        let key = |f: &str| format!("bodies[{k}].{f}");
        if !(b.density.is_finite() && b.density > 0.0) {
            return Err(invalid(
                key("density"),
                format!("{} must be positive and finite", exact(b.density)),
            ));
        }
        let [hx, hy] = self.grid.cell_size;
        if !(b.density * hx * hy).is_finite() {
            return Err(invalid(
                key("density"),
                format!(
                    "{} is too large for cells of {} x {}: the mass of a cell's particles overflows",
                    exact(b.density),
                    exact(hx),
                    exact(hy)
                ),
            ));
        }
        if b.particles_per_cell == 0 || b.particles_per_cell > MAX_PARTICLES_PER_CELL {
            return Err(invalid(
                key("particles_per_cell"),
                format!(
                    "{} must lie between 1 and {MAX_PARTICLES_PER_CELL} (per axis)",
                    b.particles_per_cell
                ),
            ));
        }
        b.material
            .validate()
            .map_err(|e| parameter_error(&key("material"), e))?;
        let c = b.material.wave_speed(b.density);
        if !(c.is_finite() && c > 0.0) {
            return Err(invalid(
                key("material"),
                format!(
                    "the wave speed of this material at `density` = {} is {}: it must be positive and finite",
                    exact(b.density),
                    exact(c)
                ),
            ));
        }
        self.check_vector(&key("velocity"), b.velocity, MAX_SPEED)?;
        self.check_vector(&key("body_force"), b.body_force, MAX_ACCELERATION)?;
        match &b.geometry {
            Geometry::Rectangle { min, max } => {
                if !(min.iter().chain(max).all(|v| v.is_finite()) && min[0] < max[0] && min[1] < max[1]) {
                    return Err(invalid(
                        key("geometry.rectangle"),
                        format!(
                            "min = {}, max = {}: needs finite values with min < max in x and y",
                            pair(*min),
                            pair(*max)
                        ),
                    ));
                }
            }
            Geometry::Disk { center, radius } => {
                if !(center.iter().all(|v| v.is_finite()) && radius.is_finite() && *radius > 0.0) {
                    return Err(invalid(
                        key("geometry.disk"),
                        format!(
                            "center = {}, radius = {}: needs a finite centre and a positive finite radius",
                            pair(*center),
                            exact(*radius)
                        ),
                    ));
                }
            }
            Geometry::File(_) => {}
        }
        Ok(())
    }

    /// A vector of the scene at `key` (an acceleration or a velocity): finite, of magnitude at
    /// most `bound`, and such that its magnitude times `time.end` and times the cell size do
    /// not overflow.
    fn check_vector(&self, key: &str, v: [f64; 2], bound: f64) -> Result<()> {
        if !v.iter().all(|c| c.is_finite()) {
            return Err(invalid(key, format!("{} must be finite", pair(v))));
        }
        let magnitude = v[0].hypot(v[1]);
        if magnitude > bound {
            return Err(invalid(
                key,
                format!(
                    "{} is too large: its magnitude {} exceeds the {} this program accepts",
                    pair(v),
                    exact(magnitude),
                    exact(bound)
                ),
            ));
        }
        let h = self.grid.cell_size[0].max(self.grid.cell_size[1]);
        for (factor, what) in [(self.time.end, "`time.end`"), (h, "the cell size")] {
            if !(magnitude * factor).is_finite() {
                return Err(invalid(
                    key,
                    format!(
                        "{} is too large: its magnitude {} times {what} ({}) overflows",
                        pair(v),
                        exact(magnitude),
                        exact(factor)
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The grid.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] for `grid` when [`Grid::new`] rejects it.
    pub fn grid(&self) -> Result<Grid> {
        Grid::new(self.grid.origin, self.grid.cell_size, self.grid.cells).map_err(|e| invalid("grid", e.to_string()))
    }

    /// The simulation options the scene describes.
    pub fn options(&self) -> Options {
        let s = &self.schemes;
        Options {
            shape: s.shape,
            update: s.update,
            transfer: s.transfer,
            mass: s.mass,
            position_update: s.position_update,
            time_step: match (self.time.dt, self.time.cfl) {
                (Some(dt), _) => TimeStep::Fixed { dt },
                (None, Some(number)) => TimeStep::Cfl { number },
                (None, None) => TimeStep::Cfl { number: 0.5 },
            },
            allow_unstable_time_step: self.time.allow_unstable,
            gravity: self.loads.gravity,
            boundaries: self.boundaries.clone(),
            sort_interval: s.sort_interval,
            stability_interval: self
                .time
                .stability_interval
                .unwrap_or(crate::simulation::DEFAULT_STABILITY_INTERVAL),
            threads: 1,
        }
    }

    /// The particles of every body, in body order, with `body` set.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] for a body that yields no particles or an unreadable particle
    /// file (naming the file, the row and the column).
    pub fn particles(&self) -> Result<Particles> {
        let grid = self.grid()?;
        let mut all = Particles::default();
        for (k, body) in self.bodies.iter().enumerate() {
            let mut p = self.body_particles(k, body, &grid)?;
            p.body = vec![k; p.len()];
            all.append(p)
                .map_err(|e| invalid(format!("bodies[{k}]"), e.to_string()))?;
        }
        Ok(all)
    }

    /// The file body `body` reads its particles from, checked as it will be read: `None` when
    /// the body's geometry is not a file; else the path, taken from [`Scene::base_dir`] (the
    /// current directory when `None`), with symbolic links resolved unless
    /// [`Scene::allow_outside_files`] is set. A program that reads or copies the file itself
    /// should use this path.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] at `bodies[k].geometry.file` naming the path when it is
    /// absolute, leaves the scene's folder (`..`, a symbolic link) or cannot be resolved
    /// (it does not exist), unless [`Scene::allow_outside_files`] is set.
    pub fn particle_file_path(&self, body: usize) -> Result<Option<PathBuf>> {
        let Some(BodySpec {
            geometry: Geometry::File(written),
            ..
        }) = self.bodies.get(body)
        else {
            return Ok(None);
        };
        self.locate_particle_file(written)
            .map(|(_, path)| Some(path))
            .map_err(|reason| invalid(format!("bodies[{body}].geometry.file"), reason))
    }

    /// The particle file named `written` in the scene: the path to show in messages (joined to
    /// the scene's folder) and the path to open (the same with symbolic links resolved, once it
    /// is known to lie in the folder).
    fn locate_particle_file(&self, written: &Path) -> std::result::Result<(PathBuf, PathBuf), String> {
        let folder = match &self.base_dir {
            Some(dir) if !dir.as_os_str().is_empty() => dir.clone(),
            _ => PathBuf::from("."),
        };
        let joined = folder.join(written);
        if self.allow_outside_files {
            return Ok((joined.clone(), joined));
        }
        let refuse = |why: &str| {
            format!(
                "`{}` {why}; a particle file must lie in the scene file's folder ({}) or below it",
                written.display(),
                folder.display()
            )
        };
        // Decided from the path's text first, so that nothing outside the folder is looked at.
        let mut depth = 0usize;
        for part in written.components() {
            match part {
                Component::Normal(_) => depth += 1,
                Component::CurDir => {}
                Component::ParentDir if depth == 0 => return Err(refuse("leaves the folder through `..`")),
                Component::ParentDir => depth -= 1,
                Component::RootDir | Component::Prefix(_) => return Err(refuse("is an absolute path")),
            }
        }
        if depth == 0 {
            return Err(refuse("names the folder itself, not a file in it"));
        }
        // Then with symbolic links resolved: a link inside the folder must not lead out of it.
        let root = folder
            .canonicalize()
            .map_err(|e| format!("the scene file's folder {} cannot be resolved: {e}", folder.display()))?;
        let path = joined
            .canonicalize()
            .map_err(|e| format!("{}: {e}", joined.display()))?;
        if !path.starts_with(&root) {
            return Err(refuse("leads out of the folder through a symbolic link"));
        }
        Ok((joined, path))
    }

    fn body_particles(&self, k: usize, body: &BodySpec, grid: &Grid) -> Result<Particles> {
        let key = |f: &str| format!("bodies[{k}].{f}");
        let columns = match &body.geometry {
            Geometry::File(written) => {
                let (shown, path) = self
                    .locate_particle_file(written)
                    .map_err(|reason| invalid(key("geometry.file"), reason))?;
                read_particle_file(&shown, &path, body.density)
                    .map_err(|reason| invalid(key("geometry.file"), reason))?
            }
            geometry => {
                let [x0, x1, y0, y1] = grid.bounds();
                let (lo, hi) = match geometry {
                    Geometry::Rectangle { min, max } => (*min, *max),
                    Geometry::Disk { center, radius } => (
                        [center[0] - radius, center[1] - radius],
                        [center[0] + radius, center[1] + radius],
                    ),
                    Geometry::File(_) => unreachable!("handled above"),
                };
                let tol = 1e-9 * (x1 - x0).max(y1 - y0);
                if lo[0] < x0 - tol || lo[1] < y0 - tol || hi[0] > x1 + tol || hi[1] > y1 + tol {
                    return Err(invalid(
                        key("geometry"),
                        format!(
                            "spans [{}, {}] x [{}, {}], which is not inside the grid [{x0}, {x1}] x [{y0}, {y1}]",
                            lo[0], hi[0], lo[1], hi[1]
                        ),
                    ));
                }
                let inside = |px: f64, py: f64| match geometry {
                    Geometry::Rectangle { min, max } => px > min[0] && px < max[0] && py > min[1] && py < max[1],
                    Geometry::Disk { center, radius } => (px - center[0]).hypot(py - center[1]) < *radius,
                    Geometry::File(_) => unreachable!("handled above"),
                };
                let (x, y, volume) = crate::particles::lattice(grid, body.particles_per_cell, inside);
                ParticleColumns {
                    volume: vec![volume; x.len()],
                    x,
                    y,
                    ..ParticleColumns::default()
                }
            }
        };
        let count = columns.x.len();
        if count == 0 {
            return Err(invalid(
                key("geometry"),
                "contains no particle (is it inside the grid, and larger than a particle spacing?)",
            ));
        }
        let [vx, vy, mass, sxx, syy, sxy] = columns.optional;
        let or_zero = |v: Option<Vec<f64>>| v.unwrap_or_else(|| vec![0.0; count]);
        let mass = mass.unwrap_or_else(|| columns.volume.iter().map(|v| body.density * v).collect());
        let vx = or_zero(vx).iter().map(|v| v + body.velocity[0]).collect();
        let vy = or_zero(vy).iter().map(|v| v + body.velocity[1]).collect();
        Particles::new(columns.x, columns.y, mass, columns.volume)
            .and_then(|p| p.with_velocity(vx, vy))
            .and_then(|p| p.with_stress(or_zero(sxx), or_zero(syy), or_zero(sxy)))
            .and_then(|p| p.with_body_force(vec![body.body_force[0]; count], vec![body.body_force[1]; count]))
            .map_err(|e| invalid(key("geometry"), e.to_string()))
    }

    /// The bodies (names and materials) in order.
    pub fn bodies(&self) -> Vec<Body> {
        self.bodies
            .iter()
            .map(|b| Body {
                name: b.name.clone(),
                material: b.material,
            })
            .collect()
    }

    /// Builds the simulation at time 0.
    ///
    /// # Errors
    /// The errors of [`Scene::grid`], [`Scene::particles`] and [`Simulation::new`].
    pub fn build(&self) -> Result<Simulation> {
        Simulation::new(self.grid()?, self.particles()?, self.bodies(), self.options()).map_err(|e| self.scene_error(e))
    }

    /// An [`MpmError::InvalidOption`] of the library restated as [`MpmError::InvalidScene`] at
    /// the scene key that sets the option; other errors unchanged.
    fn scene_error(&self, e: MpmError) -> MpmError {
        let MpmError::InvalidOption { option, reason } = e else {
            return e;
        };
        let key = match option {
            "time_step.dt" => "time.dt".to_string(),
            "time_step.cfl" => "time.cfl".to_string(),
            "transfer.flip" => "schemes.transfer.blend.flip".to_string(),
            "transfer.k" => format!("schemes.transfer.{}.k", self.schemes.transfer.name()),
            "transfer" => "schemes.transfer".to_string(),
            "gravity" => "loads.gravity".to_string(),
            other => format!("schemes.{other}"),
        };
        invalid(key, reason)
    }

    /// Time between snapshots: `output.snapshot_interval`, or a fiftieth of the run.
    pub fn snapshot_interval(&self) -> f64 {
        self.output.snapshot_interval.unwrap_or(self.time.end / 50.0)
    }
}

/// Columns of a particle file; optional ones are `None` when absent.
#[derive(Default)]
struct ParticleColumns {
    x: Vec<f64>,
    y: Vec<f64>,
    volume: Vec<f64>,
    optional: [Option<Vec<f64>>; 6],
}

/// Optional particle-file columns, in the order of `ParticleColumns::optional`.
const OPTIONAL_COLUMNS: [&str; 6] = ["vx", "vy", "mass", "sxx", "syy", "sxy"];

/// Reads the text of a particle file: a regular file of at most [`MAX_PARTICLE_FILE_BYTES`]
/// bytes, in UTF-8. `shown` is the path for messages, `path` the one opened.
fn read_particle_text(shown: &Path, path: &Path) -> std::result::Result<String, String> {
    let shown = shown.display();
    let before = std::fs::metadata(path).map_err(|e| format!("{shown}: {e}"))?;
    check_regular_file(&before).map_err(|what| format!("{shown} is {what}, not a regular file"))?;
    let too_large = |bytes: String| {
        format!("{shown} has {bytes} bytes, more than the {MAX_PARTICLE_FILE_BYTES} (1 GiB) a particle file may have")
    };
    if before.len() > MAX_PARTICLE_FILE_BYTES {
        return Err(too_large(before.len().to_string()));
    }
    let file = std::fs::File::open(path).map_err(|e| format!("{shown}: {e}"))?;
    let opened = file.metadata().map_err(|e| format!("{shown}: {e}"))?;
    check_regular_file(&opened).map_err(|what| format!("{shown} is {what}, not a regular file"))?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if (before.dev(), before.ino()) != (opened.dev(), opened.ino()) {
            return Err(format!("{shown} was replaced while it was being opened"));
        }
    }
    let expected = opened.len().min(MAX_PARTICLE_FILE_BYTES);
    let mut bytes = Vec::with_capacity(usize::try_from(expected).unwrap_or(0));
    file.take(MAX_PARTICLE_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("{shown}: {e}"))?;
    if bytes.len() as u64 > MAX_PARTICLE_FILE_BYTES {
        return Err(too_large(format!(
            "more than {MAX_PARTICLE_FILE_BYTES} (it grew while being read)"
        )));
    }
    String::from_utf8(bytes).map_err(|e| {
        let valid = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..valid].iter().filter(|&&b| b == b'\n').count() + 1;
        format!("{shown} line {line}: not UTF-8 text (a particle file is CSV text)")
    })
}

/// `Ok` for a regular file; else what it is, in words.
fn check_regular_file(meta: &std::fs::Metadata) -> std::result::Result<(), &'static str> {
    let kind = meta.file_type();
    if kind.is_file() {
        return Ok(());
    }
    if kind.is_dir() {
        return Err("a folder");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() {
            return Err("a named pipe (FIFO)");
        }
        if kind.is_char_device() || kind.is_block_device() {
            return Err("a device");
        }
        if kind.is_socket() {
            return Err("a socket");
        }
    }
    Err("something else")
}

/// Whether a piece of a particle file may be quoted in a message: a short word of letters,
/// digits and `+-._` (a misspelt number or column name), nothing longer or stranger.
fn quotable(text: &str) -> bool {
    !text.is_empty() && text.len() <= 24 && text.bytes().all(|b| b.is_ascii_alphanumeric() || b"+-._".contains(&b))
}

/// Reads a CSV particle file: columns `x, y, volume` and optionally `vx, vy, mass, sxx, syy, sxy`.
/// `density` gives the mass of a file without a `mass` column.
///
/// Messages name the line and the column and say what is wrong. They show nothing of a file
/// whose header does not name `x`, `y` and `volume` (it is not a particle file, and its content
/// is none of the scene's business), and of a particle file at most a short word ([`quotable`]).
fn read_particle_file(shown: &Path, path: &Path, density: f64) -> std::result::Result<ParticleColumns, String> {
    let text = read_particle_text(shown, path)?;
    let shown = shown.display();
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let (header_index, header) = lines
        .next()
        .ok_or_else(|| format!("{shown}: the file has no header line (it is empty or only comments)"))?;
    let header_line = header_index + 1;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let column = |name: &str| names.iter().position(|n| *n == name);
    let missing: Vec<String> = ["x", "y", "volume"]
        .iter()
        .filter(|n| column(n).is_none())
        .map(|n| format!("`{n}`"))
        .collect();
    if !missing.is_empty() {
        return Err(format!(
            "{shown} line {header_line}: the header ({} column{}) must name the columns `x`, `y` and `volume`; \
             it lacks {}",
            names.len(),
            if names.len() == 1 { "" } else { "s" },
            missing.join(", ")
        ));
    }
    for (c, name) in names.iter().enumerate() {
        if !["x", "y", "volume"].contains(name) && !OPTIONAL_COLUMNS.contains(name) {
            let known = format!("known: x, y, volume, {}", OPTIONAL_COLUMNS.join(", "));
            return Err(if quotable(name) {
                format!(
                    "{shown} line {header_line}: unknown column `{name}` (column {}; {known})",
                    c + 1
                )
            } else {
                format!(
                    "{shown} line {header_line}: column {} of the header is not a known column name (not shown; \
                     {known})",
                    c + 1
                )
            });
        }
        if let Some(first) = names[..c].iter().position(|n| n == name) {
            return Err(format!(
                "{shown} line {header_line}: column `{name}` is named twice (columns {} and {})",
                first + 1,
                c + 1
            ));
        }
    }
    let (cx, cy, cv) = (
        column("x").unwrap_or(0),
        column("y").unwrap_or(0),
        column("volume").unwrap_or(0),
    );
    let optional: Vec<Option<usize>> = OPTIONAL_COLUMNS.iter().map(|n| column(n)).collect();
    let mut out = ParticleColumns::default();
    for (k, c) in optional.iter().enumerate() {
        if c.is_some() {
            out.optional[k] = Some(Vec::new());
        }
    }
    for (line_index, line) in lines {
        let line_no = line_index + 1;
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != names.len() {
            return Err(format!(
                "{shown} line {line_no}: {} values but the header has {} columns",
                cells.len(),
                names.len()
            ));
        }
        let at = |c: usize| format!("{shown} line {line_no}, column `{}` (column {})", names[c], c + 1);
        let value = |c: usize| -> std::result::Result<f64, String> {
            let cell = cells[c];
            let v = cell.parse::<f64>().map_err(|_| {
                if cell.is_empty() {
                    format!("{}: the value is missing", at(c))
                } else if quotable(cell) {
                    format!("{}: `{cell}` is not a number", at(c))
                } else {
                    format!("{}: not a number ({} bytes, not shown)", at(c), cell.len())
                }
            })?;
            if !v.is_finite() {
                return Err(format!("{}: {} is not a finite number", at(c), exact(v)));
            }
            Ok(v)
        };
        out.x.push(value(cx)?);
        out.y.push(value(cy)?);
        let volume = value(cv)?;
        if volume <= 0.0 {
            return Err(format!("{}: {} must be positive", at(cv), exact(volume)));
        }
        if optional[2].is_none() && !(density * volume).is_finite() {
            return Err(format!(
                "{}: {} times the body's density {} (its mass) overflows",
                at(cv),
                exact(volume),
                exact(density)
            ));
        }
        out.volume.push(volume);
        for (k, c) in optional.iter().enumerate() {
            if let (Some(c), Some(values)) = (*c, out.optional[k].as_mut()) {
                let v = value(c)?;
                match OPTIONAL_COLUMNS[k] {
                    "mass" if v <= 0.0 => return Err(format!("{}: {} must be positive", at(c), exact(v))),
                    "vx" | "vy" if v.abs() > MAX_SPEED => {
                        return Err(format!(
                            "{}: {} is too large: speeds of at most {} are accepted",
                            at(c),
                            exact(v),
                            exact(MAX_SPEED)
                        ))
                    }
                    _ => {}
                }
                values.push(v);
            }
        }
    }
    Ok(out)
}
