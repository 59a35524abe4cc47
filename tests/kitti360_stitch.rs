//! The stitch (`warp::stitch`) of the four KITTI-360 cameras: on a zero-baseline synthetic rig
//! (all four centres at image_00's) against the scene rendered directly in the panorama, where
//! the remap is exact, so each camera's region of the panorama must match the direct render to
//! the resampling limit (`tests/kitti360_stitch/direct_render.rs`); and with an ego mask
//! (`tests/kitti360_stitch/ego_mask.rs`). This file holds the rig and the panorama they share.

mod depth_guided;
mod direct_render;
mod ego_mask;

use crate::common;
use panoconv::camera::{Equirect, ImageSize, Intrinsics};
use panoconv::image::RgbImage;
use panoconv::kitti360::Sequence;
use panoconv::warp::StitchCamera;
use std::f64::consts::PI;

/// A full-sphere equirect camera of `size` (pixel centres at integers) and its intrinsics.
fn full_equirect(size: ImageSize) -> (Intrinsics, Equirect) {
    let k = Intrinsics::new(
        size.width as f64 / (2.0 * PI),
        size.height as f64 / PI,
        size.width as f64 / 2.0 - 0.5,
        size.height as f64 / 2.0 - 0.5,
    );
    (k, Equirect::new(k, size))
}

/// The frame's four rig cameras as the stitch takes them (the fisheyes with their field of
/// view).
fn stitch_cameras<'a>(frame: &'a panoconv::source::Frame, seq: &Sequence) -> Vec<StitchCamera<'a>> {
    let lenses = &seq.calibration.fisheye;
    frame
        .rig
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let inv = c.reference_from_camera.inverse().unwrap();
            StitchCamera {
                model: c.model.as_ref(),
                rotation: inv.rotation,
                translation: inv.translation,
                max_theta: (i >= 2).then(|| lenses[i - 2].max_theta()),
            }
        })
        .collect()
}

fn rgb(path: &std::path::Path) -> RgbImage {
    let png = common::read_rgb8(path);
    RgbImage::from_raw(png.width, png.height, png.data).unwrap()
}
