//! Crash safety, resume and shards, with the real binary: kill -9 at several moments, SIGINT,
//! 4 shard processes + merge, all compared byte for byte with one uninterrupted run.

use crate::common;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

const BIN: &str = env!("CARGO_BIN_EXE_panoconv");

/// A 24-frame dataset: the shipped synthetic training frames under new ids.
fn dataset(root: &Path) -> PathBuf {
    let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synthetic_kitti/training");
    let d = root.join("in");
    for sub in ["image_2", "calib", "label_2"] {
        std::fs::create_dir_all(d.join("training").join(sub)).unwrap();
    }
    for i in 0..24 {
        let src = format!("{:06}", i % 3);
        let id = format!("{i:06}");
        for (sub, ext) in [("image_2", "png"), ("calib", "txt"), ("label_2", "txt")] {
            std::fs::copy(
                sample.join(sub).join(format!("{src}.{ext}")),
                d.join("training").join(sub).join(format!("{id}.{ext}")),
            )
            .unwrap();
        }
    }
    d
}

fn kitti(input: &Path, output: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(BIN);
    c.args(["kitti", "--to", "equirect", "--quiet", "--input"])
        .arg(input)
        .arg("--output")
        .arg(output)
        .args(extra);
    c
}

/// Every visible (non-temporary) file is whole: PNGs decode, the manifest parses.
fn assert_no_partial_file(root: &Path) {
    for (name, bytes) in common::tree_bytes(root) {
        let file = name.rsplit('/').next().unwrap();
        if file.starts_with('.') {
            continue; // a temporary being written: never read by anyone
        }
        if name.ends_with(".png") {
            panoconv::codec::png::decode_rgb8(&bytes, Path::new(&name))
                .unwrap_or_else(|e| panic!("partial file: {e}"));
        } else if name.ends_with(".json") {
            serde_json::from_slice::<serde_json::Value>(&bytes)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
}

#[test]
fn kill_nine_then_resume_gives_the_uninterrupted_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let input = dataset(tmp.path());
    let reference = tmp.path().join("reference");
    assert!(kitti(&input, &reference, &["--jobs", "2"])
        .status()
        .unwrap()
        .success());
    let expected = common::tree_bytes(&reference);
    for (round, delay_ms) in [50u64, 300, 700, 1500].into_iter().enumerate() {
        let out = tmp.path().join(format!("killed{round}"));
        // kill the same output twice, at the delay and again after a first resume started
        for attempt in 0..2 {
            let extra: &[&str] = if attempt == 0 {
                &["--jobs", "2"]
            } else {
                &["--jobs", "2", "--resume"]
            };
            let mut child = kitti(&input, &out, extra)
                .stderr(Stdio::null())
                .spawn()
                .unwrap();
            std::thread::sleep(Duration::from_millis(delay_ms));
            let _ = child.kill(); // SIGKILL
            let _ = child.wait();
            if out.exists() {
                assert_no_partial_file(&out);
            }
        }
        let status = kitti(&input, &out, &["--jobs", "1", "--resume"])
            .status()
            .unwrap();
        assert!(status.success());
        let mut got = common::tree_bytes(&out);
        got.retain(|k, _| !k.rsplit('/').next().unwrap().starts_with('.'));
        assert_eq!(
            got.keys().collect::<Vec<_>>(),
            expected.keys().collect::<Vec<_>>(),
            "kill at {delay_ms} ms"
        );
        for (k, v) in &expected {
            assert!(
                &got[k] == v,
                "kill at {delay_ms} ms: {k} differs after resume"
            );
        }
    }
}

#[test]
fn sigint_stops_cleanly_and_resume_finishes() {
    let tmp = tempfile::tempdir().unwrap();
    let input = dataset(tmp.path());
    let reference = tmp.path().join("reference");
    assert!(kitti(&input, &reference, &[]).status().unwrap().success());
    let out = tmp.path().join("o");
    let child = kitti(&input, &out, &["--jobs", "1"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(800));
    let pid = child.id().to_string();
    assert!(Command::new("kill")
        .args(["-INT", &pid])
        .status()
        .unwrap()
        .success());
    let result = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&result.stderr);
    if result.status.code() == Some(0) {
        eprintln!("the run finished before the signal; nothing to check");
        return;
    }
    assert_eq!(result.status.code(), Some(130), "{stderr}");
    assert!(
        stderr.contains("interrupted") && stderr.contains("--resume"),
        "{stderr}"
    );
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("panoconv.json")).unwrap()).unwrap();
    assert_eq!(m["complete"], false);
    let listed = m["frames"].as_array().unwrap().len();
    assert!(
        listed < 24,
        "an interrupted run lists only finished frames ({listed})"
    );
    assert_no_partial_file(&out);
    let resumed = kitti(&input, &out, &["--resume"]).output().unwrap();
    assert!(resumed.status.success());
    assert!(
        common::tree_bytes(&out) == common::tree_bytes(&reference),
        "resumed output differs from an uninterrupted run"
    );
}

#[test]
fn resume_refuses_other_parameters() {
    let tmp = tempfile::tempdir().unwrap();
    let input = dataset(tmp.path());
    let out = tmp.path().join("o");
    assert!(kitti(&input, &out, &[]).status().unwrap().success());
    let o = Command::new(BIN)
        .args(["kitti", "--to", "cylindrical", "--resume", "-q", "-i"])
        .arg(&input)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("cannot resume") && err.contains("output_spec"),
        "{err}"
    );
    // a resume with the same parameters keeps everything: nothing is converted again
    let o = Command::new(BIN)
        .args(["kitti", "--to", "equirect", "--resume", "-i"])
        .arg(&input)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("24 frames converted (24 kept from the previous run)"),
        "{err}"
    );
}

#[test]
fn four_shards_and_merge_equal_one_run() {
    let tmp = tempfile::tempdir().unwrap();
    let input = dataset(tmp.path());
    let single = tmp.path().join("single");
    assert!(kitti(&input, &single, &["--jobs", "2"])
        .status()
        .unwrap()
        .success());
    let sharded = tmp.path().join("sharded");
    let children: Vec<_> = (0..4)
        .map(|k| {
            kitti(
                &input,
                &sharded,
                &["--jobs", "1", "--shard", &format!("{k}/4")],
            )
            .spawn()
            .unwrap()
        })
        .collect();
    for mut c in children {
        assert!(c.wait().unwrap().success());
    }
    let parts: Vec<String> = common::tree_bytes(&sharded)
        .into_keys()
        .filter(|k| k.starts_with("panoconv.shard-"))
        .collect();
    assert_eq!(parts.len(), 4, "{parts:?}");
    // each frame in exactly one shard, every shard non-empty for 24 frames
    let o = Command::new(BIN)
        .arg("merge")
        .arg(&sharded)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        common::tree_bytes(&sharded) == common::tree_bytes(&single),
        "4 shards + merge differ from one run"
    );
}

#[test]
fn merge_refuses_a_missing_shard() {
    let tmp = tempfile::tempdir().unwrap();
    let input = dataset(tmp.path());
    let out = tmp.path().join("o");
    for k in [0, 1, 3] {
        assert!(kitti(&input, &out, &["--shard", &format!("{k}/4")])
            .status()
            .unwrap()
            .success());
    }
    let o = Command::new(BIN).arg("merge").arg(&out).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("shard(s) 2 of 4 missing"), "{err}");
    assert!(!out.join("panoconv.json").exists());
}
