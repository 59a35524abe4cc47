//! The rig frame pass: one neutral [`crate::source::Frame`] into one output camera from N of its
//! rig cameras (N = 1 is a plain conversion of that camera, N > 1 a stitch through
//! [`crate::warp::Stitch`]), with the frame's objects as KITTI labels, its LiDAR as a depth map
//! and the map of which camera gave each pixel. A dataset reader that yields `source::Frame`s
//! gets the whole conversion from here: `run.rs` runs any `source::RigSource` (KITTI-360's
//! sequences, ...) through it.
//!
//! - `pass.rs`: the output camera, the stitch, the source map and the depth map of a frame;
//! - `objects.rs`: which objects a frame's labels hold (range, LiDAR support, image) and why
//!   the others were dropped;
//! - `scene_depth.rs`: a frame's scene (boxes, ground, scan) as a depth-guided stitch sees it;
//! - `frame_cache.rs`: what a frame's views share (its scan's positions, its scene);
//! - `stitch_cache.rs`: the fixed stitches a run keeps for frames of the same geometry;
//! - `gray.rs`: the 8-bit PNG of the source map;
//! - `scan_error.rs`: a frame that fails on its scan told what reads the scan;
//! - `canvas.rs`: the output canvas and scale a rig's flags ask for;
//! - `job.rs`, `setup.rs` and `run.rs`: a rig run's job, what it checks before anything is
//!   written, its frames, files and manifest, for any dataset.

mod canvas;
mod coverage;
mod frame_cache;
mod gray;
mod ground;
mod job;
mod objects;
mod pass;
mod run;
mod scan_error;
mod scene_depth;
mod setup;
mod stitch_cache;

pub use canvas::{coverage, rig_output_spec, CanvasFlags, Coverage, DEFAULT_PANO_WIDTH};
pub use ground::Ground;
pub use job::{ObjectCounts, RigJob, RigSpec, RigSummary, SPLIT};
pub use objects::{
    DropReason, ObjectOutcome, ObjectRule, PlacedObject, GROUND_MARGIN, TILT_TOLERANCE,
};
pub use pass::{
    convert_frame, convert_into, count_objects, output_camera, read_images, rig_stitch, CameraInfo,
    RigFrame, RigOptions, RigStitch,
};
pub use run::run_rig;
pub use scene_depth::{frame_stitch, SceneDepth, StitchMode, FAR};
