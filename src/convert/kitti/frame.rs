//! One frame's conversion, in two halves around the style pass: [`Context::prepare`] (read,
//! parse, decode; `read.rs`) and [`Context::finish`] (warp, labels, depth, encode, write;
//! `write.rs`), so that the style pass can take several frames' images at once. The output
//! cameras and remap tables a frame uses (cached here as `CameraMapping`s), shared or drawn for
//! `--augment`, are made in `views.rs`.

use super::{KittiJob, StyleOrder};
use crate::camera::{ImageSize, OutputCamera};
use crate::kitti::Dataset;
use crate::run::manifest::FrameRecord;
use crate::run::OnceMap;
use crate::style::StyleModel;
use crate::warp::RemapTable;
use std::path::Path;
use std::sync::atomic::AtomicUsize;
use std::sync::Arc;

/// The output camera and remap table of one source camera.
#[derive(Clone)]
pub(super) struct CameraMapping {
    pub(super) output: Arc<dyn OutputCamera>,
    pub(super) table: Arc<RemapTable>,
}

/// A source camera: its intrinsics' bits and image size.
pub(super) type CameraMappingKey = ([u64; 4], ImageSize);

pub(super) struct Context<'a> {
    pub(super) job: &'a KittiJob,
    pub(super) style: Option<&'a StyleModel>,
    pub(super) dataset: &'a Dataset,
    pub(super) mappings: OnceMap<CameraMappingKey, std::result::Result<CameraMapping, String>>,
    /// Per split: the file written once for the whole split (raw drives' `calib.txt`), as
    /// (path relative to the output, blake3). Every frame of the split lists it, so the
    /// manifest covers it whichever frames a shard or a resumed run converts.
    pub(super) split_files: std::sync::Mutex<std::collections::HashMap<String, (String, String)>>,
    pub(super) thin_views: AtomicUsize,
}

pub(super) struct FrameOutput {
    pub(super) record: FrameRecord,
}

/// `path` relative to `root`, with `/` separators (the manifest's form).
pub(super) fn relative(root: &Path, path: &Path) -> String {
    path.strip_prefix(root)
        .unwrap_or(path)
        .to_string_lossy()
        .replace('\\', "/")
}

impl<'a> Context<'a> {
    pub(super) fn new(
        job: &'a KittiJob,
        style: Option<&'a StyleModel>,
        dataset: &'a Dataset,
    ) -> Self {
        Context {
            job,
            style,
            dataset,
            mappings: OnceMap::default(),
            split_files: Default::default(),
            thin_views: AtomicUsize::new(0),
        }
    }

    /// Distinct (source camera → output camera) mappings built so far.
    pub(super) fn tables_built(&self) -> usize {
        self.mappings.len()
    }

    /// Whether the style pass takes the warped views (else the source images).
    pub(super) fn style_after_warp(&self) -> bool {
        self.style.is_some()
            && self
                .job
                .style
                .as_ref()
                .is_some_and(|s| s.order == StyleOrder::AfterWarp)
    }
}
