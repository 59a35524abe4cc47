//! KITTI object-dataset files: calibration, labels, LiDAR scans, and the folder layout.

pub mod calib;
mod cam;
pub mod dataset;
mod label;
pub(crate) mod not_frames;
pub(crate) mod raw;
mod reader;
pub(crate) mod rig_output;
pub mod velodyne;

pub use calib::{Calib, SourceCamera};
pub use cam::Cam;
pub use dataset::{Dataset, FrameRef, Layout, OutputKind, Split};
pub use label::{Label, LabelClass, LabelFile, DONT_CARE};
pub use reader::{FrameLabels, KittiFrame, LabelItem, Wants};
