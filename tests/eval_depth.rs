//! eval-depth against metrics computed by hand on a tiny fixture.

use panoconv::codec::png::{encode_gray16, PngCompression};
use std::path::Path;
use std::process::Command;

fn write(dir: &Path, name: &str, w: u32, h: u32, metres: &[f64]) {
    std::fs::create_dir_all(dir).unwrap();
    let v: Vec<u16> = metres.iter().map(|d| (d * 256.0).round() as u16).collect();
    std::fs::write(
        dir.join(name),
        encode_gray16(w, h, &v, PngCompression::Fast),
    )
    .unwrap();
}

#[test]
fn metrics_match_a_hand_computation() {
    let tmp = tempfile::tempdir().unwrap();
    let (gt, pred) = (tmp.path().join("gt"), tmp.path().join("pred"));
    // Image a: gt 10, 20 valid; 0 (none) and 60 (beyond 50 m) discarded. pred 12, 18.
    write(&gt, "a.png", 2, 2, &[10.0, 20.0, 0.0, 60.0]);
    write(&pred, "a.png", 2, 2, &[12.0, 18.0, 5.0, 30.0]);
    // Image b: gt 4, pred 8 (ratio 2: fails every δ); gt 40, pred 70 → clamped to 50.
    write(&gt, "b.png", 2, 1, &[4.0, 40.0]);
    write(&pred, "b.png", 2, 1, &[8.0, 70.0]);
    let out = Command::new(env!("CARGO_BIN_EXE_panoconv"))
        .args(["eval-depth", "--json", "--pred"])
        .arg(&pred)
        .arg("--gt")
        .arg(&gt)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let m = &j["mean"];
    // by hand, per image then averaged:
    // a: abs_rel (2/10 + 2/20)/2 = 0.15; sq_rel (4/10 + 4/20)/2 = 0.3; rmse sqrt(8/2) = 2;
    //    rmse_log sqrt((ln 1.2² + ln 0.9²)/2); δ1 = δ2 = δ3 = 1
    // b: abs_rel (4/4 + 10/40)/2 = 0.625; sq_rel (16/4 + 100/40)/2 = 3.25; rmse sqrt(116/2);
    //    rmse_log sqrt((ln 2² + ln 1.25²)/2); δ1 0 (2 and 1.25 are not < 1.25); δ2 (1.25 < 1.5625) 0.5; δ3 0.5
    let rl_a = ((1.2f64.ln().powi(2) + 0.9f64.ln().powi(2)) / 2.0).sqrt();
    let rl_b = ((2f64.ln().powi(2) + 1.25f64.ln().powi(2)) / 2.0).sqrt();
    let expect = [
        ("abs_rel", (0.15 + 0.625) / 2.0),
        ("sq_rel", (0.3 + 3.25) / 2.0),
        ("rmse", (2.0 + 58f64.sqrt()) / 2.0),
        ("rmse_log", (rl_a + rl_b) / 2.0),
        ("delta_1", 0.5),
        ("delta_2", 0.75),
        ("delta_3", 0.75),
    ];
    for (k, v) in expect {
        let got = m[k].as_f64().unwrap();
        assert!((got - v).abs() < 1e-12, "{k}: {got} vs {v}");
    }
    assert_eq!(m["pixels"], 4);
    assert_eq!(j["images"], 2);

    // the range flags: with max 100, the 60 m pixel of a counts, and b's 70 m prediction is not clamped
    let out = Command::new(env!("CARGO_BIN_EXE_panoconv"))
        .args(["eval-depth", "--json", "--max-depth", "100", "--pred"])
        .arg(&pred)
        .arg("--gt")
        .arg(&gt)
        .output()
        .unwrap();
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["mean"]["pixels"], 5);
}

#[test]
fn missing_prediction_is_reported_and_counted() {
    let tmp = tempfile::tempdir().unwrap();
    let (gt, pred) = (tmp.path().join("gt"), tmp.path().join("pred"));
    write(&gt, "a.png", 1, 1, &[10.0]);
    write(&gt, "b.png", 1, 1, &[10.0]);
    write(&pred, "a.png", 1, 1, &[11.0]);
    let out = Command::new(env!("CARGO_BIN_EXE_panoconv"))
        .args(["eval-depth", "--pred"])
        .arg(&pred)
        .arg("--gt")
        .arg(&gt)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("b.png not evaluated") && err.contains("No such file"),
        "{err}"
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.starts_with("1 images, 1 pixels"), "{text}");
}
