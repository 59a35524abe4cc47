//! `panoconv merge OUT`: joins the shard parts into `panoconv.json`. Streamed: each part is read
//! frame by frame into a spool of JSON lines beside the output (each frame's text kept as it
//! is, never parsed into numbers), and the manifest is written from the spool in order, so
//! memory does not grow with the frames and the bytes are those one run writes.

use super::index::LineIndex;
use super::pretty;
use crate::error::{Error, Result};
use crate::run::manifest::{FrameRecord, FrameStatus};
use crate::run::names::{shard_part, spool_name, IMAGE_SETS, MANIFEST};
use serde::de::{self, DeserializeSeed, MapAccess, SeqAccess, Visitor};
use serde_json::value::RawValue;
use serde_json::{Map, Value};
use std::collections::BTreeMap;
use std::fmt;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// `text` without the whitespace outside its strings: the compact form serde_json writes.
pub(super) fn compacted(text: &str) -> Vec<u8> {
    let mut out = Vec::with_capacity(text.len());
    let (mut in_string, mut escaped) = (false, false);
    for &c in text.as_bytes() {
        if in_string {
            match (escaped, c) {
                (true, _) => escaped = false,
                (false, b'\\') => escaped = true,
                (false, b'"') => in_string = false,
                _ => {}
            }
        } else if c.is_ascii_whitespace() {
            continue;
        } else if c == b'"' {
            in_string = true;
        }
        out.push(c);
    }
    out
}

/// The spool the parts' frames are appended to, and where each one is.
struct Spool {
    writer: BufWriter<File>,
    end: u64,
    index: LineIndex,
    /// The ids each split's converted frames (or their `--augment` views) were written as.
    written: BTreeMap<String, Vec<String>>,
}

impl Spool {
    fn push(&mut self, raw: &RawValue, part: u32) -> std::result::Result<(), String> {
        let text = raw.get();
        let r: FrameRecord =
            serde_json::from_str(text).map_err(|e| format!("malformed frame record: {e}"))?;
        let mut line = compacted(text);
        line.push(b'\n');
        self.writer.write_all(&line).map_err(|e| e.to_string())?;
        let failed = r.status == FrameStatus::Failed;
        self.index
            .push(&r.split, &r.id, failed, (self.end, line.len()), part);
        let ids = self.written.entry(r.split).or_default();
        if !failed {
            if r.views.iter().any(|v| v.view.is_some()) {
                ids.extend(r.views.into_iter().map(|v| v.id));
            } else {
                ids.push(r.id);
            }
        }
        self.end += line.len() as u64;
        Ok(())
    }
}

/// Reads a part: its fields other than `frames` are returned, its frames go to the spool.
struct PartVisitor<'a> {
    spool: &'a mut Spool,
    part: u32,
}

impl<'de> Visitor<'de> for PartVisitor<'_> {
    type Value = Map<String, Value>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a panoconv manifest")
    }

    fn visit_map<A: MapAccess<'de>>(
        self,
        mut map: A,
    ) -> std::result::Result<Self::Value, A::Error> {
        let mut header = Map::new();
        while let Some(key) = map.next_key::<String>()? {
            if key == "frames" {
                let (spool, part) = (&mut *self.spool, self.part);
                map.next_value_seed(EachFrame(|raw: &RawValue| spool.push(raw, part)))?;
            } else {
                header.insert(key, map.next_value()?);
            }
        }
        Ok(header)
    }
}

/// A manifest's `frames` array read one record at a time, never held whole: the function gets
/// each record's raw JSON, and an error it returns stops the read.
pub(super) struct EachFrame<F>(pub(super) F);

impl<'de, F: FnMut(&RawValue) -> std::result::Result<(), String>> DeserializeSeed<'de>
    for EachFrame<F>
{
    type Value = ();

    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> std::result::Result<(), D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de, F: FnMut(&RawValue) -> std::result::Result<(), String>> Visitor<'de> for EachFrame<F> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a list of frame records")
    }

    fn visit_seq<A: SeqAccess<'de>>(mut self, mut seq: A) -> std::result::Result<(), A::Error> {
        while let Some(raw) = seq.next_element::<Box<RawValue>>()? {
            (self.0)(&raw).map_err(de::Error::custom)?;
        }
        Ok(())
    }
}

/// Removes the spool however `merge` ends.
struct Remove(PathBuf);

impl Drop for Remove {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// Joins the shard manifests of `output` into `panoconv.json`: same parameters, every shard
/// present once and finished, no frame twice. Removes the parts afterwards. Returns the number
/// of frames.
pub fn merge(output: &Path) -> Result<usize> {
    let parts = shard_manifests(output)?;
    let spool_path = output.join(spool_name("merge"));
    let file = File::create(&spool_path).map_err(|e| Error::io(&spool_path, e))?;
    let _remove = Remove(spool_path.clone());
    let mut spool = Spool {
        writer: BufWriter::with_capacity(1 << 20, file),
        end: 0,
        index: LineIndex::default(),
        written: BTreeMap::new(),
    };
    let (mut header, parameters) = read_parts(&parts, &mut spool)?;
    spool
        .writer
        .flush()
        .map_err(|e| Error::io(&spool_path, e))?;
    spool.index.sort();
    if let Some((split, id, a, b)) = spool.index.duplicate() {
        return Err(Error::Setup(format!(
            "cannot merge: frame {split}/{id} is in shards {} and {}",
            a.min(b),
            a.max(b)
        )));
    }
    let augmented = parameters.get("augment").is_some_and(|a| !a.is_null());
    header.insert("parameters".into(), parameters);
    let counts = spool.index.counts();
    let lines = spool.index.lines(&spool_path)?;
    let counts = pretty::Counts {
        frames: counts.0,
        failed: counts.1,
        selected: None,
    };
    pretty::write_manifest(
        &output.join(MANIFEST),
        &header,
        counts,
        true,
        lines,
        &Map::new(),
    )?;
    if augmented {
        // As the unsharded run: the view ids, so that KITTI loaders find the views.
        let dir = output.join(IMAGE_SETS);
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        for (split, mut ids) in std::mem::take(&mut spool.written) {
            ids.sort_unstable();
            let text: String = ids.iter().map(|id| format!("{id}\n")).collect();
            crate::fs::write_atomic(&dir.join(format!("{split}.txt")), text.as_bytes())?;
        }
    }
    for path in parts.values() {
        let _ = std::fs::remove_file(path);
    }
    Ok(counts.frames)
}

/// The shard manifests of `output` by shard index: every shard of one count present, none
/// still running (a journal).
fn shard_manifests(output: &Path) -> Result<BTreeMap<u32, PathBuf>> {
    let entries = std::fs::read_dir(output)
        .map_err(|e| Error::Setup(format!("{}: {e}", output.display())))?;
    let mut parts: BTreeMap<u32, PathBuf> = BTreeMap::new();
    let mut unfinished: Vec<PathBuf> = Vec::new();
    let mut count = None;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let (part, journal) = match (shard_part(&name, "json"), shard_part(&name, "journal")) {
            (Some(p), _) => (p, false),
            (None, Some(p)) => (p, true),
            (None, None) => continue,
        };
        let (k, n) = part;
        if count.is_some_and(|c| c != n) {
            return Err(Error::Setup(format!(
                "{}: shards of different counts ({} and {n})",
                output.display(),
                count.unwrap_or(0)
            )));
        }
        count = Some(n);
        if journal {
            unfinished.push(e.path());
        } else {
            parts.insert(k, e.path());
        }
    }
    let n = count.ok_or_else(|| {
        Error::Setup(format!(
            "{}: no shard manifests (panoconv.shard-K-of-N.json)",
            output.display()
        ))
    })?;
    if let Some(j) = unfinished.first() {
        return Err(Error::Setup(format!(
            "cannot merge: {} is the journal of a shard that is running or was killed; resume it first",
            j.display()
        )));
    }
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
    Ok(parts)
}

/// A shard manifest's parameters without its shard: what every shard must share.
fn strip_shard(doc: &Map<String, Value>) -> Value {
    let mut p = doc.get("parameters").cloned().unwrap_or(Value::Null);
    if let Some(o) = p.as_object_mut() {
        o.insert("shard".into(), Value::Null);
    }
    p
}

/// Every shard's frame records into `spool`; the merged manifest's header (shard 0's tool,
/// version and command) and parameters, every shard's the same and complete.
fn read_parts(
    parts: &BTreeMap<u32, PathBuf>,
    spool: &mut Spool,
) -> Result<(Map<String, Value>, Value)> {
    let mut header = Map::new();
    let mut parameters = Value::Null;
    let mut complete = true;
    for (&k, path) in parts {
        let file = File::open(path).map_err(|e| Error::io(path, e))?;
        let mut de = serde_json::Deserializer::from_reader(std::io::BufReader::new(file));
        let doc = de::Deserializer::deserialize_map(
            &mut de,
            PartVisitor {
                spool: &mut *spool,
                part: k,
            },
        )
        .and_then(|doc| de.end().map(|()| doc))
        .map_err(|e| Error::parse(path, e.line(), "json", e.to_string()))?;
        if k == 0 {
            for key in ["tool", "version", "command"] {
                header.insert(key.into(), doc.get(key).cloned().unwrap_or(Value::Null));
            }
            parameters = strip_shard(&doc);
        } else if strip_shard(&doc) != parameters {
            return Err(Error::Setup(format!(
                "cannot merge: {} has other parameters than shard 0",
                path.display()
            )));
        }
        complete &= doc.get("complete") == Some(&Value::Bool(true));
    }
    if !complete {
        return Err(Error::Setup(
            "cannot merge: a shard did not finish (complete: false); resume it first".into(),
        ));
    }
    Ok((header, parameters))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compacted_pretty_text_is_the_compact_text() {
        let v = serde_json::json!({
            "split": "a b", "id": " \" \\\" { } [ ] : , \n", "x": [1.5e-7, -0.0, {}, [], [[]]],
            "y": {"z": null, "w": [true, false, 123456789012345678u64]}
        });
        let pretty = serde_json::to_string_pretty(&v).unwrap();
        assert_eq!(
            String::from_utf8(compacted(&pretty)).unwrap(),
            serde_json::to_string(&v).unwrap()
        );
    }

    #[test]
    fn a_frame_in_two_parts_is_refused_naming_both() {
        let dir = tempfile::tempdir().unwrap();
        let frame =
            r#"{"split": "training", "id": "000001", "status": "ok", "inputs": [], "outputs": []}"#;
        for k in 0..2 {
            let doc = format!(
                r#"{{"tool": "panoconv", "parameters": {{"shard": {{"index": {k}, "count": 2}}}}, "complete": true, "frames": [{frame}]}}"#
            );
            std::fs::write(
                dir.path().join(format!("panoconv.shard-{k}-of-2.json")),
                doc,
            )
            .unwrap();
        }
        let err = merge(dir.path()).unwrap_err().to_string();
        assert!(
            err.contains("frame training/000001 is in shards 0 and 1"),
            "{err}"
        );
        assert!(!dir.path().join(MANIFEST).exists());
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(left.len(), 2, "the spool is removed, the parts stay");
    }
}
