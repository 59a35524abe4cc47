//! A run's machinery as for `kitti`: resume, shards and merge, export, several sequences.

use super::{kitti360, sequence};
use crate::common::{self, assert_success, panoconv, read_manifest};
use panoconv::tools::synth360::SEQUENCE;
use std::path::Path;

/// A copy of the offset sequence under another drive number.
fn rename_sequence(root: &Path, to: &str) {
    for dir in ["data_2d_raw", "data_3d_raw", "data_poses"] {
        std::fs::rename(root.join(dir).join(SEQUENCE), root.join(dir).join(to)).unwrap();
    }
    let boxes = root.join("data_3d_bboxes/train");
    std::fs::rename(
        boxes.join(format!("{SEQUENCE}.xml")),
        boxes.join(format!("{to}.xml")),
    )
    .unwrap();
}

#[test]
fn resume_shards_export_and_several_sequences_work_as_for_kitti() {
    let tmp = tempfile::tempdir().unwrap();
    let small = ["--to", "equirect", "--pano-width", "360"];
    // --resume keeps every frame of a finished run, and the files stay the same
    let out = tmp.path().join("out");
    let mut args = small.to_vec();
    args.extend(["--export", "coco,yolo"]);
    assert_success(&kitti360(sequence(false), &out, &args));
    assert!(out.join("annotations/instances_train.json").is_file());
    assert!(tmp.path().join("out_yolo/data.yaml").is_file());
    let before = common::tree_bytes(&out.join("training"));
    let mut again = small.to_vec();
    again.push("--resume");
    let run = kitti360(sequence(false), &out, &again);
    assert_success(&run);
    assert_eq!(common::tree_bytes(&out.join("training")), before);
    assert_success(&panoconv(["verify", out.to_str().unwrap()]));
    // other parameters are refused by --resume
    let mut other = again.clone();
    other.extend(["--max-distance", "20"]);
    assert_eq!(kitti360(sequence(false), &out, &other).code, 2);

    // two shards, merged, are the whole run
    let sharded = tmp.path().join("sharded");
    for k in ["0/2", "1/2"] {
        let mut a = small.to_vec();
        a.extend(["--shard", k]);
        assert_success(&kitti360(sequence(false), &sharded, &a));
    }
    assert_success(&panoconv(["merge", sharded.to_str().unwrap()]));
    assert_success(&panoconv(["verify", sharded.to_str().unwrap()]));
    assert_eq!(common::tree_bytes(&sharded.join("training")), before);

    // two sequences: ids with the drive number first, recorded in the manifest
    let root = tmp.path().join("two");
    common::copy_tree(sequence(false), &root);
    let other_seq = "2013_05_28_drive_0003_sync";
    let both = tmp.path().join("both");
    {
        let three = tmp.path().join("three");
        common::copy_tree(sequence(false), &three);
        rename_sequence(&three, other_seq);
        for dir in ["data_2d_raw", "data_3d_raw", "data_poses"] {
            std::fs::rename(
                three.join(dir).join(other_seq),
                root.join(dir).join(other_seq),
            )
            .unwrap();
        }
        std::fs::rename(
            three.join(format!("data_3d_bboxes/train/{other_seq}.xml")),
            root.join(format!("data_3d_bboxes/train/{other_seq}.xml")),
        )
        .unwrap();
    }
    let mut a = vec!["kitti360", "--input", root.to_str().unwrap(), "--sequence"];
    let sequences = format!("{SEQUENCE},{other_seq}");
    a.push(&sequences);
    a.extend(["--output", both.to_str().unwrap()]);
    a.extend(small);
    assert_success(&panoconv(&a));
    let ids: Vec<String> = common::tree_files(&both.join("training/image_2"))
        .into_iter()
        .collect();
    assert_eq!(
        ids,
        [
            "0000000250.png",
            "0000000251.png",
            "0003000250.png",
            "0003000251.png"
        ]
    );
    let m = read_manifest(&both);
    assert_eq!(m["parameters"]["frame_ids"], "drive_frame");
    // the same frame of the same scene: the same files whatever the sequence's name
    for (a, b) in [("0000000250", "0003000250"), ("0000000251", "0003000251")] {
        let f = |id: &str| std::fs::read(both.join(format!("training/label_2/{id}.txt"))).unwrap();
        assert_eq!(f(a), f(b));
        assert_eq!(
            f(a),
            std::fs::read(out.join(format!("training/label_2/{}.txt", &a[4..]))).unwrap()
        );
    }
}
