//! The run's record of finished frames. While a conversion runs, each finished frame is
//! appended as one JSON line to `OUT/panoconv.journal` (a write-ahead log, fsynced in batches),
//! so the cost of a frame does not grow with the frames before it and a killed run leaves a
//! record of what is complete. At the end the manifest `panoconv.json` is written once,
//! streamed from the journal in frame order, and the journal removed. `--resume` reads
//! whichever of the two exists (both, the journal being newer); shards write a part each,
//! joined by `merge`.

mod index;
pub(crate) mod lock;
mod merge;
mod pretty;
mod previous;

use crate::error::{Error, Result};
use crate::run::manifest::{FrameRecord, FrameStatus};
use crate::run::names::{journal_path, manifest_name};
use serde_json::{json, Value};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

pub use crate::run::shard::Shard;
use index::LineIndex;
pub use lock::OutputLock;
pub use merge::merge;
pub use previous::{load_previous, previous_derived, Previous};

/// How often a running conversion makes its journal durable (fsync).
const SYNC_EVERY: Duration = Duration::from_secs(2);

struct State {
    file: File,
    /// The journal's length: where the next line goes.
    end: u64,
    index: LineIndex,
    last_sync: Instant,
    /// The first failed append; `finish` reports it (the frame's line is not in the journal).
    error: Option<std::io::Error>,
}

/// The record of a running conversion.
pub struct Journal {
    manifest: PathBuf,
    journal: PathBuf,
    /// tool, version, command, parameters (in that order).
    header: serde_json::Map<String, Value>,
    state: Mutex<State>,
    /// A second handle on the journal, to fsync outside the lock the workers take.
    sync: File,
    /// Items the run was to take (its selection); an unfinished manifest records it, so that
    /// `verify` can say how far the run got.
    selected: usize,
    /// Files tools derived from the previous run's outputs (its manifest's `derived`), kept by
    /// a resumed run.
    derived: Option<Value>,
}

/// What `finish` wrote.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Finished {
    /// Frames the manifest records, failed ones included.
    pub frames: usize,
    /// Of those, the frames that failed.
    pub failed: usize,
}

/// A record's line as the manifest lays it out: through a `Value`, as the manifest of the
/// whole run was always built (field order, numbers).
fn compact(r: &FrameRecord) -> Vec<u8> {
    serde_json::to_vec(&serde_json::to_value(r).expect("records serialise"))
        .expect("records serialise")
}

/// The length of `file` up to and including its last newline (a line torn by a kill is cut).
fn whole_lines_len(file: &mut File) -> std::io::Result<u64> {
    let len = file.seek(SeekFrom::End(0))?;
    let mut end = len;
    let mut buf = vec![0u8; 64 * 1024];
    while end > 0 {
        let start = end.saturating_sub(buf.len() as u64);
        let chunk = &mut buf[..(end - start) as usize];
        file.seek(SeekFrom::Start(start))?;
        file.read_exact(chunk)?;
        if let Some(i) = chunk.iter().rposition(|&b| b == b'\n') {
            return Ok(start + i as u64 + 1);
        }
        end = start;
    }
    Ok(0)
}

impl Journal {
    /// Starts the journal of a run into `output` (which the caller holds the lock of). With
    /// `resume`, a journal a killed run left is continued (its lines stay readable by a later
    /// `--resume` until the manifest is written); otherwise a new one is started. `selected`:
    /// the items the run is to take, which its journal's header records.
    pub fn new(
        output: &Path,
        shard: Option<Shard>,
        command: &str,
        parameters: Value,
        resume: bool,
        selected: usize,
    ) -> Result<Self> {
        let mut header = serde_json::Map::new();
        header.insert("tool".into(), json!("panoconv"));
        header.insert("version".into(), json!(env!("CARGO_PKG_VERSION")));
        header.insert("command".into(), json!(command));
        header.insert("parameters".into(), parameters);
        let manifest = output.join(manifest_name(shard));
        let journal = journal_path(&manifest);
        let io = |e| Error::io(&journal, e);
        let mut file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&journal)
            .map_err(io)?;
        let kept = if resume {
            whole_lines_len(&mut file).map_err(io)?
        } else {
            0
        };
        file.set_len(kept).map_err(io)?;
        file.seek(SeekFrom::Start(kept)).map_err(io)?;
        let mut end = kept;
        if kept == 0 {
            let mut first = header.clone();
            first.insert("selected".into(), json!(selected));
            let mut line = serde_json::to_vec(&Value::Object(first)).expect("header serialises");
            line.push(b'\n');
            file.write_all(&line).map_err(io)?;
            file.sync_data().map_err(io)?;
            end = line.len() as u64;
        }
        let sync = file.try_clone().map_err(io)?;
        Ok(Self {
            manifest,
            journal,
            header,
            state: Mutex::new(State {
                file,
                end,
                index: LineIndex::with_capacity(selected),
                last_sync: Instant::now(),
                error: None,
            }),
            sync,
            selected,
            derived: None,
        })
    }

    /// Keeps the previous manifest's `derived` entries (see [`previous_derived`]) in the
    /// manifest this run writes.
    pub fn keep_derived(&mut self, derived: Option<Value>) {
        self.derived = derived.filter(|d| d.as_array().is_some_and(|a| !a.is_empty()));
    }

    /// Appends a finished frame's line; every ~2 s the journal is fsynced (outside the lock).
    /// A failed append is reported by `finish`.
    pub fn record(&self, r: FrameRecord) {
        let mut line = compact(&r);
        line.push(b'\n');
        let due = {
            let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
            if s.error.is_some() {
                return;
            }
            if let Err(e) = s.file.write_all(&line) {
                // A partial line is cut by the next `--resume`; later lines would follow it.
                s.error.get_or_insert(e);
                return;
            }
            let at = (s.end, line.len());
            s.end += line.len() as u64;
            let failed = r.status == FrameStatus::Failed;
            s.index.push(&r.split, &r.id, failed, at, 0);
            let due = s.last_sync.elapsed() >= SYNC_EVERY;
            if due {
                s.last_sync = Instant::now();
            }
            due
        };
        if due {
            let _ = self.sync.sync_data();
        }
    }

    /// Calls `f` with every frame recorded so far, in manifest order (split, then id), read
    /// back from the journal one at a time.
    pub fn for_each_record(&self, mut f: impl FnMut(FrameRecord)) -> Result<()> {
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(e) = s.error.take() {
            return Err(Error::io(&self.journal, e));
        }
        s.index.sort();
        for line in s.index.lines(&self.journal)? {
            let r = serde_json::from_slice(&line?)
                .map_err(|e| Error::file(&self.journal, format!("malformed frame record: {e}")))?;
            f(r);
        }
        Ok(())
    }

    /// Writes the manifest (streamed from the journal) and removes the journal; `complete` is
    /// false for an interrupted run, whose summary then also says how many items the run was
    /// to take (`selected`).
    pub fn finish(self, complete: bool) -> Result<Finished> {
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(e) = s.error.take() {
            return Err(Error::io(&self.journal, e));
        }
        s.index.sort();
        let (frames, failed) = s.index.counts();
        let lines = s.index.lines(&self.journal)?;
        let mut after = serde_json::Map::new();
        if let Some(d) = &self.derived {
            after.insert("derived".into(), d.clone());
        }
        pretty::write_manifest(
            &self.manifest,
            &self.header,
            pretty::Counts {
                frames,
                failed,
                selected: (!complete).then_some(self.selected.max(frames)),
            },
            complete,
            lines,
            &after,
        )?;
        // The manifest now holds every line: a kill before this removal leaves both, and
        // `--resume` reads the same records from either.
        let _ = std::fs::remove_file(&self.journal);
        Ok(Finished { frames, failed })
    }
}
