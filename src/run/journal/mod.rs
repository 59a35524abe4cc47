//! The run's record of finished frames. While a conversion runs, each finished frame is
//! appended as one JSON line to `OUT/panoconv.journal` (a write-ahead log, fsynced in batches),
//! so the cost of a frame does not grow with the frames before it and a killed run leaves a
//! record of what is complete. At the end the manifest `panoconv.json` is written once,
//! streamed from the journal in frame order, and the journal removed. `--resume` reads
//! whichever of the two exists (both, the journal being newer); shards write a part each,
//! joined by `merge`.

mod index;
mod lock;
mod merge;
mod pretty;
mod previous;

use crate::error::{Error, Result};
use crate::fs::hash_hex;
use crate::run::manifest::MANIFEST;
use crate::run::manifest::{FrameRecord, FrameStatus};
use serde_json::{json, Value};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use index::LineIndex;
pub use lock::OutputLock;
pub use merge::merge;
pub use previous::{load_previous, previous_derived, Previous};

/// How often a running conversion makes its journal durable (fsync).
const SYNC_EVERY: Duration = Duration::from_secs(2);

/// `--shard K/N`: this process converts the frames whose key hashes to K modulo N (K from 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Shard {
    /// K: which shard this process converts, from 0 to `count` − 1.
    pub index: u32,
    /// N: the number of shards (at least 1).
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

    /// File name of this shard's manifest part: `panoconv.shard-K-of-N.json`.
    pub fn manifest_name(&self) -> String {
        format!("panoconv.shard-{}-of-{}.json", self.index, self.count)
    }
}

fn manifest_name(shard: Option<Shard>) -> String {
    shard.map_or(MANIFEST.to_owned(), |s| s.manifest_name())
}

/// The journal beside a manifest: `panoconv.json` → `panoconv.journal`.
fn journal_path(manifest: &Path) -> PathBuf {
    manifest.with_extension("journal")
}

/// Checks the output (see [`crate::fs::check_output_dir`]) and takes its lock, so one
/// process at a time converts into it (one per shard). A live holder is named in the
/// refusal, before the folder is found non-empty.
pub fn claim_output(
    input: &Path,
    output: &Path,
    shard: Option<Shard>,
    allow_nonempty: bool,
) -> Result<OutputLock> {
    lock::refuse_if_held(output, shard)?;
    crate::fs::check_output_dir(input, output, allow_nonempty)?;
    let existed = output.exists();
    std::fs::create_dir_all(output).map_err(|e| Error::io(output, e))?;
    let mut lock = lock::acquire(output, shard).inspect_err(|_| {
        if !existed {
            let _ = std::fs::remove_dir(output);
        }
    })?;
    lock.created = (!existed).then(|| output.to_path_buf());
    Ok(lock)
}

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
                index: LineIndex::default(),
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

/// Removes temporary files a killed run left behind (`.NAME.tmp-PID`). Those of a live process
/// on this host (another shard writing into the same folder) are left alone.
pub fn remove_stale_temporaries(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        // the entry's type from the folder listing: no stat per file (300 000 files at
        // 100 000 frames), and a link to a folder is not followed
        if e.file_type().is_ok_and(|t| t.is_dir()) {
            remove_stale_temporaries(&p);
            continue;
        }
        let name = e.file_name();
        let Some(pid) = name
            .to_str()
            .filter(|n| n.starts_with('.'))
            .and_then(|n| n.rsplit_once(".tmp-"))
            .map(|(_, pid)| pid)
        else {
            continue;
        };
        let live = pid
            .parse::<u32>()
            .is_ok_and(|pid| pid != std::process::id() && lock::pid_alive(pid));
        if !live {
            let _ = std::fs::remove_file(&p);
        }
    }
}
