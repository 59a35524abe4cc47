//! The camera of a view centred on its own optical axis (the folder converters' outputs).

use super::ceil_px;
use crate::camera::{ImageSize, Intrinsics, LinearCamera, Projection};
use crate::error::{Error, Result};
use std::f64::consts::PI;

/// The output camera of a view centred on its own optical axis: `hfov`/`vfov` in radians,
/// `fu`/`fv` in pixels per radian at the centre (per unit of tangent for perspective and for
/// the cylindrical height). A 360° cylindrical or equirect view gets a width of exactly 2π·fu
/// (fu rounded to fit) so that it wraps without a seam; an equirect view of 360°×180° is 2:1.
pub fn view_camera(
    projection: Projection,
    fu: f64,
    fv: f64,
    hfov: f64,
    vfov: f64,
) -> Result<Box<dyn LinearCamera>> {
    if !(fu > 0.0 && fu.is_finite() && fv > 0.0 && fv.is_finite()) {
        return Err(Error::Setup(format!(
            "invalid output scale {fu}x{fv} px/rad"
        )));
    }
    let full = (hfov - 2.0 * PI).abs() < 1e-9;
    let ((max_h, h_limit_ok), (max_v, v_limit_ok)) = projection.view_limits();
    let h_ok = hfov > 0.0 && (hfov < max_h || (h_limit_ok && (hfov - max_h).abs() < 1e-9));
    let v_ok = vfov > 0.0 && (vfov < max_v || (v_limit_ok && (vfov - max_v).abs() < 1e-9));
    if !h_ok || !v_ok {
        return Err(Error::Setup(format!(
            "a {projection} view cannot cover {:.3}°x{:.3}° (perspective: both below 180°; \
             cylindrical: up to 360° wide and below 180° tall; equirect: up to 360°x180°)",
            hfov.to_degrees(),
            vfov.to_degrees()
        )));
    }
    let (a_half, b_half) = projection.view_half_extent(hfov, vfov);
    let (width, fu, cu) = if full {
        let w = (2.0 * PI * fu).round().max(1.0) as u32;
        (w, w as f64 / (2.0 * PI), w as f64 / 2.0 - 0.5)
    } else {
        let w = ceil_px(2.0 * a_half * fu);
        (w, fu, (w as f64 - 1.0) / 2.0)
    };
    let (height, fv) = if projection == Projection::Equirect && full && vfov >= PI - 1e-9 {
        let h = width.div_ceil(2);
        (h, h as f64 / PI)
    } else {
        (ceil_px(2.0 * b_half * fv), fv)
    };
    if width > 65535 || height > 65535 {
        return Err(Error::Setup(format!(
            "output of {width}x{height} pixels is too large"
        )));
    }
    let cv = (height as f64 - 1.0) / 2.0;
    Ok(projection.camera(
        Intrinsics::new(fu, fv, cu, cv),
        ImageSize::new(width, height),
    ))
}
