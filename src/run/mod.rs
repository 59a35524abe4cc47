//! Running many items: the output folder a conversion claims and its one frame loop
//! (`output`, `frames`), the names of panoconv's own files in it, progress reporting, the
//! run's summary, values built once and shared between frames, the manifest's records, the
//! journal, files derived from an output, and the clearing of a previous run for
//! `--overwrite`.

pub mod alloc;
pub(crate) mod clear;
pub mod derived;
pub(crate) mod frames;
pub mod journal;
pub mod manifest;
pub(crate) mod names;
mod once_map;
pub(crate) mod output;
mod shard;

pub use frames::{FrameRun, FrameWork};
pub use once_map::OnceMap;
pub use output::{Claim, OutputFolder, OutputMode};
pub use shard::Shard;

use crate::error::Error;

/// Reports progress; the CLI passes an indicatif bar, tests a no-op.
pub trait Progress: Sync {
    /// The run begins with `total` items to do.
    fn start(&self, total: usize);
    /// One item finished without error (converted, or kept from a previous run).
    fn frame_done(&self);
    /// An item failed: report it (once) without disturbing the bar. `item` names it: a KITTI
    /// frame as `split/id`, a folder image by its file name.
    fn frame_failed(&self, item: &str, error: &Error);
    /// The run ended, every item taken or stopped early.
    fn finish(&self);
    /// A step that takes a while with no item finishing (building a remap table), shown until
    /// the next note or item; an empty message ends it.
    fn note(&self, _message: &str) {}
}

/// A progress reporter that says nothing.
pub struct Silent;

impl Progress for Silent {
    fn start(&self, _: usize) {}
    fn frame_done(&self) {}
    fn frame_failed(&self, _: &str, _: &Error) {}
    fn finish(&self) {}
}

/// What a run did, for the summary line and the exit code.
#[derive(Debug)]
pub struct Summary {
    /// Items the manifest records (KITTI frames or folder images), resumed ones included.
    pub frames: usize,
    /// Of those, the items converted without error.
    pub converted: usize,
    /// Of those, the items that failed (listed in the manifest with their error).
    pub failed: usize,
    /// Frames a previous run had completed (--resume).
    pub resumed: usize,
    /// Stopped by SIGINT/SIGTERM before every frame was taken.
    pub interrupted: bool,
    /// Stopped because the output device refused writes: what to tell the user.
    pub device_full: Option<String>,
    /// Stopped because the frames' source no longer answers: what to tell the user.
    pub source_lost: Option<String>,
    /// Wall-clock duration of the run, seconds.
    pub seconds: f64,
    /// Distinct remap tables built (one per source camera and output camera).
    pub tables_built: usize,
}
