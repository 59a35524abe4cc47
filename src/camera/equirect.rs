//! Equirectangular: (a, b) = (longitude λ = atan2(x, z), latitude φ = asin(y / |p|)); distance
//! is the range |p|. Latitude is positive downwards (y down). Pixels beyond a pole are outside
//! the domain (clamped, never wrapped); longitude is periodic.

use super::linear::{Linear, Mapping};
use super::separable::Share;
use super::{Projection, ProjectionReject};
use nalgebra::Vector3;
use std::f64::consts::FRAC_PI_2;

/// The equirectangular (a, b) mapping; see the module documentation.
#[derive(Debug, PartialEq)]
pub struct EquirectMapping;

/// An equirectangular camera: `EquirectMapping` with K (fu, fv in pixels per radian).
pub type Equirect = Linear<EquirectMapping>;

/// |d|, or the rejection of a bearing without a direction.
#[inline]
fn length(d: &Vector3<f64>) -> Result<f64, ProjectionReject> {
    let n = d.norm();
    if !(n > 0.0) || !n.is_finite() {
        return Err(ProjectionReject::Singular);
    }
    Ok(n)
}

/// The latitude of `d`, whose length is `n`.
#[inline]
fn latitude(d: &Vector3<f64>, n: f64) -> f64 {
    (d.y / n).clamp(-1.0, 1.0).asin()
}

impl Mapping for EquirectMapping {
    const PROJECTION: Projection = Projection::Equirect;
    const PERIODIC: bool = true;
    const FRONT_ONLY: bool = false;

    #[inline]
    fn bearing_to_ab(d: &Vector3<f64>) -> Result<(f64, f64), ProjectionReject> {
        let n = length(d)?;
        Ok((d.x.atan2(d.z), latitude(d, n)))
    }

    #[inline]
    fn bearing_to_a(d: &Vector3<f64>) -> Result<f64, ProjectionReject> {
        length(d)?;
        Ok(d.x.atan2(d.z))
    }

    #[inline]
    fn bearing_to_b(d: &Vector3<f64>) -> Result<f64, ProjectionReject> {
        Ok(latitude(d, length(d)?))
    }

    fn split_a(lon: f64) -> [f64; 2] {
        if !lon.is_finite() {
            return [f64::NAN; 2];
        }
        let (so, co) = lon.sin_cos();
        [so, co]
    }

    fn split_b(lat: f64) -> [f64; 2] {
        // A pole pixel computed in floating point may land a rounding error beyond π/2.
        if !lat.is_finite() || lat.abs() > FRAC_PI_2 + 1e-12 {
            return [f64::NAN; 2];
        }
        let (sl, cl) = lat.clamp(-FRAC_PI_2, FRAC_PI_2).sin_cos();
        [sl, cl]
    }

    #[inline]
    fn join([so, co]: [f64; 2], [sl, cl]: [f64; 2]) -> Result<Vector3<f64>, ProjectionReject> {
        // sines and cosines of finite angles are never NaN: NaN marks a split outside the domain
        if so.is_nan() || sl.is_nan() {
            return Err(ProjectionReject::OutsideDomain);
        }
        Ok(Vector3::new(cl * so, sl, cl * co))
    }

    #[inline]
    fn join_lanes(columns: &[Share], [sl, cl]: [f64; 2], [x, y, z]: [&mut [f64]; 3]) {
        if sl.is_nan() {
            for out in [x, y, z] {
                out.fill(f64::NAN);
            }
            return;
        }
        for (((col, x), y), z) in columns.iter().zip(x).zip(y).zip(z) {
            // (a NaN sine of the longitude, outside the domain, gives a NaN x)
            let [so, co] = col.0;
            (*x, *y, *z) = (cl * so, sl, cl * co);
        }
    }

    fn distance(p: &Vector3<f64>) -> f64 {
        p.norm()
    }
}
