//! KITTI object-dataset files: calibration, labels, PNG images, and the folder layout.

pub mod calib;
pub mod dataset;
pub mod label;
pub mod png_decode;
pub mod png_encode;
pub mod png_io;
pub mod raw;
pub mod velodyne;

pub use calib::{Calib, SourceCamera};
pub use dataset::{Dataset, FrameRef, Layout, OutputKind, Split};
pub use label::{Label, LabelFile};
