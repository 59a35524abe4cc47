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
//! over the field of view is refused by [`Fisheye::new`]. A [`Fisheye`] is a [`Lens`] of a
//! [`RadialModel`].

pub use super::lens_domain::FisheyeError;

use super::lens::Lens;
use super::lens_domain::expect_parameters;
use super::lens_model::{affine_fields, LensModel, ReadLensModel};
use super::{ImageSize, Intrinsics, ProjectionReject};
use nalgebra::{Point2, Vector3};
use serde_json::{json, Value};
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

/// A fisheye camera: a [`RadialModel`], the affine part (fx, fy, cx, cy: pixels per unit of r
/// and the principal point), the image size and the field of view.
pub type Fisheye = Lens<RadialModel>;

impl Fisheye {
    /// A fisheye seeing up to `max_fov` radians (full angle). Refuses a field of view the model
    /// cannot represent and a radial function that is not strictly increasing over it.
    pub fn new(
        model: RadialModel,
        k: Intrinsics,
        size: ImageSize,
        max_fov: f64,
    ) -> Result<Self, FisheyeError> {
        Lens::with_model(model, k, size, max_fov / 2.0)
    }

    /// θ of a normalised radius, as used by `unproject`.
    pub fn theta_of_radius(&self, r: f64) -> f64 {
        self.model.theta(r, self.max_theta)
    }
}

impl From<Fisheye> for Lens {
    fn from(f: Fisheye) -> Self {
        f.erased()
    }
}

impl LensModel for RadialModel {
    fn name(&self) -> &'static str {
        RadialModel::name(self)
    }

    fn parameters(&self) -> Vec<(&'static str, f64)> {
        match self {
            RadialModel::KannalaBrandt(k) | RadialModel::Polynomial(k) => {
                vec![("k1", k[0]), ("k2", k[1]), ("k3", k[2]), ("k4", k[3])]
            }
            _ => vec![],
        }
    }

    /// At most the model's own limit (the limit itself when asked for up to 1e-12 more), over
    /// which R must be strictly increasing.
    fn usable_max_theta(&self, max_theta: f64) -> Result<f64, FisheyeError> {
        let model = self;
        let max_fov = 2.0 * max_theta;
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
                    model,
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
        Ok(max_theta)
    }

    /// R(max_theta).
    fn edge_radius(&self, max_theta: f64) -> f64 {
        self.radius(max_theta)
    }

    fn project(
        &self,
        k: &Intrinsics,
        max_theta: f64,
        d: &Vector3<f64>,
    ) -> Result<Point2<f64>, ProjectionReject> {
        let rho = d.x.hypot(d.y);
        if !(rho.is_finite() && d.z.is_finite()) || !(rho > 0.0 || d.z > 0.0) {
            return Err(ProjectionReject::Singular);
        }
        let theta = rho.atan2(d.z);
        if theta > max_theta * (1.0 + 1e-12) {
            return Err(ProjectionReject::OutsideDomain);
        }
        if !(rho > 1e-300) {
            return Ok(Point2::new(k.cu, k.cv));
        }
        let r = self.radius(theta.min(max_theta)) / rho;
        Ok(Point2::new(k.cu + k.fu * r * d.x, k.cv + k.fv * r * d.y))
    }

    fn unproject(
        &self,
        k: &Intrinsics,
        max_theta: f64,
        r_max: f64,
        p: &Point2<f64>,
    ) -> Result<Vector3<f64>, ProjectionReject> {
        let mx = (p.x - k.cu) / k.fu;
        let my = (p.y - k.cv) / k.fv;
        let r = mx.hypot(my);
        if !r.is_finite() || r > r_max * (1.0 + 1e-12) {
            return Err(ProjectionReject::OutsideDomain);
        }
        if !(r > 1e-300) {
            return Ok(Vector3::z());
        }
        let theta = self.theta(r.min(r_max), max_theta);
        let (s, c) = theta.sin_cos();
        Ok(Vector3::new(s * mx / r, s * my / r, c))
    }

    /// (fx·R'(0), fy·R'(0)).
    fn centre_intrinsics(&self, k: &Intrinsics) -> Intrinsics {
        let d = self.derivative(0.0);
        Intrinsics::new(k.fu * d, k.fv * d, k.cu, k.cv)
    }

    fn description_fields(&self, k: &Intrinsics, size: ImageSize) -> Vec<(&'static str, Value)> {
        match self {
            RadialModel::Polynomial(c) => {
                // r in pixels = fx·poly(θ): fold fx into the coefficients, fy/fx is the
                // aspect ratio, the principal point an offset from the image centre.
                vec![
                    ("k", json!(c.map(|v| v * k.fu))),
                    ("aspect_ratio", json!(k.fv / k.fu)),
                    ("cx_offset", json!(k.cu - (size.width as f64 / 2.0 - 0.5))),
                    ("cy_offset", json!(k.cv - (size.height as f64 / 2.0 - 0.5))),
                ]
            }
            RadialModel::KannalaBrandt(c) => {
                let mut out = affine_fields(k);
                out.push(("k", json!(c)));
                out
            }
            _ => affine_fields(k),
        }
    }
}

impl ReadLensModel for RadialModel {
    fn from_parameters(name: &str, values: &[f64]) -> Option<Result<Self, FisheyeError>> {
        let (n, model): (usize, fn([f64; 4]) -> RadialModel) = match name {
            "equidistant" => (0, |_| RadialModel::Equidistant),
            "equisolid" => (0, |_| RadialModel::Equisolid),
            "stereographic" => (0, |_| RadialModel::Stereographic),
            "orthographic" => (0, |_| RadialModel::Orthographic),
            "kannala_brandt" => (4, RadialModel::KannalaBrandt),
            "woodscape" => (4, RadialModel::Polynomial),
            _ => return None,
        };
        Some(expect_parameters(name, n, values).map(|()| {
            model(std::array::from_fn(|i| {
                values.get(i).copied().unwrap_or(0.0)
            }))
        }))
    }
}
