//! Errors list the choices, and `inspect` describes a rig root: a missing nuScenes version
//! names the versions present, an unknown `--classes` name lists the categories (and says how
//! the KITTI types follow from them), and `inspect` on a nuScenes or KITTI-360 root reports its
//! scenes, samples, cameras, LiDAR, annotations and what a conversion writes. Through the
//! binary on the fixtures.

use crate::common::*;

fn fixture(name: &str) -> String {
    repo()
        .join("fixtures")
        .join(name)
        .to_str()
        .unwrap()
        .to_owned()
}

/// A set-up error: exit 2, one line holding every one of `wanted`, nothing written.
#[track_caller]
fn assert_lists(args: &[&str], out: &std::path::Path, wanted: &[&str]) {
    let run = panoconv(args);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert_eq!(run.stderr.lines().count(), 1, "{}", run.stderr);
    for w in wanted {
        assert!(run.stderr.contains(w), "{w:?} not in {}", run.stderr);
    }
    assert!(!out.exists());
}

#[test]
fn a_missing_version_lists_the_versions_present() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("o");
    let (input, o) = (fixture("nuscenes"), out.to_str().unwrap());
    let mut args = vec!["nuscenes", "--input", &input, "--version", "v1.0-trainval"];
    args.extend(["--to", "equirect", "--output", o]);
    assert_lists(
        &args,
        &out,
        &["v1.0-trainval", "the versions in", ": v1.0-mini"],
    );
}

#[test]
fn unknown_classes_list_the_categories_and_the_kitti_types_they_give() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("o");
    let (input, o) = (fixture("nuscenes"), out.to_str().unwrap());
    let categories = "human.pedestrian.adult, human.pedestrian.child, movable_object.barrier, \
         vehicle.bicycle, vehicle.car, vehicle.trailer, vehicle.truck";
    let types = "the KITTI types (Car, Truck, Van, Pedestrian, Cyclist) follow from them";
    for (class, why) in [
        ("vehicle.tank", "\"vehicle.tank\": not a category"),
        ("Car", "\"Car\": a KITTI type, not a category: KITTI's types are written without --classes, Car from vehicle.car"),
    ] {
        let mut args = vec!["nuscenes", "--input", &input, "--version", "v1.0-mini"];
        args.extend(["--classes", class, "--to", "equirect", "--output", o]);
        assert_lists(&args, &out, &[why, categories, types]);
    }
    let input = fixture("kitti360");
    let seq = panoconv::tools::synth360::SEQUENCE;
    for (class, why) in [
        ("tank", "\"tank\": not a KITTI-360 class"),
        ("Car", "\"Car\": a KITTI type, not a KITTI-360 class"),
    ] {
        let mut args = vec!["kitti360", "--input", &input, "--sequence", seq];
        args.extend(["--classes", class, "--to", "equirect", "--output", o]);
        let every = "road, parking, sidewalk";
        assert_lists(&args, &out, &[why, every, "unknown object (or `all`)"]);
    }
}

#[test]
fn inspect_describes_a_nuscenes_or_kitti360_root() {
    let nus = fixture("nuscenes");
    let table = |name: &str| -> usize {
        let text = read_text(&repo().join(format!("fixtures/nuscenes/v1.0-mini/{name}.json")));
        let records: serde_json::Value = serde_json::from_str(&text).unwrap();
        records.as_array().unwrap().len()
    };
    let counts = format!(
        "version v1.0-mini: 1 scene, {} samples, {} annotations in {} categories",
        table("sample"),
        table("sample_annotation"),
        table("category")
    );
    let run = panoconv(["inspect", &nus]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    for w in [
        "a nuScenes-format dataset",
        &counts,
        "cameras: CAM_FRONT, CAM_FRONT_RIGHT, CAM_BACK_RIGHT, CAM_BACK, CAM_BACK_LEFT, CAM_FRONT_LEFT (6)",
        "LiDAR: LIDAR_TOP",
        &format!("converts to {} frames: panoconv nuscenes --input", table("sample")),
        "OUT/training/{image_2,label_2,calib,source_2,objects}/ID.*",
    ] {
        assert!(run.stdout.contains(w), "{w:?} not in\n{}", run.stdout);
    }
    let k360 = fixture("kitti360");
    let run = panoconv(["inspect", "--json", &k360]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let report: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    assert_eq!(report["format"], "kitti360");
    let part = &report["parts"][0];
    assert_eq!(part["name"], panoconv::tools::synth360::SEQUENCE);
    assert_eq!(part["samples"], 3);
    assert_eq!(part["frames"], 3);
    assert_eq!(part["cameras"].as_array().unwrap().len(), 4);
    assert_eq!(part["lidar"], "velodyne_points");
    // the boxes the fixture's XML holds
    let xml = std::fs::read_to_string(format!(
        "{k360}/data_3d_bboxes/train/{}.xml",
        panoconv::tools::synth360::SEQUENCE
    ))
    .unwrap();
    let boxes = xml.matches("<semanticId>").count();
    assert!(boxes > 0);
    assert_eq!(part["annotations"], boxes as u64);
    // --split names a KITTI split: refused on a rig root
    let run = panoconv(["inspect", &nus, "--split", "training"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("not a KITTI layout"), "{}", run.stderr);
}
