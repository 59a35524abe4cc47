//! The style pass batches equal-size images of consecutive frames (`--style-batch N`): fewer
//! model runs, and output byte-identical to frame-by-frame styling whatever N and `--jobs`.
//! Runs the real binary and the real ONNX Runtime (scripts/install_ort.sh) on a dataset made
//! from the shipped synthetic sample.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::ort_lib;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The sample's training frames 000000 and 000002 are 1242x375, 000001 is 1224x370.
const SOURCES: [&str; 6] = ["000000", "000002", "000000", "000001", "000002", "000001"];

/// Six frames (sizes A A A B A B) with both colour cameras, copied from the shipped sample.
fn dataset(root: &Path) {
    let from = repo().join("fixtures/synthetic_kitti/training");
    let to = root.join("training");
    for (id, src) in SOURCES.iter().enumerate() {
        let id = format!("{id:06}");
        for (dir, ext) in [
            ("image_2", "png"),
            ("image_3", "png"),
            ("calib", "txt"),
            ("label_2", "txt"),
        ] {
            std::fs::create_dir_all(to.join(dir)).unwrap();
            std::fs::copy(
                from.join(dir).join(format!("{src}.{ext}")),
                to.join(dir).join(format!("{id}.{ext}")),
            )
            .unwrap();
        }
    }
}

/// Runs the conversion; returns the style summary line of stderr.
fn convert(input: &Path, output: &Path, args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_panoconv"))
        .args(["kitti", "--to", "equirect", "--cameras", "2,3", "--input"])
        .arg(input)
        .arg("--output")
        .arg(output)
        .arg("--style")
        .arg(repo().join("fixtures/style/generator.onnx"))
        .arg("--ort-lib")
        .arg(ort_lib())
        .args(args)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{args:?}: {stderr}");
    stderr
        .lines()
        .find(|l| l.contains("style pass:"))
        .unwrap_or_else(|| panic!("no style summary in: {stderr}"))
        .to_owned()
}

/// (model runs, images) from "panoconv: style pass: I images in R model runs".
fn runs(line: &str) -> (usize, usize) {
    let words: Vec<&str> = line.split_whitespace().collect();
    let at = |w: &str| words.iter().position(|x| *x == w).unwrap();
    (
        words[at("model") - 1].parse().unwrap(),
        words[at("images") - 1].parse().unwrap(),
    )
}

fn tree(root: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path.strip_prefix(root).unwrap().to_path_buf();
                files.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    files
}

fn assert_same_tree(a: &Path, b: &Path, what: &str) {
    let (ta, tb) = (tree(a), tree(b));
    assert_eq!(
        ta.keys().collect::<Vec<_>>(),
        tb.keys().collect::<Vec<_>>(),
        "{what}: file lists differ"
    );
    for (path, bytes) in &ta {
        assert!(bytes == &tb[path], "{what}: {} differs", path.display());
    }
}

#[test]
fn batches_equal_sizes_and_output_does_not_depend_on_batch_or_jobs() {
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("in");
    dataset(&input);
    let out = |name: &str| tmp.path().join(name);

    let single = convert(&input, &out("b1j1"), &["--style-batch", "1", "--jobs", "1"]);
    // 6 frames x 2 cameras, one run each.
    assert_eq!(runs(&single), (12, 12), "{single}");

    let batched = convert(&input, &out("b4j2"), &["--style-batch", "4", "--jobs", "2"]);
    // Groups: frames 0-3 (images A A A A A A B B) and 4-5 (A A B B). First group: size A is
    // checked once (1 single run + 1 batch of 4), then runs of 4 and 2; size B is checked
    // (2 runs, 5 images), then one run of 2. Second group: one run of 2 per size.
    // Runs: 2 + 2 + 2 + 1 + 2 = 9; images: 5 + 6 + 5 + 2 + 4 = 22.
    assert_eq!(runs(&batched), (9, 22), "{batched}");
    assert_same_tree(&out("b1j1"), &out("b4j2"), "--style-batch 4 --jobs 2");

    // Other groups (frames 0-2, 3-5), other thread counts: same bytes.
    convert(&input, &out("b3j4"), &["--style-batch", "3", "--jobs", "4"]);
    assert_same_tree(&out("b1j1"), &out("b3j4"), "--style-batch 3 --jobs 4");
    convert(&input, &out("b8j1"), &["--style-batch", "8", "--jobs", "1"]);
    assert_same_tree(&out("b1j1"), &out("b8j1"), "--style-batch 8 --jobs 1");
}

#[test]
fn batching_after_the_warp_gives_the_same_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("in");
    dataset(&input);
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    let single = convert(&input, &a, &["--style-after-warp", "--style-batch", "1"]);
    assert_eq!(runs(&single), (12, 12), "{single}");
    let batched = convert(
        &input,
        &b,
        &["--style-after-warp", "--style-batch", "4", "--jobs", "2"],
    );
    // Both cameras share K, so a frame's two warped images have one size, set by the source
    // size: the groups are those of the test above, and so are the counts.
    assert_eq!(runs(&batched), (9, 22), "{batched}");
    assert_same_tree(&a, &b, "--style-after-warp --style-batch 4");
}

#[test]
fn style_batch_is_validated() {
    let out = Command::new(env!("CARGO_BIN_EXE_panoconv"))
        .args(["kitti", "--to", "equirect", "--input", "x", "--output", "y"])
        .args(["--style", "m.onnx", "--style-batch", "9"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--style-batch"), "{stderr}");
}
