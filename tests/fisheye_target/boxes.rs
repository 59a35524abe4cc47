//! Written 2D boxes against the dense exact projection of the 3D boxes, all around a 190°
//! fisheye and on the sample converted to a turned one.

use super::*;
use nalgebra::{Point2, Vector3};
use panoconv::camera::CameraModel;
use panoconv::kitti::Cam;
use panoconv::tools::synth::{frames, SynthCalib};

/// The bar for a written box against the dense exact projection.
const MIN_BOX_IOU: f64 = 0.99;

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

pub(super) fn parse_label(line: &str) -> panoconv::kitti::Label {
    panoconv::kitti::Label::parse(Path::new("label.txt"), 1, line).unwrap()
}

/// The worst IoU of the written boxes of `labels` against the dense projection; every object
/// the dense projection puts on the image must have a box and every box a dense projection.
#[track_caller]
pub(super) fn check_boxes(
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
