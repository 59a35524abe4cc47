//! `panoconv inspect` on a PandaSet sequence says what it is and what reads it (the Python
//! package's `python -m panoconv pandaset`), instead of "neither training/ nor testing/";
//! on a folder of sequences it names them and one to pass. Through the binary on a folder in
//! PandaSet's layout (its folder and file names; inspect reads no file of it).

use crate::common::*;
use std::path::Path;

/// A sequence folder in PandaSet's layout: six cameras, `frames` LiDAR sweeps.
fn sequence(dir: &Path, frames: usize) {
    for camera in ["front_camera", "back_camera", "left_camera"] {
        std::fs::create_dir_all(dir.join("camera").join(camera)).unwrap();
    }
    std::fs::create_dir_all(dir.join("annotations/cuboids")).unwrap();
    std::fs::create_dir_all(dir.join("meta")).unwrap();
    std::fs::create_dir_all(dir.join("lidar")).unwrap();
    for i in 0..frames {
        std::fs::write(dir.join(format!("lidar/{i:02}.pkl.gz")), b"").unwrap();
    }
    std::fs::write(dir.join("lidar/poses.json"), b"[]").unwrap();
}

#[test]
fn inspect_names_a_pandaset_sequence_and_the_python_command_that_converts_it() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = tmp.path().join("pandaset/002");
    sequence(&seq, 4);
    let run = panoconv(["inspect", seq.to_str().unwrap()]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    for said in [
        &format!("{} is a PandaSet sequence", seq.display()),
        "4 frames on disk, cameras back_camera, front_camera, left_camera",
        "panoconv reads PandaSet through its Python package (pip install panoconv[pandaset]",
        &format!(
            "`python -m panoconv pandaset --input {} --to equirect",
            seq.display()
        ),
    ] {
        assert!(run.stderr.contains(said), "{said:?} not in {}", run.stderr);
    }
    assert!(!run.stderr.contains("neither training/"), "{}", run.stderr);

    // the dataset's folder: its sequences named, one of them to pass
    let root = tmp.path().join("pandaset");
    sequence(&root.join("001"), 2);
    let run = panoconv(["inspect", root.to_str().unwrap()]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    let said = "holds PandaSet sequences (001, 002), not a KITTI, nuScenes or KITTI-360 root; \
                panoconv reads PandaSet through its Python package";
    assert!(run.stderr.contains(said), "{said:?} not in {}", run.stderr);
    let input = format!("--input {}", root.join("001").display());
    assert!(
        run.stderr.contains(&input),
        "{input:?} not in {}",
        run.stderr
    );

    // a folder that is none of these still gets the layout panoconv expects
    let other = tmp.path().join("other");
    std::fs::create_dir_all(other.join("lidar")).unwrap();
    let run = panoconv(["inspect", other.to_str().unwrap()]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr.contains("holds neither training/ nor testing/"),
        "{}",
        run.stderr
    );
}
