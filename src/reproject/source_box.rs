//! A neutral [`SourceBox`] in an output camera: the exact (curved) 2D box of its true corners,
//! through [`box_bounds`], so a tilted box keeps its exact outline.

use super::labels::{box_bounds, clip, clipped_fraction, Bounds};
use crate::camera::CameraModel;
use crate::source::SourceBox;
use nalgebra::Vector3;

/// A box's 2D box in an output camera: clipped to KITTI's range, and the fraction of it that
/// clipping removed (KITTI's truncation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxInImage {
    /// [left, top, right, bottom], clipped to [0, W−1] × [0, H−1].
    pub bounds: Bounds,
    /// Fraction of the unclipped box's area outside the image (0 to 1).
    pub truncation: f64,
}

/// The 2D box of `b` (reference frame) in `camera`, whose centre is `centre` and whose axes
/// are the reference frame's; None when the box has no image in it.
pub fn source_box_in_image(
    b: &SourceBox,
    centre: &Vector3<f64>,
    camera: &dyn CameraModel,
) -> Option<BoxInImage> {
    let corners = b.corners().map(|c| c - centre);
    let unclipped = box_bounds(&corners, camera)?;
    let size = camera.size();
    let bounds = clip(unclipped, size.width, size.height)?;
    Some(BoxInImage {
        bounds,
        truncation: clipped_fraction(unclipped, bounds),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{ImageSize, Intrinsics, Perspective};

    #[test]
    fn an_upright_box_matches_the_kitti_label_of_the_same_box() {
        let camera = Perspective::new(
            Intrinsics::new(700.0, 700.0, 600.0, 180.0),
            ImageSize::new(1200, 360),
        );
        let b = SourceBox::from_kitti("Car", [1.5, 1.6, 3.9], Vector3::new(2.0, 1.6, 15.0), 0.4);
        let centre = Vector3::new(0.5, 0.0, 0.0);
        let got = source_box_in_image(&b, &centre, &camera).unwrap();
        let corners = b.corners().map(|c| c - centre);
        let want = box_bounds(&corners, &camera).unwrap();
        assert_eq!(got.bounds, want);
        assert_eq!(got.truncation, 0.0);
        // a box behind the camera has no image
        let behind =
            SourceBox::from_kitti("Car", [1.5, 1.6, 3.9], Vector3::new(0.0, 1.6, -15.0), 0.0);
        assert!(source_box_in_image(&behind, &centre, &camera).is_none());
    }
}
