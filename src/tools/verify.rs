//! `panoconv verify OUT`: checks a converted dataset against its manifest.
//!
//! Every output listed in `OUT/panoconv.json` is re-hashed (blake3) and compared with the
//! recorded hash. Files under `OUT` that no frame lists are reported too, so a stale file from an
//! earlier run, a half-written temporary or a file copied in by hand does not go unnoticed.
//! Files that tools derived from the dataset and wrote inside it (`labels-to-pixels`,
//! `preview`, ...) are listed under `derived` and checked the same way. Not counted as extra:
//! the manifest itself, manifest parts (`panoconv.*.json`), and with `--augment` the
//! `ImageSets/<split>.txt` lists the conversion writes beside the frames.
//!
//! A run that did not finish is not a dataset to train on, however well its files match: an
//! interrupted run (`"complete": false`) and a killed one (a journal, no manifest yet) are
//! reported as incomplete, with how many frames of how many it holds. Nor is a run whose
//! manifest records failed frames: it did not convert what it was asked, and the report lists
//! them ([`Report::failed`]) unless the caller allows them.

use crate::error::{Error, Result};
use crate::run::manifest::MANIFEST;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt;
use std::io::Read;
use std::path::{Component, Path, PathBuf};

/// The part of the manifest `verify` reads; other fields are ignored.
#[derive(Debug, Deserialize)]
struct ManifestView {
    #[serde(default)]
    parameters: Option<ParametersView>,
    frames: Vec<FrameView>,
    /// What tools wrote into the dataset afterwards (see [`crate::run::derived`]).
    #[serde(default)]
    derived: Vec<FrameView>,
    /// False for a run that was interrupted (absent in manifests of other tools' making).
    #[serde(default)]
    complete: Option<bool>,
    #[serde(default)]
    summary: Option<SummaryView>,
}

#[derive(Debug, Deserialize)]
struct SummaryView {
    #[serde(default)]
    frames: usize,
    /// The frames the run was to take (written when it did not finish).
    #[serde(default)]
    selected: Option<usize>,
}

#[derive(Debug, Deserialize)]
struct ParametersView {
    #[serde(default)]
    augment: Option<serde_json::Value>,
}

#[derive(Debug, Deserialize)]
struct FrameView {
    #[serde(default)]
    outputs: Vec<(String, String)>,
    #[serde(default)]
    split: String,
    #[serde(default)]
    id: String,
    /// `"failed"` for a frame the run could not convert (absent in `derived` entries).
    #[serde(default)]
    status: Option<String>,
    #[serde(default)]
    error: Option<String>,
}

/// A frame the run that wrote the folder recorded as failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FailedFrame {
    /// `split/id`, or the id alone for an item without a split (a folder image).
    pub frame: String,
    /// The error the run recorded.
    pub error: String,
}

/// How many failed frames the `failed:` line names before it only counts.
const FAILED_NAMED: usize = 3;

/// One disagreement between the manifest and the files.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Problem {
    /// Listed in the manifest, absent from the folder.
    Missing {
        /// The file, relative to the folder.
        path: String,
    },
    /// Present, but its blake3 differs from the manifest's.
    Changed {
        /// The file, relative to the folder.
        path: String,
        /// The blake3 the manifest records, hexadecimal.
        expected: String,
        /// The blake3 of the file as it is, hexadecimal.
        actual: String,
    },
    /// Present under the folder, listed by no frame.
    Extra {
        /// The file, relative to the folder.
        path: String,
    },
    /// Listed, present, but it cannot be read (permissions, a directory, a symlink loop...).
    Unreadable {
        /// The file, relative to the folder.
        path: String,
        /// The error reading it.
        cause: String,
    },
    /// The manifest lists a path that is absolute or climbs out of the folder with `..`; it is
    /// not opened.
    BadPath {
        /// The path as the manifest lists it.
        path: String,
    },
    /// The manifest lists the same path twice with different hashes.
    Conflict {
        /// The file, relative to the folder.
        path: String,
    },
}

impl Problem {
    /// The output path the problem concerns, relative to the folder.
    pub fn path(&self) -> &str {
        match self {
            Problem::Missing { path }
            | Problem::Changed { path, .. }
            | Problem::Extra { path }
            | Problem::Unreadable { path, .. }
            | Problem::BadPath { path }
            | Problem::Conflict { path } => path,
        }
    }
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Problem::Missing { path } => write!(f, "missing: {path}"),
            Problem::Changed {
                path,
                expected,
                actual,
            } => write!(
                f,
                "changed: {path} (manifest blake3 {expected}, file {actual})"
            ),
            Problem::Extra { path } => write!(f, "extra: {path} (not in the manifest)"),
            Problem::Unreadable { path, cause } => write!(f, "unreadable: {path}: {cause}"),
            Problem::BadPath { path } => write!(
                f,
                "bad path: {path:?} (absolute or outside the folder; not checked)"
            ),
            Problem::Conflict { path } => {
                write!(f, "conflict: {path} is listed twice with different hashes")
            }
        }
    }
}

/// A run that did not finish: the frames it recorded, of those it was to take.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Incomplete {
    /// Frames recorded (converted or failed).
    pub recorded: usize,
    /// Frames the run was to take, when its records say.
    pub selected: Option<usize>,
    /// Killed (a journal and no manifest) rather than interrupted (a manifest marked
    /// incomplete).
    pub killed: bool,
}

impl fmt::Display for Incomplete {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let how = if self.killed {
            "the run was killed (its journal, panoconv.journal, and no manifest)"
        } else {
            "the run was interrupted (the manifest says \"complete\": false)"
        };
        let of = self.selected.map_or(String::new(), |n| format!(" of {n}"));
        write!(
            f,
            "incomplete: {how} after {}{of} frames; run the same command again with --resume to finish it",
            self.recorded
        )
    }
}

/// The outcome of `verify`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Report {
    /// Distinct output files listed in the manifest.
    pub listed: usize,
    /// Listed files whose hash matched.
    pub matched: usize,
    /// Problems, sorted by kind then path.
    pub problems: Vec<Problem>,
    /// Set when the run that wrote the folder did not finish.
    pub incomplete: Option<Incomplete>,
    /// The frames the manifest records as failed, in its order.
    pub failed: Vec<FailedFrame>,
}

impl Report {
    /// Whether the folder is a finished dataset that agrees with its manifest: no problem of
    /// any kind.
    pub fn is_ok(&self) -> bool {
        self.is_ok_allowing_failed(false)
    }

    /// [`Report::is_ok`], with failed frames accepted when `allow_failed` (a run that was
    /// expected to leave some frames out).
    pub fn is_ok_allowing_failed(&self, allow_failed: bool) -> bool {
        self.problems.is_empty()
            && self.incomplete.is_none()
            && (allow_failed || self.failed.is_empty())
    }

    /// `failed: N frames failed in the run that wrote the folder (first: ...)`, or `None`
    /// when none did.
    pub fn failed_line(&self) -> Option<String> {
        let n = self.failed.len();
        if n == 0 {
            return None;
        }
        let named: Vec<String> = self
            .failed
            .iter()
            .take(FAILED_NAMED)
            .map(|f| format!("{}: {}", f.frame, f.error))
            .collect();
        let more = if n > FAILED_NAMED {
            format!("; and {} more", n - FAILED_NAMED)
        } else {
            String::new()
        };
        let frames = if n == 1 { "frame" } else { "frames" };
        Some(format!(
            "failed: {n} {frames} failed in the run that wrote the folder ({}{more}); see the manifest's \"failed\" records, or pass --allow-failed if that is intended",
            named.join("; ")
        ))
    }

    fn count(&self, pred: impl Fn(&Problem) -> bool) -> usize {
        self.problems.iter().filter(|p| pred(p)).count()
    }

    /// Number of [`Problem::Missing`] files.
    pub fn missing(&self) -> usize {
        self.count(|p| matches!(p, Problem::Missing { .. }))
    }
    /// Number of [`Problem::Changed`] files.
    pub fn changed(&self) -> usize {
        self.count(|p| matches!(p, Problem::Changed { .. }))
    }
    /// Number of [`Problem::Extra`] files.
    pub fn extra(&self) -> usize {
        self.count(|p| matches!(p, Problem::Extra { .. }))
    }

    /// `N files listed, M match, a missing, b changed, c extra[, d other problems]`.
    pub fn summary(&self) -> String {
        let other = self.problems.len() - self.missing() - self.changed() - self.extra();
        let mut s = format!(
            "{} files listed, {} match, {} missing, {} changed, {} extra",
            self.listed,
            self.matched,
            self.missing(),
            self.changed(),
            self.extra()
        );
        if other > 0 {
            s.push_str(&format!(", {other} other problems"));
        }
        s
    }
}

/// A killed run's records: `root/panoconv.journal`'s header line (with the frames the run was
/// to take) and one frame a line; a line a kill tore is left out.
fn read_journal(path: &Path) -> Result<ManifestView> {
    let bytes = crate::fs::read_file(path)?;
    let mut lines = bytes.split(|&b| b == b'\n');
    let header: serde_json::Value = lines
        .next()
        .and_then(|h| serde_json::from_slice(h).ok())
        .ok_or_else(|| Error::parse(path, 1, "header", "not a panoconv journal"))?;
    let frames: Vec<FrameView> = lines
        .filter_map(|l| serde_json::from_slice(l).ok())
        .collect();
    Ok(ManifestView {
        parameters: serde_json::from_value(header["parameters"].clone()).ok(),
        summary: Some(SummaryView {
            frames: frames.len(),
            selected: header["selected"].as_u64().map(|n| n as usize),
        }),
        frames,
        derived: Vec::new(),
        complete: Some(false),
    })
}

/// Reads `root/panoconv.json`, or the journal of a killed run when there is no manifest:
/// `Err` when neither exists, or it is unreadable or not a manifest (a JSON error names the
/// line and column).
fn read_manifest(root: &Path) -> Result<(ManifestView, bool)> {
    let path = root.join(MANIFEST);
    let journal = path.with_extension("journal");
    if !path.exists() && journal.is_file() {
        return Ok((read_journal(&journal)?, true));
    }
    let bytes = crate::fs::read_file(&path)?;
    serde_json::from_slice::<ManifestView>(&bytes)
        .map_err(|e| {
            let text = e.to_string();
            let suffix = format!(" at line {} column {}", e.line(), e.column());
            let what = text.strip_suffix(&suffix).unwrap_or(&text);
            Error::Parse {
                path: path.clone(),
                line: e.line(),
                field: format!("column {}", e.column()),
                message: format!("not a panoconv manifest: {what}"),
            }
        })
        .map(|m| (m, false))
}

/// A manifest path that stays inside the folder: relative, no `..`, no root.
fn safe_relative(rel: &str) -> bool {
    !rel.is_empty()
        && Path::new(rel)
            .components()
            .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
}

fn hash_file(path: &Path) -> std::io::Result<String> {
    let mut file = std::fs::File::open(path)?;
    let mut hasher = blake3::Hasher::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = file.read(&mut buf)?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    Ok(hasher.finalize().to_hex().to_string())
}

/// Whether an unlisted file is one the conversion writes without listing it.
fn ignored(rel: &str, augmented: bool) -> bool {
    // The journal and the lock a killed run leaves: its incompleteness is reported instead.
    if rel == MANIFEST || rel == "panoconv.journal" || rel == "panoconv.lock" {
        return true;
    }
    if let Some(part) = rel
        .strip_prefix("panoconv.")
        .and_then(|r| r.strip_suffix(".json"))
    {
        if !part.is_empty() && !part.contains('/') {
            return true;
        }
    }
    augmented
        && rel
            .strip_prefix("ImageSets/")
            .is_some_and(|n| n.ends_with(".txt") && !n.contains('/'))
}

/// Checks the folder `root` against its manifest. `Err` only when the manifest is missing,
/// unreadable or malformed, or the folder cannot be listed; every disagreement between the
/// manifest and the files is a [`Problem`] in the report.
pub fn verify(root: &Path) -> Result<Report> {
    let (manifest, killed) = read_manifest(root)?;
    let augmented = manifest
        .parameters
        .as_ref()
        .and_then(|p| p.augment.as_ref())
        .is_some_and(|a| !a.is_null());

    let mut report = Report::default();
    if manifest.complete == Some(false) {
        report.incomplete = Some(Incomplete {
            recorded: manifest
                .summary
                .as_ref()
                .map_or(manifest.frames.len(), |s| s.frames),
            selected: manifest.summary.as_ref().and_then(|s| s.selected),
            killed,
        });
    }
    report.failed = manifest
        .frames
        .iter()
        .filter(|f| f.status.as_deref() == Some("failed"))
        .map(|f| FailedFrame {
            frame: if f.split.is_empty() {
                f.id.clone()
            } else {
                format!("{}/{}", f.split, f.id)
            },
            error: f.error.clone().unwrap_or_default(),
        })
        .collect();
    let mut listed: BTreeMap<String, String> = BTreeMap::new();
    let listed_files = manifest
        .frames
        .iter()
        .chain(&manifest.derived)
        .flat_map(|f| &f.outputs);
    for (rel, hash) in listed_files {
        if !safe_relative(rel) {
            report.problems.push(Problem::BadPath { path: rel.clone() });
            continue;
        }
        let rel = rel.trim_start_matches("./").to_owned();
        match listed.get(&rel) {
            Some(h) if h != hash => report.problems.push(Problem::Conflict { path: rel }),
            Some(_) => {}
            None => {
                listed.insert(rel, hash.to_ascii_lowercase());
            }
        }
    }
    report.listed = listed.len();

    check_listed(root, &listed, &mut report);

    let (present, _) = crate::fs::walk_tree(root)?;
    for rel in present {
        if !listed.contains_key(&rel) && !ignored(&rel, augmented) {
            report.problems.push(Problem::Extra { path: rel });
        }
    }

    let rank = |p: &Problem| match p {
        Problem::BadPath { .. } => 0,
        Problem::Conflict { .. } => 1,
        Problem::Missing { .. } => 2,
        Problem::Changed { .. } => 3,
        Problem::Unreadable { .. } => 4,
        Problem::Extra { .. } => 5,
    };
    report
        .problems
        .sort_by(|a, b| (rank(a), a.path()).cmp(&(rank(b), b.path())));
    Ok(report)
}

/// Each listed file of `root` against its hash: matched, or a problem (missing, changed,
/// unreadable).
fn check_listed(root: &Path, listed: &BTreeMap<String, String>, report: &mut Report) {
    for (rel, expected) in listed {
        let path: PathBuf = root.join(rel);
        match std::fs::symlink_metadata(&path) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                report.problems.push(Problem::Missing { path: rel.clone() });
                continue;
            }
            _ => {}
        }
        match hash_file(&path) {
            Ok(actual) if &actual == expected => report.matched += 1,
            Ok(actual) => report.problems.push(Problem::Changed {
                path: rel.clone(),
                expected: expected.clone(),
                actual,
            }),
            Err(e) => report.problems.push(Problem::Unreadable {
                path: rel.clone(),
                cause: e.to_string(),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifest_parts_and_image_sets_are_not_extra() {
        assert!(ignored("panoconv.json", false));
        assert!(ignored("panoconv.part-1.json", false));
        assert!(!ignored("panoconv..json", false));
        assert!(!ignored("training/panoconv.json", false));
        assert!(!ignored("ImageSets/training.txt", false));
        assert!(ignored("ImageSets/training.txt", true));
        assert!(!ignored("ImageSets/a/b.txt", true));
    }

    #[test]
    fn unsafe_manifest_paths_are_refused() {
        assert!(safe_relative("training/image_2/000000.png"));
        assert!(!safe_relative("/etc/passwd"));
        assert!(!safe_relative("../x.png"));
        assert!(!safe_relative("training/../../x.png"));
        assert!(!safe_relative(""));
    }
}
