//! The double sphere camera model (Usenko, Demmel & Cremers 2018):
//!
//! ```text
//! d1 = |p|,  d2 = sqrt(x² + y² + (ξ·d1 + z)²)
//! den = α·d2 + (1 − α)·(ξ·d1 + z)
//! u = fx·x/den + cx,  v = fy·y/den + cy
//! ```
//!
//! with α ∈ [0, 1], ξ ∈ (−1, 1). ξ = 0 is the EUCM with β = 1; α = 0 is the unified model
//! without distortion (MEI) with the same ξ and fx, fy.
//!
//! Valid field of view: the paper's bound (eq. 43) z > −w2·d1, w2 = (w1 + ξ) /
//! sqrt(2·w1·ξ + ξ² + 1), w1 = α/(1 − α) for α ≤ 0.5, (1 − α)/α otherwise, i.e. θ < acos(−w2),
//! narrowed to where the denominator stays positive and the image radius keeps growing (checked
//! numerically: the bound alone is not sufficient for ξ < 0). Bearings beyond the camera's
//! `max_theta` are rejected.
//!
//! Inverse: closed-form (eqs. 47-49).

use super::lens::Lens;
use super::lens_domain::{
    bearing_within, check_fov, expect_parameters, field_angle, radial_limit, unified_w,
    FisheyeError,
};
use super::lens_model::{LensModel, ReadLensModel};
use super::{ImageSize, Intrinsics, ProjectionReject};
use nalgebra::{Point2, Vector3};

/// The double sphere model's parameters (formula in the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoubleSphereModel {
    /// ξ: the offset between the two unit spheres' centres, in (−1, 1).
    pub xi: f64,
    /// α: the blend between the second sphere and the image plane, in [0, 1].
    pub alpha: f64,
}

/// A double sphere camera: a [`Lens`] of a [`DoubleSphereModel`].
pub type DoubleSphere = Lens<DoubleSphereModel>;

impl DoubleSphereModel {
    /// The supremum of the half field of view, and whether the image radius is finite there.
    pub fn fov_limit(xi: f64, alpha: f64) -> (f64, bool) {
        let w1 = unified_w(alpha);
        let w2 = (w1 + xi) / (2.0 * w1 * xi + xi * xi + 1.0).sqrt();
        // The paper's bound is not sufficient for ξ < 0 (with α = 0, for instance, the image
        // exists only for z > −ξ): the image radius must exist and grow up to the limit.
        radial_limit((-w2).clamp(-1.0, 1.0).acos(), alpha > 0.5, |t| {
            let (s, c) = t.sin_cos();
            let shifted = xi + c;
            let den = alpha * (s * s + shifted * shifted).sqrt() + (1.0 - alpha) * shifted;
            (den > 0.0).then(|| s / den)
        })
    }
}

impl DoubleSphere {
    /// [`DoubleSphereModel::fov_limit`].
    pub fn fov_limit(xi: f64, alpha: f64) -> (f64, bool) {
        DoubleSphereModel::fov_limit(xi, alpha)
    }

    /// A camera seeing up to `max_theta` (half field of view, radians) within
    /// [`DoubleSphere::fov_limit`].
    pub fn new(
        xi: f64,
        alpha: f64,
        k: Intrinsics,
        size: ImageSize,
        max_theta: f64,
    ) -> Result<Self, FisheyeError> {
        Lens::with_model(DoubleSphereModel { xi, alpha }, k, size, max_theta)
    }
}

impl LensModel for DoubleSphereModel {
    fn name(&self) -> &'static str {
        "double_sphere"
    }

    fn parameters(&self) -> Vec<(&'static str, f64)> {
        vec![("xi", self.xi), ("alpha", self.alpha)]
    }

    fn check(&self) -> Result<(), FisheyeError> {
        let (xi, alpha) = (self.xi, self.alpha);
        if !(xi > -1.0 && xi < 1.0) {
            return Err(FisheyeError::Parameter(
                "xi",
                format!("xi must be in (-1, 1), not {xi}"),
            ));
        }
        if !(0.0..=1.0).contains(&alpha) {
            return Err(FisheyeError::Parameter(
                "alpha",
                format!("alpha must be in [0, 1], not {alpha}"),
            ));
        }
        Ok(())
    }

    fn usable_max_theta(&self, max_theta: f64) -> Result<f64, FisheyeError> {
        let (limit, finite) = Self::fov_limit(self.xi, self.alpha);
        check_fov("double_sphere", max_theta, limit, finite)?;
        Ok(max_theta)
    }

    fn project(
        &self,
        k: &Intrinsics,
        max_theta: f64,
        d: &Vector3<f64>,
    ) -> Result<Point2<f64>, ProjectionReject> {
        let s = bearing_within(d, max_theta)?;
        let shifted = self.xi + s.z;
        let d2 = (s.x * s.x + s.y * s.y + shifted * shifted).sqrt();
        let den = self.alpha * d2 + (1.0 - self.alpha) * shifted;
        if !(den > 0.0) {
            return Err(ProjectionReject::OutsideDomain);
        }
        Ok(Point2::new(
            k.fu * s.x / den + k.cu,
            k.fv * s.y / den + k.cv,
        ))
    }

    fn unproject(
        &self,
        k: &Intrinsics,
        max_theta: f64,
        _edge: f64,
        p: &Point2<f64>,
    ) -> Result<Vector3<f64>, ProjectionReject> {
        let (a, xi) = (self.alpha, self.xi);
        let mx = (p.x - k.cu) / k.fu;
        let my = (p.y - k.cv) / k.fv;
        let r2 = mx * mx + my * my;
        let inside = 1.0 - (2.0 * a - 1.0) * r2;
        if !(r2.is_finite() && inside >= -1e-12) {
            return Err(ProjectionReject::OutsideDomain);
        }
        let mz = (1.0 - a * a * r2) / (a * inside.max(0.0).sqrt() + 1.0 - a);
        let scale = (mz * xi + (mz * mz + (1.0 - xi * xi) * r2).max(0.0).sqrt()) / (mz * mz + r2);
        let d = Vector3::new(scale * mx, scale * my, scale * mz - xi).normalize();
        if !(d.iter().all(|v| v.is_finite()) && field_angle(&d) <= max_theta * (1.0 + 1e-9)) {
            return Err(ProjectionReject::OutsideDomain);
        }
        Ok(d)
    }

    /// r ≈ θ/(1 + ξ) near the axis.
    fn centre_intrinsics(&self, k: &Intrinsics) -> Intrinsics {
        let s = 1.0 / (1.0 + self.xi);
        Intrinsics::new(k.fu * s, k.fv * s, k.cu, k.cv)
    }
}

impl ReadLensModel for DoubleSphereModel {
    fn from_parameters(name: &str, values: &[f64]) -> Option<Result<Self, FisheyeError>> {
        (name == "double_sphere").then(|| {
            expect_parameters(name, 2, values)?;
            Ok(DoubleSphereModel {
                xi: values[0],
                alpha: values[1],
            })
        })
    }
}

impl From<DoubleSphere> for Lens {
    fn from(lens: DoubleSphere) -> Self {
        lens.erased()
    }
}
