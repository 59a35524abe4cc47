//! panoconv: adapt rectilinear driving datasets (KITTI) to panoramic, cylindrical and fisheye
//! cameras. Images, 2D/3D labels and calibration are reprojected exactly; see `docs/` and the
//! README for the conventions.

// `!(x > 0.0)` is used on purpose: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod alloc;
pub mod augment;
pub mod camera;
pub mod depth;
pub mod derived;
pub mod error;
pub mod eval;
pub mod export;
pub mod folder;
pub mod geometry;
pub mod image;
pub mod inspect;
pub mod journal;
pub mod jpeg;
pub mod kitti;
pub mod labels;
pub mod output;
pub mod pano;
pub mod pipeline;
pub mod predictions;
pub mod preview;
pub mod style;
pub mod synth;
pub mod unproject;
pub mod verify;
pub mod warp;
