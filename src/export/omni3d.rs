//! Omni3D's COCO-like JSON (`Omni3D_<split>.json`), as Cube R-CNN reads it.
//!
//! Conventions (facebookresearch/omni3d, DATA.md and `cubercnn/util/math_util.py`): camera
//! frame x right, y down, z forward, origin at the optical centre; `dimensions` = [w, h, l];
//! `center_cam` the 3D box centre; `R_cam` rotates the object frame (x along the length, y
//! along the height, z along the width) into the camera frame; `bbox3D_cam` lists the corners
//! R_cam·v + center_cam for v = (∓l/2, ∓h/2, ∓w/2) in the order v0..v7 of
//! `get_cuboid_verts_faces` (v0..v3 the face at −w/2, v4..v7 the one at +w/2). 2D boxes are
//! [x1, y1, x2, y2] in the pixel convention of K (pixel centres at integers, as KITTI's P2).
//! A fisheye's camera frame is the lens's own (its calib's R2 turns it into the level axes).

use crate::camera::{FisheyeCamera, OutputCamera, OutputProjection, Projection};
use crate::error::{Error, Result};
use crate::export::{round_to, ExportData, Frame, Object};
use crate::reproject::labels::{box_bounds, clip};
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

/// Omni3D's "not available".
const NA: f64 = -1.0;

#[derive(Serialize)]
struct Omni3dFile<'a> {
    info: Info<'a>,
    images: Vec<Image>,
    categories: Vec<Category<'a>>,
    annotations: Vec<Annotation<'a>>,
}

#[derive(Serialize)]
struct Info<'a> {
    id: u32,
    source: u32,
    name: &'a str,
    split: &'a str,
    version: &'a str,
    url: &'a str,
}

#[derive(Serialize)]
struct Image {
    id: u64,
    dataset_id: u32,
    width: u32,
    height: u32,
    file_path: String,
    #[serde(rename = "K")]
    k: [[f64; 3]; 3],
    /// How pixels relate to rays: Omni3D assumes perspective; see docs/formats.md.
    projection: &'static str,
    src_90_rotate: u32,
    src_flagged: bool,
    /// A fisheye's lens, as its calib lines give it (Omni3D readers ignore extra keys).
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    lens: Option<LensEntry>,
}

/// The calib's `model2:`, `D2:`, `fov2:` and `R2:` lines of a fisheye output.
#[derive(Serialize)]
struct LensEntry {
    model: &'static str,
    #[serde(rename = "D")]
    d: Vec<f64>,
    /// Full field of view, degrees.
    fov: f64,
    /// The camera's axes in the level rect frame (row-major 3×3): the 3D fields of the image's
    /// annotations are in the camera's axes, X_rect = R · X_cam + C2.
    #[serde(rename = "R")]
    r: [[f64; 3]; 3],
}

impl LensEntry {
    fn of(camera: &FisheyeCamera) -> Self {
        LensEntry {
            model: camera.lens.name(),
            d: camera.lens.parameters().iter().map(|(_, v)| *v).collect(),
            fov: 2.0 * camera.lens.max_theta().to_degrees(),
            r: rows(&camera.rect_from_camera),
        }
    }
}

#[derive(Serialize)]
struct Category<'a> {
    id: usize,
    name: &'a str,
    supercategory: &'static str,
}

#[derive(Serialize)]
#[allow(non_snake_case)] // Omni3D's own field names
struct Annotation<'a> {
    id: u64,
    image_id: u64,
    category_id: usize,
    category_name: &'a str,
    valid3D: bool,
    bbox2D_tight: [f64; 4],
    bbox2D_proj: [f64; 4],
    bbox2D_trunc: [f64; 4],
    bbox3D_cam: [[f64; 3]; 8],
    center_cam: [f64; 3],
    dimensions: [f64; 3],
    R_cam: [[f64; 3]; 3],
    behind_camera: bool,
    visibility: f64,
    truncation: f64,
    segmentation_pts: i32,
    lidar_pts: i32,
    depth_error: f64,
    /// The line of the image's `label_2` file the object comes from, from 1 (as in the COCO
    /// export): an annotation traces back to its label.
    label_line: usize,
}

/// Omni3D's corner order in the object frame, as multiples of (l, h, w).
pub const UNIT_CORNERS: [[f64; 3]; 8] = [
    [-0.5, -0.5, -0.5],
    [0.5, -0.5, -0.5],
    [0.5, 0.5, -0.5],
    [-0.5, 0.5, -0.5],
    [-0.5, -0.5, 0.5],
    [0.5, -0.5, 0.5],
    [0.5, 0.5, 0.5],
    [-0.5, 0.5, 0.5],
];

/// KITTI's rotation_y as a rotation of the object frame into the camera frame (about y).
pub fn r_cam(rotation_y: f64) -> Matrix3<f64> {
    let (s, c) = rotation_y.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

/// KITTI's occlusion state as a visibility fraction: 0 fully visible, 1 partly, 2 largely
/// occluded; 3 (unknown) is Omni3D's "not available".
fn visibility(occluded: i32) -> f64 {
    match occluded {
        0 => 1.0,
        1 => 0.5,
        2 => 0.25,
        _ => NA,
    }
}

fn rows(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    [0, 1, 2].map(|r| [m[(r, 0)], m[(r, 1)], m[(r, 2)]])
}

fn point(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z].map(|x| round_to(x, 6))
}

fn annotation<'a>(
    id: u64,
    frame: &Frame,
    object: &Object,
    category_name: &'a str,
) -> Annotation<'a> {
    let label = &object.label;
    let mut a = Annotation {
        id,
        image_id: frame.image_id,
        category_id: object.category + 1,
        category_name,
        valid3D: label.has_box_3d(),
        bbox2D_tight: label.bbox,
        bbox2D_proj: [NA; 4],
        bbox2D_trunc: [NA; 4],
        bbox3D_cam: [[NA; 3]; 8],
        center_cam: [NA; 3],
        dimensions: [NA; 3],
        R_cam: [[NA; 3]; 3],
        behind_camera: false,
        visibility: visibility(label.occluded),
        truncation: if label.truncated >= 0.0 {
            label.truncated
        } else {
            NA
        },
        segmentation_pts: -1,
        lidar_pts: -1,
        depth_error: NA,
        label_line: object.line,
    };
    if !a.valid3D {
        return a;
    }
    // The camera frame's origin is the optical centre. A rig conversion's exact box keeps a
    // tilted box's pitch and roll; else KITTI's location is the bottom centre and its one angle
    // the rotation.
    let (center, r, [h, w, l]) = match &object.exact {
        Some(e) => (
            e.centre - frame.centre,
            e.rotation,
            [e.size.y, e.size.z, e.size.x],
        ),
        None => {
            let [h, w, l] = label.dimensions;
            let bottom = label.location - Vector3::new(0.0, h / 2.0, 0.0);
            (bottom - frame.centre, r_cam(label.rotation_y), [h, w, l])
        }
    };
    // The box in the level axes at the optical centre, which the camera projects from.
    let corners = UNIT_CORNERS.map(|[x, y, z]| r * Vector3::new(x * l, y * h, z * w) + center);
    let camera: &dyn OutputCamera = frame.camera.as_ref();
    // Omni3D's 3D values are in the camera's own axes: a turned lens (R2) sees X − C2 as
    // R2ᵀ·(X − C2), and a trainer projects them with the lens alone.
    let cam_from_rect = camera
        .as_fisheye()
        .map_or_else(Matrix3::identity, |f| f.rect_from_camera.transpose());
    a.bbox3D_cam = corners.map(|c| point(&(cam_from_rect * c)));
    a.center_cam = point(&(cam_from_rect * center));
    a.dimensions = [w, h, l];
    a.R_cam = rows(&(cam_from_rect * r));
    let mut visible = false;
    if let Some(b) = box_bounds(&corners, camera).filter(|b| b.iter().all(|v| v.is_finite())) {
        a.bbox2D_proj = b.map(|v| round_to(v, 4));
        if let Some(t) = clip(b, frame.size.width, frame.size.height) {
            a.bbox2D_trunc = t.map(|v| round_to(v, 4));
            visible = true;
        }
    }
    // Cube R-CNN drops objects flagged behind the camera. In a perspective image that means
    // a corner behind the image plane (Omni3D's meaning); a panorama or a fisheye sees
    // behind its optical axis, so there the flag means "not visible in this image".
    a.behind_camera = match camera.projection() {
        OutputProjection::Linear(Projection::Perspective) => corners.iter().any(|c| !(c.z > 0.0)),
        OutputProjection::Linear(Projection::Equirect | Projection::Cylindrical)
        | OutputProjection::Fisheye => !visible,
    };
    a
}

/// The Omni3D file of one export split: its name (`Omni3D_<split>.json`) and bytes.
pub fn render(data: &ExportData, split: &str, frames: &[&Frame]) -> Result<(String, Vec<u8>)> {
    let name = format!("panoconv_{split}");
    let mut file = Omni3dFile {
        info: Info {
            id: 0,
            source: 0,
            name: &name,
            split,
            version: env!("CARGO_PKG_VERSION"),
            url: "",
        },
        images: Vec::new(),
        categories: data
            .categories
            .iter()
            .enumerate()
            .map(|(i, name)| Category {
                id: i + 1,
                name,
                supercategory: "kitti",
            })
            .collect(),
        annotations: Vec::new(),
    };
    let mut next_id = 1u64;
    for f in frames {
        let k = f.camera.intrinsics().matrix();
        file.images.push(Image {
            id: f.image_id,
            dataset_id: 0,
            width: f.size.width,
            height: f.size.height,
            file_path: format!("{}{}", data.path_prefix, f.image_rel),
            k: [[k[0], k[1], k[2]], [k[3], k[4], k[5]], [k[6], k[7], k[8]]],
            projection: f.camera.projection().name(),
            src_90_rotate: 0,
            src_flagged: false,
            lens: f.camera.as_fisheye().map(LensEntry::of),
        });
        for o in &f.objects {
            let name = data.categories[o.category].as_str();
            file.annotations.push(annotation(next_id, f, o, name));
            next_id += 1;
        }
    }
    let mut bytes = serde_json::to_vec(&file)
        .map_err(|e| Error::Setup(format!("cannot serialise the Omni3D file: {e}")))?;
    bytes.push(b'\n');
    Ok((format!("Omni3D_{split}.json"), bytes))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kitti::Label;
    use std::path::Path;

    /// Omni3D's corners, from centre, dimensions and R_cam, are KITTI's 8 corners (as a set).
    #[test]
    fn corners_are_kittis_box() {
        let line = "Car 0.00 0 0.5 100 100 200 200 1.5 1.6 3.9 2.0 1.7 15.0 0.7";
        let label = Label::parse(Path::new("t.txt"), 1, line).unwrap();
        let [h, w, l] = label.dimensions;
        let center = label.location - Vector3::new(0.0, h / 2.0, 0.0);
        let r = r_cam(label.rotation_y);
        let ours = UNIT_CORNERS.map(|[x, y, z]| r * Vector3::new(x * l, y * h, z * w) + center);
        for k in label.corners() {
            let nearest = ours.iter().map(|o| (o - k).norm()).fold(f64::MAX, f64::min);
            assert!(
                nearest < 1e-12,
                "KITTI corner {k:?} is not an Omni3D corner"
            );
        }
        // v0..v3 share z_obj = -w/2: their mean is the centre moved by -w/2 along R's z.
        let face: Vector3<f64> = ours[..4].iter().sum::<Vector3<f64>>() / 4.0;
        assert!((face - (center - r.column(2) * w / 2.0)).norm() < 1e-12);
    }
}
