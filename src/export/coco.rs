//! COCO detection JSON (`instances_<split>.json`), as pycocotools, MMDetection and Detectron2
//! read it.
//!
//! Boxes are COCO's [x, y, w, h] in COCO's pixel convention (pixel (0, 0) covers [0, 1)²), so
//! x = left + 0.5 for a KITTI box whose pixel centres are at integers. DontCare regions are
//! `iscrowd: 1` annotations, one per category, because COCO's ignore regions are per category
//! and KITTI's apply to every class.

use crate::error::{Error, Result};
use crate::export::boxes::{image_boxes, PixelBox};
use crate::export::{round_to, ExportData, Frame, Object};
use crate::reproject::source_box::box_distance;
use serde::Serialize;

/// COCO's pixel (0, 0) is centred at (0.5, 0.5), KITTI's at (0, 0).
pub const COCO_FROM_KITTI_PIXEL: f64 = 0.5;

#[derive(Serialize)]
struct CocoFile<'a> {
    info: Info<'a>,
    licenses: [(); 0],
    images: Vec<Image>,
    annotations: Vec<Annotation>,
    categories: Vec<Category<'a>>,
}

#[derive(Serialize)]
struct Info<'a> {
    description: &'a str,
    version: &'a str,
    split: &'a str,
}

#[derive(Serialize)]
pub(crate) struct Camera {
    /// How pixels relate to rays: perspective, equirect or cylindrical (docs/geometry.md).
    pub projection: &'static str,
    /// Row-major 3×3, in panoconv's pixel convention (centres at integers).
    #[serde(rename = "K")]
    pub k: [[f64; 3]; 3],
    /// Camera 2's optical centre in KITTI's rect frame, metres.
    #[serde(rename = "C")]
    pub c: [f64; 3],
}

#[derive(Serialize)]
struct Image {
    id: u64,
    file_name: String,
    width: u32,
    height: u32,
    camera: Camera,
}

#[derive(Serialize)]
struct Annotation {
    id: u64,
    image_id: u64,
    category_id: usize,
    bbox: [f64; 4],
    area: f64,
    iscrowd: u8,
    /// KITTI's truncation (0..1); -1 for ignore regions.
    truncated: f64,
    /// KITTI's occlusion state (0 visible .. 3 unknown); -1 for ignore regions.
    occluded: i32,
    /// Metres from the camera centre to the 3D box centre: the distance the projection pairs
    /// with (z, range or cylindrical rho); null without a 3D box.
    distance: Option<f64>,
    /// True on both boxes of an object cut by the ±180° seam of a 360° image.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    wraps_seam: bool,
    /// The line of the image's `label_2` file the annotation comes from, from 1: shared by
    /// both boxes of a seam-cut object and by the per-category copies of an ignore region.
    label_line: usize,
}

#[derive(Serialize)]
struct Category<'a> {
    id: usize,
    name: &'a str,
    supercategory: &'static str,
}

pub(crate) fn camera_of(frame: &Frame) -> Camera {
    let k = frame.camera.intrinsics().matrix();
    Camera {
        projection: frame.camera.projection().name(),
        k: [[k[0], k[1], k[2]], [k[3], k[4], k[5]], [k[6], k[7], k[8]]],
        c: [frame.centre.x, frame.centre.y, frame.centre.z],
    }
}

/// COCO's [x, y, w, h] of a KITTI-convention box, to the 0.01 px KITTI's labels carry.
pub fn coco_bbox(b: PixelBox) -> [f64; 4] {
    [
        round_to(b[0] + COCO_FROM_KITTI_PIXEL, 2),
        round_to(b[1] + COCO_FROM_KITTI_PIXEL, 2),
        round_to(b[2] - b[0], 2),
        round_to(b[3] - b[1], 2),
    ]
}

/// The detection boxes of a frame: (category index, KITTI-convention box, wraps the seam,
/// object), in label order. YOLO writes the same list.
pub(crate) fn frame_boxes(frame: &Frame) -> Vec<(usize, PixelBox, bool, &Object)> {
    let mut out = Vec::new();
    for o in &frame.objects {
        let parts = image_boxes(&o.label, frame.camera.as_ref(), &frame.centre);
        let wraps = parts.len() > 1;
        for b in parts {
            out.push((o.category, b, wraps, o));
        }
    }
    out
}

/// The COCO file of one export split: its name (`instances_<split>.json`) and bytes.
pub fn render(data: &ExportData, split: &str, frames: &[&Frame]) -> Result<(String, Vec<u8>)> {
    let mut file = CocoFile {
        info: Info {
            description: "panoconv export of a KITTI-layout dataset",
            version: env!("CARGO_PKG_VERSION"),
            split,
        },
        licenses: [],
        images: Vec::new(),
        annotations: Vec::new(),
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
    };
    let mut next_id = 1u64;
    for f in frames {
        file.images.push(Image {
            id: f.image_id,
            file_name: format!("{}{}", data.path_prefix, f.image_rel),
            width: f.size.width,
            height: f.size.height,
            camera: camera_of(f),
        });
        for (category, b, wraps_seam, object) in frame_boxes(f) {
            let (bbox, label) = (coco_bbox(b), &object.label);
            file.annotations.push(Annotation {
                id: next_id,
                image_id: f.image_id,
                category_id: category + 1,
                bbox,
                area: round_to(bbox[2] * bbox[3], 4),
                iscrowd: 0,
                truncated: label.truncated,
                occluded: label.occluded,
                distance: label
                    .to_source_box()
                    .map(|b| box_distance(&b, f.camera.as_ref(), &f.centre))
                    .map(|d| round_to(d, 4)),
                wraps_seam,
                label_line: object.line,
            });
            next_id += 1;
        }
        for region in &f.ignore_regions {
            let bbox = coco_bbox(region.bbox);
            for category in 0..data.categories.len() {
                file.annotations.push(Annotation {
                    id: next_id,
                    image_id: f.image_id,
                    category_id: category + 1,
                    bbox,
                    area: round_to(bbox[2] * bbox[3], 4),
                    iscrowd: 1,
                    truncated: -1.0,
                    occluded: -1,
                    distance: None,
                    wraps_seam: false,
                    label_line: region.line,
                });
                next_id += 1;
            }
        }
    }
    let mut bytes = serde_json::to_vec(&file)
        .map_err(|e| Error::Setup(format!("cannot serialise the COCO file: {e}")))?;
    bytes.push(b'\n');
    Ok((format!("instances_{split}.json"), bytes))
}
