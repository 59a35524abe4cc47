//! Bad input: a failed frame is named with its file and counted, a malformed poses file or an
//! impossible output camera is a set-up error that writes nothing.

use super::{kitti360, sequence};
use crate::common::{self, assert_success, panoconv, read_manifest, read_text};
use panoconv::tools::synth360::SEQUENCE;

#[test]
fn bad_input_is_named_with_its_file_and_counted() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("in");
    common::copy_tree(sequence(false), &root);
    // a frame without a pose, and a frame whose scan is malformed: both failed, counted
    let scan = root.join(format!(
        "data_3d_raw/{SEQUENCE}/velodyne_points/data/0000000251.bin"
    ));
    let bytes = std::fs::read(&scan).unwrap();
    std::fs::write(&scan, &bytes[..bytes.len() - 3]).unwrap();
    let out = tmp.path().join("out");
    let run = kitti360(
        &root,
        &out,
        &[
            "--to",
            "equirect",
            "--pano-width",
            "360",
            "--frames",
            "250,251,400",
        ],
    );
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert!(
        run.stderr.contains("poses.txt") && run.stderr.contains("frame 400 has no pose"),
        "{}",
        run.stderr
    );
    assert!(run.stderr.contains("0000000251.bin"), "{}", run.stderr);
    let m = read_manifest(&out);
    let frames = m["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    let failed: Vec<&str> = frames
        .iter()
        .filter(|f| f["status"] == "failed")
        .map(|f| f["id"].as_str().unwrap())
        .collect();
    assert_eq!(failed, ["000251", "000400"]);
    assert!(!out.join("training/image_2/000251.png").exists());
    assert!(out.join("training/image_2/000250.png").exists());
    assert_success(&panoconv([
        "verify",
        "--allow-failed",
        out.to_str().unwrap(),
    ]));

    // a malformed poses file: a set-up error naming file, line and field, nothing written
    let poses = root.join(format!("data_poses/{SEQUENCE}/poses.txt"));
    let text = read_text(&poses);
    let broken: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 1 {
                l.replacen(' ', " x", 2)
            } else {
                l.to_owned()
            }
        })
        .collect();
    std::fs::write(&poses, broken.join("\n") + "\n").unwrap();
    let out2 = tmp.path().join("out2");
    let run = kitti360(&root, &out2, &["--to", "equirect", "--pano-width", "360"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("poses.txt:2"), "{}", run.stderr);
    assert!(!out2.exists());

    // an output camera too large for any frame: a set-up error, nothing written
    let huge = tmp.path().join("huge");
    let run = kitti360(
        sequence(false),
        &huge,
        &["--to", "equirect", "--pano-width", "200000"],
    );
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("too large"), "{}", run.stderr);
    assert!(!huge.exists());

    // options kitti360 does not take say so
    let run = kitti360(
        &root,
        &tmp.path().join("o3"),
        &["--to", "equirect", "--style-after-warp"],
    );
    assert_eq!(run.code, 2);
    assert!(
        run.stderr
            .contains("--style-after-warp is not supported by kitti360"),
        "{}",
        run.stderr
    );
}
