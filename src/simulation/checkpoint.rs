//! Checkpoints: a [`Simulation`] written whole to one file, and read back to continue with the
//! same bits as if it had never stopped.
//!
//! ## The file
//!
//! ```text
//! "sparse-mpm checkpoint\n"     22 bytes, the format name
//! format version                u32, little-endian (CHECKPOINT_FORMAT_VERSION)
//! crate version                 u8 length, then that many bytes of UTF-8 ("0.1.0")
//! payload length                u64, little-endian
//! payload                       the state below, serde in postcard's wire format
//! checksum                      u32, little-endian: CRC-32 (IEEE) of every byte before it
//! ```
//!
//! The payload holds, in this order: the grid (origin, cell size, cells, node order), the
//! options (every field, the boundary conditions as given), the bodies (name and material), the
//! particles (every field, in their current memory order, which the sums of the next steps
//! follow), each body's reference density, time, steps completed, the failure of an earlier step
//! if any, the cumulative transfer loss, the strain energy, the particle and wave speeds the
//! time loop keeps (the stable step of the next step reads them), the last frequency estimate
//! and the step it was made at, the conjugate gradient's warm-start vectors (the next solves
//! start from them), and the lumped grid mass and updated grid velocity of the last step (what
//! [`Simulation::lumped_mass`] and [`Simulation::grid_velocity`] show).
//!
//! What is left out is rebuilt on reading, by the same functions that built it, and so to the
//! same bits: the resolved boundary conditions, the materials' constants, the worker threads
//! and the operators (assembled at the particles' current positions, as
//! [`Simulation::new`] does; the time loop reassembles them at the start of every step anyway),
//! the grid mass and its factorizations (prepared again at the start of the next step; the
//! symbolic analysis depends on the sparsity pattern only), and the work arrays of a step.
//! Profiling is off after reading.
//!
//! Postcard numbers enum variants by position and writes struct fields in order, without
//! names: a change to the order or the fields of any type written here (including the option
//! types of other modules, through their serde derives) changes the format and must increase
//! [`CHECKPOINT_FORMAT_VERSION`].

use std::borrow::Cow;
use std::fs;
use std::io::{self, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::stability::{Speeds, Stability};
use super::{prescribed_velocity_field, Body, Options, Scratch, Simulation, TimeStep, Transfer, UpdateScheme};
use crate::boundary::{self, BoundaryCondition, Condition, Edge};
use crate::error::{MpmError, Result};
use crate::grid::{Grid, NodeOrder};
use crate::kernels::{GridState, ParticleScratch};
use crate::mass::{GridMass, MassOptions};
use crate::material::{LinearElastic, Material, NeoHookean};
use crate::operators::Operators;
use crate::parallel::Workers;
use crate::particles::Particles;
use crate::schemes::PositionUpdate;
use crate::shape::ShapeFunction;
use crate::stiffness::FrequencyEstimate;
use crate::transfer::VectorField;

/// The version of the checkpoint file format this build writes and reads. Files of another
/// version are refused.
pub const CHECKPOINT_FORMAT_VERSION: u32 = 1;

/// The first bytes of every checkpoint file: the format name.
const MAGIC: &[u8] = b"sparse-mpm checkpoint\n";

/// The crate version written into the header.
const CRATE_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Bytes of the trailing checksum.
const CHECKSUM_BYTES: usize = 4;

impl Simulation {
    /// Writes the whole simulation to `path`: everything the next step reads, so that
    /// [`Simulation::read_checkpoint`] of the file continues with results bit for bit equal to
    /// those of never having stopped (same build of the crate, any number of threads).
    ///
    /// The file is written beside `path` under a temporary name and renamed over `path` once
    /// complete and flushed to disk, so that `path` always holds either the previous file or
    /// the whole new one; on an error the temporary file is removed. The layout is described
    /// in docs/simulation.md ("Checkpoint and resume"): a header naming the format, its version
    /// ([`CHECKPOINT_FORMAT_VERSION`]) and the crate version, the state, and a CRC-32 of it all.
    ///
    /// # Errors
    /// [`MpmError::Io`] naming `path` when the temporary file cannot be created, written or
    /// renamed; [`MpmError::Checkpoint`] when `path` names no file (a directory such as `..`).
    pub fn write_checkpoint(&self, path: &Path) -> Result<()> {
        let encoding = |e: postcard::Error| MpmError::Checkpoint {
            path: Some(path.to_path_buf()),
            reason: format!("the state cannot be encoded: {e}"),
        };
        if path.file_name().is_none() {
            return Err(MpmError::Checkpoint {
                path: Some(path.to_path_buf()),
                reason: "the path names no file to write".into(),
            });
        }
        let payload = Payload::of(self);
        let payload_len =
            postcard::serialize_with_flavor(&payload, postcard::ser_flavors::Size::default()).map_err(encoding)?;
        let mut failed_encoding = None;
        let written = crate::io::write_atomically(path, |file| {
            let mut out = ChecksumWriter::new(file);
            out.write_all(&header(payload_len))?;
            if let Err(e) = postcard::to_io(&payload, &mut out) {
                return Err(out.error.take().unwrap_or_else(|| {
                    failed_encoding = Some(e);
                    io::Error::other("the state cannot be encoded")
                }));
            }
            let checksum = out.hasher.clone().finalize();
            out.write_all(&checksum.to_le_bytes())
        });
        match failed_encoding {
            Some(e) => Err(encoding(e)),
            None => written,
        }
    }

    /// Reads a simulation written by [`Simulation::write_checkpoint`]; its next step continues
    /// the written run bit for bit.
    ///
    /// # Errors
    /// [`MpmError::Io`] when the file cannot be read; [`MpmError::Checkpoint`] naming the file
    /// when it is not a checkpoint, was written in another format version, is truncated or
    /// corrupted (checksum mismatch), or holds a state that does not hold together (which a
    /// file with a good checksum only does when it was made by other means).
    pub fn read_checkpoint(path: &Path) -> Result<Simulation> {
        let bytes = fs::read(path).map_err(|source| MpmError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        decode(&bytes).map_err(|reason| MpmError::Checkpoint {
            path: Some(path.to_path_buf()),
            reason,
        })
    }

    /// [`Simulation::read_checkpoint`] from the bytes of a checkpoint file. Any bytes give a
    /// simulation or an error, never a panic.
    ///
    /// # Errors
    /// [`MpmError::Checkpoint`] (with no path) as for [`Simulation::read_checkpoint`].
    pub fn from_checkpoint_bytes(bytes: &[u8]) -> Result<Simulation> {
        decode(bytes).map_err(|reason| MpmError::Checkpoint { path: None, reason })
    }
}

/// The header for a payload of `payload_len` bytes.
fn header(payload_len: usize) -> Vec<u8> {
    let mut h = Vec::with_capacity(MAGIC.len() + 4 + 1 + CRATE_VERSION.len() + 8);
    h.extend_from_slice(MAGIC);
    h.extend_from_slice(&CHECKPOINT_FORMAT_VERSION.to_le_bytes());
    // Cargo versions are short; a longer one is cut (the field is informative).
    let version = &CRATE_VERSION.as_bytes()[..CRATE_VERSION.len().min(255)];
    h.push(version.len() as u8);
    h.extend_from_slice(version);
    h.extend_from_slice(&(payload_len as u64).to_le_bytes());
    h
}

/// Reads fields off the front of a byte slice, naming what is missing when it runs out.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, what: &str) -> std::result::Result<&'a [u8], String> {
        match self.at.checked_add(n).filter(|&end| end <= self.bytes.len()) {
            Some(end) => {
                let out = &self.bytes[self.at..end];
                self.at = end;
                Ok(out)
            }
            None => Err(format!(
                "the file is truncated: it ends after {} bytes, within the header's {what}",
                self.bytes.len()
            )),
        }
    }

    fn array<const N: usize>(&mut self, what: &str) -> std::result::Result<[u8; N], String> {
        let mut out = [0; N];
        out.copy_from_slice(self.take(N, what)?);
        Ok(out)
    }
}

/// The simulation in `bytes`, or what is wrong with them.
fn decode(bytes: &[u8]) -> std::result::Result<Simulation, String> {
    let n = bytes.len().min(MAGIC.len());
    if bytes[..n] != MAGIC[..n] {
        return Err("not a sparse-mpm checkpoint (the file does not start with the format name)".into());
    }
    let mut r = Reader { bytes, at: 0 };
    r.take(MAGIC.len(), "format name")?;
    let version = u32::from_le_bytes(r.array("format version")?);
    let writer_len = r.array::<1>("crate version")?[0] as usize;
    let writer = String::from_utf8_lossy(r.take(writer_len, "crate version")?).into_owned();
    if version != CHECKPOINT_FORMAT_VERSION {
        return Err(format!(
            "written in checkpoint format version {version} (by sparse-mpm {writer}); this build (sparse-mpm \
             {CRATE_VERSION}) reads version {CHECKPOINT_FORMAT_VERSION} only"
        ));
    }
    let payload_len = u64::from_le_bytes(r.array("payload length")?);
    let start = r.at;
    let expected = usize::try_from(payload_len)
        .ok()
        .and_then(|p| p.checked_add(start))
        .and_then(|p| p.checked_add(CHECKSUM_BYTES));
    match expected {
        Some(total) if total == bytes.len() => {}
        Some(total) if total > bytes.len() => {
            return Err(format!(
                "the file is truncated: it holds {} bytes, its header announces {total}",
                bytes.len()
            ))
        }
        Some(total) => {
            return Err(format!(
                "{} unexpected bytes after the end of the checkpoint ({total} bytes)",
                bytes.len() - total
            ))
        }
        None => {
            return Err(format!(
            "the file is truncated or corrupted: its header announces a payload of {payload_len} bytes, it holds {}",
            bytes.len()
        ))
        }
    }
    let end = bytes.len() - CHECKSUM_BYTES;
    let mut stored = [0; CHECKSUM_BYTES];
    stored.copy_from_slice(&bytes[end..]);
    let stored = u32::from_le_bytes(stored);
    let computed = crc32fast::hash(&bytes[..end]);
    if stored != computed {
        return Err(format!(
            "the file is corrupted: its checksum is {stored:08x}, its contents give {computed:08x}"
        ));
    }
    let (payload, rest): (Payload, _) = postcard::take_from_bytes(&bytes[start..end])
        .map_err(|e| format!("the state does not decode ({e}); the file was not written by this format version"))?;
    if !rest.is_empty() {
        return Err(format!("{} bytes are left over after the state", rest.len()));
    }
    payload.restore()
}

/// Everything a checkpoint holds, in file order. Written from borrowed state, read into owned.
#[derive(Serialize, Deserialize)]
struct Payload<'a> {
    grid: GridRecord,
    options: OptionsRecord,
    bodies: Vec<BodyRecord>,
    particles: ParticlesRecord<'a>,
    /// Each body's reference density (from the initial state: not recomputable from the
    /// current one).
    density: Cow<'a, [f64]>,
    time: f64,
    steps: usize,
    failed: Option<String>,
    transfer_loss: f64,
    strain_energy: f64,
    /// `[max_p |v_p|, max_p √(C11 V / m)]` as the time loop kept them.
    speeds: [f64; 2],
    stability: Option<StabilityRecord>,
    /// The conjugate gradient's warm-start vectors, per (role, component).
    cg_warm_start: [Vec<f64>; 4],
    /// `m_L` of the last step.
    lumped_mass: Cow<'a, [f64]>,
    /// `w` of the last step.
    grid_velocity: [Cow<'a, [f64]>; 2],
}

#[derive(Serialize, Deserialize)]
struct GridRecord {
    origin: [f64; 2],
    cell_size: [f64; 2],
    cells: [usize; 2],
    /// 0: x fastest, 1: y fastest.
    node_order: u8,
}

#[derive(Serialize, Deserialize)]
struct OptionsRecord {
    shape: ShapeFunction,
    update: UpdateScheme,
    transfer: Transfer,
    mass: MassOptions,
    position_update: PositionUpdate,
    time_step: TimeStep,
    allow_unstable_time_step: bool,
    gravity: [f64; 2],
    boundaries: Vec<BoundaryRecord>,
    sort_interval: usize,
    stability_interval: usize,
    threads: usize,
}

/// A [`BoundaryCondition`] with every field written (its own serde form omits absent ones,
/// which a format without field names cannot read back).
#[derive(Serialize, Deserialize)]
struct BoundaryRecord {
    edge: Option<Edge>,
    layers: Option<usize>,
    rectangle: Option<[[f64; 2]; 2]>,
    nodes: Option<Vec<usize>>,
    condition: Condition,
    vx: Option<f64>,
    vy: Option<f64>,
}

#[derive(Serialize, Deserialize)]
struct BodyRecord {
    name: String,
    material: MaterialRecord,
}

/// A [`Material`] tagged by position (its own serde form is tagged by a field, which needs a
/// self-describing format).
#[derive(Serialize, Deserialize)]
enum MaterialRecord {
    LinearElastic(LinearElastic),
    NeoHookean(NeoHookean),
}

#[derive(Serialize, Deserialize)]
struct ParticlesRecord<'a> {
    x: Cow<'a, [f64]>,
    y: Cow<'a, [f64]>,
    vx: Cow<'a, [f64]>,
    vy: Cow<'a, [f64]>,
    mass: Cow<'a, [f64]>,
    volume: Cow<'a, [f64]>,
    sxx: Cow<'a, [f64]>,
    syy: Cow<'a, [f64]>,
    sxy: Cow<'a, [f64]>,
    bx: Cow<'a, [f64]>,
    by: Cow<'a, [f64]>,
    fxx: Cow<'a, [f64]>,
    fxy: Cow<'a, [f64]>,
    fyx: Cow<'a, [f64]>,
    fyy: Cow<'a, [f64]>,
    affine_xx: Cow<'a, [f64]>,
    affine_xy: Cow<'a, [f64]>,
    affine_yx: Cow<'a, [f64]>,
    affine_yy: Cow<'a, [f64]>,
    body: Cow<'a, [usize]>,
    id: Cow<'a, [usize]>,
}

#[derive(Serialize, Deserialize)]
struct StabilityRecord {
    wave_step: f64,
    wave_speed: f64,
    at_step: usize,
    omega_squared: f64,
    lanczos_steps: usize,
}

impl<'a> Payload<'a> {
    /// The checkpoint of `sim`, borrowing its arrays.
    fn of(sim: &'a Simulation) -> Payload<'a> {
        // Every field named, so that a field added to the simulation is considered here.
        let Simulation {
            grid,
            particles,
            bodies,
            options,
            density,
            time,
            steps,
            failed,
            stability,
            transfer_loss,
            nodes,
            strain_energy,
            speeds,
            grid_mass,
            // Rebuilt on reading from the options and the grid (boundary::resolve).
            prescribed: _,
            prescribed_velocity: _,
            // Reassembled at the start of every step; on reading, at the current positions.
            ops: _,
            // Work arrays, overwritten by every step before they are read.
            particle_scratch: _,
            scratch: _,
            // Rebuilt from the bodies and the options.
            materials: _,
            workers: _,
            // Wall-clock times: not part of the state.
            profile: _,
        } = sim;
        Payload {
            grid: GridRecord {
                origin: grid.origin(),
                cell_size: grid.cell_size(),
                cells: grid.cells(),
                node_order: match grid.node_order() {
                    NodeOrder::XFastest => 0,
                    NodeOrder::YFastest => 1,
                },
            },
            options: OptionsRecord::of(options),
            bodies: bodies.iter().map(BodyRecord::of).collect(),
            particles: ParticlesRecord::of(particles),
            density: Cow::Borrowed(density),
            time: *time,
            steps: *steps,
            failed: failed.clone(),
            transfer_loss: *transfer_loss,
            strain_energy: *strain_energy,
            speeds: [speeds.particle, speeds.wave],
            stability: stability.map(|s| StabilityRecord {
                wave_step: s.wave_step,
                wave_speed: s.wave_speed,
                at_step: s.at_step,
                omega_squared: s.estimate.omega_squared,
                lanczos_steps: s.estimate.lanczos_steps,
            }),
            cg_warm_start: grid_mass.warm_start(),
            lumped_mass: Cow::Borrowed(&nodes.mass),
            grid_velocity: [Cow::Borrowed(&nodes.updated.x), Cow::Borrowed(&nodes.updated.y)],
        }
    }

    /// The simulation this checkpoint holds, after checking that its parts fit together (so
    /// that no later step can panic on them).
    fn restore(self) -> std::result::Result<Simulation, String> {
        let Payload {
            grid,
            options,
            bodies,
            particles,
            density,
            time,
            steps,
            failed,
            transfer_loss,
            strain_energy,
            speeds,
            stability,
            cg_warm_start,
            lumped_mass,
            grid_velocity: [updated_x, updated_y],
        } = self;
        let order = match grid.node_order {
            0 => NodeOrder::XFastest,
            1 => NodeOrder::YFastest,
            other => {
                return Err(format!(
                    "grid: node order {other} is not 0 (x fastest) or 1 (y fastest)"
                ))
            }
        };
        let grid = Grid::new(grid.origin, grid.cell_size, grid.cells)
            .map_err(|e| format!("grid: {e}"))?
            .with_node_order(order);
        // The node count, checked against the node fields the file holds before anything is
        // sized by it.
        let [cx, cy] = grid.cells();
        let num_nodes = cx
            .checked_add(1)
            .zip(cy.checked_add(1))
            .and_then(|(a, b)| a.checked_mul(b))
            .ok_or_else(|| format!("grid: {cx} x {cy} cells are too many"))?;
        for (name, len) in [
            ("lumped mass", lumped_mass.len()),
            ("grid velocity x", updated_x.len()),
            ("grid velocity y", updated_y.len()),
        ] {
            if len != num_nodes {
                return Err(format!("{name}: {len} values for a grid of {num_nodes} nodes"));
            }
        }
        for (k, warm) in cg_warm_start.iter().enumerate() {
            if !(warm.is_empty() || warm.len() == num_nodes) {
                return Err(format!(
                    "warm start {k}: {} values for a grid of {num_nodes} nodes",
                    warm.len()
                ));
            }
        }
        let options = options.into_options();
        options.validate().map_err(|e| format!("options: {e}"))?;
        let bodies: Vec<Body> = bodies.into_iter().map(BodyRecord::into_body).collect();
        for body in &bodies {
            body.material
                .validate()
                .map_err(|e| format!("body `{}`: {e}", body.name))?;
        }
        if density.len() != bodies.len() {
            return Err(format!(
                "{} reference densities for {} bodies",
                density.len(),
                bodies.len()
            ));
        }
        let particles = particles.into_particles();
        particles.validate().map_err(|e| format!("particles: {e}"))?;
        if let Some(p) = (0..particles.len()).find(|&p| particles.body[p] >= bodies.len()) {
            return Err(format!(
                "particle {p} names body {} of {}",
                particles.body[p],
                bodies.len()
            ));
        }
        if !time.is_finite() {
            return Err(format!("time {time} is not finite"));
        }
        let stability = match stability {
            None => None,
            Some(s) => {
                if s.at_step > steps || s.at_step.checked_add(options.stability_interval).is_none() {
                    return Err(format!(
                        "the stable-step estimate is dated step {}, after the {steps} steps taken",
                        s.at_step
                    ));
                }
                Some(Stability {
                    wave_step: s.wave_step,
                    wave_speed: s.wave_speed,
                    at_step: s.at_step,
                    estimate: FrequencyEstimate {
                        omega_squared: s.omega_squared,
                        lanczos_steps: s.lanczos_steps,
                    },
                })
            }
        };
        if steps == usize::MAX {
            return Err("the step count is at its largest value".into());
        }
        let prescribed =
            boundary::resolve(&grid, options.shape, &options.boundaries).map_err(|e| format!("options: {e}"))?;
        let workers = Workers::new(options.threads).map_err(|e| format!("options: {e}"))?;
        let mut ops = Operators::default();
        ops.reassemble_with(&grid, options.shape, &particles.x, &particles.y, &workers)
            .map_err(|e| format!("particles: {e}"))?;
        let mut nodes = GridState::new(&grid);
        nodes.mass = lumped_mass.into_owned();
        nodes.updated = VectorField {
            x: updated_x.into_owned(),
            y: updated_y.into_owned(),
        };
        let mut grid_mass = GridMass::default();
        grid_mass.set_warm_start(cg_warm_start);
        let materials = bodies.iter().map(|b| b.material.prepared()).collect();
        Ok(Simulation {
            prescribed_velocity: prescribed_velocity_field(&prescribed),
            scratch: Scratch::for_grid(&grid),
            grid,
            particles,
            bodies,
            options,
            prescribed,
            density: density.into_owned(),
            ops,
            grid_mass,
            time,
            steps,
            failed,
            stability,
            transfer_loss,
            nodes,
            particle_scratch: ParticleScratch::default(),
            strain_energy,
            profile: None,
            speeds: Speeds {
                particle: speeds[0],
                wave: speeds[1],
            },
            materials,
            workers,
        })
    }
}

impl OptionsRecord {
    fn of(options: &Options) -> OptionsRecord {
        let Options {
            shape,
            update,
            transfer,
            mass,
            position_update,
            time_step,
            allow_unstable_time_step,
            gravity,
            boundaries,
            sort_interval,
            stability_interval,
            threads,
        } = options;
        OptionsRecord {
            shape: *shape,
            update: *update,
            transfer: *transfer,
            mass: *mass,
            position_update: *position_update,
            time_step: *time_step,
            allow_unstable_time_step: *allow_unstable_time_step,
            gravity: *gravity,
            boundaries: boundaries.iter().map(BoundaryRecord::of).collect(),
            sort_interval: *sort_interval,
            stability_interval: *stability_interval,
            threads: *threads,
        }
    }

    fn into_options(self) -> Options {
        let OptionsRecord {
            shape,
            update,
            transfer,
            mass,
            position_update,
            time_step,
            allow_unstable_time_step,
            gravity,
            boundaries,
            sort_interval,
            stability_interval,
            threads,
        } = self;
        Options {
            shape,
            update,
            transfer,
            mass,
            position_update,
            time_step,
            allow_unstable_time_step,
            gravity,
            boundaries: boundaries.into_iter().map(BoundaryRecord::into_condition).collect(),
            sort_interval,
            stability_interval,
            threads,
        }
    }
}

impl BoundaryRecord {
    fn of(bc: &BoundaryCondition) -> BoundaryRecord {
        let BoundaryCondition {
            edge,
            layers,
            rectangle,
            nodes,
            condition,
            vx,
            vy,
        } = bc;
        BoundaryRecord {
            edge: *edge,
            layers: *layers,
            rectangle: *rectangle,
            nodes: nodes.clone(),
            condition: *condition,
            vx: *vx,
            vy: *vy,
        }
    }

    fn into_condition(self) -> BoundaryCondition {
        let BoundaryRecord {
            edge,
            layers,
            rectangle,
            nodes,
            condition,
            vx,
            vy,
        } = self;
        BoundaryCondition {
            edge,
            layers,
            rectangle,
            nodes,
            condition,
            vx,
            vy,
        }
    }
}

impl BodyRecord {
    fn of(body: &Body) -> BodyRecord {
        let Body { name, material } = body;
        BodyRecord {
            name: name.clone(),
            material: match *material {
                Material::LinearElastic(m) => MaterialRecord::LinearElastic(m),
                Material::NeoHookean(m) => MaterialRecord::NeoHookean(m),
            },
        }
    }

    fn into_body(self) -> Body {
        Body {
            name: self.name,
            material: match self.material {
                MaterialRecord::LinearElastic(m) => Material::LinearElastic(m),
                MaterialRecord::NeoHookean(m) => Material::NeoHookean(m),
            },
        }
    }
}

impl<'a> ParticlesRecord<'a> {
    fn of(p: &'a Particles) -> ParticlesRecord<'a> {
        let Particles {
            x,
            y,
            vx,
            vy,
            mass,
            volume,
            sxx,
            syy,
            sxy,
            bx,
            by,
            fxx,
            fxy,
            fyx,
            fyy,
            affine_xx,
            affine_xy,
            affine_yx,
            affine_yy,
            body,
            id,
        } = p;
        let b = |v: &'a Vec<f64>| Cow::Borrowed(v.as_slice());
        ParticlesRecord {
            x: b(x),
            y: b(y),
            vx: b(vx),
            vy: b(vy),
            mass: b(mass),
            volume: b(volume),
            sxx: b(sxx),
            syy: b(syy),
            sxy: b(sxy),
            bx: b(bx),
            by: b(by),
            fxx: b(fxx),
            fxy: b(fxy),
            fyx: b(fyx),
            fyy: b(fyy),
            affine_xx: b(affine_xx),
            affine_xy: b(affine_xy),
            affine_yx: b(affine_yx),
            affine_yy: b(affine_yy),
            body: Cow::Borrowed(body),
            id: Cow::Borrowed(id),
        }
    }

    fn into_particles(self) -> Particles {
        let ParticlesRecord {
            x,
            y,
            vx,
            vy,
            mass,
            volume,
            sxx,
            syy,
            sxy,
            bx,
            by,
            fxx,
            fxy,
            fyx,
            fyy,
            affine_xx,
            affine_xy,
            affine_yx,
            affine_yy,
            body,
            id,
        } = self;
        Particles {
            x: x.into_owned(),
            y: y.into_owned(),
            vx: vx.into_owned(),
            vy: vy.into_owned(),
            mass: mass.into_owned(),
            volume: volume.into_owned(),
            sxx: sxx.into_owned(),
            syy: syy.into_owned(),
            sxy: sxy.into_owned(),
            bx: bx.into_owned(),
            by: by.into_owned(),
            fxx: fxx.into_owned(),
            fxy: fxy.into_owned(),
            fyx: fyx.into_owned(),
            fyy: fyy.into_owned(),
            affine_xx: affine_xx.into_owned(),
            affine_xy: affine_xy.into_owned(),
            affine_yx: affine_yx.into_owned(),
            affine_yy: affine_yy.into_owned(),
            body: body.into_owned(),
            id: id.into_owned(),
        }
    }
}

/// A writer that keeps the CRC-32 of what passes through it and the first I/O error (postcard
/// reports a failed write without its cause).
struct ChecksumWriter<W: Write> {
    inner: W,
    hasher: crc32fast::Hasher,
    error: Option<io::Error>,
}

impl<W: Write> ChecksumWriter<W> {
    fn new(inner: W) -> Self {
        ChecksumWriter {
            inner,
            hasher: crc32fast::Hasher::new(),
            error: None,
        }
    }
}

impl<W: Write> Write for ChecksumWriter<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self.inner.write(buf) {
            Ok(n) => {
                self.hasher.update(&buf[..n]);
                Ok(n)
            }
            Err(e) => {
                let kind = e.kind();
                let message = e.to_string();
                self.error.get_or_insert(e);
                Err(io::Error::new(kind, message))
            }
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}
