//! `panoconv kitti --to fisheye --camera FILE` against exact maths: the synthetic scene rendered
//! directly in each fisheye camera, 2D boxes against the dense projection of the 3D boxes, the
//! written calib read back (by panoconv and by the Python function of docs/formats.md), crops,
//! resizes, augmentation, depth along the ray, determinism and the set-up errors.

use crate::opencv_ref;

use crate::common::*;
use nalgebra::{Point2, Vector3};
use panoconv::camera::description::CameraDescription;
use panoconv::camera::{CameraModel, FisheyeCamera};
use panoconv::image::RgbImage;
use panoconv::kitti::Cam;
use panoconv::tools::synth::{frames, SynthCalib};
use std::path::{Path, PathBuf};

/// The issue's bar for a conversion against the exact render, over the covered area.
const MIN_PSNR_DB: f64 = 48.0;
/// The issue's bar for a written box against the dense exact projection.
const MIN_BOX_IOU: f64 = 0.99;

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

/// PSNR over the pixels `keep` selects, and how many there were.
fn psnr(a: &RgbImage, b: &RgbImage, keep: impl Fn(u32, u32) -> bool) -> (f64, usize) {
    let (mut se, mut n) = (0.0, 0usize);
    for v in 0..a.height() {
        for u in 0..a.width() {
            if keep(u, v) {
                let (p, q) = (a.pixel(u, v), b.pixel(u, v));
                se += (0..3)
                    .map(|c| (p[c] as f64 - q[c] as f64).powi(2))
                    .sum::<f64>();
                n += 1;
            }
        }
    }
    (10.0 * (255.0f64.powi(2) / (se / (3 * n) as f64)).log10(), n)
}

// ---------------------------------------------------------------------------------------------
// 1. The conversion against the exact render

#[test]
fn every_model_matches_the_exact_render_over_the_covered_area() {
    let dir = tempfile::tempdir().unwrap();
    let frame = &frames()[0];
    let centre = SynthCalib::standard().centre();
    let mut report = Vec::new();
    for model in MODELS {
        // 10° nose down: the source's field of view lies above the fisheye's centre.
        let size = (1360, 560);
        let json = camera_json(model, fov_of(model), -10.0, size, (679.5, 379.5));
        let cam_path = write_camera(dir.path(), &format!("{model}.json"), &json);
        let out = dir.path().join(model);
        convert(
            &cam_path,
            synth_source(),
            &out,
            &["--frames", "000000", "--mask"],
        );
        let warped = read_image(&out.join("training/image_2/000000.png"));
        let (mw, mh, mask) = read_mask(&out.join("training/mask_2/000000.png"));
        assert_eq!((mw, mh), (size.0, size.1), "{model}: mask size");
        assert_eq!((warped.width(), warped.height()), (size.0, size.1));
        let camera = fisheye_camera(&cam_path);
        let covered = |u: u32, v: u32| mask[(v * mw + u) as usize];
        // `Scene::render` over the covered pixels only
        let exact = render_where(&frame.scene, &camera, &centre, 0.55, 6, covered);
        let (db, n) = psnr(&warped, &exact, covered);
        report.push(format!("{model}: {db:.2} dB over {n} px"));
        assert!(n > 200_000, "{model}: only {n} covered pixels");
        assert!(db >= MIN_PSNR_DB, "{model}: {db:.2} dB < {MIN_PSNR_DB} dB");
        assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
    }
    eprintln!("{}", report.join("\n"));
}

// ---------------------------------------------------------------------------------------------
// 2. Boxes against the dense exact projection

/// Samples per face side of the dense reference.
const FACE_SAMPLES: usize = 120;
/// Bisection steps where a grid line leaves the camera's field of view.
const EDGE_BISECTIONS: usize = 40;

/// The bounds of the dense projection of a 3D box (corners in rect) seen from `centre`: every
/// face sampled on a FACE_SAMPLES² grid, and where a grid line leaves the field of view, the
/// last point with a pixel (bisection). Clipped to [0, W−1] × [0, H−1]; None when empty.
fn dense_box(
    corners: &[Vector3<f64>; 8],
    centre: &Vector3<f64>,
    camera: &dyn CameraModel,
) -> Option<[f64; 4]> {
    const FACES: [[usize; 4]; 6] = [
        [0, 1, 2, 3],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 0, 4, 7],
    ];
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut add = |p: Point2<f64>| {
        b[0] = b[0].min(p.x);
        b[1] = b[1].min(p.y);
        b[2] = b[2].max(p.x);
        b[3] = b[3].max(p.y);
    };
    let n = FACE_SAMPLES;
    for face in FACES {
        let [p0, p1, _, p3] = face.map(|i| corners[i] - centre);
        let at = |s: f64, t: f64| p0 + (p1 - p0) * s + (p3 - p0) * t;
        let pixel = |s: f64, t: f64| camera.project_point(&at(s, t)).ok();
        let grid: Vec<Vec<Option<Point2<f64>>>> = (0..=n)
            .map(|j| {
                (0..=n)
                    .map(|i| pixel(i as f64 / n as f64, j as f64 / n as f64))
                    .collect()
            })
            .collect();
        for row in &grid {
            for p in row.iter().flatten() {
                add(*p);
            }
        }
        // Along both grid directions: bisect between a sample with a pixel and one without.
        for j in 0..=n {
            for i in 0..n {
                for (a, c) in [((i, j), (i + 1, j)), ((j, i), (j, i + 1))] {
                    let (pa, pc) = (grid[a.1][a.0], grid[c.1][c.0]);
                    if pa.is_some() == pc.is_some() {
                        continue;
                    }
                    let coords = |k: (usize, usize)| (k.0 as f64 / n as f64, k.1 as f64 / n as f64);
                    let (mut inside, mut outside) = if pa.is_some() {
                        (coords(a), coords(c))
                    } else {
                        (coords(c), coords(a))
                    };
                    for _ in 0..EDGE_BISECTIONS {
                        let mid = ((inside.0 + outside.0) / 2.0, (inside.1 + outside.1) / 2.0);
                        if pixel(mid.0, mid.1).is_some() {
                            inside = mid;
                        } else {
                            outside = mid;
                        }
                    }
                    if let Some(p) = pixel(inside.0, inside.1) {
                        add(p);
                    }
                }
            }
        }
    }
    let s = camera.size();
    let (wm, hm) = ((s.width - 1) as f64, (s.height - 1) as f64);
    if !(b[0] <= wm && b[2] >= 0.0 && b[1] <= hm && b[3] >= 0.0) {
        return None;
    }
    Some([b[0].max(0.0), b[1].max(0.0), b[2].min(wm), b[3].min(hm)])
}

/// A KITTI label line of a 3D box (the 2D box is recomputed by the code under test).
fn label_line(kind: &str, dims: [f64; 3], loc: Vector3<f64>, ry: f64) -> String {
    format!(
        "{kind} 0.00 0 0.00 0.00 0.00 1.00 1.00 {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2}",
        dims[0], dims[1], dims[2], loc.x, loc.y, loc.z, ry
    )
}

fn parse_label(line: &str) -> panoconv::kitti::Label {
    panoconv::kitti::Label::parse(Path::new("label.txt"), 1, line).unwrap()
}

/// The worst IoU of the written boxes of `labels` against the dense projection; every object
/// the dense projection puts on the image must have a box and every box a dense projection.
#[track_caller]
fn check_boxes(
    what: &str,
    written: &[String],
    camera: &dyn CameraModel,
    centre: &Vector3<f64>,
) -> (f64, usize) {
    let mut worst = 1.0f64;
    for line in written {
        let t = tokens(line);
        if t[0] == "DontCare" {
            continue;
        }
        let label = parse_label(line);
        let dense = dense_box(&label.corners(), centre, camera)
            .unwrap_or_else(|| panic!("{what}: {line}: written, but no dense sample on the image"));
        let iou = iou(bbox_of(&t), dense);
        assert!(
            iou >= MIN_BOX_IOU,
            "{what}: {line}: IoU {iou:.4} against the dense projection {dense:?}"
        );
        worst = worst.min(iou);
    }
    (worst, written.len())
}

/// A 900×900 equidistant fisheye of 190° (its whole circle on the image), 10° nose down.
const WIDE_EQUIDISTANT: &str = "{\"version\": 1, \"model\": \"equidistant\", \"width\": 900, \
    \"height\": 900, \"max_fov_deg\": 190, \"fx\": 250, \"fy\": 250, \"cx\": 449.5, \"cy\": 449.5, \
    \"rotation\": {\"pitch_deg\": -10}}";

#[test]
fn boxes_all_around_a_190_degree_fisheye_match_the_dense_projection() {
    use panoconv::convert::kitti::transform_label;
    let dir = tempfile::tempdir().unwrap();
    let mut cameras = vec![(
        "equidistant",
        write_camera(dir.path(), "eq.json", WIDE_EQUIDISTANT),
    )];
    // The MEI and double sphere lenses of test 1, with their circle inside the image too.
    for model in ["mei", "double_sphere", "kannala_brandt"] {
        let json = camera_json(model, 190.0, -10.0, (900, 900), (449.5, 449.5))
            .replace(&format!("{CENTRE_SCALE}"), "250");
        let json = match model {
            "mei" => json.replace(&format!("{}", 2.2 * CENTRE_SCALE), "550"),
            "double_sphere" => json.replace(&format!("{}", 0.8 * CENTRE_SCALE), "200"),
            _ => json,
        };
        cameras.push((
            model,
            write_camera(dir.path(), &format!("{model}.json"), &json),
        ));
    }
    // A narrower one too: 150°, which only sees its front half-space.
    cameras.push((
        "equisolid 150°",
        write_camera(
            dir.path(),
            "narrow.json",
            &WIDE_EQUIDISTANT
                .replace("equidistant", "equisolid")
                .replace("190", "150"),
        ),
    ));
    let centre = SynthCalib::standard().centre();
    // Not used by transform_label's 3D path beyond its domain checks.
    let source = panoconv::camera::Perspective::new(
        SynthCalib::standard().intrinsics(),
        SynthCalib::standard().size,
    );
    let (mut worst, mut boxes, mut beyond_90) = (1.0f64, 0usize, 0usize);
    for (model, path) in &cameras {
        let camera = fisheye_camera(path);
        for az_deg in (-180..180).step_by(10) {
            // Cars near and far, and a truck whose long side straddles the field's edge.
            for (dims, dist, ry) in [
                ([1.52, 1.65, 3.9], 2.5, 0.3),
                ([1.52, 1.65, 3.9], 5.0, 1.2),
                ([1.52, 1.65, 3.9], 11.0, -0.7),
                ([3.2, 2.5, 12.0], 3.5, 0.1),
            ] {
                let az = (az_deg as f64).to_radians();
                let loc = Vector3::new(dist * az.sin(), 1.65, dist * az.cos());
                let line = label_line("Car", dims, loc, ry);
                let label = parse_label(&line);
                let dense = dense_box(&label.corners(), &centre, &camera);
                let written = transform_label(&label, &centre, &source, &camera);
                match (written, dense) {
                    (None, None) => {}
                    (Some(w), Some(d)) => {
                        let iou = iou(bbox_of(&tokens(&w)), d);
                        assert!(
                            iou >= MIN_BOX_IOU,
                            "{model} azimuth {az_deg}° at {dist} m: IoU {iou:.4}: {w} vs {d:?}"
                        );
                        worst = worst.min(iou);
                        boxes += 1;
                        // Off the optical axis by more than 90° (the axis is pitched down 10°).
                        let axis = camera.rect_from_camera * Vector3::z();
                        let to_box = loc - Vector3::new(0.0, 0.76, 0.0) - centre;
                        if axis.angle(&to_box) > std::f64::consts::FRAC_PI_2 {
                            beyond_90 += 1;
                        }
                    }
                    (w, d) => {
                        panic!("{model} azimuth {az_deg}° at {dist} m: written {w:?}, dense {d:?}")
                    }
                }
            }
        }
    }
    eprintln!("{boxes} boxes, {beyond_90} beyond 90° off-axis: worst IoU {worst:.5}");
    assert!(beyond_90 >= 20, "only {beyond_90} boxes beyond 90°");
}

#[test]
fn the_sample_converted_to_a_turned_190_degree_fisheye_has_exact_boxes() {
    let dir = tempfile::tempdir().unwrap();
    // Turned 60° right: the cars on the left lie beyond 90° from its axis.
    let cam = write_camera(
        dir.path(),
        "right.json",
        &WIDE_EQUIDISTANT.replace("\"pitch_deg\": -10", "\"yaw_deg\": 60, \"pitch_deg\": -10"),
    );
    let out = dir.path().join("out");
    convert(&cam, synth_source(), &out, &["--split", "training"]);
    let (mut worst, mut boxes, mut beyond_90) = (1.0f64, 0usize, 0usize);
    for (_, id) in SYNTH_FRAMES.iter().filter(|(s, _)| *s == "training") {
        let calib =
            panoconv::kitti::Calib::read(&out.join(format!("training/calib/{id}.txt"))).unwrap();
        let (camera, centre) = calib
            .output_camera(Cam::C2, panoconv::camera::ImageSize::new(900, 900))
            .unwrap();
        let written: Vec<String> =
            label_lines(&read_text(&out.join(format!("training/label_2/{id}.txt"))))
                .into_iter()
                .map(str::to_owned)
                .collect();
        let (w, n) = check_boxes(id, &written, camera.as_ref(), &centre);
        worst = worst.min(w);
        boxes += n;
        let axis = camera.unproject(&Point2::new(449.5, 449.5)).unwrap();
        let source = frames().into_iter().find(|f| f.id == *id).unwrap();
        for b in &source.scene.boxes {
            let to_box = b.location - Vector3::new(0.0, b.dimensions[0] / 2.0, 0.0) - centre;
            let on_image = dense_box(
                &parse_label(&label_line(b.kind, b.dimensions, b.location, b.rotation_y)).corners(),
                &centre,
                camera.as_ref(),
            );
            if axis.angle(&to_box) > std::f64::consts::FRAC_PI_2 && on_image.is_some() {
                beyond_90 += 1;
            }
        }
    }
    eprintln!("sample: {boxes} boxes ({beyond_90} beyond 90° off-axis), worst IoU {worst:.5}");
    assert!(beyond_90 >= 2, "only {beyond_90} boxes beyond 90°");
    assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
}

// ---------------------------------------------------------------------------------------------
// 3. The calib read back, by panoconv and by the Python function of docs/formats.md

/// Bearings all over the sphere (θ up to 180°), in rect.
fn sphere_bearings() -> Vec<Vector3<f64>> {
    let mut out = Vec::new();
    for i in 0..=90 {
        let theta = std::f64::consts::PI * i as f64 / 90.0;
        for j in 0..48 {
            let phi = std::f64::consts::TAU * j as f64 / 48.0;
            out.push(Vector3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ));
        }
    }
    out
}

/// The Python function between the markers of docs/formats.md.
fn docs_python() -> String {
    let doc = read_text(&Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/formats.md"));
    let begin = doc
        .find("<!-- fisheye-python-begin -->")
        .expect("docs/formats.md: no fisheye-python-begin marker");
    let end = doc
        .find("<!-- fisheye-python-end -->")
        .expect("docs/formats.md: no fisheye-python-end marker");
    let block = &doc[begin..end];
    let code = block
        .split_once("```python\n")
        .and_then(|(_, rest)| rest.split_once("```"))
        .expect("a ```python block between the markers")
        .0;
    code.to_owned()
}

/// Runs the docs' function on the box centres (location − half the height) of `labels` with
/// `calib`: one line per label, "u v" or "None".
fn python_box_centres(calib: &Path, labels: &[String]) -> Vec<Option<(f64, f64)>> {
    let driver = r#"
import sys, json
calib = read_calib(sys.argv[1])
for x, y, z, h in json.load(open(sys.argv[2])):
    p = project_fisheye(calib, [x, y - h / 2, z])
    print("None" if p is None else "%r %r" % (float(p[0]), float(p[1])))
"#;
    let centres: Vec<[f64; 4]> = labels
        .iter()
        .map(|l| {
            let t: Vec<f64> = tokens(l)[8..14]
                .iter()
                .map(|v| v.parse().unwrap())
                .collect();
            [t[3], t[4], t[5], t[0]]
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let req = dir.path().join("centres.json");
    std::fs::write(&req, serde_json::to_string(&centres).unwrap()).unwrap();
    let script = format!("{}\n{driver}", docs_python());
    opencv_ref::run_python(&script, &[calib.to_str().unwrap(), req.to_str().unwrap()])
        .lines()
        .map(|l| {
            (l != "None").then(|| {
                let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
                (v[0], v[1])
            })
        })
        .collect()
}

#[test]
fn the_written_calib_projects_like_the_camera_that_wrote_it_in_panoconv_and_in_python() {
    let dir = tempfile::tempdir().unwrap();
    let mut report = Vec::new();
    for model in MODELS {
        // Yawed 70° right and pitched: objects on the left lie beyond 90° of the axis.
        let json = camera_json(model, fov_of(model), -10.0, (1000, 700), (499.5, 349.5))
            .replace("\"yaw_deg\": 0", "\"yaw_deg\": 70")
            .replace(&format!("{CENTRE_SCALE}"), "300")
            .replace(&format!("{}", 2.2 * CENTRE_SCALE), "660")
            .replace(&format!("{}", 0.8 * CENTRE_SCALE), "240");
        let cam_path = write_camera(dir.path(), &format!("{model}.json"), &json);
        let out = dir.path().join(model);
        convert(&cam_path, synth_source(), &out, &["--split", "training"]);
        let pixels = dir.path().join(format!("{model}-pixels"));
        assert_success(&panoconv([
            "labels-to-pixels".as_ref(),
            "--input".as_ref(),
            out.as_os_str(),
            "--output".as_ref(),
            pixels.as_os_str(),
        ]));
        let writer = fisheye_camera(&cam_path);
        let (mut worst_calib, mut worst_py_lib, mut worst_py_file) = (0.0f64, 0.0f64, 0.0f64);
        let mut objects = 0;
        for (_, id) in SYNTH_FRAMES.iter().filter(|(s, _)| *s == "training") {
            let calib_path = out.join(format!("training/calib/{id}.txt"));
            let calib = panoconv::kitti::Calib::read(&calib_path).unwrap();
            let (read, centre) = calib.output_camera(Cam::C2, writer.size()).unwrap();
            let truth = frames()
                .into_iter()
                .find(|f| f.id == *id)
                .unwrap()
                .calib
                .centre();
            assert!(
                (centre - truth).norm() < 1e-9,
                "{model} {id}: C2 {centre:?}"
            );
            // (a) Calib::output_camera projects like the writer, and refuses the same bearings.
            for d in sphere_bearings() {
                match (writer.project(&d), read.project(&d)) {
                    (Ok(a), Ok(b)) => worst_calib = worst_calib.max((a - b).norm()),
                    (Err(_), Err(_)) => {}
                    (a, b) => panic!("{model}: {d:?}: writer {a:?}, read back {b:?}"),
                }
            }
            // (b) The docs' Python function against panoconv's projection and its file.
            let labels: Vec<String> =
                label_lines(&read_text(&out.join(format!("training/label_2/{id}.txt"))))
                    .into_iter()
                    .filter(|l| !l.starts_with("DontCare"))
                    .map(str::to_owned)
                    .collect();
            let py = python_box_centres(&calib_path, &labels);
            let file: Vec<Vec<f64>> = read_text(&pixels.join(format!("{id}.txt")))
                .lines()
                .filter(|l| !l.starts_with('#'))
                .map(|l| tokens(l)[1..3].iter().map(|v| v.parse().unwrap()).collect())
                .collect();
            let mut in_file = file.iter();
            for (line, p) in labels.iter().zip(&py) {
                let label = parse_label(line);
                let lib =
                    panoconv::reproject::unproject::label_to_pixel(&label, read.as_ref(), &centre);
                match (p, lib) {
                    (Some((u, v)), Some(o)) => {
                        worst_py_lib = worst_py_lib.max((u - o.u).hypot(v - o.v));
                        let f = in_file.next().expect("labels-to-pixels wrote the object");
                        worst_py_file = worst_py_file.max((u - f[0]).abs().max((v - f[1]).abs()));
                        objects += 1;
                    }
                    (None, None) => {}
                    (p, o) => panic!("{model} {id}: {line}: python {p:?}, panoconv {o:?}"),
                }
            }
            assert!(
                in_file.next().is_none(),
                "{model} {id}: more objects in the file"
            );
        }
        report.push(format!(
            "{model}: read back {worst_calib:.1e} px, python vs panoconv {worst_py_lib:.1e} px, \
             vs labels-to-pixels {worst_py_file:.1e} px over {objects} objects"
        ));
        assert!(
            worst_calib <= 1e-9,
            "{model}: read back off by {worst_calib} px"
        );
        assert!(
            worst_py_lib <= 1e-6,
            "{model}: python off by {worst_py_lib} px"
        );
        // labels-to-pixels writes 4 decimals: half a unit of the last one.
        assert!(
            worst_py_file <= 5e-5 + 1e-6,
            "{model}: file off by {worst_py_file} px"
        );
        assert!(objects >= 5, "{model}: only {objects} objects compared");
        assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
    }
    eprintln!("{}", report.join("\n"));
}

// ---------------------------------------------------------------------------------------------
// 4. Crops, resizes, augmentation, pixel objects, depth, verify, determinism

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

#[test]
fn crop_and_resize_move_the_intrinsics_by_the_half_pixel_rule() {
    let dir = tempfile::tempdir().unwrap();
    let cam = kb_camera(dir.path());
    let out = dir.path().join("out");
    // A 600×240 window, enlarged 1.5 times.
    convert(
        &cam,
        synth_source(),
        &out,
        &[
            "--frames",
            "000000",
            "--mask",
            "--crop",
            "380,120,600,240",
            "--resize",
            "900x360",
        ],
    );
    let s = 1.5;
    let (cu, cv) = (679.5 - 380.0, 379.5 - 120.0);
    let want = [
        CENTRE_SCALE * s,
        CENTRE_SCALE * s,
        s * (cu + 0.5) - 0.5,
        s * (cv + 0.5) - 0.5,
    ];
    assert_k_close(
        "crop + resize",
        k2_of(&read_text(&out.join("training/calib/000000.txt"))),
        want,
    );
    // The image agrees with the scene rendered in that camera (blurred like the source,
    // whose blur the enlargement scales).
    let lens = fisheye_camera(&cam);
    let camera = FisheyeCamera {
        lens: lens
            .lens
            .with_intrinsics(
                panoconv::camera::Intrinsics::new(want[0], want[1], want[2], want[3]),
                panoconv::camera::ImageSize::new(900, 360),
            )
            .unwrap(),
        rect_from_camera: lens.rect_from_camera,
    };
    let warped = read_image(&out.join("training/image_2/000000.png"));
    let (mw, _, mask) = read_mask(&out.join("training/mask_2/000000.png"));
    let covered = |u: u32, v: u32| mask[(v * mw + u) as usize];
    let (scene, centre) = (&frames()[0].scene, SynthCalib::standard().centre());
    let exact = render_where(scene, &camera, &centre, 0.55 * s, 8, covered);
    let (db, n) = psnr(&warped, &exact, covered);
    eprintln!("crop + resize: {db:.2} dB over {n} px");
    assert!(n > 100_000, "only {n} covered pixels");
    assert!(db >= MIN_PSNR_DB, "crop + resize: {db:.2} dB");
    assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
}

#[test]
fn augmented_fisheye_views_keep_exact_intrinsics_and_boxes() {
    let dir = tempfile::tempdir().unwrap();
    let cam = kb_camera(dir.path());
    let out = dir.path().join("out");
    convert(
        &cam,
        synth_source(),
        &out,
        &[
            "--split",
            "training",
            "--augment",
            "2",
            "--seed",
            "7",
            "--scale-range",
            "0.6,0.9",
            "--crop-size",
            "640x320",
        ],
    );
    let manifest = read_manifest(&out);
    let mut views = 0;
    for frame in manifest["frames"].as_array().unwrap() {
        for view in frame["views"].as_array().expect("views in the manifest") {
            let id = view["id"].as_str().unwrap();
            let v = view;
            let (scale_w, scale_h) = (
                v["scaled"]["width"].as_f64().unwrap() / 1360.0,
                v["scaled"]["height"].as_f64().unwrap() / 560.0,
            );
            let (x, y) = (
                v["crop"]["x"].as_f64().unwrap(),
                v["crop"]["y"].as_f64().unwrap(),
            );
            let want = [
                CENTRE_SCALE * scale_w,
                CENTRE_SCALE * scale_h,
                scale_w * (679.5 + 0.5) - 0.5 - x,
                scale_h * (379.5 + 0.5) - 0.5 - y,
            ];
            let calib_path = out.join(format!("training/calib/{id}.txt"));
            assert_k_close(id, k2_of(&read_text(&calib_path)), want);
            let image = read_rgb8(&out.join(format!("training/image_2/{id}.png")));
            assert_eq!((image.width, image.height), (640, 320));
            let calib = panoconv::kitti::Calib::read(&calib_path).unwrap();
            let (camera, centre) = calib
                .output_camera(Cam::C2, panoconv::camera::ImageSize::new(640, 320))
                .unwrap();
            let written: Vec<String> =
                label_lines(&read_text(&out.join(format!("training/label_2/{id}.txt"))))
                    .into_iter()
                    .map(str::to_owned)
                    .collect();
            check_boxes(id, &written, camera.as_ref(), &centre);
            views += 1;
        }
    }
    assert_eq!(views, 6, "2 views of 3 frames");
    assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
}

#[test]
fn depth_pixel_objects_verify_and_jobs_on_a_fisheye_output() {
    let dir = tempfile::tempdir().unwrap();
    let cam = kb_camera(dir.path());
    let run = |jobs: &str| {
        let out = dir.path().join(format!("jobs{jobs}"));
        convert(
            &cam,
            synth_source(),
            &out,
            &["--split", "training", "--depth", "--mask", "--jobs", jobs],
        );
        out
    };
    let out = run("1");
    let out2 = run("2");
    assert_eq!(
        tree_hashes(&out),
        tree_hashes(&out2),
        "--jobs 1 and --jobs 2 differ"
    );

    // Depth: the range along the pixel's ray to the surface the scene shows there.
    let (mut pixels, mut correct) = (0usize, 0usize);
    for f in frames().iter().filter(|f| f.split == "training") {
        let id = f.id;
        let calib =
            panoconv::kitti::Calib::read(&out.join(format!("training/calib/{id}.txt"))).unwrap();
        let (camera, centre) = calib
            .output_camera(Cam::C2, panoconv::camera::ImageSize::new(1360, 560))
            .unwrap();
        let png = read_png(&out.join(format!("training/depth_2/{id}.png")));
        assert_eq!(png.depth, png::BitDepth::Sixteen);
        for v in 0..png.height {
            for u in 0..png.width {
                let i = 2 * (v * png.width + u) as usize;
                let raw = u16::from_be_bytes([png.data[i], png.data[i + 1]]);
                if raw == 0 {
                    continue;
                }
                pixels += 1;
                let d = raw as f64 / 256.0;
                let ray = camera.unproject(&Point2::new(u as f64, v as f64)).unwrap();
                if let Some((t, _)) = f.scene.first_hit(&centre, &ray) {
                    if (d - t).abs() <= 0.05 * t {
                        correct += 1;
                    }
                }
            }
        }
    }
    let share = correct as f64 / pixels as f64;
    eprintln!(
        "depth: {pixels} px, {:.2} % within 5 % of the range along the ray",
        100.0 * share
    );
    assert!(pixels > 5000, "only {pixels} depth pixels");
    assert!(share >= 0.995, "{:.3} % correct", 100.0 * share);

    // labels → pixel objects → unproject returns the locations.
    let pixels_dir = out.join("training/pixels");
    assert_success(&panoconv([
        "labels-to-pixels".as_ref(),
        "--input".as_ref(),
        out.as_os_str(),
        "--output".as_ref(),
        pixels_dir.as_os_str(),
    ]));
    let results = out.join("training/results");
    assert_success(&panoconv([
        "unproject".as_ref(),
        "--calib".as_ref(),
        out.join("training/calib").as_os_str(),
        "--input".as_ref(),
        pixels_dir.as_os_str(),
        "--output".as_ref(),
        results.as_os_str(),
    ]));
    let (mut worst, mut n) = (0.0f64, 0);
    for (_, id) in SYNTH_FRAMES.iter().filter(|(s, _)| *s == "training") {
        let labels = read_text(&out.join(format!("training/label_2/{id}.txt")));
        let back = read_text(&results.join(format!("{id}.txt")));
        let want: Vec<Vec<f64>> = label_lines(&labels)
            .iter()
            .filter(|l| !l.starts_with("DontCare"))
            .map(|l| {
                tokens(l)[11..14]
                    .iter()
                    .map(|v| v.parse().unwrap())
                    .collect()
            })
            .collect();
        let got: Vec<Vec<f64>> = label_lines(&back)
            .iter()
            .map(|l| {
                tokens(l)[11..14]
                    .iter()
                    .map(|v| v.parse().unwrap())
                    .collect()
            })
            .collect();
        assert_eq!(want.len(), got.len(), "{id}: objects");
        for (a, b) in want.iter().zip(&got) {
            let e = (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt();
            worst = worst.max(e);
            n += 1;
        }
    }
    eprintln!("unproject: {n} objects, worst location error {worst:.2e} m");
    assert!(n >= 8 && worst <= 1e-3, "{n} objects, worst {worst} m");
    assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
}

// ---------------------------------------------------------------------------------------------
// 5. Set-up errors, and a native calibration file as the camera

#[test]
fn fisheye_set_up_errors_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let cam = kb_camera(dir.path());
    let cam = cam.to_str().unwrap();
    let cases: [(&str, Vec<&str>, &str); 5] = [
        ("fisheye", vec![], "--camera"),
        ("equirect", vec!["--camera", cam], "--camera"),
        (
            "fisheye",
            vec!["--camera", cam, "--pano-width", "2048"],
            "--pano-width",
        ),
        (
            "fisheye",
            vec!["--camera", cam, "--size", "800x400"],
            "--size",
        ),
        (
            "fisheye",
            vec!["--camera", cam, "--px-per-deg", "9"],
            "--px-per-deg",
        ),
    ];
    for (i, (to, extra, names)) in cases.iter().enumerate() {
        let out = dir.path().join(format!("out{i}"));
        let run = kitti(to, synth_source(), &out, extra);
        assert_eq!(
            run.code, 2,
            "{to} {extra:?}: exit {}: {}",
            run.code, run.stderr
        );
        assert!(run.stderr.contains(names), "{to} {extra:?}: {}", run.stderr);
        assert!(!out.exists(), "{to} {extra:?}: wrote {}", out.display());
    }
}

#[test]
#[allow(clippy::excessive_precision)] // the published digits
fn a_kitti_360_yaml_is_a_fisheye_target() {
    let dir = tempfile::tempdir().unwrap();
    // KITTI-360's calibration/image_02.yaml, as published.
    let yaml = "%YAML:1.0\n---\nmodel_type: MEI\ncamera_name: image_02\nimage_width: 1400\n\
        image_height: 1400\nmirror_parameters:\n   xi: 2.2134047507854890e+00\n\
        distortion_parameters:\n   k1: 1.6798235660113681e-02\n   k2: 1.6548773243373522e+00\n\
        \x20  p1: 4.2223943394772046e-04\n   p2: 4.2462134260997584e-04\n\
        projection_parameters:\n   gamma1: 1.3363220825849971e+03\n\
        \x20  gamma2: 1.3357883350012958e+03\n   u0: 7.1694323510126321e+02\n\
        \x20  v0: 7.0576498308221585e+02\n";
    let cam = write_camera(dir.path(), "image_02.yaml", yaml);
    let out = dir.path().join("out");
    // Half size, so that the test stays quick (intrinsics by the half-pixel rule).
    convert(
        &cam,
        synth_source(),
        &out,
        &["--frames", "000000", "--resize", "700x700"],
    );
    let calib = read_text(&out.join("training/calib/000000.txt"));
    assert!(calib.contains("\nmodel2: mei\n"), "{calib}");
    let d = calib_values(&calib, "D2").unwrap();
    let want = [
        2.2134047507854890,
        1.6798235660113681e-02,
        1.6548773243373522,
        4.2223943394772046e-04,
        4.2462134260997584e-04,
        0.0,
    ];
    for (a, b) in d.iter().zip(want) {
        assert!((a - b).abs() <= 1e-12 * b.abs().max(1e-3), "D2 {d:?}");
    }
    assert_k_close(
        "KITTI-360 at half size",
        k2_of(&calib),
        [
            0.5 * 1.3363220825849971e+03,
            0.5 * 1.3357883350012958e+03,
            0.5 * (7.1694323510126321e+02 + 0.5) - 0.5,
            0.5 * (7.0576498308221585e+02 + 0.5) - 0.5,
        ],
    );
    let image = read_rgb8(&out.join("training/image_2/000000.png"));
    assert_eq!((image.width, image.height), (700, 700));
    // The source's view lies in the middle of the fisheye: some pixels there are not black.
    let lit = image
        .data
        .chunks(3)
        .filter(|p| p.iter().any(|&c| c > 0))
        .count();
    assert!(lit > 20_000, "only {lit} pixels with data");
    assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
}

#[test]
fn camera_3_sits_at_its_own_centre() {
    let dir = tempfile::tempdir().unwrap();
    let cam = kb_camera(dir.path());
    let out = dir.path().join("out");
    convert(
        &cam,
        synth_source(),
        &out,
        &["--frames", "000000", "--cameras", "2,3", "--mask"],
    );
    let calib_path = out.join("training/calib/000000.txt");
    let text = read_text(&calib_path);
    for key in ["model3", "D3", "fov3", "R3", "C3", "K3"] {
        assert!(
            text.contains(&format!("\n{key}: ")),
            "no {key} line:\n{text}"
        );
    }
    let calib = panoconv::kitti::Calib::read(&calib_path).unwrap();
    let (camera, centre) = calib
        .output_camera(Cam::C3, panoconv::camera::ImageSize::new(1360, 560))
        .unwrap();
    let truth = SynthCalib::standard().centre3();
    assert!(
        (centre - truth).norm() < 1e-9,
        "C3 {centre:?}, truth {truth:?}"
    );
    // The right image against the scene rendered from camera 3's centre.
    let warped = read_image(&out.join("training/image_3/000000.png"));
    let (mw, _, mask) = read_mask(&out.join("training/mask_3/000000.png"));
    let covered = |u: u32, v: u32| mask[(v * mw + u) as usize];
    let scene = &frames()[0].scene;
    let exact = render_where(scene, camera.as_ref(), &truth, 0.55, 6, covered);
    let (db, n) = psnr(&warped, &exact, covered);
    eprintln!("camera 3: {db:.2} dB over {n} px");
    assert!(
        n > 200_000 && db >= MIN_PSNR_DB,
        "camera 3: {db:.2} dB over {n} px"
    );
    assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
}
