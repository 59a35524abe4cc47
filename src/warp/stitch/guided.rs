//! The depth-guided stitch: each output pixel's ray meets the scene at its own distance, given
//! by a [`StitchDepth`] (from a frame's LiDAR and 3D boxes), instead of the proxy sphere; a
//! camera that does not see that point (something nearer on its own ray) gives the pixel
//! nothing, and a pixel no camera sees stays empty.

use super::{Stitch, StitchCamera, StitchOptions};
use crate::camera::{CameraModel, ImageSize};
use crate::error::Result;
use crate::warp::mask::EgoMask;
use crate::warp::reach::{border_cone, Cone, Frustum, Reach};
use nalgebra::Vector3;

/// The scene a depth-guided stitch is built through, in the reference frame.
pub trait StitchDepth: Sync + std::fmt::Debug {
    /// Distance from the output centre along unit bearing `d` to the scene, metres: finite and
    /// positive (a far distance where nothing is known to be nearer).
    fn distance(&self, d: &Vector3<f64>) -> f64;

    /// Whether camera `camera` (its index in the stitch's list) sees reference point `x`:
    /// nothing of the scene lies nearer on the segment from its centre to `x`.
    fn sees(&self, camera: usize, x: &Vector3<f64>) -> bool;

    /// Whether a surface other than `x`'s own lies nearer than `x` on a ray from camera
    /// `camera`'s centre within `radius` radians of its ray to `x`, its outline moved by the
    /// parallax between the camera and the output centre by more than a tenth of `radius`: the
    /// camera's sample of `x` (its blur, its bilinear taps) would mix that surface in where the
    /// output centre does not see it. By default none.
    fn hidden_near(&self, camera: usize, x: &Vector3<f64>, radius: f64) -> bool {
        let _ = (camera, x, radius);
        false
    }

    /// [`StitchDepth::sees`] and not [`StitchDepth::hidden_near`], in one call (a scene may
    /// share their work).
    fn sees_clean(&self, camera: usize, x: &Vector3<f64>, radius: f64) -> bool {
        self.sees(camera, x) && !self.hidden_near(camera, x, radius)
    }

    /// Whether the distances of the bearings within `radius` radians of unit bearing `d` may
    /// be interpolated from `d`'s where they vary smoothly: false where an exact surface
    /// (an object's outline) may lie within that radius. By default true.
    fn may_interpolate(&self, d: &Vector3<f64>, radius: f64) -> bool {
        let _ = (d, radius);
        true
    }

    /// [`StitchDepth::distance`] and [`StitchDepth::may_interpolate`] of one bearing in one
    /// call (a scene may share their work).
    fn distance_and_may_interpolate(&self, d: &Vector3<f64>, radius: f64) -> (f64, bool) {
        (self.distance(d), self.may_interpolate(d, radius))
    }

    /// A lower bound of [`StitchDepth::distance`] over every bearing, metres (0 for none).
    fn nearest(&self) -> f64;

    /// A lower bound of [`StitchDepth::distance`] over the unit bearings within `radius`
    /// radians of unit bearing `d`, metres: by default [`StitchDepth::nearest`].
    fn nearest_within(&self, d: &Vector3<f64>, radius: f64) -> f64 {
        let _ = (d, radius);
        self.nearest()
    }

    /// Where camera `camera` saw reference point `x` of the scene as the output centre sees it:
    /// a point of an object that moved between the scene's time and the camera's lies moved
    /// with it; [`StitchDepth::sees`] and [`StitchDepth::hidden_near`] are asked of that point.
    /// By default `x` (a still scene).
    fn seen_at(&self, camera: usize, x: &Vector3<f64>) -> Vector3<f64> {
        let _ = camera;
        *x
    }

    /// An upper bound of |[`StitchDepth::seen_at`] − x| over every x, metres: it widens the
    /// camera's reach bound. By default 0.
    fn motion_bound(&self, camera: usize) -> f64 {
        let _ = camera;
        0.0
    }
}

/// Camera `camera`'s reach bound for a depth-guided stitch. The scene point X = C + t·d, seen
/// from the camera (b = `baseline` from C), lies at most asin(b / t) from the bearing d: the
/// bound is the plain bound of the bearings' directions (`local` rotates them into the
/// camera's axes, parallax 1) with the cone widened by that angle per tile of the output, t a
/// lower bound of the scene's distance there ([`StitchDepth::nearest_within`]); a pinhole's
/// image border planes bound it further, widened by the same angle. None (every pixel
/// mapped) without a finite baseline.
pub(super) fn guided_cone<'a>(
    camera: &StitchCamera,
    local: &'a (dyn Fn(&Vector3<f64>) -> Vector3<f64> + Sync),
    baseline: Option<f64>,
    bounded: bool,
) -> Cone<'a> {
    let baseline = baseline.filter(|b| b.is_finite());
    let half_angle = camera
        .max_theta
        .or_else(|| border_cone(camera.model))
        .filter(|_| bounded && baseline.is_some());
    Cone {
        local,
        half_angle,
        parallax: Some(1.0),
        baseline,
        // a pinhole's image border planes, widened per tile as the cone is
        frustum: Frustum::of(camera.model).filter(|_| bounded),
    }
}

mod casts;

/// The scene's distance at every output pixel centre (0 where the output has no bearing):
/// cast per pixel where the scene has an edge, else interpolated ([`casts`]) within a share
/// of a pixel of parallax for `cameras` seen from `centre`.
pub(super) fn pixel_distances(
    reach: &Reach,
    size: ImageSize,
    depth: &dyn StitchDepth,
    (cameras, centre): (&[StitchCamera], &Vector3<f64>),
) -> Vec<f64> {
    let baseline = cameras
        .iter()
        .enumerate()
        .filter_map(|(i, c)| {
            let eye = -(c.rotation.try_inverse()? * c.translation);
            Some((eye - centre).norm() + depth.motion_bound(i))
        })
        .filter(|b| b.is_finite())
        .fold(0.0, f64::max);
    casts::pixel_distances(reach, size, depth, baseline)
}

impl Stitch {
    /// The depth-guided stitch of `cameras` into `output` (bearings in the reference frame's
    /// axes, from `centre`): as [`Stitch::build_masked`], with each output ray meeting the
    /// scene at `depth`'s distance instead of the proxy distance (`options.distance` is not
    /// used), and camera i's weight 0 wherever `depth` says it does not see that point.
    pub fn build_guided(
        output: &dyn CameraModel,
        centre: &Vector3<f64>,
        cameras: &[StitchCamera],
        masks: &[Option<&EgoMask>],
        options: StitchOptions,
        depth: &dyn StitchDepth,
    ) -> Result<Stitch> {
        Self::check_masks(cameras, masks)?;
        let built =
            Self::tables_and_weights(output, centre, cameras, masks, options, true, Some(depth));
        Ok(Stitch::from_parts(output.size(), built, options))
    }

    /// With a depth-guided stitch, the scene's distance from the output centre at each output
    /// pixel's centre, row-major, metres (0 where the output has no bearing); None otherwise.
    pub fn distances(&self) -> Option<&[f64]> {
        self.distances.as_deref()
    }
}
