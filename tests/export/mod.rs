//! `panoconv export` through the binary: COCO checked by pycocotools (COCOeval of the ground
//! truth against itself), YOLO read back by an independent reader and compared with the COCO
//! boxes, Omni3D's 3D boxes projected with K (perspective) and through the written calib
//! (equirect, against `labels-to-pixels`), the ±180° seam, splits, determinism, bad input.

mod coco_yolo;
mod errors;
mod label_lines;
mod layout;
mod omni3d;

use crate::common::*;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

pub fn synthetic_dir() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/synthetic_kitti"
    ))
}

/// The Python with pycocotools: $PANOCONV_TEST_PYTHON, else the repository's .venv-test.
pub fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("PANOCONV_TEST_PYTHON") {
        return PathBuf::from(p);
    }
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv-test/bin/python");
    assert!(
        venv.is_file(),
        "no Python with pycocotools: set PANOCONV_TEST_PYTHON or run scripts/install_test_python.sh"
    );
    venv
}

/// `panoconv kitti --to TO --input INPUT EXTRA...` into DIR/out (DIR a fresh temp dir).
pub fn convert(input: &Path, to: &str, extra: &[&str]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut args = vec!["--quiet"];
    args.extend_from_slice(extra);
    assert_success(&kitti(to, input, &out, &args));
    (dir, out)
}

pub fn export(dataset: &Path, format: &str, output: &Path, extra: &[&str]) -> Run {
    let mut args: Vec<String> = vec![
        "export".into(),
        dataset.to_string_lossy().into_owned(),
        "--format".into(),
        format.into(),
        "--output".into(),
        output.to_string_lossy().into_owned(),
        "--quiet".into(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    panoconv(args)
}

pub fn read_json(path: &Path) -> Value {
    serde_json::from_str(&read_text(path)).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

pub fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("{v} is not a number"))
}

pub fn floats(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(f).collect()
}

/// Non-crowd COCO annotations of an image, in file order.
pub fn objects_of(coco: &Value, image_id: u64) -> Vec<&Value> {
    coco["annotations"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|a| a["image_id"].as_u64() == Some(image_id) && a["iscrowd"] == 0)
        .collect()
}

/// Entries whose name starts with '.' (temporary files) anywhere under `dir`.
pub fn hidden_entries(dir: &Path) -> Vec<String> {
    tree_hashes(dir)
        .into_keys()
        .filter(|k| k.split('/').any(|part| part.starts_with('.')))
        .collect()
}

/// Runs the pycocotools script on a COCO file; its key=value figures.
pub fn coco_eval(instances: &Path, root: &Path) -> BTreeMap<String, f64> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/export/coco_eval.py");
    let out = Command::new(python())
        .arg(&script)
        .arg(instances)
        .arg(root)
        .output()
        .expect("cannot run the test python");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "pycocotools check failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line = stdout.lines().last().expect("one line of figures");
    eprintln!("{}: {line}", instances.display());
    line.split_whitespace()
        .map(|kv| {
            let (k, v) = kv.split_once('=').unwrap();
            (k.to_owned(), v.parse::<f64>().unwrap())
        })
        .collect()
}

/// (annotations, images) of a COCO-like file as pycocotools' COCO class indexes it.
pub fn pycocotools_counts(path: &Path) -> (usize, usize) {
    let code = "import sys, contextlib, io\nfrom pycocotools.coco import COCO\n\
with contextlib.redirect_stdout(io.StringIO()):\n    c = COCO(sys.argv[1])\n\
print(len(c.getAnnIds()), len(c.getImgIds()))";
    let out = Command::new(python())
        .args(["-c", code])
        .arg(path)
        .output()
        .expect("cannot run the test python");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let n: Vec<usize> = stdout
        .split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect();
    (n[0], n[1])
}
