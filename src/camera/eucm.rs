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

use super::lens::Lens;
use super::lens_domain::{
    bearing_within, check_fov, expect_parameters, field_angle, radial_limit, unified_w,
    FisheyeError,
};
use super::lens_model::{LensModel, ReadLensModel};
use super::{ImageSize, Intrinsics, ProjectionReject};
use nalgebra::{Point2, Vector3};
use std::f64::consts::PI;

/// The extended unified model's parameters (formula in the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EucmModel {
    /// α: the blend between the ellipsoid term d and z, in [0, 1].
    pub alpha: f64,
    /// β: the ellipsoid's shape (> 0; 1 is a sphere, the unified model).
    pub beta: f64,
}

/// An extended unified (EUCM) camera: a [`Lens`] of an [`EucmModel`].
pub type Eucm = Lens<EucmModel>;

impl EucmModel {
    /// The supremum of the half field of view, and whether the image radius is finite there.
    pub fn fov_limit(alpha: f64, beta: f64) -> (f64, bool) {
        let w = unified_w(alpha);
        let limit = if w >= 1.0 {
            PI
        } else {
            PI - (1.0 - w * w).sqrt().atan2(w * beta.sqrt())
        };
        // The bound above, checked: the image radius must exist and grow up to the limit.
        radial_limit(limit, alpha > 0.5, |t| {
            let (s, c) = t.sin_cos();
            let den = alpha * (beta * s * s + c * c).sqrt() + (1.0 - alpha) * c;
            (den > 0.0).then(|| s / den)
        })
    }

    /// Normalised coordinates (mx, my) of a unit bearing, before fx, fy, cx, cy.
    fn normalised(&self, s: &Vector3<f64>) -> Option<(f64, f64)> {
        let d = (self.beta * (s.x * s.x + s.y * s.y) + s.z * s.z).sqrt();
        let den = self.alpha * d + (1.0 - self.alpha) * s.z;
        (den > 0.0).then(|| (s.x / den, s.y / den))
    }
}

impl Eucm {
    /// [`EucmModel::fov_limit`].
    pub fn fov_limit(alpha: f64, beta: f64) -> (f64, bool) {
        EucmModel::fov_limit(alpha, beta)
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
        Lens::with_model(EucmModel { alpha, beta }, k, size, max_theta)
    }
}

impl LensModel for EucmModel {
    fn name(&self) -> &'static str {
        "eucm"
    }

    fn parameters(&self) -> Vec<(&'static str, f64)> {
        vec![("alpha", self.alpha), ("beta", self.beta)]
    }

    fn check(&self) -> Result<(), FisheyeError> {
        let (alpha, beta) = (self.alpha, self.beta);
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
        Ok(())
    }

    fn usable_max_theta(&self, max_theta: f64) -> Result<f64, FisheyeError> {
        let (limit, finite) = Self::fov_limit(self.alpha, self.beta);
        check_fov("eucm", max_theta, limit, finite)?;
        Ok(max_theta)
    }

    fn project(
        &self,
        k: &Intrinsics,
        max_theta: f64,
        d: &Vector3<f64>,
    ) -> Result<Point2<f64>, ProjectionReject> {
        let s = bearing_within(d, max_theta)?;
        let (mx, my) = self.normalised(&s).ok_or(ProjectionReject::OutsideDomain)?;
        Ok(Point2::new(k.fu * mx + k.cu, k.fv * my + k.cv))
    }

    fn unproject(
        &self,
        k: &Intrinsics,
        max_theta: f64,
        _edge: f64,
        p: &Point2<f64>,
    ) -> Result<Vector3<f64>, ProjectionReject> {
        let (a, b) = (self.alpha, self.beta);
        let mx = (p.x - k.cu) / k.fu;
        let my = (p.y - k.cv) / k.fv;
        let r2 = mx * mx + my * my;
        let inside = 1.0 - (2.0 * a - 1.0) * b * r2;
        if !(r2.is_finite() && inside >= -1e-12) {
            return Err(ProjectionReject::OutsideDomain);
        }
        let mz = (1.0 - b * a * a * r2) / (a * inside.max(0.0).sqrt() + (1.0 - a));
        let d = Vector3::new(mx, my, mz).normalize();
        if !(d.iter().all(|v| v.is_finite()) && field_angle(&d) <= max_theta * (1.0 + 1e-9)) {
            return Err(ProjectionReject::OutsideDomain);
        }
        Ok(d)
    }

    fn centre_intrinsics(&self, k: &Intrinsics) -> Intrinsics {
        *k
    }
}

impl ReadLensModel for EucmModel {
    fn from_parameters(name: &str, values: &[f64]) -> Option<Result<Self, FisheyeError>> {
        (name == "eucm").then(|| {
            expect_parameters(name, 2, values)?;
            Ok(EucmModel {
                alpha: values[0],
                beta: values[1],
            })
        })
    }
}

impl From<Eucm> for Lens {
    fn from(lens: Eucm) -> Self {
        lens.erased()
    }
}
