//! The one frame loop of every conversion: items in groups over the rayon pool, a previous
//! run's records kept where they still stand, each failure reported once and recorded, no new
//! group taken after SIGINT/SIGTERM or a full output device, then the manifest and the
//! summary. A command supplies only how to convert a group ([`FrameWork`]).

use crate::error::{Error, Result};
use crate::fs::hash_hex;
use crate::run::journal::{Journal, Previous};
use crate::run::manifest::{FrameRecord, FrameStatus};
use crate::run::{Progress, Summary};
use rayon::prelude::*;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::OnceLock;
use std::time::Instant;

/// What a command converts: its items, their keys and the conversion of a group.
pub trait FrameWork: Sync {
    /// One item (a frame, a folder image).
    type Item: Sync;

    /// The item's key in the manifest: `(split, id)`; a folder image has an empty split.
    fn key<'k>(&self, item: &'k Self::Item) -> (&'k str, &'k str);

    /// Converts a group of items (never empty), one result each in order: the record of a
    /// converted item, or its error. A failed item must leave no output behind, not even one
    /// from an earlier run into the same folder, which loaders would pick up.
    fn convert(&self, group: &[&Self::Item]) -> Vec<Result<FrameRecord>>;
}

/// A running conversion's frames (from [`crate::run::OutputFolder::start`]): the journal, the previous
/// run's records and what the workers share.
pub struct FrameRun<'a> {
    /// Where the records' input and output files are relative to.
    input: &'a Path,
    output: &'a Path,
    /// Whether the command offers `--resume` (what a full device's message advises).
    resumable: bool,
    /// When the run began.
    started: Instant,
    journal: Journal,
    previous: Previous,
    progress: &'a dyn Progress,
    stop: &'a AtomicBool,
    /// The first write the output device refused for want of space (or being read-only): no
    /// new item is taken after it, since every one would fail the same way.
    device_full: OnceLock<Error>,
    /// Set when the frames' source stopped answering: no new group is taken after it.
    source_lost: OnceLock<Error>,
    /// Items whose outputs exist (converted or kept from the previous run).
    written: AtomicUsize,
    /// Items given to [`Self::run`], and of those the ones taken and the ones kept.
    offered: usize,
    taken: usize,
    resumed: usize,
}

/// The item's name in progress reports: `split/id`, or the id alone without a split.
fn item_name(split: &str, id: &str) -> String {
    if split.is_empty() {
        id.to_owned()
    } else {
        format!("{split}/{id}")
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

impl<'a> FrameRun<'a> {
    /// The loop of a run from `input` into `output` (see [`crate::run::OutputFolder::start`]).
    pub(crate) fn new(
        (input, output): (&'a Path, &'a Path),
        resumable: bool,
        started: Instant,
        journal: Journal,
        previous: Previous,
        progress: &'a dyn Progress,
        stop: &'a AtomicBool,
    ) -> Self {
        Self {
            input,
            output,
            resumable,
            started,
            journal,
            previous,
            progress,
            stop,
            device_full: OnceLock::new(),
            source_lost: OnceLock::new(),
            written: AtomicUsize::new(0),
            offered: 0,
            taken: 0,
            resumed: 0,
        }
    }

    /// The previous run's records (empty unless `--resume`).
    pub fn previous(&self) -> &Previous {
        &self.previous
    }

    /// Whether the previous run recorded the item (it may still be found invalid).
    pub fn is_recorded<W: FrameWork>(&self, work: &W, item: &W::Item) -> bool {
        let (split, id) = work.key(item);
        self.previous.contains(split, id)
    }

    /// Converts `items` in groups of `group_len` consecutive items: the grouping depends on
    /// the selection and the options only, never on the thread count. Groups with an item to
    /// convert go first: a resumed run writes its first new item at once and re-checks the
    /// kept ones after (outcomes are only counted). Must run inside the caller's rayon pool.
    pub fn run<W: FrameWork>(&mut self, items: &[W::Item], group_len: usize, work: &W) {
        type Groups<'g, T> = Vec<&'g [T]>;
        let (new, kept): (Groups<W::Item>, Groups<W::Item>) = items
            .chunks(group_len.max(1))
            .partition(|g| g.iter().any(|i| !self.is_recorded(work, i)));
        let this = &*self;
        let outcomes: Vec<Option<bool>> = new
            .into_par_iter()
            .chain(kept)
            .flat_map_iter(|group| this.group(work, group))
            .collect();
        self.offered += items.len();
        for kept in outcomes.iter().flatten() {
            self.taken += 1;
            self.resumed += usize::from(*kept);
        }
    }

    /// One group: for each item, None when it was not taken (stopped, device full),
    /// Some(true) when kept from the previous run, Some(false) when converted or failed.
    fn group<W: FrameWork>(&self, work: &W, group: &[W::Item]) -> Vec<Option<bool>> {
        // SIGINT/SIGTERM, a full device or a lost source: take no new group; those in flight
        // finish.
        if self.stop.load(Ordering::Relaxed)
            || self.device_full.get().is_some()
            || self.source_lost.get().is_some()
        {
            return vec![None; group.len()];
        }
        let mut outcomes = vec![Some(true); group.len()];
        let mut todo = Vec::new();
        for (i, item) in group.iter().enumerate() {
            let (split, id) = work.key(item);
            if let Some(r) = self.previous.get(split, id) {
                if still_valid(&r, self.input, self.output) {
                    self.journal.record(r);
                    self.written.fetch_add(1, Ordering::Relaxed);
                    self.progress.frame_done();
                    continue;
                }
            }
            outcomes[i] = Some(false);
            todo.push((i, item));
        }
        if todo.is_empty() {
            return outcomes;
        }
        let items: Vec<&W::Item> = todo.iter().map(|&(_, item)| item).collect();
        let results = work.convert(&items);
        debug_assert_eq!(results.len(), items.len(), "one result per item");
        for ((i, item), converted) in todo.into_iter().zip(results) {
            let record = match converted {
                Ok(record) => {
                    self.written.fetch_add(1, Ordering::Relaxed);
                    self.progress.frame_done();
                    record
                }
                Err(e) if e.is_device_full() => {
                    // Not this item's fault: it is left for a later run, reported once.
                    let _ = self.device_full.set(e);
                    outcomes[i] = None;
                    continue;
                }
                Err(e) if e.is_source_lost() => {
                    // Nor this: the source is gone; the item is left for --resume.
                    let _ = self.source_lost.set(e);
                    outcomes[i] = None;
                    continue;
                }
                Err(e) => {
                    let (split, id) = work.key(item);
                    self.progress.frame_failed(&item_name(split, id), &e);
                    FrameRecord::failed(split, id, &e)
                }
            };
            self.journal.record(record);
        }
        outcomes
    }

    /// Reports and records an item that failed outside the loop (a file that cannot be read
    /// as a frame): counted, never silently dropped.
    pub fn record_failed(&self, split: &str, id: &str, error: &Error) {
        self.progress.frame_failed(&item_name(split, id), error);
        self.journal.record(FrameRecord::failed(split, id, error));
    }

    /// Ends the run: the files the command derives from the records (`extra`, which reads
    /// them through the journal), then the manifest (complete when every item offered was
    /// taken). `tables_built` goes to the summary.
    pub fn finish(
        self,
        tables_built: usize,
        extra: impl FnOnce(&Journal) -> Result<()>,
    ) -> Result<Summary> {
        self.progress.finish();
        let interrupted = self.taken < self.offered;
        let written = self.written.load(Ordering::Relaxed);
        let device_full = self.device_full.into_inner().map(|e| {
            if self.resumable {
                format!(
                    "output device full after {written} of {} frames ({e}): free space and run again with --resume",
                    self.offered
                )
            } else {
                format!("output device full ({e}): free space, then convert the images not in the manifest again")
            }
        });
        let source_lost = self.source_lost.into_inner().map(|e| {
            let resume = match self.resumable {
                true => "run again with --resume once it answers",
                false => "convert the frames not in the manifest again",
            };
            format!(
                "{e}: the frames' source stopped answering after {written} of {} frames; {resume}",
                self.offered
            )
        });
        // On a full device the manifest may not fit either: then say so with the rest.
        let when_full = |e: Error| match &device_full {
            Some(full) => Error::DeviceFull(format!(
                "{full}; the manifest could not be written either ({e})"
            )),
            None => e,
        };
        extra(&self.journal).map_err(when_full)?;
        let finished = self.journal.finish(!interrupted).map_err(when_full)?;
        Ok(Summary {
            frames: finished.frames,
            converted: finished.frames - finished.failed,
            failed: finished.failed,
            resumed: self.resumed,
            interrupted: interrupted && device_full.is_none() && source_lost.is_none(),
            device_full,
            source_lost,
            seconds: self.started.elapsed().as_secs_f64(),
            tables_built,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::{Claim, OutputFolder, OutputMode, Silent};
    use std::time::Instant;

    /// A client as small as a command's: frames "000001".. of one split, each written as a
    /// text file; frame "000002" fails.
    struct Numbers<'a> {
        output: &'a Path,
    }

    impl FrameWork for Numbers<'_> {
        type Item = String;

        fn key<'k>(&self, id: &'k String) -> (&'k str, &'k str) {
            ("seq", id)
        }

        fn convert(&self, group: &[&String]) -> Vec<Result<FrameRecord>> {
            group
                .iter()
                .map(|id| {
                    if id.as_str() == "000002" {
                        return Err(Error::file(Path::new(id.as_str()), "broken frame"));
                    }
                    let name = format!("{id}.txt");
                    crate::fs::write_atomic(&self.output.join(&name), id.as_bytes())?;
                    Ok(FrameRecord {
                        split: "seq".into(),
                        id: id.to_string(),
                        status: FrameStatus::Ok,
                        error: None,
                        inputs: Vec::new(),
                        outputs: vec![(name, hash_hex(id.as_bytes()))],
                        views: Vec::new(),
                        lidar: None,
                    })
                })
                .collect()
        }
    }

    fn convert(input: &Path, output: &Path, mode: OutputMode, ids: &[String]) -> Summary {
        let folder = OutputFolder::claim(Claim {
            input,
            output,
            shard: None,
            mode,
            resumable: true,
            started: Instant::now(),
        })
        .unwrap();
        let previous = folder.previous(&serde_json::json!({})).unwrap();
        folder.prepare().unwrap();
        let stop = AtomicBool::new(false);
        let mut run = folder
            .start(
                "numbers",
                serde_json::json!({}),
                previous,
                ids.len(),
                &Silent,
                &stop,
            )
            .unwrap();
        run.run(ids, 2, &Numbers { output });
        run.finish(0, |_| Ok(())).unwrap()
    }

    #[test]
    fn a_client_converts_records_failures_and_resumes() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in");
        std::fs::create_dir(&input).unwrap();
        let output = dir.path().join("out");
        let ids: Vec<String> = (1..=3).map(|n| format!("{n:06}")).collect();
        let s = convert(&input, &output, OutputMode::New, &ids);
        assert_eq!((s.frames, s.converted, s.failed, s.resumed), (3, 2, 1, 0));
        assert!(!s.interrupted && s.device_full.is_none());
        let manifest = std::fs::read_to_string(output.join(crate::run::names::MANIFEST)).unwrap();
        assert!(manifest.contains("broken frame"), "{manifest}");
        assert!(output.join("000003.txt").is_file());
        assert!(!output.join("000002.txt").exists());
        assert!(!output.join("panoconv.journal").exists());
        // A new run into the same folder is refused; a resumed one keeps what stands.
        assert!(OutputFolder::claim(Claim {
            input: &input,
            output: &output,
            shard: None,
            mode: OutputMode::New,
            resumable: true,
            started: Instant::now(),
        })
        .is_err());
        std::fs::write(output.join("000003.txt"), b"changed").unwrap();
        let s = convert(&input, &output, OutputMode::Resume, &ids);
        assert_eq!((s.frames, s.converted, s.failed, s.resumed), (3, 2, 1, 1));
        assert_eq!(std::fs::read(output.join("000003.txt")).unwrap(), b"000003");
    }
}
