//! `--overwrite`: an output folder emptied of the previous run before a new one writes into it,
//! so that the result is exactly what a run into an empty folder leaves.
//!
//! Only files a previous run accounts for are removed: the outputs its manifest, manifest parts
//! or journal list (frames and `derived` files), those records themselves, the `ImageSets/`
//! lists of an `--augment` run, and temporaries a killed run left. Any other file is a set-up
//! error that names it, and then nothing is removed. Listed paths are checked (relative, no
//! `..`) and the folder is walked without following symlinks, so a removal never reaches
//! outside it. Folders left empty are removed too (a run into an empty folder creates only the
//! folders it writes into); the locks of running processes are left alone.

use crate::error::{Error, Result};
use crate::run::names::{is_lock, is_record, is_temporary, IMAGE_SETS};
use serde::Deserialize;
use serde_json::Value;
use std::collections::BTreeSet;
use std::io::BufRead;
use std::path::{Component, Path};

/// The part of a manifest (or of a journal line) that says which files a run wrote.
#[derive(Deserialize, Default)]
struct Listed {
    #[serde(default)]
    parameters: Value,
    #[serde(default)]
    frames: Vec<Outputs>,
    #[serde(default)]
    derived: Vec<Outputs>,
}

#[derive(Deserialize, Default)]
struct Outputs {
    #[serde(default)]
    outputs: Vec<(String, String)>,
}

/// A listed path that stays inside the folder: relative, no `..`, no root.
fn safe_relative(rel: &str) -> bool {
    !rel.is_empty()
        && Path::new(rel)
            .components()
            .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
}

/// Adds what a record file lists to `listed`; returns whether the run was `--augment`ed. A
/// record that cannot be read lists nothing (its files are then unaccounted for).
fn read_record(path: &Path, listed: &mut BTreeSet<String>) -> bool {
    let mut add = |doc: &Listed| {
        for o in doc.frames.iter().chain(&doc.derived) {
            for (rel, _) in &o.outputs {
                if safe_relative(rel) {
                    listed.insert(rel.trim_start_matches("./").to_owned());
                }
            }
        }
        doc.parameters.get("augment").is_some_and(|a| !a.is_null())
    };
    let Ok(file) = std::fs::File::open(path) else {
        return false;
    };
    let reader = std::io::BufReader::new(file);
    if path.extension().is_some_and(|e| e == "journal") {
        // A header line, then one frame record a line.
        let mut augmented = false;
        for (i, line) in reader.split(b'\n').enumerate() {
            let Ok(line) = line else { break };
            if i == 0 {
                let header: Listed = serde_json::from_slice(&line).unwrap_or_default();
                augmented = add(&header);
            } else if let Ok(frame) = serde_json::from_slice::<Outputs>(&line) {
                add(&Listed {
                    frames: vec![frame],
                    ..Listed::default()
                });
            }
        }
        augmented
    } else {
        let doc: Listed = serde_json::from_reader(reader).unwrap_or_default();
        add(&doc)
    }
}

/// Empties `output` of a previous run (see the module's comment) and returns how many files
/// were removed. Refuses, removing nothing, when it holds a file no previous run accounts for.
pub fn clear_previous_run(output: &Path) -> Result<usize> {
    let (files, dirs) = crate::fs::walk_tree(output)?;
    let mut listed = BTreeSet::new();
    let mut augmented = false;
    for rel in &files {
        if !rel.contains('/') && is_record(rel) {
            augmented |= read_record(&output.join(rel), &mut listed);
        }
    }
    let accounted = |rel: &str| {
        listed.contains(rel)
            || is_temporary(rel)
            || (!rel.contains('/') && is_record(rel))
            || (augmented
                && rel
                    .strip_prefix(IMAGE_SETS)
                    .and_then(|r| r.strip_prefix('/'))
                    .is_some_and(|n| n.ends_with(".txt") && !n.contains('/')))
    };
    // A lock at the root is a running process's (ours among them): neither removed nor refused.
    let root_lock = |rel: &str| !rel.contains('/') && is_lock(rel);
    let mut unknown: Vec<&String> = files
        .iter()
        .filter(|rel| !root_lock(rel) && !accounted(rel))
        .collect();
    if !unknown.is_empty() {
        unknown.sort();
        const SHOWN: usize = 5;
        let mut names: Vec<String> = unknown.iter().take(SHOWN).map(|s| s.to_string()).collect();
        if unknown.len() > SHOWN {
            names.push(format!("and {} more", unknown.len() - SHOWN));
        }
        return Err(Error::Setup(format!(
            "--overwrite: {} holds {} that no earlier panoconv run into it wrote ({}); \
             --overwrite removes only a previous run's files: move these away, or choose another --output",
            output.display(),
            if unknown.len() == 1 {
                "1 file".to_owned()
            } else {
                format!("{} files", unknown.len())
            },
            names.join(", ")
        )));
    }
    let mut removed = 0;
    for rel in &files {
        if root_lock(rel) {
            continue;
        }
        let path = output.join(rel);
        std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?;
        removed += 1;
    }
    // Deepest first (the walk lists a folder after its contents); only empty ones go.
    for dir in &dirs {
        let _ = std::fs::remove_dir(dir);
    }
    Ok(removed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_of_records_locks_and_temporaries() {
        assert!(is_record("panoconv.json"));
        assert!(is_record("panoconv.journal"));
        assert!(!is_record("other.json"));
        assert!(is_record("panoconv.shard-1-of-4.journal"));
        assert!(!is_record("panoconv.lock"));
        assert!(is_lock("panoconv.shard-0-of-2.lock"));
        assert!(is_temporary("training/image_2/.000001.png.tmp-123"));
        assert!(!is_temporary("training/image_2/000001.png.tmp-123"));
        assert!(!is_temporary(".x.tmp-"));
        assert!(!safe_relative("../x"));
        assert!(!safe_relative("/etc/passwd"));
    }
}
