//! An export after a rig conversion maps every class the conversion wrote: the categories
//! `--classes` adds become categories of their own after KITTI's eight, in COCO and YOLO alike
//! (`nuscenes --help`'s `--classes movable_object.barrier --export coco,yolo` converted, then
//! failed "no frame to export"). Through the binary on the fixtures.

use crate::common::*;
use std::path::Path;

/// Label lines of `kind` in the conversion's `label_2/`.
fn label_lines_of(out: &Path, kind: &str) -> usize {
    let dir = out.join("training/label_2");
    std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| read_text(&e.unwrap().path()))
        .map(|t| {
            t.lines()
                .filter(|l| l.split(' ').next() == Some(kind))
                .count()
        })
        .sum()
}

/// COCO annotations of category `name` in `instances_train.json`.
fn coco_count(out: &Path, name: &str) -> usize {
    let coco: serde_json::Value =
        serde_json::from_str(&read_text(&out.join("annotations/instances_train.json"))).unwrap();
    let id = coco["categories"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == name)
        .unwrap_or_else(|| panic!("no category {name}"))["id"]
        .clone();
    let annotations = coco["annotations"].as_array().unwrap();
    annotations
        .iter()
        .filter(|a| a["category_id"] == id)
        .count()
}

#[test]
fn a_nuscenes_category_given_with_classes_is_exported_to_coco_and_yolo() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("O");
    let input = repo().join("fixtures/nuscenes");
    let (i, o) = (input.to_str().unwrap(), out.to_str().unwrap());
    let mut args = vec!["nuscenes", "--to", "equirect", "--pano-width", "512"];
    args.extend([
        "--classes",
        "movable_object.barrier",
        "--export",
        "coco,yolo",
    ]);
    args.extend(["--input", i, "--version", "v1.0-mini", "--output", o]);
    let run = panoconv(&args);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let barriers = label_lines_of(&out, "movable_object.barrier");
    assert!(barriers > 0, "the fixture has barriers");
    assert_eq!(coco_count(&out, "movable_object.barrier"), barriers);
    // YOLO: class 8, after KITTI's eight (0..=7)
    let yaml = read_text(&tmp.path().join("O_yolo/data.yaml"));
    assert!(yaml.contains("8: \"movable_object.barrier\""), "{yaml}");
    let labels = tmp.path().join("O_yolo/labels/train");
    let eights: usize = std::fs::read_dir(&labels)
        .unwrap()
        .map(|e| read_text(&e.unwrap().path()))
        .map(|t| t.lines().filter(|l| l.starts_with("8 ")).count())
        .sum();
    assert_eq!(eights, barriers);
}

#[test]
fn every_kitti360_class_is_exported_with_classes_all() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("O");
    let input = repo().join("fixtures/kitti360");
    let (i, o) = (input.to_str().unwrap(), out.to_str().unwrap());
    let seq = panoconv::tools::synth360::SEQUENCE;
    let mut args = vec!["kitti360", "--to", "equirect", "--pano-width", "360"];
    args.extend(["--classes", "all", "--export", "coco", "--input", i]);
    args.extend(["--sequence", seq, "--output", o]);
    let run = panoconv(&args);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let buildings = label_lines_of(&out, "building");
    assert!(buildings > 0, "the fixture has buildings");
    assert_eq!(coco_count(&out, "building"), buildings);
    // a class whose name has a space is one label token, and a category
    assert_eq!(coco_count(&out, "traffic_light"), 0);
}
