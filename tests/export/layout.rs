//! The ±180° seam, determinism, `kitti --export`, and the train/val split.

use super::*;
use crate::common::*;
use serde_json::Value;
use std::path::{Path, PathBuf};

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
    // The export inside the dataset is in its manifest: verify checks it, and passes.
    let verify = panoconv([std::ffi::OsStr::new("verify"), out.as_os_str()]);
    assert_eq!(verify.code, 0, "{}", verify.stdout);
    let annotations = out.join("annotations/instances_train.json");
    std::fs::write(&annotations, b"{}").unwrap();
    let verify = panoconv([std::ffi::OsStr::new("verify"), out.as_os_str()]);
    assert_eq!(verify.code, 1, "{}", verify.stdout);
    assert!(
        verify
            .stdout
            .contains("changed: annotations/instances_train.json"),
        "{}",
        verify.stdout
    );
    assert_success(&export(
        &out,
        "coco",
        &out.join("annotations"),
        &["--overwrite"],
    ));
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
    // A shard is not a whole dataset: refused before anything is written.
    let shard_out = dir.path().join("shard");
    let shard = kitti(
        "equirect",
        &synthetic_dir(),
        &shard_out,
        &["--shard", "0/2", "--export", "coco"],
    );
    assert_eq!(shard.code, 2, "{}", shard.stderr);
    assert!(shard.stderr.contains("--shard"), "{}", shard.stderr);
    assert!(!shard_out.exists());
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

/// Image ids are frame numbers within each file, even when training/ and testing/ share ids.
#[test]
fn image_ids_are_frame_numbers_in_each_split() {
    let (dir, equi) = convert(&synthetic_dir(), "equirect", &[]);
    for (from, to) in [
        ("testing/image_2/000003.png", "testing/image_2/000001.png"),
        ("testing/calib/000003.txt", "testing/calib/000001.txt"),
    ] {
        std::fs::rename(equi.join(from), equi.join(to)).unwrap();
    }
    let out = dir.path().join("coco");
    assert_success(&export(&equi, "coco", &out, &[]));
    let ids = |name: &str| -> Vec<u64> {
        read_json(&out.join(name))["images"]
            .as_array()
            .unwrap()
            .iter()
            .map(|i| i["id"].as_u64().unwrap())
            .collect()
    };
    assert_eq!(ids("instances_train.json"), [0, 1, 2]);
    assert_eq!(ids("instances_test.json"), [1]);
}
