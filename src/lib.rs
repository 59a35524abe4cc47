//! panoconv: adapt rectilinear driving datasets (KITTI) to panoramic, cylindrical and fisheye
//! cameras. Images, 2D/3D labels and calibration are reprojected exactly; see `docs/` and the
//! README for the conventions.

#![deny(missing_docs)]
// `!(x > 0.0)` is used on purpose: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod camera;
pub mod codec;
pub mod convert;
pub mod error;
pub mod export;
pub mod fs;
pub mod geometry;
pub mod image;
pub mod kitti;
pub mod kitti360;
pub mod nuscenes;
pub mod reproject;
pub mod run;
pub mod source;
pub mod stream;
pub mod style;
pub mod tools;
pub mod warp;
