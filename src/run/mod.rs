//! Running many items: progress reporting, the run's summary, values built once and shared
//! between frames, the manifest's records, the journal, and files derived from an output.

pub mod alloc;
pub mod derived;
pub mod journal;
pub mod manifest;
mod once_map;

pub use once_map::OnceMap;

use crate::error::Error;

/// Reports progress; the CLI passes an indicatif bar, tests a no-op.
pub trait Progress: Sync {
    fn start(&self, total: usize);
    fn frame_done(&self);
    /// An item failed: report it (once) without disturbing the bar. `item` names it: a KITTI
    /// frame as `split/id`, a folder image by its file name.
    fn frame_failed(&self, item: &str, error: &Error);
    fn finish(&self);
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
    pub frames: usize,
    pub converted: usize,
    pub failed: usize,
    /// Frames a previous run had completed (--resume).
    pub resumed: usize,
    /// Stopped by SIGINT/SIGTERM before every frame was taken.
    pub interrupted: bool,
    /// Stopped because the output device refused writes: what to tell the user.
    pub device_full: Option<String>,
    pub seconds: f64,
    /// Distinct remap tables built (one per source camera and output camera).
    pub tables_built: usize,
}
