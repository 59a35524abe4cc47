//! Drawing labels onto converted images with nothing but the written calib: 3D box edges as the
//! curves they are in the projection (split at the ±180° seam), the 2D box, a class and distance
//! text label in a tiny built-in bitmap font, depth maps in colour, and contact sheets.
//!
//! The camera comes from the calib alone: the `projection:`, `K2:` and `C2:` lines panoconv
//! writes, or, for a plain KITTI calib, the perspective camera of `P2`.

use crate::camera::{CameraModel, ImageSize};
use crate::codec::png;
use crate::error::{Error, Result};
use crate::fs::read_file;
use crate::image::RgbImage;
use crate::kitti::Cam;
use crate::kitti::{Calib, Label};
use crate::reproject::source_box::box_distance;
use nalgebra::Vector3;
use std::path::Path;

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
/// Distance at the far end of the depth colour map, metres.
pub const DEPTH_MAX_M: f64 = 80.0;

/// The colour a class's boxes are drawn in (RGB).
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

/// Draws the 12 edges of a label's 3D box (if it has one) projected by `camera` from `centre`,
/// each as a polyline of samples. An edge is split where it crosses the ±180° seam of a
/// periodic projection (consecutive samples half a turn apart), and clipped at a near plane
/// for one-sided cameras.
pub fn draw_box_3d(
    img: &mut RgbImage,
    label: &Label,
    camera: &dyn CameraModel,
    centre: &Vector3<f64>,
    colour: [u8; 3],
) {
    if !label.has_box_3d() {
        return;
    }
    let half_turn = camera.horizontal_period().map(|p| p / 2.0);
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
            } else {
                plot(img, q.0, q.1, colour);
            }
            last = Some(q);
        }
    }
}

/// Draws a 2D box [left, top, right, bottom].
pub fn draw_box_2d(img: &mut RgbImage, bbox: [f64; 4], colour: [u8; 3]) {
    let [l, t, r, b] = bbox;
    draw_segment(img, (l, t), (r, t), colour);
    draw_segment(img, (r, t), (r, b), colour);
    draw_segment(img, (r, b), (l, b), colour);
    draw_segment(img, (l, b), (l, t), colour);
}

/// The text drawn next to a box: class and distance, e.g. `Car 12.3m`.
pub fn label_text(label: &Label, camera: &dyn CameraModel, centre: &Vector3<f64>) -> String {
    match label
        .to_source_box()
        .map(|b| box_distance(&b, camera, centre))
    {
        Some(d) => format!("{} {:.1}m", label.kind, d),
        None => label.kind.clone(),
    }
}

/// Draws one label: its 3D box (when it has one) in the class colour, its 2D box in white,
/// and (with `text_scale` > 0) the class and distance above the 2D box.
pub fn draw_label(
    img: &mut RgbImage,
    label: &Label,
    camera: &dyn CameraModel,
    centre: &Vector3<f64>,
) {
    draw_label_with(img, label, camera, centre, default_text_scale(img));
}

/// [`draw_label`] with an explicit text scale (0: no text).
pub fn draw_label_with(
    img: &mut RgbImage,
    label: &Label,
    camera: &dyn CameraModel,
    centre: &Vector3<f64>,
    text_scale: u32,
) {
    draw_labels(img, std::slice::from_ref(label), camera, centre, text_scale);
}

/// How many text rows a label's text may move away from its box (up from above it, or down
/// from its top edge) to find a free place; a text with none is left out, its box drawn.
pub const MAX_TEXT_SHIFT: i64 = 2;

/// Draws every label of a frame: first all boxes, then the texts, taller boxes (nearer
/// objects) first, each placed where no text drawn before it lies: above its 2D box, else up
/// to [`MAX_TEXT_SHIFT`] rows further up, else below its top edge and as far down. A crowded
/// frame's other texts are left out rather than stacked far from their boxes (over the sky).
pub fn draw_labels(
    img: &mut RgbImage,
    labels: &[Label],
    camera: &dyn CameraModel,
    centre: &Vector3<f64>,
    text_scale: u32,
) {
    for label in labels {
        let colour = class_colour(&label.kind);
        draw_box_3d(img, label, camera, centre, colour);
        draw_box_2d(img, label.bbox, [255, 255, 255]);
    }
    if text_scale == 0 {
        return;
    }
    let mut order: Vec<&Label> = labels.iter().filter(|l| !l.is_dont_care()).collect();
    let height = |l: &Label| l.bbox[3] - l.bbox[1];
    order.sort_by(|a, b| height(b).total_cmp(&height(a)));
    let mut placed: Vec<[i64; 4]> = Vec::new();
    for label in order {
        let text = label_text(label, camera, centre);
        let (tw, th) = text_size(&text, text_scale);
        let (tw, th) = (tw as i64, th as i64);
        let [l, t, _, _] = label.bbox;
        let x = (l.round() as i64).clamp(0, (img.width() as i64 - tw).max(0));
        let max_y = (img.height() as i64 - th).max(0);
        let (above, below) = (t.round() as i64 - th - 2, t.round() as i64 + 2);
        // Candidates nearest the box first: above it and up, then below its top edge and down.
        let up = (0..=MAX_TEXT_SHIFT)
            .map(|k| above - k * (th + 1))
            .filter(|&y| y >= 0);
        let down = (0..=MAX_TEXT_SHIFT)
            .map(|k| below + k * (th + 1))
            .filter(|&y| y <= max_y);
        let free = |y: i64| {
            let r = [x, y, x + tw, y + th];
            placed
                .iter()
                .all(|p| r[2] <= p[0] || p[2] <= r[0] || r[3] <= p[1] || p[3] <= r[1])
        };
        let Some(y) = up.chain(down).find(|&y| free(y)) else {
            continue;
        };
        placed.push([x, y, x + tw, y + th]);
        draw_text(
            img,
            x,
            y,
            &text,
            text_scale,
            class_colour(&label.kind),
            Some([0, 0, 0]),
        );
    }
}

/// Text scale for an image: 1 up to 600 px tall, then one more per 600 px.
pub fn default_text_scale(img: &RgbImage) -> u32 {
    1 + img.height() / 600
}

// ---------------------------------------------------------------------------------------------
// 5x7 bitmap font

/// Rows top to bottom, bit 4 is the leftmost column.
fn glyph(c: char) -> [u8; 7] {
    match c {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'A' => [0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'B' => [0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E],
        'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
        'D' => [0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
        'G' => [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F],
        'H' => [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'J' => [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C],
        'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'P' => [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10],
        'Q' => [0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D],
        'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A],
        'X' => [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11],
        'Y' => [0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04],
        'Z' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F],
        'm' => [0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11],
        'x' => [0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        ',' => [0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '_' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F],
        ':' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00],
        '/' => [0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00],
        ' ' => [0; 7],
        c if c.is_ascii_lowercase() => glyph(c.to_ascii_uppercase()),
        _ => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x00, 0x04], // '?'
    }
}

/// Width and height in pixels of `text` drawn at `scale` (6 px advance, 7 px tall, 1 px margin).
pub fn text_size(text: &str, scale: u32) -> (u32, u32) {
    let n = text.chars().count() as u32;
    ((n * 6 + 1) * scale, 9 * scale)
}

/// Draws `text` with its top-left corner (margin included) at (x, y), clipped to the image;
/// `background` fills the text's rectangle first.
pub fn draw_text(
    img: &mut RgbImage,
    x: i64,
    y: i64,
    text: &str,
    scale: u32,
    colour: [u8; 3],
    background: Option<[u8; 3]>,
) {
    let s = scale.max(1) as i64;
    let mut put = |px: i64, py: i64, c: [u8; 3]| {
        if px >= 0 && py >= 0 && px < img.width() as i64 && py < img.height() as i64 {
            img.put_pixel(px as u32, py as u32, c);
        }
    };
    if let Some(bg) = background {
        let (w, h) = text_size(text, scale.max(1));
        for py in y..y + h as i64 {
            for px in x..x + w as i64 {
                put(px, py, bg);
            }
        }
    }
    for (i, c) in text.chars().enumerate() {
        let rows = glyph(c);
        let x0 = x + s * (1 + 6 * i as i64);
        for (r, bits) in rows.iter().enumerate() {
            for col in 0..5 {
                if bits & (0x10 >> col) != 0 {
                    for dy in 0..s {
                        for dx in 0..s {
                            put(x0 + col * s + dx, y + s * (1 + r as i64) + dy, colour);
                        }
                    }
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Depth

/// Colour of a distance: red (near) → yellow → green → cyan → blue (≥ [`DEPTH_MAX_M`]), on a
/// square-root scale so that the near range, where most points are, gets most of the colours.
pub fn depth_colour(d: f64) -> [u8; 3] {
    let t = (d / DEPTH_MAX_M).clamp(0.0, 1.0).sqrt();
    const STOPS: [[f64; 3]; 5] = [
        [255.0, 0.0, 0.0],
        [255.0, 255.0, 0.0],
        [0.0, 255.0, 0.0],
        [0.0, 255.0, 255.0],
        [0.0, 64.0, 255.0],
    ];
    let x = t * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let mut out = [0u8; 3];
    for c in 0..3 {
        out[c] = (STOPS[i][c] + (STOPS[i + 1][c] - STOPS[i][c]) * f).round() as u8;
    }
    out
}

/// Distances (metres) where [`depth_colour`] passes its stops: red, yellow, green, cyan, blue.
pub const DEPTH_STOPS_M: [f64; 5] = [0.0, 5.0, 20.0, 45.0, DEPTH_MAX_M];

/// Draws the colour scale of [`depth_colour`] in the bottom-left corner: a bar from 0 to
/// [`DEPTH_MAX_M`] with the metres of its stops written under it.
pub fn draw_depth_legend(img: &mut RgbImage, scale: u32) {
    let s = scale.max(1);
    let width = (160 * s).min(img.width().saturating_sub(4 * s));
    let bar_h = 6 * s;
    let (_, text_h) = text_size("0", s);
    if width < 40 || img.height() < bar_h + text_h + 4 * s {
        return;
    }
    let x0 = 2 * s;
    let y0 = img.height() - bar_h - text_h - 2 * s;
    // The bar's x is linear in the colour parameter (the square root of the distance).
    let metres_at = |x: u32| DEPTH_MAX_M * (x as f64 / (width - 1) as f64).powi(2);
    let position = |d: f64| ((d / DEPTH_MAX_M).sqrt() * (width - 1) as f64).round() as u32;
    for x in 0..width {
        let c = depth_colour(metres_at(x));
        for y in y0..y0 + bar_h {
            img.put_pixel(x0 + x, y, c);
        }
    }
    for y in y0 + bar_h..y0 + bar_h + text_h {
        for x in 0..width {
            img.put_pixel(x0 + x, y, [0, 0, 0]);
        }
    }
    for d in DEPTH_STOPS_M {
        let text = if d >= DEPTH_MAX_M {
            format!("{d:.0}m")
        } else {
            format!("{d:.0}")
        };
        let (tw, _) = text_size(&text, s);
        let x = (x0 + position(d))
            .saturating_sub(tw / 2)
            .min(x0 + width - tw);
        draw_text(
            img,
            x as i64,
            (y0 + bar_h) as i64,
            &text,
            s,
            [255, 255, 255],
            None,
        );
    }
}

/// Paints every pixel with a depth (`value > 0`, d = value / 256 m) in the colour of its
/// distance.
pub fn overlay_depth(img: &mut RgbImage, width: u32, height: u32, values: &[u16]) -> bool {
    if (width, height) != (img.width(), img.height()) || values.len() != (width * height) as usize {
        return false;
    }
    for (i, &v) in values.iter().enumerate() {
        if v > 0 {
            let (x, y) = (i as u32 % width, i as u32 / width);
            img.put_pixel(x, y, depth_colour(v as f64 / 256.0));
        }
    }
    true
}

// ---------------------------------------------------------------------------------------------
// Frames and contact sheets

/// What to draw on a preview.
#[derive(Debug, Clone, Copy)]
pub struct PreviewOptions {
    /// Overlay `depth_2/NNNNNN.png` when it exists.
    pub depth: bool,
    /// Text scale for the class and distance labels (0: none; None: by image size).
    pub text_scale: Option<u32>,
}

impl Default for PreviewOptions {
    fn default() -> Self {
        Self {
            depth: true,
            text_scale: None,
        }
    }
}

/// Renders the preview of frame `id` of `ROOT/split`: the image, the depth map (if any) in
/// colour, and every label drawn from the calib alone.
pub fn render_frame(
    root: &Path,
    split: &str,
    id: &str,
    options: &PreviewOptions,
) -> Result<RgbImage> {
    let dir = root.join(split);
    let image_path = dir.join("image_2").join(format!("{id}.png"));
    let calib_path = dir.join("calib").join(format!("{id}.txt"));
    let label_path = dir.join("label_2").join(format!("{id}.txt"));
    let depth_path = dir.join("depth_2").join(format!("{id}.png"));
    let mut image = png::decode_rgb8(&read_file(&image_path)?, &image_path)?;
    let calib = Calib::read(&calib_path)?;
    let size = ImageSize::new(image.width(), image.height());
    let (camera, centre) = calib.image_camera(Cam::C2, size)?;
    if options.depth && depth_path.is_file() {
        let (w, h, values) = png::decode_gray16(&read_file(&depth_path)?, &depth_path)?;
        if !overlay_depth(&mut image, w, h, &values) {
            return Err(Error::file(
                &depth_path,
                format!("depth map is {w}x{h}, the image is {size}"),
            ));
        }
        let scale = options
            .text_scale
            .filter(|&s| s > 0)
            .unwrap_or_else(|| default_text_scale(&image));
        draw_depth_legend(&mut image, scale);
    }
    if label_path.exists() {
        let scale = options
            .text_scale
            .unwrap_or_else(|| default_text_scale(&image));
        let labels = crate::kitti::LabelFile::read(&label_path)?.labels;
        draw_labels(&mut image, &labels, camera.as_ref(), &centre, scale);
    }
    Ok(image)
}

/// The split and id of the frame `id` names in a dataset: `split` when given, else the first
/// split holding it; an id not found as given is tried as KITTI's six-digit form (`7` →
/// `000007`). The error lists where it looked.
pub fn find_frame(root: &Path, split: Option<&str>, id: &str) -> Result<(String, String)> {
    let splits: Vec<&str> = match split {
        Some(s) => vec![s],
        None => crate::kitti::dataset::SPLITS.to_vec(),
    };
    let mut ids = vec![id.to_owned()];
    if let Ok(n) = id.parse::<u64>() {
        let padded = format!("{n:06}");
        if padded != id {
            ids.push(padded);
        }
    }
    for s in &splits {
        for candidate in &ids {
            if root
                .join(s)
                .join("image_2")
                .join(format!("{candidate}.png"))
                .is_file()
            {
                return Ok((s.to_string(), candidate.clone()));
            }
        }
    }
    let looked: Vec<String> = splits
        .iter()
        .map(|s| {
            root.join(s)
                .join("image_2")
                .join(format!("{}.png", ids.last().unwrap_or(&ids[0])))
                .display()
                .to_string()
        })
        .collect();
    Err(Error::Setup(format!(
        "frame {id} not found (looked for {})",
        looked.join(" and ")
    )))
}

/// Resizes to `width` (height in proportion) by averaging the source pixels whose centres fall
/// in each output pixel's footprint (nearest pixel when enlarging).
pub fn resize_to_width(img: &RgbImage, width: u32) -> RgbImage {
    let s = img.width() as f64 / width.max(1) as f64;
    let height = ((img.height() as f64 / s).round() as u32).max(1);
    let sy = img.height() as f64 / height as f64;
    let range = |i: u32, scale: f64, n: u32| -> (u32, u32) {
        // centres c with i*scale <= c + 0.5 < (i+1)*scale
        let lo = (i as f64 * scale - 0.5).ceil().max(0.0) as u32;
        let hi = (((i + 1) as f64 * scale - 0.5).ceil().max(0.0) as u32).min(n);
        if hi > lo {
            (lo, hi)
        } else {
            let c = (((i as f64 + 0.5) * scale).floor() as u32).min(n - 1);
            (c, c + 1)
        }
    };
    let mut out = RgbImage::new(width.max(1), height);
    for oy in 0..height {
        let (y0, y1) = range(oy, sy, img.height());
        for ox in 0..width.max(1) {
            let (x0, x1) = range(ox, s, img.width());
            let mut sum = [0u32; 3];
            for y in y0..y1 {
                for x in x0..x1 {
                    let p = img.pixel(x, y);
                    for c in 0..3 {
                        sum[c] += p[c] as u32;
                    }
                }
            }
            let n = (y1 - y0) * (x1 - x0);
            out.put_pixel(ox, oy, sum.map(|v| ((v + n / 2) / n) as u8));
        }
    }
    out
}

/// Gap between tiles of a contact sheet, pixels.
const SHEET_GAP: u32 = 4;

/// A contact sheet: `tiles` (caption, image) in rows of `cols`, each scaled to `tile_width`;
/// every cell is as tall as the tallest scaled tile.
pub fn contact_sheet(tiles: &[(String, RgbImage)], cols: u32, tile_width: u32) -> RgbImage {
    let cols = cols.max(1);
    let scaled: Vec<(&String, RgbImage)> = tiles
        .iter()
        .map(|(c, img)| (c, resize_to_width(img, tile_width)))
        .collect();
    let rows = (scaled.len() as u32).div_ceil(cols).max(1);
    let cell_h = scaled.iter().map(|(_, t)| t.height()).max().unwrap_or(1);
    let width = cols * tile_width + (cols + 1) * SHEET_GAP;
    let height = rows * cell_h + (rows + 1) * SHEET_GAP;
    let mut sheet = RgbImage::from_raw(
        width,
        height,
        [40u8, 40, 40].repeat((width * height) as usize),
    )
    .expect("buffer of the sheet's size");
    for (i, (caption, tile)) in scaled.iter().enumerate() {
        let (c, r) = (i as u32 % cols, i as u32 / cols);
        let x0 = SHEET_GAP + c * (tile_width + SHEET_GAP);
        let y0 = SHEET_GAP + r * (cell_h + SHEET_GAP);
        for y in 0..tile.height() {
            for x in 0..tile.width().min(tile_width) {
                sheet.put_pixel(x0 + x, y0 + y, tile.pixel(x, y));
            }
        }
        draw_text(
            &mut sheet,
            x0 as i64,
            y0 as i64,
            caption,
            1,
            [255, 255, 255],
            Some([0, 0, 0]),
        );
    }
    sheet
}
