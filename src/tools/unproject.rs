//! Between KITTI 3D labels and the pixel-space objects a detector predicts in a converted image.
//!
//! The pixel format (one object per line, `#` comments allowed):
//!
//! ```text
//! type u v distance height width length alpha score
//! Car 512.3040 180.2231 12.345678 1.52 1.65 3.90 -1.570796 0.97
//! ```
//!
//! (u, v) is the output-image pixel of the 3D box's centre (its geometric centre, half the
//! height above the KITTI location); `distance` is the projection's own distance from the
//! camera centre C to that point (z for perspective, the range for equirect and fisheye, the
//! cylindrical rho = sqrt(x² + z²) for cylindrical); height/width/length are metres; `alpha` is the
//! observation angle relative to the ray from C: rotation_y = alpha + atan2(x − Cx, z − Cz).
//! Going back, the location is C + t·bearing(u, v) with t chosen so that the distance matches,
//! moved down by half the height.
//!
//! A KITTI result line belongs to the *source* image: the benchmark scores its 2D box (AP, AOS,
//! and the 25/40-px height filters) against the original `label_2`. So its box is, by default,
//! the source camera's: the exact projection of the 3D box through P2, clipped to the source
//! image ([`BoxImage::Source`]); the converted image's box is the other choice.

use crate::camera::{CameraModel, OutputCamera};
use crate::error::{Error, Result};
use crate::kitti::Label;
use crate::reproject::labels::{box_bounds, clip};
use nalgebra::{Point2, Vector3};
use std::f64::consts::PI;
use std::path::Path;

/// A detected object in output pixels: one line of the pixel format (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct PixelObject {
    /// The KITTI type (`Car`, `Pedestrian`, ...).
    pub kind: String,
    /// Column of the 3D box's geometric centre in the output image, pixels (centres at integers).
    pub u: f64,
    /// Row of the 3D box's geometric centre in the output image, pixels.
    pub v: f64,
    /// The projection's own distance from the camera centre to the box centre, metres (z, range
    /// or rho).
    pub distance: f64,
    /// height, width, length, metres.
    pub dimensions: [f64; 3],
    /// Observation angle relative to the ray from the camera centre, radians.
    pub alpha: f64,
    /// Detection confidence; 1 for a label or a line without a score.
    pub score: f64,
}

fn wrap_angle(a: f64) -> f64 {
    (a + PI).rem_euclid(2.0 * PI) - PI
}

/// Azimuth of a point seen from the camera centre (about the y axis).
fn azimuth(p: &Vector3<f64>) -> f64 {
    p.x.atan2(p.z)
}

/// A KITTI label as a pixel object in `camera` (centre `centre`), or None when its centre has
/// no image there.
pub fn label_to_pixel(
    label: &Label,
    camera: &dyn CameraModel,
    centre: &Vector3<f64>,
) -> Option<PixelObject> {
    if !label.has_box_3d() {
        return None;
    }
    let h = label.dimensions[0];
    let p = label.location - Vector3::new(0.0, h / 2.0, 0.0) - centre;
    let px = camera.project_point(&p).ok()?;
    Some(PixelObject {
        kind: label.kind.clone(),
        u: px.x,
        v: px.y,
        distance: camera.distance(&p),
        dimensions: label.dimensions,
        alpha: wrap_angle(label.rotation_y - azimuth(&p)),
        score: label.score.unwrap_or(1.0),
    })
}

/// The KITTI location (bottom centre, rect) and rotation_y of a pixel object. `distance_scale`
/// multiplies the predicted distance first (see [`trained_focal_scale`]).
pub fn pixel_to_box(
    obj: &PixelObject,
    camera: &dyn CameraModel,
    centre: &Vector3<f64>,
    distance_scale: f64,
) -> Option<(Vector3<f64>, f64)> {
    let bearing = camera.unproject(&Point2::new(obj.u, obj.v)).ok()?;
    let unit = camera.distance(&bearing);
    if !(unit > 0.0) {
        return None;
    }
    let p = bearing * (obj.distance * distance_scale / unit);
    let location = centre + p + Vector3::new(0.0, obj.dimensions[0] / 2.0, 0.0);
    Some((location, wrap_angle(obj.alpha + azimuth(&p))))
}

/// Scale from a distance predicted by a detector trained on perspective images of vertical
/// focal length `trained_fv` to the output camera's distance: an object of height H spans
/// f·H/d pixels in both, so d_out = d_pred · fv_out / trained_fv (Plaut et al.: Z becomes rho;
/// a fisheye's f is its pixels per radian at the image centre).
pub fn trained_focal_scale(output: &dyn OutputCamera, trained_fv: f64) -> f64 {
    output.centre_intrinsics().fv / trained_fv
}

/// The pixel-format line of `o`, without a newline (the inverse of [`parse_pixel_line`]).
pub fn format_pixel_line(o: &PixelObject) -> String {
    format!(
        "{} {:.4} {:.4} {:.6} {:.2} {:.2} {:.2} {:.6} {:.2}",
        o.kind,
        o.u,
        o.v,
        o.distance,
        o.dimensions[0],
        o.dimensions[1],
        o.dimensions[2],
        o.alpha,
        o.score
    )
}

const PIXEL_FIELDS: [&str; 9] = [
    "type", "u", "v", "distance", "height", "width", "length", "alpha", "score",
];

/// Parses one line of the pixel format (9 fields; 8 without a score, which then counts as 1).
pub fn parse_pixel_line(path: &Path, line_no: usize, line: &str) -> Result<PixelObject> {
    let t: Vec<&str> = line.split_whitespace().collect();
    if t.len() != 9 && t.len() != 8 {
        return Err(Error::parse(
            path,
            line_no,
            "fields",
            format!(
                "expected 9 fields (type u v distance height width length alpha score), found {}",
                t.len()
            ),
        ));
    }
    let num = |i: usize| -> Result<f64> {
        match t[i].parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(Error::parse(
                path,
                line_no,
                PIXEL_FIELDS[i],
                format!("{:?} is not a finite number", t[i]),
            )),
        }
    };
    let distance = num(3)?;
    if !(distance > 0.0) {
        return Err(Error::parse(path, line_no, "distance", "must be positive"));
    }
    Ok(PixelObject {
        kind: t[0].to_owned(),
        u: num(1)?,
        v: num(2)?,
        distance,
        dimensions: [num(4)?, num(5)?, num(6)?],
        alpha: num(7)?,
        score: if t.len() == 9 { num(8)? } else { 1.0 },
    })
}

/// The image whose 2D box a KITTI result line carries.
pub enum BoxImage<'a> {
    /// The source image (the benchmark's): the 3D box projected through the source camera
    /// (P2, about its centre `centre`), clipped to its image size.
    Source {
        /// P2's pinhole at the source image's size.
        camera: &'a dyn CameraModel,
        /// P2's optical centre in rect.
        centre: Vector3<f64>,
    },
    /// The converted image the detector ran on.
    Converted,
}

/// A KITTI result line for a pixel object: truncation and occlusion unknown (-1), alpha in
/// KITTI's convention (relative to the rect origin), the 2D box of the 3D box in `image` (see
/// [`BoxImage`]; all zero when the box is wholly outside it), and the score.
pub fn result_line(
    obj: &PixelObject,
    camera: &dyn CameraModel,
    centre: &Vector3<f64>,
    distance_scale: f64,
    image: &BoxImage,
) -> Option<String> {
    let (location, ry) = pixel_to_box(obj, camera, centre, distance_scale)?;
    let label = Label {
        tokens: Vec::new(),
        kind: obj.kind.clone(),
        truncated: -1.0,
        occluded: -1,
        alpha: 0.0,
        bbox: [0.0; 4],
        dimensions: obj.dimensions,
        location,
        rotation_y: ry,
        score: Some(obj.score),
    };
    let (box_camera, box_centre) = match image {
        BoxImage::Source { camera, centre } => (*camera, *centre),
        BoxImage::Converted => (camera, *centre),
    };
    let size = box_camera.size();
    let bbox = box_bounds(&label.corners().map(|c| c - box_centre), box_camera)
        .and_then(|b| clip(b, size.width, size.height))
        .unwrap_or([0.0; 4]);
    let alpha = wrap_angle(ry - location.x.atan2(location.z));
    let [h, w, l] = obj.dimensions;
    Some(format!(
        "{} -1 -1 {:.6} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.6} {:.6} {:.6} {:.6} {:.4}",
        obj.kind,
        alpha,
        bbox[0],
        bbox[1],
        bbox[2],
        bbox[3],
        h,
        w,
        l,
        location.x,
        location.y,
        location.z,
        ry,
        obj.score
    ))
}
