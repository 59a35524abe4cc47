//! The proxy: an output bearing's point at the proxy distance, seen by one source camera
//! (steps 1 and 2 of the stitch's model), as a camera model a remap table is built through.

use super::{StitchCamera, StitchDepth};
use crate::camera::{CameraModel, ImageSize, ProjectionReject};
use nalgebra::{Point2, Vector3};

/// The mapping from output bearings to one camera's pixels through the proxy point, as a
/// camera model for [`RemapTable`] (which asks the source model for `project` only).
#[derive(Debug)]
pub(super) struct Proxy<'a> {
    pub(super) camera: StitchCamera<'a>,
    centre: Vector3<f64>,
    distance: f64,
    /// The scene's distance per output bearing, in place of the proxy distance (a
    /// depth-guided stitch).
    depth: Option<&'a dyn StitchDepth>,
    /// cos of the field of view's half-angle less and plus [`FOV_SLACK`]: a point whose
    /// cosine from the axis lies outside that interval is decided without `atan2` (None:
    /// no lens bound, or one too near 0 or π for the shortcut).
    fov_cos: Option<(f64, f64)>,
}

/// Radians between the half field of view and the angles the shortcut of [`Proxy::within`]
/// decides: far beyond the rounding of a cosine, so its answer is `atan2`'s.
pub(super) const FOV_SLACK: f64 = 1e-6;

impl<'a> Proxy<'a> {
    #[cfg(test)]
    pub(super) fn new(camera: StitchCamera<'a>, centre: Vector3<f64>, distance: f64) -> Self {
        Self::guided(camera, centre, distance, None)
    }

    /// [`Proxy::new`] whose point lies at the scene's distance along each bearing (`depth`),
    /// or at the proxy distance without one.
    pub(super) fn guided(
        camera: StitchCamera<'a>,
        centre: Vector3<f64>,
        distance: f64,
        depth: Option<&'a dyn StitchDepth>,
    ) -> Self {
        let fov_cos = camera
            .max_theta
            .filter(|t| *t > 1e-3 && *t < 3.0)
            .map(|t| ((t - FOV_SLACK).cos(), (t + FOV_SLACK).cos()));
        Self {
            camera,
            centre,
            distance,
            depth,
            fov_cos,
        }
    }

    /// The camera point of output bearing `d`: its proxy point, or with a depth the scene's
    /// point along it.
    pub(super) fn local(&self, d: &Vector3<f64>) -> Vector3<f64> {
        match self.depth {
            None => {
                let x = self.centre + d.normalize() * self.distance;
                self.camera.rotation * x + self.camera.translation
            }
            Some(depth) => {
                let n = d.normalize();
                self.local_at(&n, depth.distance(&n))
            }
        }
    }

    /// The reference point at `distance` along unit bearing `n` from the output centre.
    pub(super) fn point_at(&self, n: &Vector3<f64>, distance: f64) -> Vector3<f64> {
        self.centre + n * distance
    }

    /// The camera point of the reference point at `distance` along unit bearing `n`.
    pub(super) fn local_at(&self, n: &Vector3<f64>, distance: f64) -> Vector3<f64> {
        self.camera.rotation * self.point_at(n, distance) + self.camera.translation
    }

    /// Whether camera point `q` lies within the lens's field of view: θ(q) ≤ θ_max, θ the
    /// angle from the optical axis (`atan2` only within [`FOV_SLACK`] of the edge).
    #[inline]
    pub(super) fn within(&self, q: &Vector3<f64>) -> bool {
        let Some(t) = self.camera.max_theta else {
            return true;
        };
        if let Some((inner, outer)) = self.fov_cos.filter(|_| q.iter().all(|x| x.is_finite())) {
            let n = q.norm();
            if q.z >= inner * n && n > 0.0 {
                return true;
            }
            if q.z < outer * n {
                return false;
            }
        }
        !(q.x.hypot(q.y).atan2(q.z) > t)
    }
}

impl CameraModel for Proxy<'_> {
    fn project(&self, d: &Vector3<f64>) -> std::result::Result<Point2<f64>, ProjectionReject> {
        let q = self.local(d);
        if !self.within(&q) {
            return Err(ProjectionReject::OutsideDomain);
        }
        self.camera.model.project_point(&q)
    }

    /// The output bearing whose proxy point the pixel sees: the camera's ray met with the
    /// sphere of radius s around the output centre.
    fn unproject(&self, p: &Point2<f64>) -> std::result::Result<Vector3<f64>, ProjectionReject> {
        let b = self.camera.model.unproject(p)?;
        let inv = self
            .camera
            .rotation
            .try_inverse()
            .ok_or(ProjectionReject::Singular)?;
        let origin = -(inv * self.camera.translation) - self.centre;
        let dir = (inv * b).normalize();
        // |origin + λ·dir| = s, λ > 0
        let half_b = origin.dot(&dir);
        let c = origin.norm_squared() - self.distance * self.distance;
        let disc = half_b * half_b - c;
        if !(disc >= 0.0) {
            return Err(ProjectionReject::OutsideDomain);
        }
        let lambda = -half_b + disc.sqrt();
        if !(lambda > 0.0) {
            return Err(ProjectionReject::OutsideDomain);
        }
        Ok((origin + dir * lambda).normalize())
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        p.norm()
    }

    fn size(&self) -> ImageSize {
        self.camera.model.size()
    }
}
