//! `panoconv export` through the binary: COCO checked by pycocotools (COCOeval of the ground
//! truth against itself), YOLO read back by an independent reader and compared with the COCO
//! boxes, Omni3D's 3D boxes projected with K (perspective) and through the written calib
//! (equirect, against `labels-to-pixels`), the ±180° seam, determinism, and bad input.

mod common;

use common::*;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn synthetic_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/data/synthetic_kitti"))
}

/// The Python with pycocotools: $PANOCONV_TEST_PYTHON, else the repository's .venv-test.
fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("PANOCONV_TEST_PYTHON") {
        return PathBuf::from(p);
    }
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv-test/bin/python");
    assert!(
        venv.is_file(),
        "no Python with pycocotools: set PANOCONV_TEST_PYTHON or run scripts/install_test_python.sh"
    );
    venv
}

/// `panoconv kitti --to TO` of the training split (and testing when `all_splits`) into DIR/out.
fn convert(input: &Path, to: &str, extra: &[&str]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut args = vec!["--quiet"];
    args.extend_from_slice(extra);
    assert_success(&kitti(to, input, &out, &args));
    (dir, out)
}

fn export(dataset: &Path, format: &str, output: &Path, extra: &[&str]) -> Run {
    let mut args: Vec<String> = vec![
        "export".into(),
        dataset.to_string_lossy().into_owned(),
        "--format".into(),
        format.into(),
        "--output".into(),
        output.to_string_lossy().into_owned(),
        "--quiet".into(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    panoconv(args)
}

fn read_json(path: &Path) -> Value {
    serde_json::from_str(&read_text(path)).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("{v} is not a number"))
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(f).collect()
}

/// Non-crowd COCO annotations of an image, in file order.
fn objects_of(coco: &Value, image_id: u64) -> Vec<&Value> {
    coco["annotations"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|a| a["image_id"].as_u64() == Some(image_id) && a["iscrowd"] == 0)
        .collect()
}

/// Entries whose name starts with '.' (temporary files) anywhere under `dir`.
fn hidden_entries(dir: &Path) -> Vec<String> {
    tree_hashes(dir)
        .into_keys()
        .filter(|k| k.split('/').any(|part| part.starts_with('.')))
        .collect()
}

/// Runs the pycocotools script on a COCO file; its key=value figures.
fn coco_eval(instances: &Path, root: &Path) -> BTreeMap<String, f64> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/export_coco_eval.py");
    let out = Command::new(python())
        .arg(&script)
        .arg(instances)
        .arg(root)
        .output()
        .expect("cannot run the test python");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "pycocotools check failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line = stdout.lines().last().expect("one line of figures");
    eprintln!("{}: {line}", instances.display());
    line.split_whitespace()
        .map(|kv| {
            let (k, v) = kv.split_once('=').unwrap();
            (k.to_owned(), v.parse::<f64>().unwrap())
        })
        .collect()
}

#[test]
fn pycocotools_reads_the_coco_export_and_self_evaluation_gives_ap_1() {
    let (_real_equi_dir, real_equi) = convert(&kitti_dir(), "equirect", &["--split", "training"]);
    let (_synth_dir, synth_persp) =
        convert(&synthetic_dir(), "perspective", &["--split", "training"]);
    // A plain KITTI root is read as it is: P2 is a perspective camera.
    for (dataset, images) in [(kitti_dir(), 6.0), (real_equi, 6.0), (synth_persp, 3.0)] {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("annotations");
        assert_success(&export(&dataset, "coco", &out, &[]));
        let figures = coco_eval(&out.join("instances_train.json"), &dataset);
        assert_eq!(figures["images"], images);
        assert_eq!(
            figures["missing_images"], 0.0,
            "file_name must exist under the root"
        );
        assert!(figures["objects"] >= 3.0);
        assert_eq!(
            figures["ap_self"], 1.0,
            "ground truth as detections: AP 1.000"
        );
        assert_eq!(
            figures["ap_with_ignore_detections"], 1.0,
            "DontCare must be ignored"
        );
        assert!(
            figures["ap_shifted"] < 0.8,
            "a shifted copy must score less"
        );
        assert_eq!(figures["ap50_shifted"], 1.0, "IoU 0.6 still matches at 0.5");
    }
    let tmp = tempfile::tempdir().unwrap();
    assert_success(&export(&kitti_dir(), "coco", tmp.path(), &[]));
    let real = read_json(&tmp.path().join("instances_train.json"));
    // The real frames hold DontCare regions: one crowd annotation per category each.
    let crowd = real["annotations"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|a| a["iscrowd"] == 1)
        .count();
    let dont_care: usize = (0..6)
        .map(|i| {
            read_text(&kitti_dir().join(format!("training/label_2/00000{i}.txt")))
                .lines()
                .filter(|l| l.starts_with("DontCare"))
                .count()
        })
        .sum();
    assert!(dont_care > 0);
    assert_eq!(crowd, dont_care * 8);
    assert_eq!(real["images"][0]["camera"]["projection"], "perspective");
}

/// An independent reader of the Ultralytics layout: data.yaml, labels/<split>/*.txt and the
/// image links, checked against the COCO export of the same dataset.
#[test]
fn yolo_labels_match_the_coco_boxes() {
    let (_dir, equi) = convert(&kitti_dir(), "equirect", &["--split", "training"]);
    let (_dir2, synth) = convert(&synthetic_dir(), "cylindrical", &[]);
    let mut max_diff = 0.0f64;
    let mut boxes = 0;
    for dataset in [equi, synth] {
        let tmp = tempfile::tempdir().unwrap();
        let (coco_dir, yolo) = (tmp.path().join("coco"), tmp.path().join("yolo"));
        assert_success(&export(&dataset, "coco", &coco_dir, &[]));
        assert_success(&export(&dataset, "yolo", &yolo, &[]));
        let coco = read_json(&coco_dir.join("instances_train.json"));

        let yaml = read_text(&yolo.join("data.yaml"));
        let value = |key: &str| {
            yaml.lines()
                .find_map(|l| l.strip_prefix(&format!("{key}: ")))
                .unwrap_or_else(|| panic!("data.yaml has no {key}:\n{yaml}"))
                .trim_matches('"')
                .to_owned()
        };
        assert_eq!(
            Path::new(&value("path")),
            yolo.canonicalize().unwrap(),
            "path must be the export folder, absolute"
        );
        assert_eq!(value("train"), "images/train");
        assert_eq!(
            value("val"),
            "images/train",
            "no val split: train stands in"
        );
        let names: Vec<String> = yaml
            .lines()
            .skip_while(|l| *l != "names:")
            .skip(1)
            .enumerate()
            .map(|(k, l)| {
                let (i, n) = l.trim().split_once(": ").unwrap();
                assert_eq!(i.parse::<usize>().unwrap(), k, "names are numbered from 0");
                n.trim_matches('"').to_owned()
            })
            .collect();
        let categories: Vec<&str> = coco["categories"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c["name"].as_str().unwrap())
            .collect();
        assert_eq!(names, categories);

        for image in coco["images"].as_array().unwrap() {
            let file_name = image["file_name"].as_str().unwrap();
            let stem = Path::new(file_name).file_stem().unwrap().to_str().unwrap();
            let link = yolo.join(format!("images/train/{stem}.png"));
            assert!(std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink());
            assert_eq!(hash_file(&link), hash_file(&dataset.join(file_name)));
            let (w, h) = (f(&image["width"]), f(&image["height"]));
            let text = read_text(&yolo.join(format!("labels/train/{stem}.txt")));
            let lines: Vec<Vec<f64>> = text
                .lines()
                .map(|l| l.split_whitespace().map(|t| t.parse().unwrap()).collect())
                .collect();
            let anns = objects_of(&coco, image["id"].as_u64().unwrap());
            assert_eq!(lines.len(), anns.len(), "{stem}: one line per COCO object");
            for (line, ann) in lines.iter().zip(anns) {
                assert_eq!(line.len(), 5);
                assert_eq!(
                    line[0],
                    f(&ann["category_id"]) - 1.0,
                    "classes count from 0"
                );
                let b = floats(&ann["bbox"]);
                let expected = [
                    (b[0] + b[2] / 2.0) / w,
                    (b[1] + b[3] / 2.0) / h,
                    b[2] / w,
                    b[3] / h,
                ];
                for (got, want) in line[1..].iter().zip(expected) {
                    max_diff = max_diff.max((got - want).abs());
                }
                boxes += 1;
            }
        }
    }
    eprintln!("yolo vs coco: {boxes} boxes, max |difference| {max_diff:.2e}");
    assert!(boxes >= 10);
    assert!(max_diff <= 1e-6, "YOLO differs from COCO by {max_diff}");
}

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
        &kitti_dir(),
        "perspective",
        &["--split", "training", "--px-per-deg", "11"],
    );
    let tmp = tempfile::tempdir().unwrap();
    assert_success(&export(&persp, "omni3d", tmp.path(), &["--path-prefix", "kitti_persp/"]));
    let file = read_json(&tmp.path().join("Omni3D_train.json"));
    let by_image = omni3d_by_image(&file);
    let (mut checked, mut max_proj, mut max_corner) = (0, 0.0f64, 0.0f64);
    for image in file["images"].as_array().unwrap() {
        assert_eq!(image["projection"], "perspective");
        let path = image["file_path"].as_str().unwrap();
        let path = path.strip_prefix("kitti_persp/").expect("--path-prefix is applied");
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
        "omni3d perspective: {checked} boxes, bbox2D_proj max |difference| {max_proj:.2e} px, corners {max_corner:.2e} m"
    );
    assert!(checked >= 8);
    assert!(max_proj <= 0.01, "bbox2D_proj off by {max_proj} px");
    assert!(
        max_corner <= 1e-5,
        "bbox3D_cam is not Omni3D's corner order ({max_corner} m)"
    );
}

#[test]
fn omni3d_equirect_centres_project_to_the_labels_to_pixels_pixel() {
    let (dir, equi) = convert(&kitti_dir(), "equirect", &["--split", "training"]);
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

/// A car straight behind the camera in a 360° panorama: label_2 keeps the part on one side of
/// the ±180° seam, COCO gets both parts.
#[test]
fn an_object_across_the_seam_becomes_two_coco_boxes() {
    let s = Scratch::synth();
    let label = s.input_file("training/label_2/000000.txt");
    let mut text = read_text(&label);
    text.push_str("Car 0.00 0 0.00 0.00 0.00 10.00 10.00 1.50 1.60 4.00 0.30 1.65 -8.00 0.00\n");
    write_text(&label, &text);
    assert_success(&kitti(
        "equirect",
        &s.input,
        &s.output,
        &["--full-360", "--frames", "000000", "--quiet"],
    ));
    let coco_dir = s.path("coco");
    assert_success(&export(&s.output, "coco", &coco_dir, &[]));
    let coco = read_json(&coco_dir.join("instances_train.json"));
    let image = &coco["images"][0];
    let width = f(&image["width"]);
    let parts: Vec<&Value> = objects_of(&coco, 0)
        .into_iter()
        .filter(|a| a["wraps_seam"] == true)
        .collect();
    assert_eq!(parts.len(), 2, "the car behind the camera is two boxes");

    // Independently: the azimuths of the 8 corners, seen from C2, unwrapped about 180°.
    let calib = read_text(&s.output_file("training/calib/000000.txt"));
    let (k2, c2) = (
        calib_values(&calib, "K2").unwrap(),
        calib_values(&calib, "C2").unwrap(),
    );
    let (h, w, l, x, y, z) = (1.5, 1.6, 4.0, 0.3, 1.65, -8.0);
    let mut azimuths = Vec::new();
    for (dx, dz) in [
        (l / 2.0, w / 2.0),
        (l / 2.0, -w / 2.0),
        (-l / 2.0, w / 2.0),
        (-l / 2.0, -w / 2.0),
    ] {
        for dy in [0.0, -h] {
            let p = [x + dx - c2[0], y + dy - c2[1], z + dz - c2[2]];
            azimuths.push(p[0].atan2(p[2]).rem_euclid(2.0 * std::f64::consts::PI));
        }
    }
    let (a_min, a_max) = (
        azimuths.iter().cloned().fold(f64::MAX, f64::min),
        azimuths.iter().cloned().fold(f64::MIN, f64::max),
    );
    assert!(a_min < std::f64::consts::PI && a_max > std::f64::consts::PI);
    let u = |a: f64| k2[0] * a + k2[2];
    let right_part = [u(a_min), width - 1.0];
    let left_part = [0.0, u(a_max - 2.0 * std::f64::consts::PI)];
    let mut got: Vec<[f64; 2]> = parts
        .iter()
        .map(|a| {
            let b = floats(&a["bbox"]);
            [b[0] - 0.5, b[0] + b[2] - 0.5] // COCO's pixel convention back to KITTI's
        })
        .collect();
    got.sort_by(|a, b| a[0].total_cmp(&b[0]));
    for (g, want) in got.iter().zip([left_part, right_part]) {
        assert!(
            (g[0] - want[0]).abs() <= 0.02 && (g[1] - want[1]).abs() <= 0.02,
            "seam parts {got:?}, expected {left_part:?} and {right_part:?}"
        );
    }
    // label_2 holds one of the two parts.
    let written = read_text(&s.output_file("training/label_2/000000.txt"));
    let last = bbox_of(&tokens(label_lines(&written).last().unwrap()));
    assert!(got
        .iter()
        .any(|g| (g[0] - last[0]).abs() < 1e-9 && (g[1] - last[2]).abs() < 1e-9));
}

#[test]
fn exports_are_byte_identical_run_to_run() {
    let (dir, equi) = convert(&synthetic_dir(), "equirect", &[]);
    for format in ["coco", "omni3d"] {
        let (a, b) = (
            dir.path().join(format!("{format}_a")),
            dir.path().join(format!("{format}_b")),
        );
        assert_success(&export(&equi, format, &a, &[]));
        assert_success(&export(&equi, format, &b, &[]));
        let (ha, hb) = (tree_hashes(&a), tree_hashes(&b));
        assert_eq!(ha.len(), 2, "train and test files: {ha:?}");
        assert_eq!(ha, hb, "{format} export differs between two runs");
    }
    let yolo = dir.path().join("yolo");
    assert_success(&export(&equi, "yolo", &yolo, &[]));
    let links = |root: &Path| -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = ["images/train", "images/test"]
            .iter()
            .flat_map(|d| std::fs::read_dir(root.join(d)).unwrap())
            .map(|e| std::fs::read_link(e.unwrap().path()).unwrap())
            .collect();
        v.sort();
        v
    };
    let (first, first_links) = (tree_hashes(&yolo), links(&yolo));
    // A second run needs --overwrite, and replaces the folder with the same bytes.
    let again = export(&equi, "yolo", &yolo, &[]);
    assert_eq!(again.code, 2, "{}", again.stderr);
    assert_success(&export(&equi, "yolo", &yolo, &["--overwrite"]));
    assert_eq!(tree_hashes(&yolo), first);
    assert_eq!(links(&yolo), first_links);
    assert!(
        hidden_entries(dir.path()).is_empty(),
        "{:?}",
        hidden_entries(dir.path())
    );
}

#[test]
fn kitti_export_option_writes_the_same_files_as_export() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("equi");
    let run = kitti(
        "equirect",
        &synthetic_dir(),
        &out,
        &["--export", "coco,yolo,omni3d", "--quiet"],
    );
    assert_success(&run);
    for name in [
        "instances_train.json",
        "instances_test.json",
        "Omni3D_train.json",
    ] {
        assert!(out.join("annotations").join(name).is_file(), "{name}");
    }
    let yolo = dir.path().join("equi_yolo");
    assert!(yolo.join("data.yaml").is_file() && yolo.join("labels/train/000001.txt").is_file());
    let separate = dir.path().join("separate");
    assert_success(&export(&out, "coco", &separate, &[]));
    assert_eq!(
        hash_file(&separate.join("instances_train.json")),
        hash_file(&out.join("annotations/instances_train.json"))
    );
    let raw = panoconv([
        "kitti-raw",
        "--to",
        "equirect",
        "--input",
        "x",
        "--output",
        "y",
        "--export",
        "coco",
    ]);
    assert_eq!(raw.code, 2, "{}", raw.stderr);
}

#[test]
fn image_sets_and_a_seeded_val_fraction_split_the_frames() {
    let (dir, equi) = convert(&synthetic_dir(), "equirect", &["--split", "training"]);
    std::fs::create_dir_all(equi.join("ImageSets")).unwrap();
    write_text(&equi.join("ImageSets/train.txt"), "000000\n000002\n");
    write_text(&equi.join("ImageSets/val.txt"), "000001\n");
    let images = |file: &Path| -> Vec<String> {
        read_json(file)["images"]
            .as_array()
            .unwrap()
            .iter()
            .map(|i| i["file_name"].as_str().unwrap().to_owned())
            .collect()
    };
    let sets = dir.path().join("sets");
    assert_success(&export(&equi, "coco", &sets, &[]));
    assert_eq!(
        images(&sets.join("instances_train.json")),
        ["training/image_2/000000.png", "training/image_2/000002.png"]
    );
    assert_eq!(
        images(&sets.join("instances_val.json")),
        ["training/image_2/000001.png"]
    );
    let yolo = dir.path().join("yolo");
    assert_success(&export(&equi, "yolo", &yolo, &[]));
    assert!(read_text(&yolo.join("data.yaml")).contains("\nval: images/val\n"));
    assert!(yolo.join("labels/val/000001.txt").is_file());

    let draw = |seed: &str, run: u32| {
        let out = dir.path().join(format!("fraction{seed}_{run}"));
        assert_success(&export(
            &equi,
            "coco",
            &out,
            &["--val-fraction", "0.34", "--seed", seed],
        ));
        (
            images(&out.join("instances_train.json")),
            images(&out.join("instances_val.json")),
        )
    };
    let (train, val) = draw("1", 0);
    assert_eq!(
        (train.len(), val.len()),
        (2, 1),
        "round(0.34 x 3) = 1 frame in val"
    );
    assert_eq!(
        draw("1", 1),
        (train, val),
        "the same seed draws the same split"
    );
    let missing = export(
        &equi,
        "coco",
        &dir.path().join("x"),
        &["--image-sets", "/nonexistent"],
    );
    assert_eq!(missing.code, 2, "{}", missing.stderr);
    assert!(!dir.path().join("x").exists());
}

/// A converted synthetic dataset in a scratch dir, to damage.
fn damaged_copy() -> (tempfile::TempDir, PathBuf) {
    convert(&synthetic_dir(), "equirect", &["--split", "training"])
}

#[test]
fn an_unknown_class_fails_its_frame_with_file_line_field() {
    let (dir, equi) = damaged_copy();
    let label = equi.join("training/label_2/000001.txt");
    let text = read_text(&label);
    let (first, rest) = text.split_once(' ').unwrap();
    assert_eq!(first, "Car");
    write_text(&label, &format!("Bus {rest}"));
    let out = dir.path().join("coco");
    let run = export(&equi, "coco", &out, &[]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert!(
        run.stderr
            .contains("training/label_2/000001.txt:1: type: unknown class \"Bus\""),
        "{}",
        run.stderr
    );
    let coco = read_json(&out.join("instances_train.json"));
    let ids: Vec<u64> = coco["images"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["id"].as_u64().unwrap())
        .collect();
    assert_eq!(
        ids,
        [0, 2],
        "the failed frame is left out, the others exported"
    );
    assert!(hidden_entries(&out).is_empty());

    // Mapped, the class is exported: Bus and Car merged, the rest dropped.
    let mapped = dir.path().join("mapped");
    let run = export(
        &equi,
        "coco",
        &mapped,
        &["--classes", "Bus=Vehicle,Car=Vehicle,*=-"],
    );
    assert_success(&run);
    let coco = read_json(&mapped.join("instances_train.json"));
    assert_eq!(coco["images"].as_array().unwrap().len(), 3);
    assert_eq!(
        coco["categories"],
        serde_json::json!([{"id": 1, "name": "Vehicle", "supercategory": "kitti"}])
    );
    let bad = export(
        &equi,
        "coco",
        &dir.path().join("bad"),
        &["--classes", "Car"],
    );
    assert_eq!(bad.code, 2, "{}", bad.stderr);
    assert!(bad.stderr.contains("--classes"), "{}", bad.stderr);
    assert!(
        !dir.path().join("bad").exists(),
        "nothing written on a set-up error"
    );
}

#[test]
fn a_label_without_image_and_a_missing_calib_fail_their_frames() {
    let (dir, equi) = damaged_copy();
    std::fs::copy(
        equi.join("training/label_2/000001.txt"),
        equi.join("training/label_2/000009.txt"),
    )
    .unwrap();
    std::fs::remove_file(equi.join("training/calib/000002.txt")).unwrap();
    for format in ["coco", "omni3d", "yolo"] {
        let out = dir.path().join(format);
        let run = export(&equi, format, &out, &[]);
        assert_eq!(run.code, 1, "{format}: {}", run.stderr);
        assert!(
            run.stderr.contains("training/label_2/000009.txt: no image"),
            "{}",
            run.stderr
        );
        assert!(
            run.stderr.contains("training/calib/000002.txt"),
            "{}",
            run.stderr
        );
        assert_eq!(run.frame_failures().len(), 2, "{}", run.stderr);
        assert!(hidden_entries(dir.path()).is_empty());
    }
    let coco = read_json(&dir.path().join("coco/instances_train.json"));
    assert_eq!(coco["images"].as_array().unwrap().len(), 2);
    let yolo_labels: Vec<String> = tree_files(&dir.path().join("yolo/labels"))
        .into_iter()
        .collect();
    assert_eq!(yolo_labels, ["train/000000.txt", "train/000001.txt"]);
}

#[test]
fn set_up_errors_write_nothing() {
    let (dir, equi) = damaged_copy();
    let out = dir.path().join("coco");
    assert_success(&export(&equi, "coco", &out, &[]));
    let before = tree_hashes(&out);
    // An existing export is kept unless --overwrite.
    write_text(&equi.join("training/label_2/000000.txt"), "");
    let run = export(&equi, "coco", &out, &[]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("--overwrite"), "{}", run.stderr);
    assert_eq!(tree_hashes(&out), before);
    assert_success(&export(&equi, "coco", &out, &["--overwrite"]));
    assert_ne!(tree_hashes(&out), before);

    let inside = equi.join("yolo");
    let run = export(&equi, "yolo", &inside, &[]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(!inside.exists());
    for (dataset, extra) in [
        (dir.path().join("nonexistent"), vec![]),
        (equi.clone(), vec!["--val-fraction", "1.5"]),
    ] {
        let target = dir.path().join("never");
        let run = export(&dataset, "coco", &target, &extra);
        assert_eq!(run.code, 2, "{}", run.stderr);
        assert!(!target.exists());
    }
    assert!(hidden_entries(dir.path()).is_empty());
}
