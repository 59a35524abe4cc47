//! The 2D boxes of an object as a detector sees them: the box written in label_2, plus, in a
//! 360° image, the part that wraps around the ±180° seam to the other edge.

use crate::camera::CameraModel;
use crate::export::round_to;
use crate::kitti::Label;
use crate::reproject::labels::{box_bounds, clip};
use nalgebra::Vector3;

/// [left, top, right, bottom], pixel centres at integers (panoconv's and KITTI's convention).
pub type PixelBox = [f64; 4];

/// The image boxes of an object: its label_2 box first, then the part of the object beyond the
/// seam of a periodic projection, when that part is in the image too (label_2 holds only the
/// part on the side of the box's centre).
pub fn image_boxes(
    label: &Label,
    camera: &dyn CameraModel,
    centre: &Vector3<f64>,
) -> Vec<PixelBox> {
    let mut out = vec![label.bbox];
    let Some(period) = camera.horizontal_period() else {
        return out;
    };
    if !label.has_box_3d() {
        return out;
    }
    let corners = label.corners().map(|c| c - centre);
    let Some(b) = box_bounds(&corners, camera) else {
        return out;
    };
    // A box around the vertical axis covers every azimuth already: no other part.
    if !(b[0].is_finite() && b[2].is_finite()) {
        return out;
    }
    let size = camera.size();
    for turn in [-1.0, 1.0] {
        let shifted = [b[0] + turn * period, b[1], b[2] + turn * period, b[3]];
        if let Some(part) = clip(shifted, size.width, size.height) {
            out.push(part.map(|v| round_to(v, 2)));
        }
    }
    out
}
