//! Whole tiles of a fixed stitch's pinhole weights decided at once: where every pixel of a
//! tile provably has a margin of at least the blend width, each weight is exactly 1 and no
//! pixel's projection is needed.
//!
//! Between adjacent output centres the bearing turns by at most A (the reach bound's largest
//! turn), so every centre of a tile lies within α = k·A of its middle's bearing (k the most
//! positions between them). The proxy points of those bearings lie on the proxy sphere of
//! radius s, within the chord s·α of the middle's point, so camera i sees them within
//! α' = asin(s·α / ρ) of it (ρ the middle point's distance from the camera). With θ the
//! middle's angle from the optical axis, every pixel's direction lies within θ + α' of the axis
//! and, the gnomonic projection stretching an arc by at most sec²(θ + α'), its image point
//! within F·α'·(1 + r²) of the middle's (F the larger focal length, r = tan(θ + α')). Its
//! distance from the image border is therefore at least the middle's less that, and where
//! this still meets [`super::saturated`]'s test at r, and the field of view's margin exceeds
//! the blend width at θ + α', each pixel's weight saturates.

use super::{Proxy, StitchCamera, FOV_SLACK};
use crate::camera::Intrinsics;
use nalgebra::Vector3;

/// Output pixels per side of a tile decided whole.
pub(super) const TILE: usize = 8;

/// The widest angle from the optical axis a tile may reach: r = tan θ stays below 2.9, within
/// [`super::saturated`]'s r ≤ 3 with the rounding of every pixel's r far below the gap.
const WIDEST_R: f64 = 2.9;

/// What decides camera i's tiles: its pinhole intrinsics and field of view, the blend width
/// and the output's largest turn between adjacent centres.
#[derive(Debug, Clone, Copy)]
pub(super) struct TileBound {
    pub(super) k: Intrinsics,
    /// The widest angle from the axis at which the margin saturates, radians.
    pub(super) widest: f64,
    pub(super) width: f64,
    /// A, radians.
    pub(super) step: f64,
    /// The proxy sphere's radius s, metres.
    pub(super) distance: f64,
}

impl TileBound {
    /// The bound of a fixed stitch's `camera` (None: not a pinhole, a rotation not orthonormal
    /// to 1e-9, or no blend width), `step` the output's largest turn.
    pub(super) fn of(
        camera: &StitchCamera,
        width: f64,
        step: f64,
        distance: f64,
    ) -> Option<TileBound> {
        let k = camera.model.pinhole()?;
        let r = &camera.rotation;
        let off = (r.transpose() * r - nalgebra::Matrix3::identity()).amax();
        if !(off < 1e-9 && width > 0.0 && width.is_finite() && step.is_finite()) {
            return None;
        }
        if !(distance > 0.0 && distance.is_finite()) {
            return None;
        }
        // (the per-pixel field of view's margin, by the angle or its cosine, is at least the
        // width 1e-6 rad inside this)
        let fov = camera
            .max_theta
            .map_or(f64::INFINITY, |t| t - width - FOV_SLACK - 1e-6);
        Some(TileBound {
            k,
            widest: WIDEST_R.atan().min(fov),
            width,
            step,
            distance,
        })
    }

    /// Whether every pixel of a tile whose centres lie within `k` positions of its middle,
    /// whose bearing is `middle`, has a weight of exactly 1 in `proxy`'s camera (every centre of
    /// the tile with a bearing, the caller checks).
    pub(super) fn saturates(&self, proxy: &Proxy, middle: &Vector3<f64>, k: usize) -> bool {
        // (1e-9 rad and a part in 1e9 cover the rounding of the angles and lengths)
        let alpha = k as f64 * self.step + 1e-9;
        let q = proxy.local(middle);
        let rho = q.norm();
        let chord = self.distance * alpha * (1.0 + 1e-9);
        if !(chord < 0.5 * rho) {
            return false;
        }
        let turn = (chord / rho).asin() * (1.0 + 1e-9) + 1e-9;
        let theta = q.x.hypot(q.y).atan2(q.z) + turn;
        if !(theta <= self.widest) {
            return false;
        }
        let r = theta.tan() * (1.0 + 1e-9);
        let kk = &self.k;
        let (x, y) = kk.to_pixel(q.x / q.z, q.y / q.z);
        let size = proxy.camera.model.size();
        let border = (x + 0.5)
            .min(size.width as f64 - 0.5 - x)
            .min(y + 0.5)
            .min(size.height as f64 - 0.5 - y);
        let f = kk.fu.abs().max(kk.fv.abs());
        let moved = f * turn * (1.0 + r * r) * (1.0 + 1e-9) + 1e-6;
        let most = f * (1.0 + (r + 0.01).powi(2)) * 1.001 * (1.0 + 1e-9);
        border - moved >= self.width * most
    }
}
