//! KITTI object-dataset files: calibration, labels, PNG images, and the folder layout.

pub mod calib;
pub mod dataset;
pub mod label;
pub mod png_io;
pub mod velodyne;

pub use calib::{Calib, SourceCamera};
pub use dataset::{Dataset, FrameRef, Split};
pub use label::{Label, LabelFile};
