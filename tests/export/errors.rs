//! Bad input: frames that fail with file:line:field, set-up errors that write nothing.

use super::*;
use crate::common::*;
use std::path::PathBuf;

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
