//! KITTI-360's formats: the calibration folder, the poses, the 3D boxes (world coordinates,
//! OpenCV XML), the Velodyne scans, its class table, and a reader that yields neutral
//! [`crate::source::Frame`]s of a sequence in each frame's level reference frame. See
//! docs/kitti360.md.

mod bboxes;
mod calib;
pub mod classes;
mod poses;
mod sequence;
mod source;
mod text;
pub mod velodyne;

pub use bboxes::{parse_boxes, WorldBox};
pub use calib::{Calibration, RectCamera, CAMERAS, DEFAULT_FISHEYE_FOV_DEG};
pub use sequence::{Options, Sequence};
pub use source::{drive_number, frame_id, Kitti360Classes, Kitti360Selection, Kitti360Source};
