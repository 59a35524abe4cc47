//! Omni3D: the 3D boxes projected with K (perspective) and through the written calib (equirect).

use super::*;
use crate::common::*;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

/// Omni3D's corner order (DATA.md, `get_cuboid_verts_faces`) as multiples of (l, h, w).
const OMNI3D_UNIT_CUBE: [[f64; 3]; 8] = [
    [-0.5, -0.5, -0.5],
    [0.5, -0.5, -0.5],
    [0.5, 0.5, -0.5],
    [-0.5, 0.5, -0.5],
    [-0.5, -0.5, 0.5],
    [0.5, -0.5, 0.5],
    [0.5, 0.5, 0.5],
    [-0.5, 0.5, 0.5],
];

/// Annotations of an Omni3D file grouped by image id, in file order.
fn omni3d_by_image(file: &Value) -> BTreeMap<u64, Vec<&Value>> {
    let mut by_image: BTreeMap<u64, Vec<&Value>> = BTreeMap::new();
    for a in file["annotations"].as_array().unwrap() {
        by_image
            .entry(a["image_id"].as_u64().unwrap())
            .or_default()
            .push(a);
    }
    by_image
}

#[test]
fn omni3d_perspective_3d_boxes_project_with_k_onto_bbox2d_proj() {
    let (_dir, persp) = convert(
        &real_kitti(),
        "perspective",
        &["--split", "training", "--px-per-deg", "11"],
    );
    let tmp = tempfile::tempdir().unwrap();
    assert_success(&export(
        &persp,
        "omni3d",
        tmp.path(),
        &["--path-prefix", "kitti_persp/"],
    ));
    let file = read_json(&tmp.path().join("Omni3D_train.json"));
    // Cube R-CNN's loader is pycocotools' COCO class: it must index the file.
    let (anns, imgs) = (
        file["annotations"].as_array().unwrap().len(),
        file["images"].as_array().unwrap().len(),
    );
    let indexed = pycocotools_counts(&tmp.path().join("Omni3D_train.json"));
    assert_eq!(
        indexed,
        (anns, imgs),
        "pycocotools indexes every object and image"
    );
    let by_image = omni3d_by_image(&file);
    let (mut checked, mut max_proj, mut max_corner, mut max_tight) = (0, 0.0f64, 0.0f64, 0.0f64);
    for image in file["images"].as_array().unwrap() {
        assert_eq!(image["projection"], "perspective");
        let path = image["file_path"].as_str().unwrap();
        let path = path
            .strip_prefix("kitti_persp/")
            .expect("--path-prefix is applied");
        assert!(persp.join(path).is_file(), "{path}");
        let stem = Path::new(path).file_stem().unwrap().to_str().unwrap();
        let calib = read_text(&persp.join(format!("training/calib/{stem}.txt")));
        let k: Vec<f64> = image["K"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(floats)
            .collect();
        assert_eq!(
            k,
            calib_values(&calib, "K2").unwrap(),
            "K is the written K2"
        );
        let labels = read_text(&persp.join(format!("training/label_2/{stem}.txt")));
        let objects: Vec<Vec<&str>> = label_lines(&labels)
            .into_iter()
            .map(tokens)
            .filter(|t| t[0] != "DontCare")
            .collect();
        let anns = &by_image[&image["id"].as_u64().unwrap()];
        assert_eq!(anns.len(), objects.len());
        for (a, t) in anns.iter().zip(&objects) {
            assert_eq!(a["category_name"], t[0]);
            assert_eq!(floats(&a["bbox2D_tight"]), bbox_of(t).to_vec());
            let dims = floats(&a["dimensions"]);
            let kitti_hwl: Vec<f64> = t[8..11].iter().map(|v| v.parse().unwrap()).collect();
            assert_eq!(
                dims,
                vec![kitti_hwl[1], kitti_hwl[0], kitti_hwl[2]],
                "w, h, l"
            );
            // The corners follow from centre, dimensions and R_cam in Omni3D's order.
            let c = floats(&a["center_cam"]);
            let r: Vec<Vec<f64>> = a["R_cam"].as_array().unwrap().iter().map(floats).collect();
            let corners: Vec<Vec<f64>> = a["bbox3D_cam"]
                .as_array()
                .unwrap()
                .iter()
                .map(floats)
                .collect();
            for (unit, corner) in OMNI3D_UNIT_CUBE.iter().zip(&corners) {
                let v = [unit[0] * dims[2], unit[1] * dims[1], unit[2] * dims[0]];
                for i in 0..3 {
                    let want = r[i][0] * v[0] + r[i][1] * v[1] + r[i][2] * v[2] + c[i];
                    max_corner = max_corner.max((corner[i] - want).abs());
                }
            }
            if a["behind_camera"] == true {
                continue;
            }
            // An object wholly in the image: label_2's box is the same projection, to 0.01 px.
            if t[1] == "0.00" {
                for (p, q) in floats(&a["bbox2D_proj"]).iter().zip(bbox_of(t)) {
                    max_tight = max_tight.max((p - q).abs());
                }
            }
            let px: Vec<(f64, f64)> = corners
                .iter()
                .map(|p| {
                    (
                        (k[0] * p[0] + k[2] * p[2]) / p[2],
                        (k[4] * p[1] + k[5] * p[2]) / p[2],
                    )
                })
                .collect();
            let bounds = [
                px.iter().map(|p| p.0).fold(f64::MAX, f64::min),
                px.iter().map(|p| p.1).fold(f64::MAX, f64::min),
                px.iter().map(|p| p.0).fold(f64::MIN, f64::max),
                px.iter().map(|p| p.1).fold(f64::MIN, f64::max),
            ];
            for (got, want) in floats(&a["bbox2D_proj"]).iter().zip(bounds) {
                max_proj = max_proj.max((got - want).abs());
            }
            checked += 1;
        }
    }
    eprintln!(
        "omni3d perspective: {checked} boxes, bbox2D_proj max |difference| {max_proj:.2e} px (to label_2 {max_tight:.2e} px), corners {max_corner:.2e} m"
    );
    assert!(checked >= 8);
    assert!(max_proj <= 0.01, "bbox2D_proj off by {max_proj} px");
    assert!(
        max_tight <= 0.0051,
        "bbox2D_proj is {max_tight} px from label_2's box"
    );
    assert!(
        max_corner <= 1e-5,
        "bbox3D_cam is not Omni3D's corner order ({max_corner} m)"
    );
}

#[test]
fn omni3d_equirect_centres_project_to_the_labels_to_pixels_pixel() {
    let (dir, equi) = convert(&real_kitti(), "equirect", &["--split", "training"]);
    let pixels = dir.path().join("pixels");
    let run = panoconv([
        "labels-to-pixels",
        "--input",
        equi.to_str().unwrap(),
        "--output",
        pixels.to_str().unwrap(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let tmp = tempfile::tempdir().unwrap();
    assert_success(&export(&equi, "omni3d", tmp.path(), &[]));
    let file = read_json(&tmp.path().join("Omni3D_train.json"));
    let by_image = omni3d_by_image(&file);
    let (mut checked, mut max_diff) = (0, 0.0f64);
    for image in file["images"].as_array().unwrap() {
        assert_eq!(image["projection"], "equirect");
        let stem = Path::new(image["file_path"].as_str().unwrap())
            .file_stem()
            .unwrap()
            .to_str()
            .unwrap()
            .to_owned();
        let calib = read_text(&equi.join(format!("training/calib/{stem}.txt")));
        assert!(calib.contains("projection: equirect"));
        let k2 = calib_values(&calib, "K2").unwrap();
        let targets: Vec<Vec<String>> = read_text(&pixels.join(format!("{stem}.txt")))
            .lines()
            .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
            .map(|l| l.split_whitespace().map(str::to_owned).collect())
            .collect();
        let anns: Vec<&&Value> = by_image[&image["id"].as_u64().unwrap()]
            .iter()
            .filter(|a| a["valid3D"] == true)
            .collect();
        assert_eq!(anns.len(), targets.len(), "{stem}");
        for (a, t) in anns.iter().zip(&targets) {
            assert_eq!(a["category_name"], t[0].as_str());
            let p = floats(&a["center_cam"]);
            let range = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            // equirect: (a, b) = (atan2(x, z), asin(y / |p|)), pixel = K2 · (a, b, 1)
            let (ea, eb) = (p[0].atan2(p[2]), (p[1] / range).asin());
            let u = k2[0] * ea + k2[1] * eb + k2[2];
            let v = k2[4] * eb + k2[5];
            let (tu, tv): (f64, f64) = (t[1].parse().unwrap(), t[2].parse().unwrap());
            max_diff = max_diff.max((u - tu).abs()).max((v - tv).abs());
            checked += 1;
        }
    }
    eprintln!("omni3d equirect: {checked} centres, max |difference| to labels-to-pixels {max_diff:.2e} px");
    assert!(checked >= 8);
    assert!(
        max_diff <= 1e-3,
        "center_cam lands {max_diff} px from labels-to-pixels"
    );
}

/// The pixel of a bearing `p` (camera axes) through the lens an Omni3D image entry names, by
/// the models' own formulas (docs/fisheye.md); None beyond half the field of view.
fn lens_pixel(image: &Value, p: [f64; 3]) -> Option<(f64, f64)> {
    let k: Vec<f64> = image["K"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(floats)
        .collect();
    let d = floats(&image["D"]);
    let [x, y, z] = p;
    let r = x.hypot(y);
    let theta = r.atan2(z);
    if theta > f(&image["fov"]).to_radians() / 2.0 {
        return None;
    }
    let (a, b) = match image["model"].as_str().unwrap() {
        "kannala_brandt" => {
            let t2 = theta * theta;
            let td = theta * (1.0 + t2 * (d[0] + t2 * (d[1] + t2 * (d[2] + t2 * d[3]))));
            (td * x / r, td * y / r)
        }
        "eucm" => {
            let (alpha, beta) = (d[0], d[1]);
            let den = alpha * (beta * (x * x + y * y) + z * z).sqrt() + (1.0 - alpha) * z;
            (x / den, y / den)
        }
        m => panic!("no formula for {m} here"),
    };
    Some((k[0] * a + k[1] * b + k[2], k[4] * b + k[5]))
}

/// Omni3D's 12 box edges as corner pairs (v0..v3 one face, v4..v7 the other).
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

/// A lens turned 10° nose down (and 0.5° roll): Omni3D's 3D values are in the lens's own axes,
/// so its edges, sampled and projected through the image entry's lens alone (no R2), bound
/// `bbox2D_proj` to 0.01 px. Kannala-Brandt 190° and EUCM with α = 0 (a pinhole: K alone).
#[test]
fn omni3d_turned_lens_boxes_project_in_the_cameras_own_axes() {
    let dir = tempfile::tempdir().unwrap();
    let pinhole = dir.path().join("pinhole.json");
    std::fs::write(
        &pinhole,
        r#"{"version": 1, "model": "eucm", "width": 1280, "height": 966, "max_fov_deg": 120,
            "fx": 500, "fy": 500, "cx": 639.5, "cy": 482.5, "alpha": 0, "beta": 1,
            "rotation": {"yaw_deg": 0, "pitch_deg": -10, "roll_deg": 0.5}}"#,
    )
    .unwrap();
    let front = repo().join("fixtures/cameras/front.json");
    for (n, camera) in [front.as_path(), pinhole.as_path()].into_iter().enumerate() {
        let cam = camera.to_str().unwrap();
        let (_out_dir, out) = convert(&synthetic_dir(), "fisheye", &["--camera", cam]);
        let ann = dir.path().join(format!("ann{n}"));
        assert_success(&export(&out, "omni3d", &ann, &[]));
        let file = read_json(&ann.join("Omni3D_train.json"));
        let images: BTreeMap<u64, &Value> = file["images"]
            .as_array()
            .unwrap()
            .iter()
            .map(|i| (i["id"].as_u64().unwrap(), i))
            .collect();
        for image in images.values() {
            let stem = Path::new(image["file_path"].as_str().unwrap())
                .file_stem()
                .unwrap()
                .to_str()
                .unwrap()
                .to_owned();
            let calib = read_text(&out.join(format!("training/calib/{stem}.txt")));
            let r: Vec<f64> = image["R"]
                .as_array()
                .unwrap()
                .iter()
                .flat_map(floats)
                .collect();
            assert_eq!(
                r,
                calib_values(&calib, "R2").unwrap(),
                "R is the calib's R2"
            );
            assert_eq!(floats(&image["D"]), calib_values(&calib, "D2").unwrap());
        }
        let (mut checked, mut worst) = (0, 0.0f64);
        for a in file["annotations"].as_array().unwrap() {
            if a["valid3D"] != true || a["behind_camera"] == true {
                continue;
            }
            let image = images[&a["image_id"].as_u64().unwrap()];
            let c: Vec<Vec<f64>> = a["bbox3D_cam"]
                .as_array()
                .unwrap()
                .iter()
                .map(floats)
                .collect();
            let mut px = Vec::new();
            for (i, j) in EDGES {
                for s in 0..=4000 {
                    let t = s as f64 / 4000.0;
                    let p = [0, 1, 2].map(|k| c[i][k] + t * (c[j][k] - c[i][k]));
                    px.push(lens_pixel(image, p));
                }
            }
            // A box partly beyond the field of view is bounded by the clipped edges: skipped.
            let Some(px) = px.into_iter().collect::<Option<Vec<_>>>() else {
                continue;
            };
            let bounds = [
                px.iter().map(|p| p.0).fold(f64::MAX, f64::min),
                px.iter().map(|p| p.1).fold(f64::MAX, f64::min),
                px.iter().map(|p| p.0).fold(f64::MIN, f64::max),
                px.iter().map(|p| p.1).fold(f64::MIN, f64::max),
            ];
            for (got, want) in floats(&a["bbox2D_proj"]).iter().zip(bounds) {
                worst = worst.max((got - want).abs());
            }
            checked += 1;
        }
        eprintln!(
            "omni3d {}: {checked} boxes, bbox2D_proj max |difference| {worst:.2e} px",
            camera.file_name().unwrap().to_string_lossy()
        );
        assert!(checked >= 3, "too few boxes checked ({checked})");
        assert!(worst <= 0.01, "{cam}: bbox2D_proj off by {worst} px");
    }
}
