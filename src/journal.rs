//! The run's manifest as a journal: rewritten atomically as frames finish, so a killed run
//! leaves a valid manifest of what is complete; read back by `--resume`; split into one part
//! per shard and joined by `merge`.

use crate::error::{read_file, Error, Result};
use crate::output::{hash_hex, write_atomic_durable, FrameRecord, FrameStatus};
use serde_json::{json, Value};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

pub const MANIFEST: &str = "panoconv.json";
/// How often a running conversion rewrites its manifest.
const FLUSH_EVERY: Duration = Duration::from_secs(2);

/// `--shard K/N`: this process converts the frames whose key hashes to K modulo N (K from 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Shard {
    pub index: u32,
    pub count: u32,
}

impl Shard {
    /// Whether a frame belongs to this shard. A hash of the frame's own key, so the split is
    /// stable when frames are added or removed.
    pub fn owns(&self, split: &str, id: &str) -> bool {
        let h = blake3::hash(format!("{split}/{id}").as_bytes());
        let v = u64::from_le_bytes(h.as_bytes()[..8].try_into().expect("8 bytes"));
        v % self.count as u64 == self.index as u64
    }

    pub fn manifest_name(&self) -> String {
        format!("panoconv.shard-{}-of-{}.json", self.index, self.count)
    }
}

/// The manifest being written by a run.
pub struct Journal {
    path: PathBuf,
    /// tool, version, command, parameters (in that order).
    header: serde_json::Map<String, Value>,
    state: Mutex<(Vec<FrameRecord>, Instant)>,
}

fn sorted(mut records: Vec<FrameRecord>) -> Vec<FrameRecord> {
    records.sort_by(|a, b| (&a.split, &a.id).cmp(&(&b.split, &b.id)));
    records
}

fn document(
    header: &serde_json::Map<String, Value>,
    records: &[FrameRecord],
    complete: bool,
) -> Value {
    let failed = records
        .iter()
        .filter(|r| r.status == FrameStatus::Failed)
        .count();
    let mut doc = header.clone();
    doc.insert(
        "summary".into(),
        json!({"frames": records.len(), "converted": records.len() - failed, "failed": failed}),
    );
    doc.insert("complete".into(), Value::Bool(complete));
    doc.insert(
        "frames".into(),
        serde_json::to_value(records).expect("records serialise"),
    );
    Value::Object(doc)
}

fn write_document(path: &Path, doc: &Value) -> Result<()> {
    let mut bytes = serde_json::to_vec_pretty(doc).expect("manifest serialises");
    bytes.push(b'\n');
    write_atomic_durable(path, &bytes)
}

impl Journal {
    pub fn new(
        output: &Path,
        shard: Option<Shard>,
        command: &str,
        parameters: Value,
        resumed: Vec<FrameRecord>,
    ) -> Self {
        let mut header = serde_json::Map::new();
        header.insert("tool".into(), json!("panoconv"));
        header.insert("version".into(), json!(env!("CARGO_PKG_VERSION")));
        header.insert("command".into(), json!(command));
        header.insert("parameters".into(), parameters);
        let name = shard.map_or(MANIFEST.to_owned(), |s| s.manifest_name());
        Self {
            path: output.join(name),
            header,
            state: Mutex::new((resumed, Instant::now())),
        }
    }

    /// Adds a finished frame; rewrites the manifest now and then. A failed intermediate write
    /// is retried at the next one; the final write reports its errors.
    pub fn record(&self, r: FrameRecord) {
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        state.0.push(r);
        if state.1.elapsed() >= FLUSH_EVERY {
            state.1 = Instant::now();
            let doc = document(&self.header, &sorted(state.0.clone()), false);
            let _ = write_document(&self.path, &doc);
        }
    }

    /// Writes the final manifest; `complete` is false for an interrupted run. Returns the
    /// records, sorted.
    pub fn finish(self, complete: bool) -> Result<Vec<FrameRecord>> {
        let records = sorted(self.state.into_inner().unwrap_or_else(|e| e.into_inner()).0);
        write_document(&self.path, &document(&self.header, &records, complete))?;
        Ok(records)
    }
}

/// A previous run's records, for `--resume`: refuses when its parameters differ.
pub fn load_previous(
    output: &Path,
    shard: Option<Shard>,
    parameters: &Value,
) -> Result<HashMap<(String, String), FrameRecord>> {
    let path = output.join(shard.map_or(MANIFEST.to_owned(), |s| s.manifest_name()));
    if !path.exists() {
        return Ok(HashMap::new());
    }
    let doc: Value = serde_json::from_slice(&read_file(&path)?)
        .map_err(|e| Error::parse(&path, e.line(), "json", e.to_string()))?;
    if doc.get("parameters") != Some(parameters) {
        let old = doc.get("parameters").cloned().unwrap_or(Value::Null);
        let differ: Vec<String> = match (&old, parameters) {
            (Value::Object(a), Value::Object(b)) => b
                .iter()
                .filter(|(k, v)| a.get(*k) != Some(v))
                .map(|(k, _)| k.clone())
                .collect(),
            _ => vec!["parameters".into()],
        };
        return Err(Error::Setup(format!(
            "cannot resume: {} was written with other parameters ({}); use the same options, or a new output folder",
            path.display(),
            differ.join(", ")
        )));
    }
    let mut out = HashMap::new();
    for f in doc
        .get("frames")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
    {
        if let Ok(r) = serde_json::from_value::<FrameRecord>(f.clone()) {
            out.insert((r.split.clone(), r.id.clone()), r);
        }
    }
    Ok(out)
}

/// Whether a previous record still stands: converted, inputs unchanged, every output present
/// with its recorded hash.
pub fn still_valid(r: &FrameRecord, input: &Path, output: &Path) -> bool {
    let same = |root: &Path, files: &[(String, String)]| {
        files
            .iter()
            .all(|(rel, hash)| std::fs::read(root.join(rel)).is_ok_and(|b| &hash_hex(&b) == hash))
    };
    r.status == FrameStatus::Ok
        && !r.outputs.is_empty()
        && same(input, &r.inputs)
        && same(output, &r.outputs)
}

/// Removes temporary files a killed run left behind (`.NAME.tmp-PID`).
pub fn remove_stale_temporaries(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            remove_stale_temporaries(&p);
        } else if e
            .file_name()
            .to_str()
            .is_some_and(|n| n.starts_with('.') && n.contains(".tmp-"))
        {
            let _ = std::fs::remove_file(&p);
        }
    }
}

/// Joins the shard manifests of `output` into `panoconv.json`: same parameters, every shard
/// present once, no frame twice. Removes the parts afterwards. Returns the number of frames.
pub fn merge(output: &Path) -> Result<usize> {
    let entries = std::fs::read_dir(output)
        .map_err(|e| Error::Setup(format!("{}: {e}", output.display())))?;
    let mut parts: BTreeMap<u32, (PathBuf, Value)> = BTreeMap::new();
    let mut count = None;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = name
            .strip_prefix("panoconv.shard-")
            .and_then(|r| r.strip_suffix(".json"))
        else {
            continue;
        };
        let Some((k, n)) = rest.split_once("-of-") else {
            continue;
        };
        let (Ok(k), Ok(n)) = (k.parse::<u32>(), n.parse::<u32>()) else {
            continue;
        };
        if count.is_some_and(|c| c != n) {
            return Err(Error::Setup(format!(
                "{}: shards of different counts ({} and {n})",
                output.display(),
                count.unwrap_or(0)
            )));
        }
        count = Some(n);
        let path = e.path();
        let doc: Value = serde_json::from_slice(&read_file(&path)?)
            .map_err(|err| Error::parse(&path, err.line(), "json", err.to_string()))?;
        parts.insert(k, (path, doc));
    }
    let n = count.ok_or_else(|| {
        Error::Setup(format!(
            "{}: no shard manifests (panoconv.shard-K-of-N.json)",
            output.display()
        ))
    })?;
    let missing: Vec<String> = (0..n)
        .filter(|k| !parts.contains_key(k))
        .map(|k| k.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(Error::Setup(format!(
            "cannot merge: shard(s) {} of {n} missing",
            missing.join(", ")
        )));
    }
    let strip_shard = |doc: &Value| -> Value {
        let mut p = doc.get("parameters").cloned().unwrap_or(Value::Null);
        if let Some(o) = p.as_object_mut() {
            o.insert("shard".into(), Value::Null);
        }
        p
    };
    let first = &parts[&0].1;
    let parameters = strip_shard(first);
    let mut records: Vec<FrameRecord> = Vec::new();
    let mut seen = HashMap::new();
    let mut complete = true;
    for (k, (path, doc)) in &parts {
        if strip_shard(doc) != parameters {
            return Err(Error::Setup(format!(
                "cannot merge: {} has other parameters than shard 0",
                path.display()
            )));
        }
        complete &= doc.get("complete") == Some(&Value::Bool(true));
        for f in doc
            .get("frames")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            let r: FrameRecord = serde_json::from_value(f.clone())
                .map_err(|e| Error::file(path, format!("malformed frame record: {e}")))?;
            if let Some(other) = seen.insert((r.split.clone(), r.id.clone()), *k) {
                return Err(Error::Setup(format!(
                    "cannot merge: frame {}/{} is in shards {other} and {k}",
                    r.split, r.id
                )));
            }
            records.push(r);
        }
    }
    if !complete {
        return Err(Error::Setup(
            "cannot merge: a shard did not finish (complete: false); resume it first".into(),
        ));
    }
    let mut header = serde_json::Map::new();
    for key in ["tool", "version", "command"] {
        header.insert(key.into(), first.get(key).cloned().unwrap_or(Value::Null));
    }
    header.insert("parameters".into(), parameters);
    let records = sorted(records);
    write_document(&output.join(MANIFEST), &document(&header, &records, true))?;
    for (path, _) in parts.values() {
        let _ = std::fs::remove_file(path);
    }
    Ok(records.len())
}
