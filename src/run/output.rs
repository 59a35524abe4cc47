//! The output folder of a conversion, as one object that every converting command goes
//! through in the same order: claim (the folder checked and locked) → the previous run's
//! records (`--resume`) → the folder made ready (`--overwrite`'s clearing, a killed run's
//! temporaries) → the journal and the frame loop ([`crate::run::frames::FrameRun`]) → the
//! manifest. A command adds only what is its own: its checks, its folders and its frames.

use crate::error::{Error, Result};
use crate::run::frames::FrameRun;
use crate::run::journal::{self, OutputLock, Previous};
use crate::run::names;
use crate::run::shard::Shard;
use crate::run::Progress;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Mutex;
use std::time::Instant;

/// What the run does with what the output folder already holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputMode {
    /// The folder must be empty (or absent).
    New,
    /// `--overwrite`: a previous run's files are removed first (only files a previous run
    /// accounts for; anything else is refused, and nothing is removed).
    Overwrite,
    /// `--resume`: a previous run's records are kept where they still stand.
    Resume,
}

impl OutputMode {
    /// The mode of the command-line flags; `--resume` wins over `--overwrite`.
    pub fn from_flags(overwrite: bool, resume: bool) -> Self {
        match (overwrite, resume) {
            (_, true) => Self::Resume,
            (true, false) => Self::Overwrite,
            (false, false) => Self::New,
        }
    }
}

/// How a run claims its output folder.
#[derive(Debug, Clone)]
pub struct Claim<'a> {
    /// The input (dataset root or folder); the output may not lie inside it.
    pub input: &'a Path,
    /// The output folder.
    pub output: &'a Path,
    /// `--shard K/N`: several processes share the folder, one lock and manifest part each.
    pub shard: Option<Shard>,
    /// New, overwrite or resume.
    pub mode: OutputMode,
    /// Whether the command offers `--resume` (what a full device's message advises).
    pub resumable: bool,
    /// When the run began (the summary's duration).
    pub started: Instant,
}

/// A claimed output folder: checked, locked for this process (per shard) until dropped.
#[derive(Debug)]
pub struct OutputFolder {
    input: PathBuf,
    root: PathBuf,
    shard: Option<Shard>,
    mode: OutputMode,
    resumable: bool,
    started: Instant,
    /// The folders [`Self::create_dirs`] made, parents first: removed when the run ends if
    /// still empty.
    created: Mutex<Vec<PathBuf>>,
    _lock: OutputLock,
}

impl OutputFolder {
    /// Checks the output (see [`crate::fs::check_output_dir`]) and takes its lock, so one
    /// process at a time converts into it (one per shard). A live holder is named in the
    /// refusal, before the folder is found non-empty. Resumed runs, overwrites and shards
    /// write into a folder that already holds outputs.
    pub fn claim(c: Claim) -> Result<Self> {
        let allow_nonempty = c.mode != OutputMode::New || c.shard.is_some();
        journal::lock::refuse_if_held(c.output, c.shard)?;
        crate::fs::check_output_dir(c.input, c.output, allow_nonempty)?;
        let existed = c.output.exists();
        std::fs::create_dir_all(c.output).map_err(|e| Error::io(c.output, e))?;
        let mut lock = journal::lock::acquire(c.output, c.shard).inspect_err(|_| {
            if !existed {
                let _ = std::fs::remove_dir(c.output);
            }
        })?;
        lock.created = (!existed).then(|| c.output.to_path_buf());
        Ok(Self {
            input: c.input.to_path_buf(),
            root: c.output.to_path_buf(),
            shard: c.shard,
            mode: c.mode,
            resumable: c.resumable,
            started: c.started,
            created: Mutex::default(),
            _lock: lock,
        })
    }

    /// Creates the folders the run writes into (`training/image_2`, ...), noting those it
    /// makes, the ones between them and the root included. Those still empty when the run
    /// ends are removed again, so that a run that wrote no frame (every one failed, or a stop
    /// before the first) leaves no empty `image_2/` that looks like a dataset; only folders
    /// this run made, only empty ones. Shards share the folders (another may be about to
    /// write into one), so a sharded run removes none.
    pub fn create_dirs(&self, dirs: impl IntoIterator<Item = PathBuf>) -> Result<()> {
        let mut created = self.created.lock().unwrap_or_else(|e| e.into_inner());
        for dir in dirs {
            let mut missing = Vec::new();
            let mut d = dir.as_path();
            while d.starts_with(&self.root) && d != self.root && !d.exists() {
                missing.push(d.to_path_buf());
                d = d.parent().unwrap_or(&self.root);
            }
            std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
            created.extend(missing.into_iter().rev());
        }
        Ok(())
    }

    /// The output folder.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The input the records' input files are relative to.
    pub fn input(&self) -> &Path {
        &self.input
    }

    /// This process's shard.
    pub fn shard(&self) -> Option<Shard> {
        self.shard
    }

    /// New, overwrite or resume.
    pub fn mode(&self) -> OutputMode {
        self.mode
    }

    /// Whether this process writes the folder's files that belong to no frame (image lists,
    /// reports of the whole input): an unsharded run, or shard 0.
    pub fn writes_shared_files(&self) -> bool {
        self.shard.is_none_or(|s| s.index == 0)
    }

    /// The previous run's records with `--resume` (refused when its parameters differ from
    /// `parameters`); none otherwise.
    pub fn previous(&self, parameters: &Value) -> Result<Previous> {
        match self.mode {
            OutputMode::Resume => journal::load_previous(&self.root, self.shard, parameters),
            OutputMode::New | OutputMode::Overwrite => Ok(Previous::default()),
        }
    }

    /// Makes the folder ready to be written, after every set-up check: `--overwrite` removes
    /// the previous run's files (the result must be what a run into an empty folder leaves;
    /// shards share the folder, so they clear nothing), `--resume` the temporaries a killed
    /// run left.
    pub fn prepare(&self) -> Result<()> {
        match self.mode {
            OutputMode::Overwrite if self.shard.is_none() => {
                crate::run::clear::clear_previous_run(&self.root)?;
            }
            OutputMode::Resume => remove_stale_temporaries(&self.root),
            OutputMode::New | OutputMode::Overwrite => {}
        }
        std::fs::create_dir_all(&self.root).map_err(|e| Error::io(&self.root, e))
    }

    /// Starts the journal of the run (the manifest's `command` and `parameters`; `selected`
    /// items to take, which progress counts) and returns the frame loop that writes it.
    /// `previous`: from [`Self::previous`]; `stop` (SIGINT, SIGTERM) ends the taking of
    /// frames.
    pub fn start<'a>(
        &'a self,
        command: &str,
        parameters: Value,
        previous: Previous,
        selected: usize,
        progress: &'a dyn Progress,
        stop: &'a AtomicBool,
    ) -> Result<FrameRun<'a>> {
        let resume = self.mode == OutputMode::Resume;
        let mut journal = journal::Journal::new(
            &self.root, self.shard, command, parameters, resume, selected,
        )?;
        if resume && self.shard.is_none() {
            journal.keep_derived(journal::previous_derived(&self.root));
        }
        progress.start(selected);
        Ok(FrameRun::new(
            (&self.input, &self.root),
            self.resumable,
            self.started,
            journal,
            previous,
            progress,
            stop,
        ))
    }
}

impl Drop for OutputFolder {
    /// The folders this run made that it left empty, deepest first (before the lock goes).
    fn drop(&mut self) {
        if self.shard.is_some() {
            return;
        }
        let created = self.created.get_mut().unwrap_or_else(|e| e.into_inner());
        for dir in created.iter().rev() {
            let _ = std::fs::remove_dir(dir); // only if empty
        }
    }
}

/// Removes temporary files a killed run left behind (`.NAME.tmp-PID`). Those of a live process
/// on this host (another shard writing into the same folder) are left alone.
fn remove_stale_temporaries(dir: &Path) {
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
        let Some(name) = name.to_str().filter(|n| names::is_temporary(n)) else {
            continue;
        };
        let live = names::temporary_owner(name)
            .is_some_and(|pid| pid != std::process::id() && journal::lock::pid_alive(pid));
        if !live {
            let _ = std::fs::remove_file(&p);
        }
    }
}
