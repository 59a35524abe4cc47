//! The extended unified camera model (EUCM, Khomutenko et al. 2016, in the form of Usenko et
//! al. 2018):
//!
//! ```text
//! d = sqrt(β·(x² + y²) + z²),  den = α·d + (1 − α)·z
//! u = fx·x/den + cx,  v = fy·y/den + cy
//! ```
//!
//! with α ∈ [0, 1], β > 0. α = 0 is the pinhole camera; α = 0.5, β = 1 is the stereographic
//! fisheye r = 2·tan(θ/2) (in units of fx).
//!
//! Valid field of view (Usenko et al., eq. 24): bearings with z > −w·d, w = α/(1 − α) for
//! α ≤ 0.5, (1 − α)/α otherwise; for a unit bearing that is θ < π − atan2(sqrt(1 − w²), w·√β)
//! (w < 1), the whole sphere but the backward axis when w ≥ 1. For α > 0.5 the image radius
//! peaks at that limit (r² = 1/(β(2α − 1))), so the limit itself is included; for α ≤ 0.5 the
//! image is unbounded there. The bound is checked numerically (positive denominator, growing
//! image radius). Bearings beyond the camera's `max_theta` are rejected.
//!
//! Inverse: closed-form (eq. 25).

use super::fisheye::{check_intrinsics, FisheyeError};
use super::lens_domain::{bearing_within, field_angle, front_halfspace_of};
use super::{CameraModel, ImageSize, Intrinsics, ProjectionReject};
use nalgebra::{Point2, Vector3};
use std::f64::consts::PI;

/// An extended unified (EUCM) camera (formula in the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct Eucm {
    /// α: the blend between the ellipsoid term d and z, in [0, 1].
    pub alpha: f64,
    /// β: the ellipsoid's shape (> 0; 1 is a sphere, the unified model).
    pub beta: f64,
    /// fx, fy, cx, cy (pixel centres at integers).
    pub k: Intrinsics,
    /// Image size in pixels.
    pub size: ImageSize,
    /// Half the field of view (radians); bearings beyond it are rejected.
    pub max_theta: f64,
}

/// w of Usenko et al.: the valid region is z > −w·d.
pub(crate) fn unified_w(alpha: f64) -> f64 {
    if alpha <= 0.5 {
        alpha / (1.0 - alpha)
    } else {
        (1.0 - alpha) / alpha
    }
}

impl Eucm {
    /// The supremum of the half field of view, and whether the image radius is finite there.
    pub fn fov_limit(alpha: f64, beta: f64) -> (f64, bool) {
        let w = unified_w(alpha);
        let limit = if w >= 1.0 {
            PI
        } else {
            PI - (1.0 - w * w).sqrt().atan2(w * beta.sqrt())
        };
        // The bound above, checked: the image radius must exist and grow up to the limit.
        super::lens_domain::radial_limit(limit, alpha > 0.5, |t| {
            let (s, c) = t.sin_cos();
            let den = alpha * (beta * s * s + c * c).sqrt() + (1.0 - alpha) * c;
            (den > 0.0).then(|| s / den)
        })
    }

    /// A camera seeing up to `max_theta` (half field of view, radians) within
    /// [`Eucm::fov_limit`].
    pub fn new(
        alpha: f64,
        beta: f64,
        k: Intrinsics,
        size: ImageSize,
        max_theta: f64,
    ) -> Result<Self, FisheyeError> {
        check_intrinsics(&k, size)?;
        if !(0.0..=1.0).contains(&alpha) {
            return Err(FisheyeError::Parameter(
                "alpha",
                format!("alpha must be in [0, 1], not {alpha}"),
            ));
        }
        if !(beta > 0.0 && beta.is_finite()) {
            return Err(FisheyeError::Parameter(
                "beta",
                format!("beta must be positive, not {beta}"),
            ));
        }
        let (limit, finite) = Self::fov_limit(alpha, beta);
        super::lens_domain::check_fov("eucm", max_theta, limit, finite)?;
        Ok(Self {
            alpha,
            beta,
            k,
            size,
            max_theta,
        })
    }

    /// Normalised coordinates (mx, my) of a unit bearing, before fx, fy, cx, cy.
    fn normalised(&self, s: &Vector3<f64>) -> Option<(f64, f64)> {
        let d = (self.beta * (s.x * s.x + s.y * s.y) + s.z * s.z).sqrt();
        let den = self.alpha * d + (1.0 - self.alpha) * s.z;
        (den > 0.0).then(|| (s.x / den, s.y / den))
    }
}

impl CameraModel for Eucm {
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        let s = bearing_within(d, self.max_theta)?;
        let (mx, my) = self.normalised(&s).ok_or(ProjectionReject::OutsideDomain)?;
        Ok(Point2::new(
            self.k.fu * mx + self.k.cu,
            self.k.fv * my + self.k.cv,
        ))
    }

    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        let (a, b) = (self.alpha, self.beta);
        let mx = (p.x - self.k.cu) / self.k.fu;
        let my = (p.y - self.k.cv) / self.k.fv;
        let r2 = mx * mx + my * my;
        let inside = 1.0 - (2.0 * a - 1.0) * b * r2;
        if !(r2.is_finite() && inside >= -1e-12) {
            return Err(ProjectionReject::OutsideDomain);
        }
        let mz = (1.0 - b * a * a * r2) / (a * inside.max(0.0).sqrt() + (1.0 - a));
        let d = Vector3::new(mx, my, mz).normalize();
        if !(d.iter().all(|v| v.is_finite()) && field_angle(&d) <= self.max_theta * (1.0 + 1e-9)) {
            return Err(ProjectionReject::OutsideDomain);
        }
        Ok(d)
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        p.norm()
    }

    fn size(&self) -> ImageSize {
        self.size
    }

    fn front_halfspace(&self) -> Option<Vector3<f64>> {
        front_halfspace_of(self.max_theta)
    }
}
