//! Fisheye cameras: radially symmetric projections r = R(θ) of the angle θ between a ray and the
//! optical axis, one [`RadialModel`] per lens model, all behind one [`CameraModel`] (the radial
//! function is the only thing that differs between the models).
//!
//! pixel = (cx + fx·R(θ)·x/ρ, cy + fy·R(θ)·y/ρ), ρ = sqrt(x² + y²), θ = atan2(ρ, z).
//!
//! Fields of view beyond 180° work (rays with z < 0 have an image up to `max_theta`); rays and
//! pixels beyond `max_theta` (outside the fisheye circle) have none, so warps leave them black.
//! Inverting R is closed-form for the classic models and safeguarded Newton (bisection fallback)
//! for the polynomial ones, accurate to ~1e-12 rad; a polynomial that is not strictly increasing
//! over the field of view is refused by [`Fisheye::new`].

use super::{CameraModel, ImageSize, Intrinsics, ProjectionReject};
use nalgebra::{Point2, Vector3};
use std::f64::consts::PI;

/// The radial function r = R(θ) of a lens model (r in units of fx/fy).
#[derive(Debug, Clone, PartialEq)]
pub enum RadialModel {
    /// r = θ
    Equidistant,
    /// r = 2 sin(θ/2)
    Equisolid,
    /// r = 2 tan(θ/2)
    Stereographic,
    /// r = sin θ (at most 180° field of view)
    Orthographic,
    /// Kannala-Brandt / OpenCV fisheye: r = θ(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸)
    KannalaBrandt([f64; 4]),
    /// WoodScape: r = k1θ + k2θ² + k3θ³ + k4θ⁴ (pixels when fx = 1, fy = aspect ratio)
    Polynomial([f64; 4]),
}

impl RadialModel {
    /// The model's name as in a camera description's `"model"` key (`woodscape` for
    /// [`RadialModel::Polynomial`]).
    pub fn name(&self) -> &'static str {
        match self {
            RadialModel::Equidistant => "equidistant",
            RadialModel::Equisolid => "equisolid",
            RadialModel::Stereographic => "stereographic",
            RadialModel::Orthographic => "orthographic",
            RadialModel::KannalaBrandt(_) => "kannala_brandt",
            RadialModel::Polynomial(_) => "woodscape",
        }
    }

    /// R(θ).
    #[inline]
    pub fn radius(&self, t: f64) -> f64 {
        match self {
            RadialModel::Equidistant => t,
            RadialModel::Equisolid => 2.0 * (t / 2.0).sin(),
            RadialModel::Stereographic => 2.0 * (t / 2.0).tan(),
            RadialModel::Orthographic => t.sin(),
            RadialModel::KannalaBrandt(k) => {
                let t2 = t * t;
                t * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))))
            }
            RadialModel::Polynomial(k) => t * (k[0] + t * (k[1] + t * (k[2] + t * k[3]))),
        }
    }

    /// dR/dθ.
    #[inline]
    pub fn derivative(&self, t: f64) -> f64 {
        match self {
            RadialModel::Equidistant => 1.0,
            RadialModel::Equisolid => (t / 2.0).cos(),
            RadialModel::Stereographic => {
                let c = (t / 2.0).cos();
                1.0 / (c * c)
            }
            RadialModel::Orthographic => t.cos(),
            RadialModel::KannalaBrandt(k) => {
                let t2 = t * t;
                1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])))
            }
            RadialModel::Polynomial(k) => {
                k[0] + t * (2.0 * k[1] + t * (3.0 * k[2] + t * 4.0 * k[3]))
            }
        }
    }

    /// The largest field angle the model can represent at all (before any monotonicity check).
    fn theta_limit(&self) -> f64 {
        match self {
            RadialModel::Orthographic => PI / 2.0,
            _ => PI,
        }
    }

    /// θ with R(θ) = r, for r in [0, R(max_theta)]; R must be increasing on [0, max_theta].
    pub fn theta(&self, r: f64, max_theta: f64) -> f64 {
        match self {
            RadialModel::Equidistant => r,
            RadialModel::Equisolid => 2.0 * (r / 2.0).clamp(-1.0, 1.0).asin(),
            RadialModel::Stereographic => 2.0 * (r / 2.0).atan(),
            RadialModel::Orthographic => r.clamp(-1.0, 1.0).asin(),
            _ => invert_newton(|t| self.radius(t), |t| self.derivative(t), r, max_theta),
        }
    }
}

/// Solves R(θ) = r on [0, hi] for an increasing R: Newton steps kept inside a shrinking
/// bracket, bisection whenever a step would leave it or the derivative is not positive.
pub fn invert_newton(
    radius: impl Fn(f64) -> f64,
    derivative: impl Fn(f64) -> f64,
    r: f64,
    hi: f64,
) -> f64 {
    if !(r > 0.0) {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0f64, hi);
    if radius(hi) <= r {
        return hi;
    }
    let d0 = derivative(0.0);
    let mut t = if d0 > 0.0 {
        (r / d0).clamp(lo, hi)
    } else {
        hi / 2.0
    };
    for _ in 0..200 {
        let f = radius(t) - r;
        if f == 0.0 {
            return t;
        }
        if f > 0.0 {
            hi = t;
        } else {
            lo = t;
        }
        let d = derivative(t);
        let newton = t - f / d;
        let next = if d > 0.0 && newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if (next - t).abs() <= 1e-15 * (1.0 + t) || hi - lo <= 1e-15 {
            return next;
        }
        t = next;
    }
    t
}

/// Why a fisheye description is unusable.
#[derive(Debug, Clone, PartialEq)]
pub enum FisheyeError {
    /// Field of view outside (0°, 360°) or beyond what the model can represent.
    FieldOfView(String),
    /// R(θ) is not strictly increasing over the field of view.
    NotMonotonic(String),
    /// Focal lengths, principal point or size unusable.
    Intrinsics(String),
    /// A model parameter (named) outside the range the model is defined for.
    Parameter(&'static str, String),
}

impl std::fmt::Display for FisheyeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FisheyeError::FieldOfView(m)
            | FisheyeError::NotMonotonic(m)
            | FisheyeError::Intrinsics(m)
            | FisheyeError::Parameter(_, m) => f.write_str(m),
        }
    }
}

impl std::error::Error for FisheyeError {}

/// Refuses non-positive or non-finite focal lengths, a non-finite principal point and an empty
/// image: the checks every lens model shares.
pub(crate) fn check_intrinsics(k: &Intrinsics, size: ImageSize) -> Result<(), FisheyeError> {
    if !(k.fu.is_finite() && k.fv.is_finite() && k.fu > 0.0 && k.fv > 0.0) {
        return Err(FisheyeError::Intrinsics(format!(
            "focal lengths must be positive (fx {}, fy {})",
            k.fu, k.fv
        )));
    }
    if !(k.cu.is_finite() && k.cv.is_finite()) {
        return Err(FisheyeError::Intrinsics(
            "principal point must be finite".into(),
        ));
    }
    if size.width == 0 || size.height == 0 {
        return Err(FisheyeError::Intrinsics(
            "image size must be positive".into(),
        ));
    }
    Ok(())
}

/// A fisheye camera: a radial model, the affine part (fx, fy, cx, cy) and the field of view.
#[derive(Debug, Clone, PartialEq)]
pub struct Fisheye {
    /// The radial function R(θ).
    pub model: RadialModel,
    /// fx, fy: pixels per unit of r; cx, cy: principal point (pixel centres at integers).
    pub k: Intrinsics,
    /// Image size in pixels.
    pub size: ImageSize,
    /// Half the maximum field of view (radians): rays beyond it have no image.
    pub max_theta: f64,
    /// R(max_theta).
    r_max: f64,
}

/// Samples of the monotonicity check over the field of view.
const MONOTONIC_SAMPLES: usize = 4096;

/// Where R stops increasing between `lo` (increasing there) and `hi` (not): the root of R' by
/// bisection, so that the angle a message gives is exact to its printed digits rather than to
/// the check's sampling step.
fn turning_angle(model: &RadialModel, mut lo: f64, mut hi: f64) -> f64 {
    if !(model.derivative(lo) > 0.0) || model.derivative(hi) > 0.0 {
        return hi;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if model.derivative(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

impl Fisheye {
    /// A fisheye seeing up to `max_fov` radians (full angle). Refuses a field of view the model
    /// cannot represent and a radial function that is not strictly increasing over it.
    pub fn new(
        model: RadialModel,
        k: Intrinsics,
        size: ImageSize,
        max_fov: f64,
    ) -> Result<Self, FisheyeError> {
        check_intrinsics(&k, size)?;
        let max_theta = max_fov / 2.0;
        let limit = model.theta_limit();
        if !(max_theta > 0.0 && max_theta < PI) || max_theta > limit + 1e-12 {
            return Err(FisheyeError::FieldOfView(format!(
                "max field of view {:.3}° is outside what the {} model can represent (0° < fov ≤ {:.0}°{})",
                max_fov.to_degrees(),
                model.name(),
                (2.0 * limit).to_degrees(),
                if limit >= PI { ", exclusive" } else { "" }
            )));
        }
        let max_theta = max_theta.min(limit);
        // Strictly increasing R over [0, max_theta]: positive slope at every sample and
        // increasing values between samples.
        let mut prev = model.radius(0.0);
        for i in 0..=MONOTONIC_SAMPLES {
            let t = max_theta * i as f64 / MONOTONIC_SAMPLES as f64;
            let r = model.radius(t);
            let d = model.derivative(t);
            // A zero slope is allowed only at the very edge (orthographic at 180°).
            let edge_flat = i == MONOTONIC_SAMPLES && (0.0..1e-12).contains(&d);
            let bad_slope = !(d > 0.0 || edge_flat);
            if bad_slope || (i > 0 && !(r > prev)) || !r.is_finite() {
                let turn = turning_angle(
                    &model,
                    max_theta * (i.max(1) - 1) as f64 / MONOTONIC_SAMPLES as f64,
                    t,
                );
                return Err(FisheyeError::NotMonotonic(format!(
                    "the {} radial function r(θ) is not strictly increasing over the requested field of view: \
                     it stops increasing at θ = {:.4}° (max_fov_deg {:.3} needs θ up to {:.3}°); \
                     lower max_fov_deg below {:.4} or fix the coefficients",
                    model.name(),
                    turn.to_degrees(),
                    max_fov.to_degrees(),
                    max_theta.to_degrees(),
                    2.0 * turn.to_degrees()
                )));
            }
            prev = r;
        }
        let r_max = model.radius(max_theta);
        Ok(Self {
            model,
            k,
            size,
            max_theta,
            r_max,
        })
    }

    /// Pixels per radian at the image centre (fx·R'(0), fy·R'(0)), the scale an output keeps by
    /// default, as intrinsics with the principal point.
    pub fn centre_intrinsics(&self) -> Intrinsics {
        let d = self.model.derivative(0.0);
        Intrinsics::new(self.k.fu * d, self.k.fv * d, self.k.cu, self.k.cv)
    }

    /// θ of a normalised radius, as used by `unproject`.
    pub fn theta_of_radius(&self, r: f64) -> f64 {
        self.model.theta(r, self.max_theta)
    }
}

impl CameraModel for Fisheye {
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        let rho = d.x.hypot(d.y);
        if !(rho.is_finite() && d.z.is_finite()) || !(rho > 0.0 || d.z > 0.0) {
            return Err(ProjectionReject::Singular);
        }
        let theta = rho.atan2(d.z);
        if theta > self.max_theta * (1.0 + 1e-12) {
            return Err(ProjectionReject::OutsideDomain);
        }
        if !(rho > 1e-300) {
            return Ok(Point2::new(self.k.cu, self.k.cv));
        }
        let r = self.model.radius(theta.min(self.max_theta)) / rho;
        Ok(Point2::new(
            self.k.cu + self.k.fu * r * d.x,
            self.k.cv + self.k.fv * r * d.y,
        ))
    }

    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        let mx = (p.x - self.k.cu) / self.k.fu;
        let my = (p.y - self.k.cv) / self.k.fv;
        let r = mx.hypot(my);
        if !r.is_finite() || r > self.r_max * (1.0 + 1e-12) {
            return Err(ProjectionReject::OutsideDomain);
        }
        if !(r > 1e-300) {
            return Ok(Vector3::z());
        }
        let theta = self.theta_of_radius(r.min(self.r_max));
        let (s, c) = theta.sin_cos();
        Ok(Vector3::new(s * mx / r, s * my / r, c))
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        p.norm()
    }

    fn size(&self) -> ImageSize {
        self.size
    }

    fn front_halfspace(&self) -> Option<Vector3<f64>> {
        (self.max_theta <= PI / 2.0).then(Vector3::z)
    }
}
