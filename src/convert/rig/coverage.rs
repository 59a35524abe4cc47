//! Which part of an object's 2D box the chosen cameras see.
//!
//! With a subset of a rig's cameras (`--cameras`), part of the output image has no source: an
//! object there is not in the image and must not be a label. Whether a chosen camera sees an
//! output pixel of an object is decided by exact geometry, independent of the stitch (so fixed
//! and depth-guided stitches label alike, and the labels do not depend on the warp): the
//! pixel's ray from the output centre C2 meets the object's 3D box (or, for a pixel of its 2D
//! box beside the box, the sphere through the box centre about C2), and some chosen camera
//! projects that point inside its image (and within its lens's field of view).
//!
//! The 2D box is sampled on a grid of at most [`SAMPLES`] × [`SAMPLES`] pixels, its edges
//! included: an object with no covered sample is `uncovered`; a partly covered one goes
//! through the visibility rule with its covered part (the covered samples' box, and the
//! covered share of its full box).

use crate::camera::CameraModel;
use crate::error::{Error, Result};
use crate::reproject::source_box::BoxInImage;
use crate::source::{CameraInfo, Frame, Pose, SourceBox};
use nalgebra::{Point2, Vector3};

/// Samples per side of a 2D box (one per pixel for a smaller box).
pub const SAMPLES: usize = 16;

/// A chosen camera: its model, where a reference-frame point is in its axes, its field of view.
struct Covering<'a> {
    model: &'a dyn CameraModel,
    camera_from_reference: Pose,
    max_theta: Option<f64>,
}

impl Covering<'_> {
    /// Whether the camera's image holds `p` (reference frame).
    fn sees(&self, p: &Vector3<f64>) -> bool {
        let q = self.camera_from_reference.apply(p);
        if self
            .max_theta
            .is_some_and(|t| !(q.x.hypot(q.y).atan2(q.z) <= t))
        {
            return false;
        }
        let Ok(pixel) = self.model.project_point(&q) else {
            return false;
        };
        let size = self.model.size();
        // the pixel squares' outer edges, as the stitch's border margin counts them
        pixel.x >= -0.5
            && pixel.y >= -0.5
            && pixel.x <= size.width as f64 - 0.5
            && pixel.y <= size.height as f64 - 0.5
    }
}

/// The chosen cameras of a frame, by which an object's output pixels are covered or not.
pub struct Coverage<'a> {
    cameras: Vec<Covering<'a>>,
}

impl<'a> Coverage<'a> {
    /// The cameras `chosen` (indices into the frame's rig; `info` by the same index).
    pub fn of(frame: &'a Frame, info: &[CameraInfo], chosen: &[usize]) -> Result<Self> {
        let cameras = chosen
            .iter()
            .map(|&k| {
                let c = frame.rig.get(k).ok_or_else(|| {
                    Error::Setup(format!(
                        "the rig has no camera {k} ({} cameras)",
                        frame.rig.len()
                    ))
                })?;
                let camera_from_reference = c
                    .reference_from_camera
                    .inverse()
                    .ok_or_else(|| Error::file(&c.image, format!("{}: singular pose", c.name)))?;
                Ok(Covering {
                    model: c.model.as_ref(),
                    camera_from_reference,
                    max_theta: info.get(k).and_then(|i| i.max_theta),
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self { cameras })
    }

    /// One camera at the reference frame's origin, in its axes, with no lens field of view.
    #[cfg(test)]
    pub fn single(model: &'a dyn CameraModel) -> Self {
        Self {
            cameras: vec![Covering {
                model,
                camera_from_reference: Pose::identity(),
                max_theta: None,
            }],
        }
    }

    /// Whether some chosen camera sees `p` (reference frame).
    fn sees(&self, p: &Vector3<f64>) -> bool {
        self.cameras.iter().any(|c| c.sees(p))
    }

    /// What of `image`, the 2D box of `b` in `camera` (centre `centre`), the chosen cameras
    /// see: all of it (`image` itself), a part (the covered samples' box, its truncation the
    /// share of the full box outside the image or not covered), or nothing (None).
    pub fn covered(
        &self,
        b: &SourceBox,
        centre: &Vector3<f64>,
        camera: &dyn CameraModel,
        image: &BoxInImage,
    ) -> Option<BoxInImage> {
        let [left, top, right, bottom] = image.bounds;
        let steps = |lo: f64, hi: f64| ((hi - lo).ceil() as usize + 1).clamp(1, SAMPLES);
        let (nu, nv) = (steps(left, right), steps(top, bottom));
        let at = |lo: f64, hi: f64, i: usize, n: usize| {
            if n == 1 {
                lo
            } else {
                lo + (hi - lo) * i as f64 / (n - 1) as f64
            }
        };
        let centre_range = (b.centre - centre).norm();
        let mut seen = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut count = 0usize;
        for j in 0..nv {
            let v = at(top, bottom, j, nv);
            for i in 0..nu {
                let u = at(left, right, i, nu);
                let Ok(ray) = camera.unproject(&Point2::new(u, v)) else {
                    continue;
                };
                let ray = ray.normalize();
                let t = ray_box_entry(b, centre, &ray).unwrap_or(centre_range);
                if self.sees(&(centre + ray * t)) {
                    count += 1;
                    seen = [
                        seen[0].min(u),
                        seen[1].min(v),
                        seen[2].max(u),
                        seen[3].max(v),
                    ];
                }
            }
        }
        let total = nu * nv;
        match count {
            0 => None,
            n if n == total => Some(*image),
            n => Some(BoxInImage {
                bounds: seen,
                truncation: 1.0 - (1.0 - image.truncation) * n as f64 / total as f64,
            }),
        }
    }
}

/// Where the ray `centre + t·ray` (t ≥ 0) enters the box `b`, None when it misses it (the
/// slab test in the box's axes; a centre inside the box gives t = 0).
fn ray_box_entry(b: &SourceBox, centre: &Vector3<f64>, ray: &Vector3<f64>) -> Option<f64> {
    let box_from_reference = b.rotation.transpose();
    let o = box_from_reference * (centre - b.centre);
    let d = box_from_reference * ray;
    let half = b.size / 2.0;
    let (mut enter, mut exit) = (0.0f64, f64::INFINITY);
    for k in 0..3 {
        if d[k] == 0.0 {
            if o[k].abs() > half[k] {
                return None;
            }
            continue;
        }
        let (a, c) = ((-half[k] - o[k]) / d[k], (half[k] - o[k]) / d[k]);
        enter = enter.max(a.min(c));
        exit = exit.min(a.max(c));
    }
    (enter <= exit).then_some(enter)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{ImageSize, Intrinsics, Perspective};
    use crate::reproject::source_box::source_box_in_image;

    #[test]
    fn a_ray_enters_a_box_at_its_near_face() {
        // 4 m long along x, 2 m wide along z, its centre at (0, 0, 10)
        let b = SourceBox::from_kitti("Car", [2.0, 2.0, 4.0], Vector3::new(0.0, 1.0, 10.0), 0.0);
        // from the origin along +z: the near face is at z = 10 − 1
        let t = ray_box_entry(&b, &Vector3::zeros(), &Vector3::z()).unwrap();
        assert!((t - 9.0).abs() < 1e-12, "{t}");
        assert!(ray_box_entry(&b, &Vector3::zeros(), &Vector3::x()).is_none());
        assert!(ray_box_entry(&b, &Vector3::zeros(), &-Vector3::z()).is_none());
    }

    /// A camera at the origin turned by `yaw` about the reference frame's y axis.
    fn covering(model: &dyn CameraModel, yaw: f64) -> Covering<'_> {
        let r = nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), yaw).into_inner();
        Covering {
            model,
            camera_from_reference: Pose::new(r.transpose(), Vector3::zeros()),
            max_theta: None,
        }
    }

    #[test]
    fn a_box_is_covered_whole_in_part_or_not_at_all() {
        // 90° fields of view: the front camera sees |x| ≤ z exactly
        let pinhole = Perspective::new(
            Intrinsics::new(100.0, 100.0, 99.5, 99.5),
            ImageSize::new(200, 200),
        );
        let output = Perspective::new(
            Intrinsics::new(100.0, 100.0, 199.5, 99.5),
            ImageSize::new(400, 200),
        );
        let front = Coverage {
            cameras: vec![covering(&pinhole, 0.0)],
        };
        let place = |x: f64| {
            let b = SourceBox::from_kitti("Car", [1.5, 1.6, 1.0], Vector3::new(x, 0.5, 10.0), 0.0);
            let image = source_box_in_image(&b, &Vector3::zeros(), &output).unwrap();
            (b, image)
        };
        // ahead: all of it, the box itself
        let (b, image) = place(0.0);
        let got = front
            .covered(&b, &Vector3::zeros(), &output, &image)
            .unwrap();
        assert_eq!(got, image);
        // (1 m long along x, 1.6 m wide along z) far to the side, x/z from 1.25 to 1.58: nothing
        let (b, image) = place(14.0);
        assert!(front
            .covered(&b, &Vector3::zeros(), &output, &image)
            .is_none());
        // across the edge x = z (x/z from 0.83 to 1.09): the covered part ends at u ≈ 299.5
        let (b, image) = place(9.5);
        let got = front
            .covered(&b, &Vector3::zeros(), &output, &image)
            .unwrap();
        assert!(got.truncation > 0.0 && got.truncation < 1.0, "{got:?}");
        assert_eq!(got.bounds[0], image.bounds[0]);
        let step = (image.bounds[2] - image.bounds[0]) / (SAMPLES - 1) as f64;
        assert!((got.bounds[2] - 299.5).abs() <= step, "{got:?} {image:?}");
        // a second camera looking right covers the rest
        let both = Coverage {
            cameras: vec![covering(&pinhole, 0.0), covering(&pinhole, 1.5)],
        };
        let got = both
            .covered(&b, &Vector3::zeros(), &output, &image)
            .unwrap();
        assert_eq!(got, image);
    }
}
