//! `panoconv kitti --to fisheye --camera FILE` against exact maths: the synthetic scene rendered
//! directly in each fisheye camera, 2D boxes against the dense projection of the 3D boxes, the
//! written calib read back (by panoconv and by the Python function of docs/formats.md), crops,
//! resizes, augmentation, depth along the ray, determinism and the set-up errors. This file
//! holds the test cameras and readers the topics share; each topic is a file of
//! `tests/fisheye_target/`.

mod boxes;
mod calib;
mod camera_file;
mod outputs;
mod render;

use crate::common::*;
use panoconv::camera::description::CameraDescription;
use panoconv::camera::FisheyeCamera;
use panoconv::image::RgbImage;
use std::path::{Path, PathBuf};

/// The bar for a conversion against the exact render, over the covered area.
const MIN_PSNR_DB: f64 = 48.0;

/// Pixels per radian at the fisheye's centre: the source's focal length (721.5 px), so that the
/// comparison measures the geometry rather than a resampling filter.
const CENTRE_SCALE: f64 = 721.5377;

/// A camera description of `model` with centre scale [`CENTRE_SCALE`], `fov` degrees, turned
/// by `pitch` degrees, `width`×`height` with the principal point at (cx, cy).
fn camera_json(model: &str, fov: f64, pitch: f64, size: (u32, u32), c: (f64, f64)) -> String {
    let f = CENTRE_SCALE;
    let (cx, cy) = c;
    let affine = |fx: f64| format!("\"fx\": {fx}, \"fy\": {fx}, \"cx\": {cx}, \"cy\": {cy}");
    let fields = match model {
        "equidistant" | "equisolid" | "stereographic" | "orthographic" => affine(f),
        "kannala_brandt" => format!("{}, \"k\": [0.04, -0.012, 0.002, -0.0002]", affine(f)),
        // WoodScape's front camera's polynomial, in units of the centre scale (r in pixels).
        "woodscape" => format!(
            "\"k\": [{}, {}, {}, {}], \"aspect_ratio\": 1.0, \"cx_offset\": {}, \"cy_offset\": {}",
            f,
            -0.0941 * f,
            0.1421 * f,
            -0.0212 * f,
            cx - (size.0 as f64 / 2.0 - 0.5),
            cy - (size.1 as f64 / 2.0 - 0.5)
        ),
        // r ≈ θ/(1 + ξ) at the centre: γ = (1 + ξ)·f keeps the centre scale.
        "mei" => format!(
            "{}, \"xi\": 1.2, \"k\": [-0.08, 0.015], \"p\": [4e-4, -3e-4]",
            affine(2.2 * f)
        ),
        "eucm" => format!("{}, \"alpha\": 0.6, \"beta\": 1.1", affine(f)),
        "double_sphere" => format!("{}, \"xi\": -0.2, \"alpha\": 0.59", affine(0.8 * f)),
        other => panic!("no test camera for {other}"),
    };
    format!(
        "{{\n  \"version\": 1, \"model\": \"{model}\", \"width\": {}, \"height\": {}, \
         \"max_fov_deg\": {fov},\n  {fields},\n  \"rotation\": {{\"yaw_deg\": 0, \"pitch_deg\": {pitch}, \"roll_deg\": 0}}\n}}\n",
        size.0, size.1
    )
}

const MODELS: [&str; 9] = [
    "equidistant",
    "equisolid",
    "stereographic",
    "orthographic",
    "kannala_brandt",
    "woodscape",
    "mei",
    "eucm",
    "double_sphere",
];

/// The widest field of view the test gives each model (orthographic stops at 180°).
fn fov_of(model: &str) -> f64 {
    if model == "orthographic" {
        180.0
    } else {
        190.0
    }
}

/// The camera a description file describes, as the conversion places it (rect axes).
fn fisheye_camera(path: &Path) -> FisheyeCamera {
    let desc = CameraDescription::read(path).unwrap();
    FisheyeCamera {
        lens: desc.camera,
        rect_from_camera: desc.output_from_camera,
    }
}

/// `panoconv kitti --to fisheye --camera CAMERA --input IN --output OUT EXTRA...`, successful.
fn convert(camera: &Path, input: &Path, output: &Path, extra: &[&str]) {
    let mut args = vec!["--camera", camera.to_str().unwrap()];
    args.extend_from_slice(extra);
    assert_success(&kitti("fisheye", input, output, &args));
}

fn write_camera(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    write_text(&path, text);
    path
}

/// A 1-bit or 8-bit grey PNG as one bool per pixel (white = true).
fn read_mask(path: &Path) -> (u32, u32, Vec<bool>) {
    let p = read_png(path);
    assert_eq!(p.color, png::ColorType::Grayscale, "{}", path.display());
    let (w, h) = (p.width as usize, p.height as usize);
    let bits = match p.depth {
        png::BitDepth::One => 1,
        png::BitDepth::Eight => 8,
        other => panic!("{}: mask of depth {other:?}", path.display()),
    };
    let stride = (w * bits).div_ceil(8);
    assert_eq!(p.data.len(), stride * h);
    let mut out = Vec::with_capacity(w * h);
    for v in 0..h {
        for u in 0..w {
            let on = if bits == 1 {
                p.data[v * stride + u / 8] >> (7 - u % 8) & 1 == 1
            } else {
                p.data[v * stride + u] > 127
            };
            out.push(on);
        }
    }
    (p.width, p.height, out)
}

fn read_image(path: &Path) -> RgbImage {
    let p = read_rgb8(path);
    RgbImage::from_raw(p.width, p.height, p.data).unwrap()
}

/// The test-1 Kannala-Brandt camera (1360×560, 721.5 px/rad at the centre, 10° nose down).
fn kb_camera(dir: &Path) -> PathBuf {
    let json = camera_json("kannala_brandt", 190.0, -10.0, (1360, 560), (679.5, 379.5));
    write_camera(dir, "kb.json", &json)
}

fn k2_of(calib: &str) -> [f64; 4] {
    let k = calib_values(calib, "K2").expect("a K2 line");
    [k[0], k[4], k[2], k[5]]
}

#[track_caller]
fn assert_k_close(what: &str, got: [f64; 4], want: [f64; 4]) {
    for i in 0..4 {
        assert!(
            (got[i] - want[i]).abs() <= 1e-9 * want[i].abs().max(1.0),
            "{what}: K2 {got:?}, the half-pixel rule gives {want:?}"
        );
    }
}
