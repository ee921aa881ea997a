//! A run's output folder: owned by one run at a time, with a manifest of what the run wrote.
//!
//! A run takes an advisory lock on its output folder (`flock` on the folder itself, so no lock
//! file is left behind and a killed run releases it) for as long as it writes there; a second
//! run or resume into the same folder is refused while the first holds it
//! ([`MpmError::OutputInUse`]). Before it writes a file, the run lists its name in
//! `manifest.json` ([`MANIFEST`]), so the manifest always covers every file of the run, whole or
//! begun. `--overwrite` ([`OutputPolicy::Overwrite`]) removes exactly the files the earlier
//! run's manifest lists (and the temporary files of their interrupted writes), and refuses,
//! removing nothing, when the folder holds a file the run would write that the manifest does not
//! list ([`MpmError::OutputNotOwned`]).

use std::fs::File;
use std::path::{Path, PathBuf};

use super::OutputPolicy;
use sparse_mpm::error::{MpmError, Result};
use sparse_mpm::io::temporary_of;

/// The manifest of a run's output folder: the names of the files the run wrote there.
pub const MANIFEST: &str = "manifest.json";

const MANIFEST_FORMAT: &str = "sparse-mpm run files 1";

/// Largest manifest read (about a million names).
const MAX_MANIFEST_BYTES: u64 = 64 << 20;

/// `manifest.json` as written.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestFile {
    format: String,
    files: Vec<String>,
}

/// `particles_NNNNNN.vtp` (six or more digits).
fn is_snapshot(name: &str) -> bool {
    name.strip_prefix("particles_")
        .and_then(|s| s.strip_suffix(".vtp"))
        .is_some_and(|d| d.len() >= 6 && d.bytes().all(|b| b.is_ascii_digit()))
}

/// `input_K_NAME`: a particle file copied beside the scene copy.
fn is_input_copy(name: &str) -> bool {
    name.strip_prefix("input_")
        .and_then(|s| s.split_once('_'))
        .is_some_and(|(k, rest)| {
            !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit()) && !rest.is_empty() && !rest.contains(['/', '\\'])
        })
}

/// `checkpoints/step_NNNNNNNN`.
fn is_checkpoint(name: &str) -> bool {
    name.strip_prefix("checkpoints/step_")
        .is_some_and(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
}

/// Whether `name` is a file (or folder) a run writes into its output folder, as its manifest
/// names it: the only names a manifest may hold.
pub(crate) fn is_run_output(name: &str) -> bool {
    is_snapshot(name)
        || is_input_copy(name)
        || is_checkpoint(name)
        || matches!(name, "particles.pvd" | "report.csv" | "scene.toml" | "checkpoints")
}

/// Whether a file named `name` in an output folder is in the way of a run: a name of the kind
/// a run writes (broader than [`is_run_output`], so that an unlisted look-alike is not
/// overwritten either).
fn in_the_way(name: &str) -> bool {
    (name.starts_with("particles_") && name.ends_with(".vtp"))
        || name.starts_with("input_")
        || matches!(name, "particles.pvd" | "report.csv" | "scene.toml")
}

/// A run's hold on its output folder: the folder's lock, and its manifest.
#[derive(Debug)]
pub(crate) struct OutputClaim {
    out: PathBuf,
    /// The locked folder; `None` where the system cannot lock a folder.
    _lock: Option<File>,
    /// The names the manifest lists, in the order they were added.
    files: Vec<String>,
    /// A folder resumed without a manifest (an older run's): every run-output name counts as
    /// listed.
    legacy: bool,
}

impl OutputClaim {
    /// Takes `out` (created if needed) for a run under `policy`.
    ///
    /// # Errors
    /// [`MpmError::OutputInUse`] when another run holds the folder; [`MpmError::OutputExists`]
    /// for a folder that holds anything under [`OutputPolicy::RefuseNonEmpty`];
    /// [`MpmError::OutputNotOwned`] under [`OutputPolicy::Overwrite`] for files in the way that
    /// the manifest does not list; [`MpmError::Io`] naming a file or folder that cannot be
    /// created, read or removed, or a manifest that is not one.
    pub(crate) fn claim(out: &Path, policy: OutputPolicy) -> Result<OutputClaim> {
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |source| MpmError::Io { path, source }
        };
        std::fs::create_dir_all(out).map_err(io(out))?;
        let lock = lock_folder(out)?;
        let mut entries: Vec<String> = std::fs::read_dir(out)
            .map_err(io(out))?
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        entries.sort();
        let mut claim = OutputClaim {
            out: out.to_path_buf(),
            _lock: lock,
            files: Vec::new(),
            legacy: false,
        };
        match policy {
            OutputPolicy::RefuseNonEmpty if !entries.is_empty() => Err(MpmError::OutputExists {
                path: out.to_path_buf(),
                count: entries.len(),
                examples: entries.into_iter().take(3).collect(),
            }),
            OutputPolicy::RefuseNonEmpty => Ok(claim),
            OutputPolicy::Overwrite => {
                let listed = read_manifest(out)?.unwrap_or_default();
                // Checkpoint folders with checkpoint files in them, inside `checkpoints/`.
                let checkpoints: Vec<String> = std::fs::read_dir(out.join("checkpoints"))
                    .into_iter()
                    .flatten()
                    .filter_map(|e| e.ok())
                    .map(|e| format!("checkpoints/{}", e.file_name().to_string_lossy()))
                    .filter(|name| is_checkpoint(name) && holds_checkpoint_files(&out.join(name)))
                    .collect();
                let not_listed: Vec<String> = entries
                    .iter()
                    .filter(|n| in_the_way(n))
                    .chain(&checkpoints)
                    .filter(|n| !listed.contains(n))
                    .take(5)
                    .cloned()
                    .collect();
                if !not_listed.is_empty() {
                    return Err(MpmError::OutputNotOwned {
                        path: out.to_path_buf(),
                        names: not_listed,
                    });
                }
                remove_listed(out, &listed, &entries)?;
                Ok(claim)
            }
            OutputPolicy::Continue => {
                match read_manifest(out)? {
                    Some(files) => claim.files = files,
                    None => claim.legacy = true,
                }
                Ok(claim)
            }
        }
    }

    /// Whether the manifest lists `name`.
    pub(crate) fn lists(&self, name: &str) -> bool {
        (self.legacy && is_run_output(name)) || self.files.iter().any(|f| f == name)
    }

    /// Lists `name` in the manifest (written to disk before this returns) unless it is there.
    pub(crate) fn add(&mut self, name: &str) -> Result<()> {
        debug_assert!(is_run_output(name), "{name}");
        if self.files.iter().any(|f| f == name) {
            return Ok(());
        }
        self.files.push(name.to_string());
        self.write()
    }

    /// Takes `name` off the manifest (the file was removed).
    pub(crate) fn forget(&mut self, name: &str) -> Result<()> {
        let before = self.files.len();
        self.files.retain(|f| f != name);
        if self.files.len() == before {
            return Ok(());
        }
        self.write()
    }

    fn write(&self) -> Result<()> {
        let manifest = ManifestFile {
            format: MANIFEST_FORMAT.into(),
            files: self.files.clone(),
        };
        let json = serde_json::to_string_pretty(&manifest).expect("a manifest always serializes");
        sparse_mpm::io::write_atomically(&self.out.join(MANIFEST), |w| {
            std::io::Write::write_all(w, json.as_bytes())
        })
    }
}

/// Locks `out` for this process (released when the returned file is closed, or the process
/// ends); `None` where folders cannot be locked.
fn lock_folder(out: &Path) -> Result<Option<File>> {
    let Ok(dir) = File::open(out) else {
        return Ok(None);
    };
    match dir.try_lock() {
        Ok(()) => Ok(Some(dir)),
        Err(std::fs::TryLockError::WouldBlock) => Err(MpmError::OutputInUse {
            path: out.to_path_buf(),
        }),
        Err(std::fs::TryLockError::Error(_)) => Ok(None),
    }
}

/// The names `out/manifest.json` lists, `None` when there is none.
///
/// # Errors
/// [`MpmError::Io`] naming the manifest when it cannot be read, is not a manifest, or lists a
/// name a run does not write (an absolute path, `..`, another file).
fn read_manifest(out: &Path) -> Result<Option<Vec<String>>> {
    let path = out.join(MANIFEST);
    if std::fs::symlink_metadata(&path).is_err() {
        return Ok(None);
    }
    let text = sparse_mpm::io::read_bounded_text(&path, MAX_MANIFEST_BYTES, "run manifest")?;
    let bad = |reason: String| sparse_mpm::io::invalid_data(&path, reason);
    let manifest: ManifestFile = serde_json::from_str(&text).map_err(|e| bad(format!("not a run manifest: {e}")))?;
    if manifest.format != MANIFEST_FORMAT {
        return Err(bad(format!(
            "its format is `{}`; this version reads `{MANIFEST_FORMAT}`",
            manifest.format
        )));
    }
    if let Some(name) = manifest.files.iter().find(|n| !is_run_output(n)) {
        return Err(bad(format!(
            "it lists `{name}`, which is not a file a run writes (a run's manifest names only its own files in \
             its folder)"
        )));
    }
    Ok(Some(manifest.files))
}

/// Whether the folder `dir` holds a checkpoint file ([`CHECKPOINT_FILES`]).
pub(crate) fn holds_checkpoint_files(dir: &Path) -> bool {
    CHECKPOINT_FILES
        .iter()
        .any(|f| std::fs::symlink_metadata(dir.join(f)).is_ok())
}

/// The files a run writes into a checkpoint folder `checkpoints/step_N`.
pub(crate) const CHECKPOINT_FILES: [&str; 2] = ["simulation.ckpt", "run.json"];

/// Removes from `out` the files `listed` names (a checkpoint's own files before its folder,
/// checkpoints before their folder), the temporary files of their interrupted writes, and the
/// manifest. A folder goes only when it is empty then: what else was put there stays.
fn remove_listed(out: &Path, listed: &[String], entries: &[String]) -> Result<()> {
    let remove = |path: PathBuf| {
        let removed = match std::fs::symlink_metadata(&path) {
            Err(_) => return Ok(()),
            Ok(meta) if meta.is_dir() => match std::fs::remove_dir(&path) {
                Err(e) if e.kind() == std::io::ErrorKind::DirectoryNotEmpty => Ok(()),
                other => other,
            },
            Ok(_) => std::fs::remove_file(&path),
        };
        removed.map_err(|source| MpmError::Io { path, source })
    };
    let mut ordered: Vec<&String> = listed.iter().collect();
    ordered.sort_by_key(|n| n.as_str() == "checkpoints");
    for name in ordered {
        let path = out.join(name);
        if is_checkpoint(name) && path.is_dir() && !path.is_symlink() {
            let inside: Vec<String> = std::fs::read_dir(&path)
                .map_err(|source| MpmError::Io {
                    path: path.clone(),
                    source,
                })?
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect();
            for entry in inside {
                let own = CHECKPOINT_FILES.contains(&entry.as_str())
                    || temporary_of(&entry).is_some_and(|of| CHECKPOINT_FILES.contains(&of));
                if own {
                    remove(path.join(entry))?;
                }
            }
        }
        remove(path)?;
    }
    // `.NAME.PID-N-R.tmp` of a listed NAME (the atomic writer's temporary files).
    for entry in entries {
        if temporary_of(entry).is_some_and(|name| name == MANIFEST || listed.iter().any(|l| l == name)) {
            remove(out.join(entry))?;
        }
    }
    remove(out.join(MANIFEST))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifest_names_are_the_run_outputs_only() {
        for good in [
            "particles_000000.vtp",
            "particles_1234567.vtp",
            "particles.pvd",
            "report.csv",
            "scene.toml",
            "input_0_block.csv",
            "input_12_a b.csv",
            "checkpoints",
            "checkpoints/step_00000500",
        ] {
            assert!(is_run_output(good), "{good}");
        }
        for bad in [
            "../x",
            "/etc/passwd",
            "particles_1.vtp",
            "particles_000000.vtp/..",
            "input_0_../../x",
            "input__x",
            "input_0_",
            "checkpoints/../x",
            "checkpoints/step_1/../../x",
            "manifest.json",
            "notes.txt",
            "",
        ] {
            assert!(!is_run_output(bad), "{bad}");
        }
    }
}
