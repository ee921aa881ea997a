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

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::boundary::BoundaryCondition;
use crate::error::{MpmError, Result};
use crate::grid::Grid;
use crate::mass::MassOptions;
use crate::material::Material;
use crate::particles::Particles;
use crate::shape::ShapeFunction;
use crate::simulation::{Body, Options, Simulation, TimeStep, Transfer, UpdateScheme};
use crate::step::PositionUpdate;

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
    /// The folder relative paths (particle files) are taken from; set by [`Scene::load`].
    #[serde(skip)]
    pub base_dir: Option<PathBuf>,
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
    /// least one body, sensible body parameters.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] naming the key (`time.dt`, `bodies[1].density` …).
    pub fn validate(&self) -> Result<()> {
        let g = &self.grid;
        for (k, h) in g.cell_size.iter().enumerate() {
            if !(h.is_finite() && *h > 0.0) {
                return Err(invalid(
                    format!("grid.cell_size[{k}]"),
                    format!("{h} must be positive and finite"),
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
        let t = &self.time;
        if !(t.end.is_finite() && t.end > 0.0) {
            return Err(invalid("time.end", format!("{} must be positive and finite", t.end)));
        }
        if t.dt.is_some() && t.cfl.is_some() {
            return Err(invalid("time", "give `dt` or `cfl`, not both"));
        }
        if let Some(s) = self.output.snapshot_interval {
            if !(s.is_finite() && s > 0.0) {
                return Err(invalid(
                    "output.snapshot_interval",
                    format!("{s} must be positive and finite"),
                ));
            }
        }
        let s = &self.schemes;
        s.shape
            .validate()
            .map_err(|e| invalid("schemes.shape", e.to_string()))?;
        for (role, scheme) in [("velocity", s.mass.velocity), ("acceleration", s.mass.acceleration)] {
            scheme
                .validate()
                .map_err(|e| invalid(format!("schemes.mass.{role}"), e.to_string()))?;
        }
        self.options().validate().map_err(|e| self.scene_error(e))?;
        if self.bodies.is_empty() {
            return Err(invalid("bodies", "the scene needs at least one [[bodies]] entry"));
        }
        for (k, b) in self.bodies.iter().enumerate() {
            let key = |f: &str| format!("bodies[{k}].{f}");
            if !(b.density.is_finite() && b.density > 0.0) {
                return Err(invalid(
                    key("density"),
                    format!("{} must be positive and finite", b.density),
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
                .map_err(|e| invalid(key("material"), e.to_string()))?;
            match &b.geometry {
                Geometry::Rectangle { min, max } => {
                    if !(min.iter().chain(max).all(|v| v.is_finite()) && min[0] < max[0] && min[1] < max[1]) {
                        return Err(invalid(key("geometry.rectangle"), "needs finite min < max in x and y"));
                    }
                }
                Geometry::Disk { center, radius } => {
                    if !(center.iter().all(|v| v.is_finite()) && radius.is_finite() && *radius > 0.0) {
                        return Err(invalid(
                            key("geometry.disk"),
                            "needs a finite centre and a positive radius",
                        ));
                    }
                }
                Geometry::File(_) => {}
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

    fn body_particles(&self, k: usize, body: &BodySpec, grid: &Grid) -> Result<Particles> {
        let key = |f: &str| format!("bodies[{k}].{f}");
        let columns = match &body.geometry {
            Geometry::File(path) => {
                let path = match &self.base_dir {
                    Some(dir) if path.is_relative() => dir.join(path),
                    _ => path.clone(),
                };
                read_particle_file(&path).map_err(|reason| invalid(key("geometry.file"), reason))?
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

/// Reads a CSV particle file: columns `x, y, volume` and optionally `vx, vy, mass, sxx, syy, sxy`.
fn read_particle_file(path: &Path) -> std::result::Result<ParticleColumns, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let (_, header) = lines
        .next()
        .ok_or_else(|| format!("{}: the file is empty", path.display()))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let column = |name: &str| names.iter().position(|n| *n == name);
    let (Some(cx), Some(cy), Some(cv)) = (column("x"), column("y"), column("volume")) else {
        return Err(format!(
            "{}: the header must name columns `x`, `y` and `volume` (found {names:?})",
            path.display()
        ));
    };
    if let Some(unknown) = names
        .iter()
        .find(|n| !["x", "y", "volume"].contains(n) && !OPTIONAL_COLUMNS.contains(n))
    {
        return Err(format!(
            "{}: unknown column `{unknown}` (known: x, y, volume, {})",
            path.display(),
            OPTIONAL_COLUMNS.join(", ")
        ));
    }
    let optional: Vec<Option<usize>> = OPTIONAL_COLUMNS.iter().map(|n| column(n)).collect();
    let mut out = ParticleColumns::default();
    for (k, c) in optional.iter().enumerate() {
        if c.is_some() {
            out.optional[k] = Some(Vec::new());
        }
    }
    for (line_no, line) in lines {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != names.len() {
            return Err(format!(
                "{} line {}: {} values but the header has {} columns",
                path.display(),
                line_no + 1,
                cells.len(),
                names.len()
            ));
        }
        let value = |c: usize| -> std::result::Result<f64, String> {
            cells[c].parse::<f64>().map_err(|_| {
                format!(
                    "{} line {}: column `{}` = `{}` is not a number",
                    path.display(),
                    line_no + 1,
                    names[c],
                    cells[c]
                )
            })
        };
        out.x.push(value(cx)?);
        out.y.push(value(cy)?);
        let volume = value(cv)?;
        if !(volume > 0.0 && volume.is_finite()) {
            return Err(format!(
                "{} line {}: column `volume` = {volume} must be positive",
                path.display(),
                line_no + 1
            ));
        }
        out.volume.push(volume);
        for (k, c) in optional.iter().enumerate() {
            if let (Some(c), Some(v)) = (c, out.optional[k].as_mut()) {
                v.push(value(*c)?);
            }
        }
    }
    Ok(out)
}
