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
//!
//! [execution]
//! threads = 1                    # worker threads (the results are the same bits for any count)
//! fused_passes = false           # the explicit step's fused particle pass (the same bits either way)
//! ```
//!
//! Geometries ([`Geometry`]): `{ rectangle = { min = [x, y], max = [x, y] } }`, `{ disk = { center = [x, y],
//! radius = r } }`, `{ annulus = { center, inner_radius, outer_radius } }`, `{ polygon = {
//! vertices = [[x, y], …] } }`, `{ union = [shape, …] }`, `{ difference = { base = shape, minus =
//! [shape, …] } }`, `{ transformed = { shape, angle, about, translate } }`, `{ file = "particles.csv" }` (a CSV file with a header naming at least `x`,
//! `y` and `volume`, optionally `vx`, `vy`, `mass` (default `density × volume`), `sxx`, `syy`,
//! `sxy`; lines starting with `#` are comments; a relative path is taken from the scene file's
//! folder). Shapes are filled with `particles_per_cell²` particles per grid cell,
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

mod bodies;
mod contact;
mod geometry;
pub mod initial;
mod locate;
mod overlap;
mod overrides;
mod particle_file;
mod regions;
mod sampling;
mod validate;

pub use contact::{ContactSpec, NormalSpec, PairSpec, SeparationSpec};
pub use geometry::{Affine, BoundingBox, Geometry, MAX_GEOMETRY_DEPTH, MAX_GEOMETRY_PARTS};
pub use initial::InitialStress;
pub use overlap::{overlaps, Overlap, SceneWarning};
pub use overrides::{apply_overrides, MAX_OVERRIDES, MAX_OVERRIDE_STEPS};
pub use regions::{RegionSpec, MAX_REGIONS};
pub use sampling::{sample, Sampling, SplitMix64, POISSON_DISK_RADIUS};

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::boundary::BoundaryCondition;
use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::implicit::Integrator;
use crate::mass::MassOptions;
use crate::material::Material;
use crate::schemes::PositionUpdate;
use crate::shape::ShapeFunction;
use crate::simulation::{Body, Options, Simulation, TimeStep, Transfer, UpdateScheme};

/// A complete simulation description. Two scenes are equal when they describe the same
/// simulation: [`Scene::file`], where a scene was read from, is not compared.
#[derive(Debug, Clone, Serialize, Deserialize)]
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
    /// Contact between bodies, one grid velocity field per body ([`crate::contact`]); absent:
    /// the bodies share one field.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact: Option<ContactSpec>,
    /// What to write.
    #[serde(default)]
    pub output: OutputSpec,
    /// How the run is executed (worker threads); never changes the results.
    #[serde(default, skip_serializing_if = "Execution::is_default")]
    pub execution: Execution,
    /// The folder relative paths (particle files) are taken from; set by [`Scene::load`]. When
    /// `None`, the current directory.
    #[serde(skip)]
    pub base_dir: Option<PathBuf>,
    /// The scene file the scene was read from; set by [`Scene::load`]. Errors found after
    /// reading ([`Scene::build`], the cost limits) name it and the line of their key.
    #[serde(skip)]
    pub file: Option<PathBuf>,
    /// Read particle files wherever their paths lead (absolute paths, `..` out of
    /// [`Scene::base_dir`], symbolic links out of it). `false` (the default, and what a scene
    /// read from TOML gets; it is not a key of the file): a particle file must lie inside the
    /// scene's folder, so that a scene from elsewhere cannot make the program read, and report
    /// on, files it was not meant to. Only a program that trusts its scenes should set it.
    #[serde(skip)]
    pub allow_outside_files: bool,
}

impl PartialEq for Scene {
    fn eq(&self, other: &Scene) -> bool {
        // Every field but `file`, named so that a new field cannot be forgotten here.
        let Scene {
            title,
            grid,
            schemes,
            time,
            loads,
            bodies,
            boundaries,
            contact,
            output,
            execution,
            base_dir,
            allow_outside_files,
            file: _,
        } = self;
        *title == other.title
            && *grid == other.grid
            && *schemes == other.schemes
            && *time == other.time
            && *loads == other.loads
            && *bodies == other.bodies
            && *boundaries == other.boundaries
            && *contact == other.contact
            && *output == other.output
            && *execution == other.execution
            && *base_dir == other.base_dir
            && *allow_outside_files == other.allow_outside_files
    }
}

/// The uniform background grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    /// Lower-left corner.
    #[serde(default)]
    #[serde(deserialize_with = "crate::pairs::exactly_two")]
    pub origin: [f64; 2],
    /// Cell size `[hx, hy]`.
    #[serde(deserialize_with = "crate::pairs::exactly_two")]
    pub cell_size: [f64; 2],
    /// Cells along x and y.
    #[serde(deserialize_with = "crate::pairs::exactly_two")]
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
    /// `"explicit"` (the default), `{ newmark = { beta = 0.25, gamma = 0.5 } }` or
    /// `{ quasi_static = { load_steps = 20 } }`
    /// ([`crate::implicit`]).
    pub integrator: Integrator,
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
            integrator: o.integrator,
        }
    }
}

/// How a run is executed: choices that change its speed, never its results (to the bit).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Execution {
    /// Worker threads (1 to [`crate::parallel::MAX_THREADS`]; 1 runs serially).
    pub threads: usize,
    /// The explicit step's fused pass ([`Options::fused_passes`]; `false`, the default).
    pub fused_passes: bool,
}

impl Default for Execution {
    fn default() -> Self {
        Execution {
            threads: 1,
            fused_passes: false,
        }
    }
}

impl Execution {
    fn is_default(&self) -> bool {
        *self == Execution::default()
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
    #[serde(deserialize_with = "crate::pairs::exactly_two")]
    pub gravity: [f64; 2],
    /// The time over which gravity rises linearly from zero (`None`: all of it from the start;
    /// not with the quasi-static integrator, whose increments apply the loads).
    #[serde(default)]
    pub gravity_ramp: Option<f64>,
    /// Damping of the explicit step's grid force, for dynamic relaxation:
    /// `{ model = "local", alpha = 0.8 }` or `{ model = "mass_proportional", alpha = α }`,
    /// optionally `settled = 1e-6` ([`crate::damping`]).
    #[serde(default)]
    pub damping: Option<crate::damping::Damping>,
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
    /// Particles per cell along each axis (every shape but a particle file): the lattice's
    /// density, which the random samplings match on average.
    #[serde(default = "default_ppc")]
    pub particles_per_cell: usize,
    /// How the shape is filled: `"regular"` (the default), `"jittered"` or `"poisson_disk"`
    /// ([`Sampling`]).
    #[serde(default, skip_serializing_if = "Sampling::is_regular")]
    pub sampling: Sampling,
    /// The seed of a random sampling (the same scene and seed give the same particles on every
    /// machine).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub seed: u64,
    /// Initial velocity of every particle (added to a file's `vx`, `vy`).
    #[serde(default)]
    #[serde(deserialize_with = "crate::pairs::exactly_two")]
    pub velocity: [f64; 2],
    /// Body force per unit mass besides gravity.
    #[serde(default)]
    #[serde(deserialize_with = "crate::pairs::exactly_two")]
    pub body_force: [f64; 2],
    /// The initial stress ([`initial`]): `"geostatic"` or `{ geostatic = { k0 = … } }`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_stress: Option<InitialStress>,
    /// Where the particles are.
    pub geometry: Geometry,
    /// Parts of the body with a material, velocity or initial stress of their own
    /// ([`RegionSpec`]); later regions win where they overlap.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub regions: Vec<RegionSpec>,
}

/// Largest scene file read (bytes): 16 MiB, room for node lists of a million nodes; a larger
/// file, or one that is not a regular file, is refused before it is parsed.
pub const MAX_SCENE_BYTES: u64 = 16 << 20;

/// Largest grid accepted from a scene file (nodes).
pub const MAX_NODES: f64 = 1e8;

/// Largest `particles_per_cell` (per axis) accepted from a scene file.
pub const MAX_PARTICLES_PER_CELL: usize = 32;

pub use crate::particles::{MAX_ACCELERATION, MAX_SPEED};

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

fn is_zero(v: &u64) -> bool {
    *v == 0
}

/// What a run writes.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OutputSpec {
    /// Time between particle snapshots (default: a fiftieth of the run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub snapshot_interval: Option<f64>,
}

/// `table` when `message` is the parser's "missing field `table`" for a table of the scene.
fn missing_table(message: &str) -> Option<&'static str> {
    ["grid", "time", "bodies"]
        .into_iter()
        .find(|t| message == format!("missing field `{t}`"))
}

/// `e` (an [`MpmError::InvalidScene`]) with its key preceded by `path` and the line of the key
/// in `text` when it is found there.
fn located(e: MpmError, path: &Path, text: &str) -> MpmError {
    match e {
        MpmError::InvalidScene { key, reason } => {
            let place = match locate::line_of(text, &key) {
                Some(line) => format!("{}: line {line}, {key}", path.display()),
                None => format!("{}: {key}", path.display()),
            };
            invalid(place, reason)
        }
        e => e,
    }
}

/// An [`MpmError::InvalidScene`] at `key`.
fn invalid(key: impl Into<String>, reason: impl Into<String>) -> MpmError {
    MpmError::InvalidScene {
        key: key.into(),
        reason: reason.into(),
    }
}

impl Scene {
    /// Parses a scene from TOML text.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] with the parser's message (line, column, the key and what is
    /// wrong: unknown key, missing key, wrong type), then the checks of [`Scene::validate`].
    pub fn from_toml_str(text: &str) -> Result<Scene> {
        let scene = Scene::parse(text)?;
        scene.validate()?;
        Ok(scene)
    }

    /// The scene in `text`, unchecked beyond what the file format says; a parser's error at
    /// the line and key it names.
    fn parse(text: &str) -> Result<Scene> {
        toml::from_str(text).map_err(|e| {
            let message = e.message().trim();
            // A required table of the scene itself (`grid`, `time`, `bodies`) is missing: the
            // parser points at the start of the text (a missing key of a table points at the
            // table's header), whose first line has nothing to do with it.
            if let Some(table) = missing_table(message) {
                if e.span()
                    .is_none_or(|s| s.start == 0 && (s.end == 0 || s.end >= text.trim_end().len()))
                {
                    return invalid(
                        table,
                        format!(
                            "missing table {}: a scene needs [grid], [time] and at least one [[bodies]] \
                             (docs/simulation.md, \"Scene files\")",
                            if table == "bodies" {
                                "[[bodies]]".to_string()
                            } else {
                                format!("[{table}]")
                            }
                        ),
                    );
                }
            }
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
            invalid(place.unwrap_or_else(|| "scene".into()), message.to_string())
        })
    }

    /// Reads a scene file; relative particle-file paths are taken from its folder.
    ///
    /// # Errors
    /// [`MpmError::Io`] naming the file, and the errors of [`Scene::from_toml_str`].
    pub fn load(path: &Path) -> Result<Scene> {
        let text = crate::io::read_bounded_text(path, MAX_SCENE_BYTES, "scene")?;
        // The parser's errors name their line already; the checks' errors get it here.
        let mut scene = Scene::parse(&text).map_err(|e| match e {
            MpmError::InvalidScene { key, reason } => invalid(format!("{}: {key}", path.display()), reason),
            e => e,
        })?;
        scene.base_dir = path.parent().map(Path::to_path_buf);
        scene.file = Some(path.to_path_buf());
        scene.validate().map_err(|e| located(e, path, &text))?;
        Ok(scene)
    }

    /// [`Scene::load`] with `KEY=VALUE` overrides applied to the file's text first
    /// ([`apply_overrides`]): the scene of the edited file, its relative paths still taken from
    /// the file's folder. Without overrides, [`Scene::load`] itself.
    ///
    /// # Errors
    /// Those of [`Scene::load`] and [`apply_overrides`].
    pub fn load_with(path: &Path, sets: &[String]) -> Result<Scene> {
        if sets.is_empty() {
            return Scene::load(path);
        }
        let text = crate::io::read_bounded_text(path, MAX_SCENE_BYTES, "scene")?;
        let text = apply_overrides(&text, sets).map_err(|e| match e {
            MpmError::InvalidScene { key, reason } => invalid(format!("{}: {key}", path.display()), reason),
            e => e,
        })?;
        let mut scene = Scene::parse(&text)?;
        scene.base_dir = path.parent().map(Path::to_path_buf);
        scene.validate()?;
        Ok(scene)
    }

    /// An [`MpmError::InvalidScene`] about this scene, with its key preceded by the scene
    /// file and the line the key is written on (`scenes/disks.toml: line 27,
    /// bodies[1].geometry.disk`) when the scene was read from a file ([`Scene::file`]); other
    /// errors unchanged.
    pub fn locate(&self, e: MpmError) -> MpmError {
        let Some(path) = &self.file else {
            return e;
        };
        // The text as it is now: read again only for an error.
        let text = crate::io::read_bounded_text(path, MAX_SCENE_BYTES, "scene").unwrap_or_default();
        located(e, path, &text)
    }

    /// The scene as TOML text; [`Scene::from_toml_str`] reads it back to an equal scene.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] when a value has no TOML form (a particle-file path that is
    /// not valid UTF-8).
    pub fn to_toml_string(&self) -> Result<String> {
        toml::to_string(self).map_err(|e| invalid("scene", format!("cannot be written as TOML: {e}")))
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
            time_step: match (self.time.dt, self.time.cfl, s.integrator) {
                // Each load increment a step of the end time's share.
                (_, _, Integrator::QuasiStatic(q)) => TimeStep::Fixed {
                    dt: self.time.end / q.load_steps.max(1) as f64,
                },
                (Some(dt), _, _) => TimeStep::Fixed { dt },
                (None, Some(number), _) => TimeStep::Cfl { number },
                (None, None, _) => TimeStep::Cfl { number: 0.5 },
            },
            allow_unstable_time_step: self.time.allow_unstable,
            gravity: self.loads.gravity,
            gravity_ramp: self.loads.gravity_ramp,
            damping: self.loads.damping,
            contact: self.contact.as_ref().map(|c| self.contact_options(c)),
            boundaries: self.boundaries.clone(),
            sort_interval: s.sort_interval,
            stability_interval: self
                .time
                .stability_interval
                .unwrap_or(crate::simulation::DEFAULT_STABILITY_INTERVAL),
            threads: self.execution.threads,
            fused_passes: self.execution.fused_passes,
            integrator: s.integrator,
        }
    }

    /// The bodies (names and materials) in order.
    pub fn bodies(&self) -> Vec<Body> {
        let mut out: Vec<Body> = self
            .bodies
            .iter()
            .map(|b| Body {
                name: b.name.clone(),
                material: b.material,
            })
            .collect();
        // Each region with a material of its own: a body of the solver after the scene's.
        for b in &self.bodies {
            for (r, region) in b.regions.iter().enumerate() {
                if let Some(material) = region.material {
                    out.push(Body {
                        name: format!("{}/regions[{r}]", b.name),
                        material,
                    });
                }
            }
        }
        out
    }

    /// Builds the simulation at time 0.
    ///
    /// # Errors
    /// The errors of [`Scene::grid`], [`Scene::particles`] and [`Simulation::new`].
    pub fn build(&self) -> Result<Simulation> {
        let build = || {
            let particles = self.body_particles_all()?;
            let body_of = particles.body.clone();
            Simulation::new(self.grid()?, particles, self.bodies(), self.options()).map_err(|e| match e {
                MpmError::SupportOutsideGrid {
                    particle,
                    position,
                    shape,
                    allowed,
                    padding,
                } if particle < body_of.len() => {
                    self.needs_padding(body_of[particle], position, shape, allowed, padding)
                }
                e => self.scene_error(e),
            })
        };
        build().map_err(|e| self.locate(e))
    }

    /// Body `k`'s particle at `position` closer to the grid's edge than the kernel's support
    /// allows: the body named, and the padded grid that holds it.
    fn needs_padding(&self, k: usize, position: [f64; 2], shape: &str, allowed: [f64; 4], padding: usize) -> MpmError {
        let g = &self.grid;
        let p = padding as f64;
        invalid(
            format!("bodies[{k}].geometry"),
            format!(
                "body \"{}\" has a particle at ({}, {}), closer to the grid's edge than the {shape} support \
                 allows (particles must lie inside [{}, {}] x [{}, {}]): pad the grid by {padding} cell{} on each \
                 side, origin = [{}, {}] and cells = [{}, {}] (an edge's walls then stay outside the body)",
                self.bodies[k].name,
                position[0],
                position[1],
                allowed[0],
                allowed[1],
                allowed[2],
                allowed[3],
                if padding == 1 { "" } else { "s" },
                g.origin[0] - p * g.cell_size[0],
                g.origin[1] - p * g.cell_size[1],
                g.cells[0] + 2 * padding,
                g.cells[1] + 2 * padding,
            ),
        )
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
            "gravity_ramp" => "loads.gravity_ramp".to_string(),
            "damping" | "damping.alpha" | "damping.settled" => format!("loads.{option}"),
            "threads" => "execution.threads".to_string(),
            "contact" => "contact".to_string(),
            other => format!("schemes.{other}"),
        };
        invalid(key, reason)
    }

    /// Time between snapshots: `output.snapshot_interval`, or a fiftieth of the run.
    pub fn snapshot_interval(&self) -> f64 {
        self.output.snapshot_interval.unwrap_or(self.time.end / 50.0)
    }
}
