//! OpenCV (`cv2.fisheye`, `cv2.omnidir`) driven as a child process: the independent reference
//! of the camera model tests. The python comes from PANOCONV_TEST_PYTHON, else
//! `<repo>/.venv-test/bin/python` (scripts/install_test_python.sh makes it).

#![allow(dead_code)]

use nalgebra::{Point2, Vector3};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The python with OpenCV (contrib): PANOCONV_TEST_PYTHON, else <repo>/.venv-test/bin/python.
pub fn test_python() -> PathBuf {
    if let Some(p) = std::env::var_os("PANOCONV_TEST_PYTHON") {
        return PathBuf::from(p);
    }
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv-test/bin/python");
    assert!(
        venv.exists(),
        "no Python reference: set PANOCONV_TEST_PYTHON or run scripts/install_test_python.sh \
         (it creates {})",
        venv.display()
    );
    venv
}

/// Runs a python snippet with `args`, returns its stdout.
pub fn run_python(script: &str, args: &[&str]) -> String {
    let out = Command::new(test_python())
        .arg("-c")
        .arg(script)
        .args(args)
        .output()
        .expect("cannot run the test python");
    assert!(
        out.status.success(),
        "python failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

const OPENCV_PROJECT: &str = r#"
import sys, json
import numpy as np, cv2
req = json.load(open(sys.argv[1]))
pts = np.array(req["points"], dtype=np.float64).reshape(1, -1, 3)
K = np.array(req["K"], dtype=np.float64).reshape(3, 3)
D = np.array(req["D"], dtype=np.float64).reshape(1, 4)
zero = np.zeros((1, 3), dtype=np.float64)
if req["model"] == "fisheye":
    img, _ = cv2.fisheye.projectPoints(pts, zero, zero, K, D)
else:
    img, _ = cv2.omnidir.projectPoints(pts, zero, zero, K, float(req["xi"]), D)
for u, v in img.reshape(-1, 2):
    print(repr(float(u)), repr(float(v)))
"#;

/// OpenCV's projections of `points` (model "fisheye" or "omnidir").
pub fn opencv_project(
    model: &str,
    points: &[Vector3<f64>],
    k: [f64; 9],
    d: [f64; 4],
    xi: f64,
) -> Vec<Point2<f64>> {
    let dir = tempfile::tempdir().unwrap();
    let req = dir.path().join("request.json");
    let pts: Vec<[f64; 3]> = points.iter().map(|p| [p.x, p.y, p.z]).collect();
    std::fs::write(
        &req,
        serde_json::json!({"model": model, "points": pts, "K": k, "D": d, "xi": xi}).to_string(),
    )
    .unwrap();
    let out = run_python(OPENCV_PROJECT, &[req.to_str().unwrap()]);
    let px: Vec<Point2<f64>> = out
        .lines()
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            Point2::new(v[0], v[1])
        })
        .collect();
    assert_eq!(px.len(), points.len());
    px
}
