//! What the output views of one rig frame share, built by the first view that needs it: the
//! scan's positions (each view's depth map) and the depth-guided stitch's scene (its boxes,
//! ground and scan seen from the frame's centre and cameras). With `--augment` a frame has
//! several views of the same centre and cameras: neither is rebuilt per view. It also carries
//! the run's fixed stitches by geometry (`stitch_cache.rs`), which frames share.

use super::scene_depth::FrameScene;
use super::stitch_cache::StitchCache;
use crate::source::Frame;
use nalgebra::Vector3;
use std::sync::{Arc, OnceLock};

/// A frame's shared parts; a fresh one for each frame.
#[derive(Default)]
pub(super) struct FrameCache {
    points: OnceLock<Vec<Vector3<f64>>>,
    /// The frame's scene as the depth-guided stitch sees it.
    pub(super) scene: FrameScene,
    /// The run's fixed stitches, kept across frames (None: each frame builds its own).
    pub(super) stitches: Option<Arc<StitchCache>>,
}

impl FrameCache {
    /// A frame's cache that reuses the run's fixed stitches in `stitches`.
    pub(super) fn with_stitches(stitches: Option<Arc<StitchCache>>) -> Self {
        Self {
            stitches,
            ..Self::default()
        }
    }

    /// The positions of the frame's LiDAR points, copied once.
    pub(super) fn points(&self, frame: &Frame) -> &[Vector3<f64>] {
        self.points
            .get_or_init(|| frame.lidar.iter().map(|p| p.position).collect())
    }
}
