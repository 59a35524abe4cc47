//! The fixed stitches a rig run keeps across frames of one geometry (src/convert/rig/
//! stitch_cache.rs): `panoconv nuscenes --stitch-mode fixed` on fixtures/nuscenes with its
//! samples' cameras at the first sample's ego poses (the last one's geometry repeats the
//! first's; the middle one's differs in one camera's position alone, 2 m aside) writes the same bytes with the cache on and turned off
//! (`PANOCONV_STITCH_CACHE=off`), with `--jobs 1` and `--jobs 2`: a kept stitch is only ever
//! reused for its own geometry.

use crate::common::{self, assert_success, BIN};
use serde_json::Value;
use std::path::Path;
use std::process::Command;

const VERSION: &str = "v1.0-mini";

/// fixtures/nuscenes copied into `dst` with every sample's readings at the first sample's ego
/// poses (per calibrated sensor), but the middle sample's CAM_BACK 2 m aside.
fn repeated_root(dst: &Path) {
    common::copy_tree(&common::repo().join("fixtures/nuscenes"), dst);
    let tables = dst.join(VERSION);
    let read = |name: &str| -> Value {
        serde_json::from_str(&common::read_text(&tables.join(name))).unwrap()
    };
    let (mut data, mut poses) = (read("sample_data.json"), read("ego_pose.json"));
    let samples = read("sample.json");
    let tokens: Vec<&str> = samples
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["token"].as_str().unwrap())
        .collect();
    assert_eq!(tokens.len(), 3, "fixtures/nuscenes has three samples");
    let keyframe =
        |d: &Value, k: usize| d["is_key_frame"] == true && d["sample_token"] == tokens[k];
    let mut pose = std::collections::HashMap::new();
    for d in data.as_array().unwrap().iter().filter(|d| keyframe(d, 0)) {
        pose.insert(
            d["calibrated_sensor_token"].clone(),
            d["ego_pose_token"].clone(),
        );
    }
    let mut moved = 0;
    for d in data.as_array_mut().unwrap() {
        if keyframe(d, 1) || keyframe(d, 2) {
            d["ego_pose_token"] = pose[&d["calibrated_sensor_token"]].clone();
            moved += 1;
            if keyframe(d, 1) && d["filename"].as_str().unwrap().contains("/CAM_BACK/") {
                // a pose of its own, the first's translated: only this differs from sample 0
                let list = poses.as_array_mut().unwrap();
                let mut aside = list
                    .iter()
                    .find(|p| p["token"] == d["ego_pose_token"])
                    .unwrap()
                    .clone();
                aside["token"] = "cam-back-aside".into();
                aside["translation"][0] = (aside["translation"][0].as_f64().unwrap() + 2.0).into();
                list.push(aside);
                d["ego_pose_token"] = "cam-back-aside".into();
            }
        }
    }
    assert_eq!(moved, 2 * 7, "six cameras and the LiDAR, twice");
    common::write_text(&tables.join("sample_data.json"), &data.to_string());
    common::write_text(&tables.join("ego_pose.json"), &poses.to_string());
}

/// `panoconv nuscenes` at the fixed distance into `out`, the cache `on` or off.
fn convert(root: &Path, out: &Path, jobs: &str, on: bool) {
    let mut command = Command::new(BIN);
    command.args([
        "nuscenes",
        "--input",
        root.to_str().unwrap(),
        "--version",
        VERSION,
    ]);
    command.args([
        "--to",
        "equirect",
        "--pano-width",
        "256",
        "--stitch-mode",
        "fixed",
    ]);
    // C2 given: the moved camera changes no other part of the geometry (the mean would move)
    command.args([
        "--centre",
        "0,0,0",
        "--jobs",
        jobs,
        "--output",
        out.to_str().unwrap(),
    ]);
    if !on {
        command.env("PANOCONV_STITCH_CACHE", "off");
    }
    let run = command.output().unwrap();
    assert_success(&common::Run {
        code: run.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&run.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&run.stderr).into_owned(),
    });
}

#[test]
fn a_kept_stitch_writes_the_bytes_of_a_fresh_one_with_any_jobs() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("root");
    repeated_root(&root);
    let runs = [("off1", "1", false), ("on1", "1", true), ("on2", "2", true)];
    for (name, jobs, on) in runs {
        convert(&root, &tmp.path().join(name), jobs, on);
    }
    let trees: Vec<_> = runs
        .iter()
        .map(|(name, _, _)| common::tree_bytes(&tmp.path().join(name)))
        .collect();
    let files: Vec<&String> = trees[0].keys().filter(|k| *k != "panoconv.json").collect();
    assert_eq!(files.len(), 3 * 5, "{files:?}");
    for f in &files {
        for (t, (name, _, _)) in trees.iter().zip(&runs).skip(1) {
            assert!(
                t[*f] == trees[0][*f],
                "{f}: {name} differs from the run without cache"
            );
        }
    }
    // the first and last samples share their geometry, and their sources' maps with it; the
    // middle sample's CAM_BACK is elsewhere
    let source = |id: &str| trees[0][&format!("training/source_2/{id}.png")].clone();
    let image = |id: &str| trees[0][&format!("training/image_2/{id}.png")].clone();
    assert!(
        source("000000") == source("000002"),
        "one geometry, one source map"
    );
    assert!(
        image("000000") != image("000002"),
        "the images are each sample's own"
    );
    assert!(
        source("000000") != source("000001"),
        "the middle sample moved"
    );
}
