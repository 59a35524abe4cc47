//! Files that tools derive from a converted dataset and write inside it (`labels-to-pixels`
//! into `OUT/training/pixels`, `preview` into `OUT/`, exports): each run's files are recorded in
//! the dataset's manifest under `derived`, so that `panoconv verify` checks them like the
//! frames' outputs instead of calling them extra.
//!
//! One entry per (command, target): running the same command into the same place again
//! replaces its entry. A new conversion into the folder (`--overwrite`, `--resume`) writes a
//! new manifest without them.

use crate::error::{Error, Result};
use crate::fs::read_file;
use crate::fs::{hash_hex, write_atomic_durable};
use crate::run::manifest::MANIFEST;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// The converted dataset that `path` (a file or folder, existing or not) lies in: the nearest
/// enclosing folder holding a manifest.
pub fn dataset_of(path: &Path) -> Option<PathBuf> {
    let abs = std::path::absolute(path).ok()?;
    abs.ancestors()
        .find(|dir| dir.join(MANIFEST).is_file())
        .map(Path::to_path_buf)
}

/// `root`-relative path with `/` separators.
fn relative(root: &Path, path: &Path) -> Option<String> {
    let rel = path.strip_prefix(root).ok()?;
    Some(
        rel.components()
            .map(|c| c.as_os_str().to_string_lossy())
            .collect::<Vec<_>>()
            .join("/"),
    )
}

/// Records `files` (absolute, inside `root`) as what `command` wrote to `target` (the output
/// folder or file it was given, inside `root`), replacing an earlier record of the same command
/// and target. The manifest is rewritten atomically.
pub fn record(root: &Path, command: &str, target: &Path, files: &[PathBuf]) -> Result<()> {
    let root = std::path::absolute(root).map_err(|e| Error::io(root, e))?;
    let manifest = root.join(MANIFEST);
    let mut doc: Value = serde_json::from_slice(&read_file(&manifest)?)
        .map_err(|e| Error::parse(&manifest, e.line(), "json", e.to_string()))?;
    let target_abs = std::path::absolute(target).map_err(|e| Error::io(target, e))?;
    let target_rel = relative(&root, &target_abs).ok_or_else(|| {
        Error::Setup(format!(
            "{} is not inside {}",
            target.display(),
            root.display()
        ))
    })?;
    let mut outputs = Vec::with_capacity(files.len());
    for file in files {
        let abs = std::path::absolute(file).map_err(|e| Error::io(file, e))?;
        let rel = relative(&root, &abs).ok_or_else(|| {
            Error::Setup(format!(
                "{} is not inside {}",
                file.display(),
                root.display()
            ))
        })?;
        outputs.push(json!([rel, hash_hex(&read_file(&abs)?)]));
    }
    outputs.sort_by(|a, b| a[0].as_str().cmp(&b[0].as_str()));
    let Some(object) = doc.as_object_mut() else {
        return Err(Error::file(
            &manifest,
            "not a panoconv manifest (not an object)",
        ));
    };
    let entries = object
        .entry("derived")
        .or_insert_with(|| Value::Array(Vec::new()));
    let Some(list) = entries.as_array_mut() else {
        return Err(Error::file(&manifest, "`derived` is not a list"));
    };
    list.retain(|e| !(e["command"] == command && e["target"] == target_rel.as_str()));
    list.push(json!({"command": command, "target": target_rel, "outputs": outputs}));
    list.sort_by(|a, b| {
        (a["target"].as_str(), a["command"].as_str())
            .cmp(&(b["target"].as_str(), b["command"].as_str()))
    });
    let mut bytes = serde_json::to_vec_pretty(&doc).expect("manifest serialises");
    bytes.push(b'\n');
    write_atomic_durable(&manifest, &bytes)
}

/// If `target` lies inside a converted dataset, records `files` there (see [`record`]);
/// returns the dataset's root when it did.
pub fn record_if_inside(
    command: &str,
    target: &Path,
    files: &[PathBuf],
) -> Result<Option<PathBuf>> {
    match dataset_of(target) {
        Some(root) => record(&root, command, target, files).map(|()| Some(root)),
        None => Ok(None),
    }
}
