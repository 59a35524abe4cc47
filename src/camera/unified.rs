//! The unified camera model with Mei's distortion (Mei & Rives 2007; OpenCV's `cv::omnidir`,
//! KITTI-360's fisheye cameras `image_02`/`image_03`).
//!
//! A bearing s (unit) is lifted onto the plane of a projection centre shifted by ξ behind the
//! sphere's centre, distorted, then mapped by the generalised focal lengths:
//!
//! ```text
//! (xu, yu) = (sx, sy) / (sz + ξ)
//! r² = xu² + yu²,  L = 1 + k1·r² + k2·r⁴
//! xd = xu·L + 2·p1·xu·yu + p2·(r² + 2·xu²)
//! yd = yu·L + p1·(r² + 2·yu²) + 2·p2·xu·yu
//! u = γ1·xd + s·yd + u0,  v = γ2·yd + v0
//! ```
//!
//! exactly as `cv::omnidir::projectPoints` (D = (k1, k2, p1, p2), K = [[γ1, s, u0], [0, γ2, v0]]).
//! KITTI-360's own script drops p1/p2; they are part of the calibration, so they are applied.
//!
//! Valid field of view: the lift is one-to-one for θ < acos(−ξ) when ξ ≤ 1 (the image is unbounded
//! there) and θ ≤ acos(−1/ξ) when ξ > 1 (the image radius peaks there); the distortion must also
//! keep a positive Jacobian (checked on a dense polar grid of the undistorted plane). Bearings
//! beyond the camera's `max_theta` (at most that limit) are rejected with
//! [`ProjectionReject::OutsideDomain`].
//!
//! Inverse: the distortion is undone by Newton's method on the 2×2 system, kept inside the disc of
//! the field of view, with a backtracking line search, at most [`MAX_UNDISTORT_ITERATIONS`]
//! steps, accepted when the residual is below 1e-12 in normalised coordinates (~1e-9 px; 1e-9 on
//! the very edge, where a fold of the distortion makes the solution ill-conditioned); the lift
//! back to the sphere is closed-form.

use super::lens::Lens;
use super::lens_domain::{bearing_within, check_fov, expect_parameters, FisheyeError};
use super::lens_model::{affine_fields, LensModel, ReadLensModel};
use super::{ImageSize, Intrinsics, ProjectionReject};
use nalgebra::{Point2, Vector3};
use serde_json::{json, Value};
use std::f64::consts::PI;

/// Bound on the Newton iterations of the undistortion.
pub const MAX_UNDISTORT_ITERATIONS: usize = 50;
/// Largest accepted residual of the undistortion (normalised image coordinates), inside the
/// field of view and on its edge.
const UNDISTORT_TOLERANCE: f64 = 1e-12;
const UNDISTORT_EDGE_TOLERANCE: f64 = 1e-9;
/// Field-angle and azimuth samples of the Jacobian check.
const FOV_SAMPLES: usize = 1024;
const AZIMUTH_SAMPLES: usize = 16;

/// Mei's distortion: radial k1, k2 and tangential p1, p2 (OpenCV's omnidir `D`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeiDistortion {
    /// Radial coefficient of r² (`D[0]`).
    pub k1: f64,
    /// Radial coefficient of r⁴ (`D[1]`).
    pub k2: f64,
    /// First tangential coefficient (`D[2]`).
    pub p1: f64,
    /// Second tangential coefficient (`D[3]`).
    pub p2: f64,
}

impl MeiDistortion {
    /// No distortion: the plain unified model.
    pub const NONE: Self = Self {
        k1: 0.0,
        k2: 0.0,
        p1: 0.0,
        p2: 0.0,
    };

    /// Distorted point and the Jacobian [[∂xd/∂x, ∂xd/∂y], [∂yd/∂x, ∂yd/∂y]].
    #[inline]
    fn apply(&self, x: f64, y: f64) -> ((f64, f64), [[f64; 2]; 2]) {
        let Self { k1, k2, p1, p2 } = *self;
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (k1 + k2 * r2);
        let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        // ∂radial/∂x = 2x·(k1 + 2·k2·r²)
        let dl = 2.0 * (k1 + 2.0 * k2 * r2);
        let j = [
            [
                radial + x * x * dl + 2.0 * p1 * y + 6.0 * p2 * x,
                x * y * dl + 2.0 * p1 * x + 2.0 * p2 * y,
            ],
            [
                x * y * dl + 2.0 * p1 * x + 2.0 * p2 * y,
                radial + y * y * dl + 6.0 * p1 * y + 2.0 * p2 * x,
            ],
        ];
        ((xd, yd), j)
    }

    /// Undistorted point of a distorted one within the disc of radius `r_bound` (Newton steps,
    /// projected onto the disc, with a backtracking line search; at most
    /// `MAX_UNDISTORT_ITERATIONS`): (x, y, residual of the distortion there).
    pub fn undo(&self, xd: f64, yd: f64, r_bound: f64) -> (f64, f64, f64) {
        let clamp = |x: f64, y: f64| {
            let r = x.hypot(y);
            if r > r_bound {
                (x * r_bound / r, y * r_bound / r)
            } else {
                (x, y)
            }
        };
        let rd2 = xd * xd + yd * yd;
        let guess = 1.0 + rd2 * (self.k1 + self.k2 * rd2);
        let (mut x, mut y) = if guess > 0.5 {
            clamp(xd / guess, yd / guess)
        } else {
            clamp(xd, yd)
        };
        let residual = |x: f64, y: f64| {
            let ((fx, fy), _) = self.apply(x, y);
            (fx - xd).hypot(fy - yd)
        };
        let mut res = residual(x, y);
        let floor = 1e-16 * (1.0 + rd2.sqrt());
        for _ in 0..MAX_UNDISTORT_ITERATIONS {
            if !(res > floor) {
                break;
            }
            let ((fx, fy), j) = self.apply(x, y);
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if !(det > 0.0) {
                break;
            }
            let (rx, ry) = (fx - xd, fy - yd);
            let dx = -(j[1][1] * rx - j[0][1] * ry) / det;
            let dy = -(-j[1][0] * rx + j[0][0] * ry) / det;
            let mut step = 1.0;
            let mut improved = false;
            for _ in 0..40 {
                let (nx, ny) = clamp(x + step * dx, y + step * dy);
                let nres = residual(nx, ny);
                if nres < res {
                    (x, y, res) = (nx, ny, nres);
                    improved = true;
                    break;
                }
                step *= 0.5;
            }
            if !improved {
                break;
            }
        }
        (x, y, res)
    }
}

/// The unified model's parameters: ξ, Mei's distortion and OpenCV omnidir's skew.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeiModel {
    /// ξ: the projection centre's offset behind the sphere's centre (≥ 0).
    pub xi: f64,
    /// The distortion applied on the lifted plane.
    pub distortion: MeiDistortion,
    /// OpenCV omnidir's skew s (`K[0][1]`); 0 for KITTI-360.
    pub skew: f64,
}

/// A unified-model (MEI) camera: a [`Lens`] of a [`MeiModel`] (γ1, γ2, u0, v0 its intrinsics,
/// pixel centres at integers as OpenCV).
pub type Unified = Lens<MeiModel>;

impl MeiModel {
    /// The largest half field of view the model is one-to-one over, and whether the image radius
    /// stays finite there (so that the limit itself may be used).
    pub fn fov_limit(xi: f64, distortion: &MeiDistortion) -> (f64, bool) {
        let (geometric, finite) = if xi > 1.0 {
            ((-1.0 / xi).acos(), true)
        } else {
            ((-xi).acos(), false)
        };
        // The first field angle where the distortion's Jacobian stops being positive.
        for i in 1..=FOV_SAMPLES {
            let t = geometric * i as f64 / FOV_SAMPLES as f64;
            let r = t.sin() / (t.cos() + xi);
            if !r.is_finite() || r > 1e6 {
                break;
            }
            let bad = (0..AZIMUTH_SAMPLES).any(|j| {
                let phi = 2.0 * PI * j as f64 / AZIMUTH_SAMPLES as f64;
                let (_, m) = distortion.apply(r * phi.cos(), r * phi.sin());
                let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
                // The radial direction must keep moving outwards too.
                let (c, s) = (phi.cos(), phi.sin());
                let radial = c * (m[0][0] * c + m[0][1] * s) + s * (m[1][0] * c + m[1][1] * s);
                !(det > 0.0 && radial > 0.0)
            });
            if bad {
                return (geometric * (i - 1) as f64 / FOV_SAMPLES as f64, true);
            }
        }
        (geometric, finite)
    }
}

impl Unified {
    /// [`MeiModel::fov_limit`].
    pub fn fov_limit(xi: f64, distortion: &MeiDistortion) -> (f64, bool) {
        MeiModel::fov_limit(xi, distortion)
    }

    /// A camera seeing up to `max_theta` (half field of view, radians), which must lie within
    /// [`Unified::fov_limit`].
    pub fn new(
        xi: f64,
        distortion: MeiDistortion,
        k: Intrinsics,
        skew: f64,
        size: ImageSize,
        max_theta: f64,
    ) -> Result<Self, FisheyeError> {
        let model = MeiModel {
            xi,
            distortion,
            skew,
        };
        Lens::with_model(model, k, size, max_theta)
    }
}

impl LensModel for MeiModel {
    fn name(&self) -> &'static str {
        "mei"
    }

    fn parameters(&self) -> Vec<(&'static str, f64)> {
        let d = self.distortion;
        vec![
            ("xi", self.xi),
            ("k1", d.k1),
            ("k2", d.k2),
            ("p1", d.p1),
            ("p2", d.p2),
            ("skew", self.skew),
        ]
    }

    fn check(&self) -> Result<(), FisheyeError> {
        let xi = self.xi;
        if !(xi >= 0.0 && xi.is_finite()) {
            return Err(FisheyeError::Parameter(
                "xi",
                format!("xi must be a finite number ≥ 0, not {xi}"),
            ));
        }
        let d = self.distortion;
        if ![d.k1, d.k2, d.p1, d.p2, self.skew]
            .iter()
            .all(|v| v.is_finite())
        {
            return Err(FisheyeError::Parameter(
                "k",
                "distortion coefficients and skew must be finite".into(),
            ));
        }
        Ok(())
    }

    fn usable_max_theta(&self, max_theta: f64) -> Result<f64, FisheyeError> {
        let (limit, finite) = Self::fov_limit(self.xi, &self.distortion);
        check_fov("mei", max_theta, limit, finite)?;
        Ok(max_theta)
    }

    /// The undistorted radius at `max_theta`.
    fn edge_radius(&self, max_theta: f64) -> f64 {
        max_theta.sin() / (max_theta.cos() + self.xi)
    }

    fn project(
        &self,
        k: &Intrinsics,
        max_theta: f64,
        d: &Vector3<f64>,
    ) -> Result<Point2<f64>, ProjectionReject> {
        let s = bearing_within(d, max_theta)?;
        let den = s.z + self.xi;
        if !(den > 0.0) {
            return Err(ProjectionReject::OutsideDomain);
        }
        let ((xd, yd), _) = self.distortion.apply(s.x / den, s.y / den);
        Ok(Point2::new(
            k.fu * xd + self.skew * yd + k.cu,
            k.fv * yd + k.cv,
        ))
    }

    fn unproject(
        &self,
        k: &Intrinsics,
        _max_theta: f64,
        r_max: f64,
        p: &Point2<f64>,
    ) -> Result<Vector3<f64>, ProjectionReject> {
        let yd = (p.y - k.cv) / k.fv;
        let xd = (p.x - k.cu - self.skew * yd) / k.fu;
        if !(xd.is_finite() && yd.is_finite()) {
            return Err(ProjectionReject::OutsideDomain);
        }
        let (x, y, residual) = self.distortion.undo(xd, yd, r_max);
        let r2 = x * x + y * y;
        // On the edge of the field of view a fold of the distortion (zero slope) leaves the
        // solution ill-conditioned: a looser residual there, still ~1e-6 px.
        let tolerance = if r2.sqrt() >= r_max * (1.0 - 1e-9) {
            UNDISTORT_EDGE_TOLERANCE
        } else {
            UNDISTORT_TOLERANCE
        };
        if !(residual <= tolerance * (1.0 + xd.hypot(yd)) && x.is_finite() && y.is_finite()) {
            return Err(ProjectionReject::OutsideDomain);
        }
        // Closed-form lift onto the unit sphere (the near intersection of the ray from the
        // projection centre).
        let disc = (1.0 + (1.0 - self.xi * self.xi) * r2).max(0.0);
        let f = (self.xi + disc.sqrt()) / (1.0 + r2);
        Ok(Vector3::new(f * x, f * y, f - self.xi).normalize())
    }

    /// r ≈ θ/(1 + ξ) near the axis (the distortion is 1 + O(r²) there).
    fn centre_intrinsics(&self, k: &Intrinsics) -> Intrinsics {
        let s = 1.0 / (1.0 + self.xi);
        Intrinsics::new(k.fu * s, k.fv * s, k.cu, k.cv)
    }

    /// The skew is in pixels: it scales with fx as a resize scales it.
    fn rescale(&mut self, from: &Intrinsics, to: &Intrinsics) {
        self.skew = self.skew * to.fu / from.fu;
    }

    fn description_fields(&self, k: &Intrinsics, _size: ImageSize) -> Vec<(&'static str, Value)> {
        let d = self.distortion;
        let mut out = affine_fields(k);
        out.push(("xi", json!(self.xi)));
        out.push(("k", json!([d.k1, d.k2])));
        out.push(("p", json!([d.p1, d.p2])));
        if self.skew != 0.0 {
            out.push(("skew", json!(self.skew)));
        }
        out
    }
}

impl ReadLensModel for MeiModel {
    fn from_parameters(name: &str, values: &[f64]) -> Option<Result<Self, FisheyeError>> {
        (name == "mei").then(|| {
            expect_parameters(name, 6, values)?;
            let distortion = MeiDistortion {
                k1: values[1],
                k2: values[2],
                p1: values[3],
                p2: values[4],
            };
            Ok(MeiModel {
                xi: values[0],
                distortion,
                skew: values[5],
            })
        })
    }
}

impl From<Unified> for Lens {
    fn from(lens: Unified) -> Self {
        lens.erased()
    }
}
