//! Writing outputs: atomic files, the output-folder checks, and the manifest.

use crate::error::{Error, Result};
use serde::Serialize;
use std::io::Write;
use std::path::{Component, Path, PathBuf};

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so a
/// reader (or a killed process) never sees a half-written file. Not fsynced: a frame's files
/// are many and small, and after an OS crash `--resume` re-hashes every output anyway; the
/// manifest, the commit point, goes through [`write_atomic_durable`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_via_temporary(path, bytes, false)
}

/// As [`write_atomic`], and on disk before the rename.
pub fn write_atomic_durable(path: &Path, bytes: &[u8]) -> Result<()> {
    write_via_temporary(path, bytes, true)
}

fn write_via_temporary(path: &Path, bytes: &[u8], durable: bool) -> Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let write = || -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        if durable {
            f.sync_data()?;
        }
        std::fs::rename(&tmp, path)
    };
    write().map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}

/// `path` made absolute and free of `.`/`..`, resolving symlinks as far as the path exists.
pub(crate) fn resolve(path: &Path) -> Result<PathBuf> {
    let joined = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()
            .map_err(|e| Error::io(Path::new("."), e))?
            .join(path)
    };
    // `..` after a folder that does not exist yet can only be resolved lexically.
    let mut abs = PathBuf::new();
    for c in joined.components() {
        match c {
            Component::ParentDir if !abs.exists() => {
                abs.pop();
            }
            Component::CurDir => {}
            c => abs.push(c),
        }
    }
    let mut existing = abs.clone();
    let mut rest = Vec::new();
    while !existing.exists() {
        match (existing.file_name(), existing.parent()) {
            (Some(n), Some(p)) => {
                rest.push(n.to_owned());
                existing = p.to_path_buf();
            }
            _ => break,
        }
    }
    let mut out = existing
        .canonicalize()
        .map_err(|e| Error::io(&existing, e))?;
    for c in rest.iter().rev() {
        match Path::new(c).components().next() {
            Some(Component::ParentDir) => {
                out.pop();
            }
            Some(Component::CurDir) | None => {}
            _ => out.push(c),
        }
    }
    Ok(out)
}

/// Checks, before anything is written, that the output is usable: not the input, not inside it,
/// and empty unless `overwrite`.
pub fn check_output_dir(input: &Path, output: &Path, overwrite: bool) -> Result<()> {
    let (i, o) = (resolve(input)?, resolve(output)?);
    if o == i {
        return Err(Error::Setup(format!(
            "output {} is the input dataset",
            output.display()
        )));
    }
    if o.starts_with(&i) {
        return Err(Error::Setup(format!(
            "output {} is inside the input dataset {}; panoconv never writes into its input",
            output.display(),
            input.display()
        )));
    }
    if output.exists() {
        if !output.is_dir() {
            return Err(Error::Setup(format!(
                "output {} exists and is not a directory",
                output.display()
            )));
        }
        let mut entries = std::fs::read_dir(output).map_err(|e| Error::io(output, e))?;
        if entries.next().is_some() && !overwrite {
            return Err(Error::Setup(format!(
                "output {} is not empty (use --overwrite to write into it)",
                output.display()
            )));
        }
    }
    Ok(())
}

pub fn hash_hex(bytes: &[u8]) -> String {
    blake3::hash(bytes).to_hex().to_string()
}

#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct FrameRecord {
    pub split: String,
    pub id: String,
    pub status: FrameStatus,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Input file (relative to the input root) → blake3.
    pub inputs: Vec<(String, String)>,
    /// Output file (relative to the output root) → blake3.
    pub outputs: Vec<(String, String)>,
    /// With --augment: each view's output id and how it was drawn.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub views: Vec<ViewRecord>,
    /// With --depth: what happened to the LiDAR points (of the last view).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lidar: Option<LidarRecord>,
}

#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct LidarRecord {
    pub points: usize,
    pub dropped_non_finite: usize,
    pub dropped_occluded: usize,
    pub depth_pixels: usize,
}

impl FrameRecord {
    /// The record of a frame that failed: its error, no outputs.
    pub fn failed(split: &str, id: &str, error: &crate::error::Error) -> Self {
        Self {
            split: split.to_owned(),
            id: id.to_owned(),
            status: FrameStatus::Failed,
            error: Some(error.to_string()),
            inputs: Vec::new(),
            outputs: Vec::new(),
            views: Vec::new(),
            lidar: None,
        }
    }
}

#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct ViewRecord {
    pub id: String,
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub view: Option<crate::augment::View>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FrameStatus {
    Ok,
    Failed,
}
