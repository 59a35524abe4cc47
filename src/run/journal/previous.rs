//! A previous run's records, for `--resume`, flat in memory: the manifest and the journal are
//! read once, frame by frame, into a spool of compact JSON lines (a file in the output folder,
//! removed as soon as it is open, so nothing is left behind however the run ends); memory
//! holds only where each frame's line is. A record is read back and parsed when its frame
//! comes up.

use super::merge::{compacted, EachFrame};
use crate::error::{Error, Result};
use crate::run::manifest::FrameRecord;
use crate::run::names::{journal_path, manifest_name, spool_name, MANIFEST};
use crate::run::shard::Shard;
use serde::de::{self, MapAccess, Visitor};
use serde_json::value::RawValue;
use serde_json::Value;
use std::collections::HashMap;
use std::fmt;
use std::fs::File;
use std::io::{BufRead, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::Path;
use std::sync::Mutex;

/// The frames a previous run recorded, by (split, id).
#[derive(Default)]
pub struct Previous {
    /// The spool; None when there was nothing to resume.
    spool: Option<Mutex<File>>,
    splits: Vec<String>,
    /// Per split (index into `splits`): frame id → (offset, length) of its line in the spool.
    at: Vec<HashMap<Box<str>, (u64, u32)>>,
}

impl Previous {
    /// Whether a record of the frame exists (it may still be found invalid).
    pub fn contains(&self, split: &str, id: &str) -> bool {
        self.find(split, id).is_some()
    }

    /// The frame's record; None when there is none or it cannot be read back.
    pub fn get(&self, split: &str, id: &str) -> Option<FrameRecord> {
        let &(offset, len) = self.find(split, id)?;
        let mut file = self
            .spool
            .as_ref()?
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        let mut line = vec![0u8; len as usize];
        file.seek(SeekFrom::Start(offset)).ok()?;
        file.read_exact(&mut line).ok()?;
        drop(file);
        serde_json::from_slice(&line).ok()
    }

    fn find(&self, split: &str, id: &str) -> Option<&(u64, u32)> {
        let s = self.splits.iter().position(|x| x == split)?;
        self.at[s].get(id)
    }
}

/// The spool being written and the index being made.
struct Loader {
    writer: BufWriter<File>,
    end: u64,
    previous: Previous,
}

impl Loader {
    /// Adds a record's line (compact JSON, no newline) that parses as `r`; a later line of the
    /// same frame replaces an earlier one.
    fn push(&mut self, r: &FrameRecord, line: &[u8]) -> std::io::Result<()> {
        self.writer.write_all(line)?;
        let p = &mut self.previous;
        let s = match p.splits.iter().position(|x| *x == r.split) {
            Some(s) => s,
            None => {
                p.splits.push(r.split.clone());
                p.at.push(HashMap::new());
                p.splits.len() - 1
            }
        };
        p.at[s].insert(r.id.as_str().into(), (self.end, line.len() as u32));
        self.end += line.len() as u64;
        Ok(())
    }
}

/// Reads a manifest: its `parameters` are returned, its frames go to the spool (a frame that
/// cannot be read as a record is left out: it is redone).
struct ManifestVisitor<'a>(&'a mut Loader);

impl<'de> Visitor<'de> for ManifestVisitor<'_> {
    type Value = Value;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a panoconv manifest")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> std::result::Result<Value, A::Error> {
        let mut parameters = Value::Null;
        while let Some(key) = map.next_key::<String>()? {
            match key.as_str() {
                "frames" => {
                    let loader = &mut *self.0;
                    map.next_value_seed(EachFrame(|raw: &RawValue| {
                        let text = raw.get();
                        // a frame that cannot be read as a record is redone
                        let Ok(r) = serde_json::from_str::<FrameRecord>(text) else {
                            return Ok(());
                        };
                        loader.push(&r, &compacted(text)).map_err(|e| e.to_string())
                    }))?
                }
                "parameters" => parameters = map.next_value()?,
                _ => {
                    map.next_value::<de::IgnoredAny>()?;
                }
            }
        }
        Ok(parameters)
    }
}

fn check_parameters(path: &Path, old: &Value, parameters: &Value) -> Result<()> {
    if old == parameters {
        return Ok(());
    }
    let differ: Vec<String> = match (old, parameters) {
        (Value::Object(a), Value::Object(b)) => {
            let mut differ: Vec<String> = (b.iter())
                .filter(|(k, v)| a.get(*k) != Some(v))
                .map(|(k, _)| k.clone())
                .collect();
            // a key only the old run wrote (a flag it was given, e.g. `mask`) differs too
            differ.extend(a.keys().filter(|k| !b.contains_key(*k)).cloned());
            differ
        }
        _ => vec!["parameters".into()],
    };
    Err(Error::ResumeMismatch {
        manifest: path.to_path_buf(),
        differ,
    })
}

/// A previous run's records, for `--resume`: from its manifest, then its journal (newer, when
/// a later run was killed), a record of the journal replacing the manifest's. Refuses when
/// the parameters differ. A line a kill tore is ignored.
pub fn load_previous(output: &Path, shard: Option<Shard>, parameters: &Value) -> Result<Previous> {
    let manifest = output.join(manifest_name(shard));
    let journal = journal_path(&manifest);
    if !manifest.exists() && !journal.exists() {
        return Ok(Previous::default());
    }
    let spool_path = output.join(spool_name("resume"));
    let spool = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(true)
        .open(&spool_path)
        .map_err(|e| Error::io(&spool_path, e))?;
    // Open, the file stays readable; gone from the folder, it is never left behind.
    let _ = std::fs::remove_file(&spool_path);
    let mut loader = Loader {
        writer: BufWriter::with_capacity(1 << 20, spool),
        end: 0,
        previous: Previous::default(),
    };
    let spooled = |e: std::io::Error| Error::io(&spool_path, e);
    if manifest.exists() {
        let file = File::open(&manifest).map_err(|e| Error::io(&manifest, e))?;
        let mut de = serde_json::Deserializer::from_reader(std::io::BufReader::new(file));
        let old = de::Deserializer::deserialize_map(&mut de, ManifestVisitor(&mut loader))
            .and_then(|p| de.end().map(|()| p))
            .map_err(|e| Error::parse(&manifest, e.line(), "json", e.to_string()))?;
        check_parameters(&manifest, &old, parameters)?;
    }
    if journal.exists() {
        let file = File::open(&journal).map_err(|e| Error::io(&journal, e))?;
        let mut lines = std::io::BufReader::new(file).split(b'\n');
        let header = lines
            .next()
            .transpose()
            .map_err(|e| Error::io(&journal, e))?;
        // A journal whose header line was torn holds no frame.
        if let Some(Ok(header)) = header.map(|h| serde_json::from_slice::<Value>(&h)) {
            let old = header.get("parameters").cloned().unwrap_or(Value::Null);
            check_parameters(&journal, &old, parameters)?;
            for line in lines {
                let line = line.map_err(|e| Error::io(&journal, e))?;
                if let Ok(r) = serde_json::from_slice::<FrameRecord>(&line) {
                    loader.push(&r, &line).map_err(spooled)?;
                }
            }
        }
    }
    let file = loader
        .writer
        .into_inner()
        .map_err(|e| spooled(e.into_error()))?;
    let mut previous = loader.previous;
    previous.spool = Some(Mutex::new(file));
    Ok(previous)
}

/// The `derived` entries of the manifest in `output` (an unsharded run's), if it has any: what
/// tools wrote inside the dataset after the run a `--resume` continues.
pub fn previous_derived(output: &Path) -> Option<Value> {
    #[derive(serde::Deserialize)]
    struct Derived {
        #[serde(default)]
        derived: Option<Value>,
    }
    let file = File::open(output.join(MANIFEST)).ok()?;
    serde_json::from_reader::<_, Derived>(std::io::BufReader::new(file))
        .ok()?
        .derived
}
