//! What ties a checkpoint to its run: the digest of the run's scene and particle files, and the
//! checksum of the simulation state the checkpoint's `run.json` was written with.
//!
//! A checkpoint folder (`checkpoints/step_N/`) holds `simulation.ckpt` and `run.json`. The run
//! state in `run.json` records the SHA-256 digest of the run folder's `scene.toml` and of the
//! particle files it names (the copies beside it), and the CRC-32 that ends `simulation.ckpt`.
//! `mpm resume` recomputes both and refuses a checkpoint whose scene is not the run folder's, or
//! whose `simulation.ckpt` is not the one its `run.json` was written with, naming both files: a
//! checkpoint of another run put into a folder never mixes two runs.

use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use sha2::{Digest, Sha256};

use sparse_mpm::error::{MpmError, Result};
use sparse_mpm::scene::{Geometry, Scene, MAX_SCENE_BYTES};

/// The SHA-256 digest (lower-case hex) of `dir/scene.toml` and, in body order, of each particle
/// file it names (read from `dir`): `H(len(scene) ‖ scene ‖ Σ_files len(file) ‖ file)`.
///
/// # Errors
/// [`MpmError::Io`] naming a file that cannot be read; the errors of [`Scene::from_toml_str`]
/// for a scene copy that is not a scene.
pub(crate) fn scene_digest(dir: &Path) -> Result<String> {
    let scene_path = dir.join("scene.toml");
    let text = sparse_mpm::io::read_bounded_text(&scene_path, MAX_SCENE_BYTES, "scene")?;
    let mut hasher = Sha256::new();
    hasher.update((text.len() as u64).to_le_bytes());
    hasher.update(text.as_bytes());
    let scene = Scene::from_toml_str(&text)?;
    for body in &scene.bodies {
        if let Geometry::File(file) = &body.geometry {
            let path = dir.join(file);
            let io = |source| MpmError::Io {
                path: path.clone(),
                source,
            };
            let (mut f, len) =
                sparse_mpm::io::open_regular(&path, sparse_mpm::scene::MAX_PARTICLE_FILE_BYTES, "particle")?;
            hasher.update(len.to_le_bytes());
            let mut buf = vec![0u8; 1 << 16];
            loop {
                let n = f.read(&mut buf).map_err(io)?;
                if n == 0 {
                    break;
                }
                hasher.update(&buf[..n]);
            }
        }
    }
    Ok(hasher.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// The CRC-32 that ends a checkpoint file (its last four bytes, little-endian), as written by
/// [`sparse_mpm::simulation::Simulation::write_checkpoint`].
///
/// # Errors
/// [`MpmError::Io`] naming the file when it cannot be read or is shorter than four bytes.
pub(crate) fn checkpoint_checksum(path: &Path) -> Result<u32> {
    let io = |source| MpmError::Io {
        path: path.to_path_buf(),
        source,
    };
    let (mut f, _) = sparse_mpm::io::open_regular(path, sparse_mpm::simulation::MAX_CHECKPOINT_BYTES, "checkpoint")?;
    f.seek(SeekFrom::End(-4)).map_err(io)?;
    let mut tail = [0u8; 4];
    f.read_exact(&mut tail).map_err(io)?;
    Ok(u32::from_le_bytes(tail))
}
