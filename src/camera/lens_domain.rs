//! What every wide-angle model shares about its domain: the error of an unusable lens, the
//! checks of its intrinsics, the field angle of a bearing, whether a lens of a given half field
//! of view sees it, its front half-space, the check of a field of view against what a model can
//! represent, and the search for where a radial model stays one-to-one. A file of its own,
//! below the models, [`super::LensModel`] and [`super::Lens`], so that none of them imports
//! another for these.

use super::{ImageSize, Intrinsics, ProjectionReject};
use nalgebra::Vector3;
use std::f64::consts::PI;

/// Why a lens description is unusable.
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

/// w of Usenko et al. (EUCM and double sphere): the valid region is z > −w·d.
pub(crate) fn unified_w(alpha: f64) -> f64 {
    if alpha <= 0.5 {
        alpha / (1.0 - alpha)
    } else {
        (1.0 - alpha) / alpha
    }
}

/// Refuses `values` unless it holds the `n` parameters model `name` takes (calib lines).
pub(crate) fn expect_parameters(name: &str, n: usize, values: &[f64]) -> Result<(), FisheyeError> {
    if values.len() == n {
        Ok(())
    } else {
        Err(FisheyeError::Parameter(
            "parameters",
            format!("model {name} takes {n} parameters, found {}", values.len()),
        ))
    }
}

/// The angle between a bearing and the optical axis (+z).
pub(crate) fn field_angle(d: &Vector3<f64>) -> f64 {
    d.x.hypot(d.y).atan2(d.z)
}

/// The unit bearing of `d` when a lens seeing up to `max_theta` (half field of view) has an
/// image of it: the first step of every wide-angle model's `project`.
pub(crate) fn bearing_within(
    d: &Vector3<f64>,
    max_theta: f64,
) -> Result<Vector3<f64>, ProjectionReject> {
    let n = d.norm();
    if !(n.is_finite() && n > 0.0) {
        return Err(ProjectionReject::Singular);
    }
    let s = d / n;
    // in front (z > 0) the angle is below π/2: no atan2 for a lens that sees that far
    if s.z > 0.0 && max_theta >= std::f64::consts::FRAC_PI_2 {
        return Ok(s);
    }
    if field_angle(&s) > max_theta * (1.0 + 1e-12) {
        return Err(ProjectionReject::OutsideDomain);
    }
    Ok(s)
}

/// The front half-space (+z) of a lens seeing up to `max_theta`, when it sees no further.
pub(crate) fn front_halfspace_of(max_theta: f64) -> Option<Vector3<f64>> {
    (max_theta <= PI / 2.0).then(Vector3::z)
}

/// Refuses a half field of view outside (0, limit] (or (0, limit) when the image is unbounded
/// at the limit), naming the limit in degrees.
pub(crate) fn check_fov(
    model: &str,
    max_theta: f64,
    limit: f64,
    finite_at_limit: bool,
) -> Result<(), FisheyeError> {
    let within = if finite_at_limit {
        max_theta <= limit * (1.0 + 1e-12)
    } else {
        max_theta < limit
    };
    if !(max_theta > 0.0 && within) {
        return Err(FisheyeError::FieldOfView(format!(
            "max field of view {:.3}° is outside what this {model} camera can represent \
             (0° < fov {} {:.3}°)",
            2.0 * max_theta.to_degrees(),
            if finite_at_limit { "≤" } else { "<" },
            2.0 * limit.to_degrees()
        )));
    }
    Ok(())
}

/// The half field of view over which a radially symmetric model is one-to-one, searched below
/// `upper` (a closed-form bound, included when `finite_at_upper`): `radius(θ)` is the image
/// radius of field angle θ in normalised units, None where the model has no image. The first
/// angle where the radius is missing or stops increasing (4096 samples, then bisection) ends it.
pub(crate) fn radial_limit(
    upper: f64,
    finite_at_upper: bool,
    radius: impl Fn(f64) -> Option<f64>,
) -> (f64, bool) {
    const SAMPLES: usize = 4096;
    let increasing = |t: f64| match (radius(t * (1.0 - 1e-9)), radius(t)) {
        (Some(a), Some(b)) => b.is_finite() && b > a,
        _ => false,
    };
    let mut previous = 0.0;
    for i in 1..=SAMPLES {
        if i == SAMPLES && !finite_at_upper {
            break;
        }
        let t = upper * i as f64 / SAMPLES as f64;
        match radius(t) {
            Some(r) if r.is_finite() && r > previous && increasing(t) => previous = r,
            _ => {
                let (mut lo, mut hi) = (upper * (i - 1) as f64 / SAMPLES as f64, t);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if increasing(mid) && radius(mid).is_some_and(|r| r >= previous) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                return (lo, true);
            }
        }
    }
    (upper, finite_at_upper)
}
