//! [`Context`]: what every frame of a run shares: the job, the style model, the dataset, the
//! output views ([`Views`]: the cached output cameras and remap tables, `views.rs`) and the
//! files written once per split. A frame's conversion takes it in two halves around the style
//! pass, `read::prepare` (read, parse, decode) and `write::finish` (warp, labels, depth,
//! encode, write), so that the style pass can take several frames' images at once.

use super::views::Views;
use super::{KittiJob, StyleOrder};
use crate::kitti::Dataset;
use crate::style::StyleModel;

/// What the frames of a run share.
pub(super) struct Context<'a> {
    pub(super) job: &'a KittiJob,
    pub(super) style: Option<&'a StyleModel>,
    pub(super) dataset: &'a Dataset,
    /// The output cameras and tables, built once per source camera (or drawn per frame).
    pub(super) views: Views<'a>,
    /// Per split: the file written once for the whole split (raw drives' `calib.txt`), as
    /// (path relative to the output, blake3). Every frame of the split lists it, so the
    /// manifest covers it whichever frames a shard or a resumed run converts.
    pub(super) split_files: std::sync::Mutex<std::collections::HashMap<String, (String, String)>>,
}

pub(super) use crate::convert::view_pass::relative;

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
            views: Views::new(job),
            split_files: Default::default(),
        }
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
