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
//! types of other modules, through their serde forms: the scheme choices are written as their
//! text, [`crate::names`]) changes the format and must increase [`CHECKPOINT_FORMAT_VERSION`].

use std::borrow::Cow;
use std::io::{self, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};

mod records;

use records::{BodyRecord, GridRecord, OptionsRecord, ParticlesRecord, StabilityRecord};

use super::build::Resume;
use super::stability::Speeds;
use super::{Relaxation, Simulation, State};
use crate::error::{MpmError, Result};
use crate::fields::VectorField;
use crate::particles::Particles;

/// The version of the checkpoint file format this build writes and reads. Files of another
/// version are refused.
pub const CHECKPOINT_FORMAT_VERSION: u32 = 11;

/// The first bytes of every checkpoint file: the format name.
const MAGIC: &[u8] = b"sparse-mpm checkpoint\n";

/// The crate version written into the header.
const CRATE_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Bytes of the trailing checksum.
const CHECKSUM_BYTES: usize = 4;

/// Largest checkpoint file read (bytes): 8 GiB, the default memory limit of a run
/// ([`crate::limits::Limits`]); a larger file, or one that is not a regular file, is refused
/// before it is read.
pub const MAX_CHECKPOINT_BYTES: u64 = 8 << 30;

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
        let bytes = crate::io::read_bounded(path, MAX_CHECKPOINT_BYTES, "checkpoint")?;
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
    relaxation: Relaxation,
    strain_energy: f64,
    /// `[max_p |v_p|, max_p √(C11 V / m)]` as the time loop kept them.
    speeds: [f64; 2],
    stability: Option<StabilityRecord>,
    /// The conjugate gradient's warm-start vectors, per (role, component).
    cg_warm_start: [Vec<f64>; 4],
    /// The top mode the stable-step guards track (empty, or two values per node).
    frequency_mode: Cow<'a, [f64]>,
    /// `m_L` of the last step.
    lumped_mass: Cow<'a, [f64]>,
    /// `w` of the last step.
    grid_velocity: [Cow<'a, [f64]>; 2],
}

impl<'a> Payload<'a> {
    /// The checkpoint of `sim`, borrowing its arrays.
    fn of(sim: &'a Simulation) -> Payload<'a> {
        // Every field named, so that a field added to the simulation is considered here.
        let Simulation {
            setup,
            options,
            state,
            cache,
            // Work arrays, overwritten by every step before they are read, but for the mode the
            // stable-step guards track.
            scratch,
            // Wall-clock times: not part of the state.
            profile: _,
        } = sim;
        let State {
            particles,
            time,
            steps,
            failed,
            transfer_loss,
            relaxation,
            strain_energy,
            speeds,
            stability,
        } = state;
        Payload {
            grid: GridRecord::of(&setup.grid),
            options: OptionsRecord::of(options),
            bodies: setup.bodies.iter().map(BodyRecord::of).collect(),
            particles: ParticlesRecord::of(particles),
            // The rest of the setup is rebuilt on reading from the options, the grid and the
            // bodies; the operators at the current positions.
            density: Cow::Borrowed(&setup.density),
            time: *time,
            steps: *steps,
            failed: failed.clone(),
            transfer_loss: *transfer_loss,
            relaxation: *relaxation,
            strain_energy: *strain_energy,
            speeds: [speeds.particle, speeds.wave],
            stability: stability.map(|s| StabilityRecord::of(&s)),
            cg_warm_start: cache.mass.warm_start(),
            frequency_mode: Cow::Borrowed(&scratch.tracking.mode),
            lumped_mass: Cow::Borrowed(cache.mass.lumped()),
            grid_velocity: [
                Cow::Borrowed(&cache.nodes.updated.x),
                Cow::Borrowed(&cache.nodes.updated.y),
            ],
        }
    }

    /// The simulation this checkpoint holds, built by [`Simulation::build`] (which checks that
    /// its parts fit together, so that no later step can panic on them).
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
            relaxation,
            strain_energy,
            speeds,
            stability,
            cg_warm_start,
            frequency_mode,
            lumped_mass,
            grid_velocity: [updated_x, updated_y],
        } = self;
        let grid = grid.into_grid()?;
        let options = options.into_options();
        if !time.is_finite() {
            return Err(format!("time {time} is not finite"));
        }
        if steps == usize::MAX {
            return Err("the step count is at its largest value".into());
        }
        let stability = match stability {
            Some(s) if s.at_step > steps || s.at_step.checked_add(options.stability_interval).is_none() => {
                return Err(format!(
                    "the stable-step estimate is dated step {}, after the {steps} steps taken",
                    s.at_step
                ))
            }
            s => s.map(StabilityRecord::into_stability),
        };
        let resume = Resume {
            density: density.into_owned(),
            state: State {
                particles: Particles::default(),
                time,
                steps,
                failed,
                transfer_loss,
                relaxation,
                strain_energy,
                // The load and the wall speed are not saved: they follow from the options and
                // the particles, and the build measures them.
                speeds: Speeds {
                    particle: speeds[0],
                    wave: speeds[1],
                    ..Speeds::default()
                },
                stability,
            },
            lumped: lumped_mass.into_owned(),
            updated: VectorField {
                x: updated_x.into_owned(),
                y: updated_y.into_owned(),
            },
            warm_start: cg_warm_start,
            frequency_mode: frequency_mode.into_owned(),
        };
        let bodies = bodies.into_iter().map(BodyRecord::into_body).collect();
        Simulation::build(grid, particles.into_particles(), bodies, options, Some(resume))
            .map_err(|e| format!("the state does not hold together: {e}"))
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
