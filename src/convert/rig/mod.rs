//! The rig frame pass: one neutral [`crate::source::Frame`] into one output camera from N of its
//! rig cameras (N = 1 is a plain conversion of that camera, N > 1 a stitch through
//! [`crate::warp::Stitch`]), with the frame's objects as KITTI labels, its LiDAR as a depth map
//! and the map of which camera gave each pixel. A dataset reader that yields `source::Frame`s
//! gets the whole conversion from here: `kitti360.rs` runs KITTI-360 sequences through it.
//!
//! - `pass.rs`: the output camera, the stitch, the source map and the depth map of a frame;
//! - `objects.rs`: which objects a frame's labels hold (range, LiDAR support, image) and why
//!   the others were dropped;
//! - `scene_depth.rs`: a frame's scene (boxes, ground, scan) as a depth-guided stitch sees it;
//! - `gray.rs`: the 8-bit PNG of the source map;
//! - `kitti360.rs`, `kitti360_setup.rs` and `kitti360_run.rs`: `panoconv kitti360`'s job, what
//!   it opens and checks before anything is written, its frames, files and manifest.

mod gray;
mod kitti360;
mod kitti360_run;
mod kitti360_setup;
mod objects;
mod pass;
mod scene_depth;

pub use kitti360::{frame_id, Kitti360Classes, Kitti360Job, Kitti360Summary, ObjectCounts};
pub use kitti360_run::run_kitti360;
pub use objects::{DropReason, ObjectOutcome, ObjectRule, GROUND_MARGIN, TILT_TOLERANCE};
pub use pass::{
    convert_frame, convert_into, count_objects, read_images, CameraInfo, RigFrame, RigOptions,
};
pub use scene_depth::{frame_stitch, Ground, SceneDepth, StitchMode, FAR};
