//! A run that wrote no frame leaves no folder that looks like a dataset: the folders it made
//! for its outputs (`training/image_2/`, `label_2/`, ...) and left empty are removed, only its
//! manifest (the failures' record) stays, the exit code is 1 and the summary says nothing was
//! written. Folders the run did not make stay, empty or not. Through the binary on copies of
//! the nuScenes and synthetic KITTI fixtures with broken inputs.

use crate::common::*;
use std::collections::BTreeSet;
use std::path::Path;

fn nuscenes(root: &Path, out: &Path, extra: &[&str]) -> Run {
    let mut args = vec!["nuscenes", "--to", "equirect", "--pano-width", "256"];
    args.extend(["--input", root.to_str().unwrap(), "--version", "v1.0-mini"]);
    args.extend(["--output", out.to_str().unwrap()]);
    args.extend(extra);
    panoconv(&args)
}

/// Every entry under `root`, folders ending in `/`.
fn tree(root: &Path) -> BTreeSet<String> {
    tree_hashes(root).into_keys().collect()
}

fn set(entries: &[&str]) -> BTreeSet<String> {
    entries.iter().map(|e| e.to_string()).collect()
}

const NOTHING_WRITTEN: &str = "nothing written to";

#[test]
fn a_rig_run_whose_every_frame_failed_leaves_only_its_manifest() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("nuscenes");
    copy_tree(&repo().join("fixtures/nuscenes"), &root);
    let sweeps = root.join("samples/LIDAR_TOP");
    let kept = tmp.path().join("sweeps");
    std::fs::rename(&sweeps, &kept).unwrap();
    std::fs::create_dir(&sweeps).unwrap();

    let out = tmp.path().join("out");
    let run = nuscenes(&root, &out, &["--depth", "--mask"]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert_eq!(run.frame_failures().len(), 3, "{}", run.stderr);
    assert!(run.stderr.contains(NOTHING_WRITTEN), "{}", run.stderr);
    assert!(!run.stderr.contains("frames/s"), "{}", run.stderr);
    assert_eq!(tree(&out), set(&["panoconv.json"]));
    // the manifest still records the failures
    assert!(panoconv(["verify", out.to_str().unwrap()])
        .stdout
        .contains("failed: 3 frames failed"));

    // folders an earlier run made stay, even when this run (a resume whose frames now fail)
    // leaves them empty
    std::fs::remove_dir(&sweeps).unwrap();
    std::fs::rename(&kept, &sweeps).unwrap();
    let out = tmp.path().join("resumed");
    assert_success(&nuscenes(&root, &out, &[]));
    std::fs::remove_dir_all(&sweeps).unwrap();
    std::fs::create_dir(&sweeps).unwrap();
    let run = nuscenes(&root, &out, &["--resume"]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert!(run.stderr.contains(NOTHING_WRITTEN), "{}", run.stderr);
    for folder in ["image_2", "label_2", "calib", "source_2", "objects"] {
        let dir = out.join("training").join(folder);
        assert!(dir.is_dir(), "{} was made by the first run", dir.display());
    }
}

#[test]
fn a_kitti_run_removes_only_the_folders_it_made_and_left_empty() {
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("kitti");
    copy_tree(&repo().join("fixtures/synthetic_kitti"), &input);
    let break_calibs = |split: &str| {
        for e in std::fs::read_dir(input.join(split).join("calib")).unwrap() {
            std::fs::write(e.unwrap().path(), "not a calib\n").unwrap();
        }
    };

    // every training frame fails: training/ goes, testing/ stays with its frame
    break_calibs("training");
    let out = tmp.path().join("half");
    let run = kitti("equirect", &input, &out, &["--depth", "--mask"]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert!(!run.stderr.contains(NOTHING_WRITTEN), "{}", run.stderr);
    let written = tree(&out);
    assert!(
        written.contains("testing/image_2/000003.png"),
        "{written:?}"
    );
    assert!(
        !written.iter().any(|e| e.starts_with("training")),
        "{written:?}"
    );

    // every frame fails, augmented views included: the manifest alone, no ImageSets lists
    break_calibs("testing");
    let out = tmp.path().join("none");
    let augment = ["--augment", "2", "--crop-size", "448x128"];
    let run = kitti("equirect", &input, &out, &augment);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert!(run.stderr.contains(NOTHING_WRITTEN), "{}", run.stderr);
    assert_eq!(tree(&out), set(&["panoconv.json"]));
}
