//! A frame whose LiDAR scan is missing says what of the run reads the scan and how to do
//! without it: without `--depth`, a nuScenes sample fails only because the default
//! depth-guided stitch needs its LIDAR_TOP sweep, which a bare `FILE: No such file or
//! directory` does not tell. Through the binary on copies of the nuScenes and KITTI-360
//! fixtures with one scan removed.

use crate::common::*;
use std::path::{Path, PathBuf};

/// The fixture's first LIDAR_TOP keyframe: (its file under the root, its sample's token).
fn first_sweep(root: &Path) -> (PathBuf, String) {
    let table = read_text(&root.join("v1.0-mini/sample_data.json"));
    let records: serde_json::Value = serde_json::from_str(&table).unwrap();
    let sweep = (records.as_array().unwrap().iter())
        .filter(|r| r["filename"].as_str().unwrap().contains("LIDAR_TOP"))
        .min_by_key(|r| r["timestamp"].as_u64().unwrap())
        .unwrap();
    let file = root.join(sweep["filename"].as_str().unwrap());
    (file, sweep["sample_token"].as_str().unwrap().to_owned())
}

fn nuscenes(root: &Path, out: &Path, extra: &[&str]) -> Run {
    let mut args = vec!["nuscenes", "--to", "equirect", "--pano-width", "256"];
    args.extend(["--input", root.to_str().unwrap(), "--version", "v1.0-mini"]);
    args.extend(["--output", out.to_str().unwrap()]);
    args.extend(extra);
    panoconv(&args)
}

#[test]
fn a_sample_without_its_sweep_names_the_stitch_that_needs_it_and_the_way_out() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("nuscenes");
    copy_tree(&repo().join("fixtures/nuscenes"), &root);
    let (sweep, token) = first_sweep(&root);
    std::fs::remove_file(&sweep).unwrap();

    // without --depth: the stitch alone reads the sweep
    let run = nuscenes(&root, &tmp.path().join("depth_stitch"), &[]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    let failures = run.frame_failures();
    assert_eq!(failures.len(), 1, "{}", run.stderr);
    let line = failures[0];
    for said in [
        sweep.to_str().unwrap(),
        &format!("sample {token}'s LIDAR_TOP sweep cannot be read"),
        "the depth-guided stitch (--stitch-mode depth, the default) needs it",
        "pass --stitch-mode fixed",
    ] {
        assert!(line.contains(said), "{said:?} not in {line}");
    }
    assert!(!line.contains("--depth (depth_2/)"), "{line}");

    // the way out it names converts every sample
    assert_success(&nuscenes(
        &root,
        &tmp.path().join("fixed"),
        &["--stitch-mode", "fixed"],
    ));

    // with --depth the depth map needs it too, and the way out says so
    let run = nuscenes(&root, &tmp.path().join("depth"), &["--depth"]);
    let failures = run.frame_failures();
    assert_eq!(failures.len(), 1, "{}", run.stderr);
    for said in [
        "--depth (depth_2/) and the depth-guided stitch (--stitch-mode depth, the default) need it",
        "leave out --depth and pass --stitch-mode fixed",
    ] {
        assert!(
            failures[0].contains(said),
            "{said:?} not in {}",
            failures[0]
        );
    }
}

#[test]
fn a_kitti360_frame_without_its_scan_names_what_reads_it() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("kitti360");
    copy_tree(&repo().join("fixtures/kitti360"), &root);
    let seq = panoconv::tools::synth360::SEQUENCE;
    let scan = root.join(format!(
        "data_3d_raw/{seq}/velodyne_points/data/0000000250.bin"
    ));
    std::fs::remove_file(&scan).unwrap();
    let out = tmp.path().join("out");
    let mut args = vec!["kitti360", "--to", "equirect", "--pano-width", "256"];
    args.extend(["--input", root.to_str().unwrap(), "--sequence", seq]);
    args.extend(["--frames", "250", "--output", out.to_str().unwrap()]);
    let run = panoconv(&args);
    let failures = run.frame_failures();
    assert_eq!(failures.len(), 1, "{}", run.stderr);
    // KITTI-360's objects' LiDAR check (--min-points 3 by default) reads it as well
    for said in [
        scan.to_str().unwrap(),
        "frame 250's Velodyne scan cannot be read",
        "--min-points 3 (the objects' LiDAR check) and the depth-guided stitch",
        "pass --min-points 0 and --stitch-mode fixed",
    ] {
        assert!(
            failures[0].contains(said),
            "{said:?} not in {}",
            failures[0]
        );
    }
}
