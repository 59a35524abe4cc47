//! Drawing labels onto converted images with nothing but the written calib: 3D box edges as the
//! curves they are in the projection (split at the ±180° seam), and the 2D box.

use crate::camera::CameraModel;
use crate::image::RgbImage;
use crate::kitti::Label;
use nalgebra::Vector3;

const EDGES: [(usize, usize); 12] = [
    (0, 1),
    (1, 2),
    (2, 3),
    (3, 0),
    (4, 5),
    (5, 6),
    (6, 7),
    (7, 4),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];
const EDGE_SAMPLES: usize = 200;

pub fn class_colour(kind: &str) -> [u8; 3] {
    match kind {
        "Car" => [255, 60, 60],
        "Van" | "Truck" => [255, 160, 0],
        "Pedestrian" | "Person_sitting" => [60, 255, 60],
        "Cyclist" => [0, 220, 255],
        "DontCare" => [160, 160, 160],
        _ => [255, 0, 255],
    }
}

fn plot(img: &mut RgbImage, x: f64, y: f64, c: [u8; 3]) {
    let (xi, yi) = (x.round(), y.round());
    if xi >= 0.0 && yi >= 0.0 && xi < img.width() as f64 && yi < img.height() as f64 {
        img.put_pixel(xi as u32, yi as u32, c);
    }
}

/// A straight pixel segment (the curve is made of many of them).
pub fn draw_segment(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), c: [u8; 3]) {
    let steps = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).clamp(1, 100_000);
    for i in 0..=steps {
        let t = i as f64 / steps as f64;
        plot(img, a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t, c);
    }
}

/// Draws one label: its 3D box (when it has one) projected by `camera` from `centre`, and its
/// 2D box.
pub fn draw_label(
    img: &mut RgbImage,
    label: &Label,
    camera: &dyn CameraModel,
    centre: &Vector3<f64>,
) {
    let colour = class_colour(&label.kind);
    let half_turn = camera.horizontal_period().map(|p| p / 2.0);
    if label.has_box_3d() {
        let corners = label.corners().map(|c| c - centre);
        for (i, j) in EDGES {
            let mut last: Option<(f64, f64)> = None;
            for k in 0..=EDGE_SAMPLES {
                let p = corners[i] + (corners[j] - corners[i]) * (k as f64 / EDGE_SAMPLES as f64);
                let visible = camera.front_halfspace().is_none_or(|n| n.dot(&p) > 0.05);
                let px = if visible {
                    camera.project_point(&p).ok()
                } else {
                    None
                };
                let Some(px) = px else {
                    last = None;
                    continue;
                };
                let q = (px.x, px.y);
                if let Some(l) = last {
                    // a jump of half a turn is the seam: the curve continues on the other side
                    if half_turn.is_none_or(|h| (q.0 - l.0).abs() < h) {
                        draw_segment(img, l, q, colour);
                    }
                }
                last = Some(q);
            }
        }
    }
    let [l, t, r, b] = label.bbox;
    let white = [255, 255, 255];
    draw_segment(img, (l, t), (r, t), white);
    draw_segment(img, (r, t), (r, b), white);
    draw_segment(img, (r, b), (l, b), white);
    draw_segment(img, (l, b), (l, t), white);
}
