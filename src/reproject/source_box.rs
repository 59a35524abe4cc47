//! A frame's neutral annotations in an output camera: a [`SourceBox`] by the exact (curved) 2D
//! box of its true corners, through [`box_bounds`], so a tilted box keeps its exact outline; a
//! [`SourceRegion`] (a 2D box in a source camera's pixels) by its outline through the source
//! camera's bearings. What a dataset writes of them (KITTI's label line) is the dataset's.

use super::labels::{box_bounds, clip, clipped_fraction, rect_bounds, Bounds};
use crate::camera::CameraModel;
use crate::source::{SourceBox, SourceRegion};
use nalgebra::{Point2, Vector3};

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

/// The 2D box of `region`, whose pixels are `source`'s, in `output` (both cameras with the
/// same centre and axes); None when it has no image there.
pub fn region_in_image(
    region: &SourceRegion,
    source: &dyn CameraModel,
    output: &dyn CameraModel,
) -> Option<BoxInImage> {
    let map = |p: Point2<f64>| -> Option<Point2<f64>> {
        let d = source.unproject(&p).ok()?;
        output.project(&d).ok()
    };
    let unclipped = rect_bounds(region.bounds, &map, output.horizontal_period())?;
    let size = output.size();
    let bounds = clip(unclipped, size.width, size.height)?;
    Some(BoxInImage {
        bounds,
        truncation: clipped_fraction(unclipped, bounds),
    })
}

/// The distance the camera's projection pairs with (z, range or cylindrical rho, see the
/// spec) of the centre of `b`, seen from `centre` (the camera's centre, reference axes).
pub fn box_distance(b: &SourceBox, camera: &dyn CameraModel, centre: &Vector3<f64>) -> f64 {
    camera.distance(&(b.centre - centre))
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

    #[test]
    fn a_region_scales_with_the_focal_and_is_clipped_to_the_image() {
        let source = Perspective::new(
            Intrinsics::new(700.0, 700.0, 600.0, 180.0),
            ImageSize::new(1200, 360),
        );
        // half the focal about the same centre: u' = 300 + (u − 600) / 2
        let output = Perspective::new(
            Intrinsics::new(350.0, 350.0, 300.0, 90.0),
            ImageSize::new(600, 180),
        );
        let region = SourceRegion {
            camera: 0,
            bounds: [400.0, 100.0, 800.0, 300.0],
            class: None,
        };
        let got = region_in_image(&region, &source, &output).unwrap();
        let want = [200.0, 50.0, 400.0, 150.0];
        for (g, w) in got.bounds.iter().zip(want) {
            assert!((g - w).abs() < 1e-9, "{:?} vs {want:?}", got.bounds);
        }
        assert_eq!(got.truncation, 0.0);
        // one reaching past the right edge: clipped at W − 1, a quarter of it cut
        let wide = SourceRegion {
            bounds: [1000.0, 100.0, 1400.0, 300.0],
            ..region
        };
        let got = region_in_image(&wide, &source, &output).unwrap();
        assert!((got.bounds[2] - 599.0).abs() < 1e-9, "{:?}", got.bounds);
        assert!((got.truncation - 0.505).abs() < 1e-9, "{}", got.truncation);
    }

    #[test]
    fn a_box_distance_is_the_cameras_distance_of_its_centre() {
        let camera = Perspective::new(
            Intrinsics::new(700.0, 700.0, 600.0, 180.0),
            ImageSize::new(1200, 360),
        );
        let b = SourceBox::from_kitti("Car", [1.5, 1.6, 3.9], Vector3::new(2.0, 1.6, 15.0), 0.4);
        // a perspective camera pairs with z: the centre is 15 m ahead, seen from 0.5 m behind
        let d = box_distance(&b, &camera, &Vector3::new(0.0, 0.0, -0.5));
        assert!((d - 15.5).abs() < 1e-12, "{d}");
    }
}
