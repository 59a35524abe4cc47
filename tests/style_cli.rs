//! The style pass through the binary: with an identity geometry (`--to perspective`) the output
//! must equal Python onnxruntime's own result under the CycleGAN convention (references made by
//! scripts/make_style_model.py), and set-up problems stop the run before anything is written.

use panoconv::codec::png::decode_rgb8;
use panoconv::tools::synth::SynthCalib;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common::ort_lib;

/// The tolerance: 1 LSB per channel.
const MAX_LSB: i32 = 1;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/style")
}

/// A one-frame KITTI dataset whose image is the style fixture's input.
fn dataset(root: &Path, input: &str, calib: SynthCalib) {
    let split = root.join("training");
    for d in ["image_2", "calib", "label_2"] {
        std::fs::create_dir_all(split.join(d)).unwrap();
    }
    std::fs::copy(fixtures().join(input), split.join("image_2/000000.png")).unwrap();
    std::fs::write(split.join("calib/000000.txt"), calib.text()).unwrap();
    std::fs::write(split.join("label_2/000000.txt"), "").unwrap();
}

fn run(args: &[&str], input: &Path, output: &Path, lib: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_panoconv"))
        .args(["kitti", "--to", "perspective", "--quiet", "--input"])
        .arg(input)
        .arg("--output")
        .arg(output)
        .arg("--ort-lib")
        .arg(lib)
        .args(args)
        .output()
        .unwrap()
}

fn load(path: &Path) -> panoconv::image::RgbImage {
    decode_rgb8(&std::fs::read(path).unwrap(), path).unwrap()
}

#[test]
fn identity_geometry_with_style_equals_onnxruntime() {
    let model = fixtures().join("generator.onnx");
    for (input, expected, calib) in [
        (
            "input_1242x375.png",
            "expected_1242x375.png",
            SynthCalib::standard(),
        ),
        (
            "input_1224x370.png",
            "expected_1224x370.png",
            SynthCalib::narrow(),
        ),
    ] {
        let tmp = tempfile::tempdir().unwrap();
        let (k, o) = (tmp.path().join("k"), tmp.path().join("o"));
        dataset(&k, input, calib);
        let out = run(&["--style", model.to_str().unwrap()], &k, &o, &ort_lib());
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let got = load(&o.join("training/image_2/000000.png"));
        let want = load(&fixtures().join(expected));
        assert_eq!((got.width(), got.height()), (want.width(), want.height()));
        let max = got
            .as_raw()
            .iter()
            .zip(want.as_raw())
            .map(|(a, b)| (*a as i32 - *b as i32).abs())
            .max()
            .unwrap();
        eprintln!("{input}: max difference {max} LSB");
        assert!(max <= MAX_LSB, "{input}: {max} LSB");
        let manifest: serde_json::Value =
            serde_json::from_slice(&std::fs::read(o.join("panoconv.json")).unwrap()).unwrap();
        let style = &manifest["parameters"]["style"];
        assert_eq!(style["model"]["name"], "generator.onnx");
        assert_eq!(
            style["model"]["blake3"],
            blake3::hash(&std::fs::read(&model).unwrap())
                .to_hex()
                .as_str()
        );
        assert_eq!(style["order"], "before_warp");
    }
}

#[test]
fn missing_library_stops_before_writing() {
    let tmp = tempfile::tempdir().unwrap();
    let (k, o) = (tmp.path().join("k"), tmp.path().join("o"));
    dataset(&k, "input_1224x370.png", SynthCalib::narrow());
    let model = fixtures().join("generator.onnx");
    let out = run(
        &["--style", model.to_str().unwrap()],
        &k,
        &o,
        Path::new("/nonexistent/libonnxruntime.so"),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("install_ort.sh"),
        "the message says how to get the library: {err}"
    );
    assert!(!o.exists(), "nothing may be written");
}

#[test]
fn bad_model_stops_before_writing() {
    let tmp = tempfile::tempdir().unwrap();
    let (k, o) = (tmp.path().join("k"), tmp.path().join("o"));
    dataset(&k, "input_1224x370.png", SynthCalib::narrow());
    for bad in ["bad_one_channel.onnx", "bad_not_onnx.onnx"] {
        let model = fixtures().join(bad);
        let out = run(&["--style", model.to_str().unwrap()], &k, &o, &ort_lib());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{bad}: {err}");
        assert!(err.contains(bad), "the error names the model: {err}");
        assert!(!o.exists(), "{bad}: nothing may be written");
    }
}

#[test]
fn style_after_warp_changes_the_order() {
    let tmp = tempfile::tempdir().unwrap();
    let k = tmp.path().join("k");
    dataset(&k, "input_1242x375.png", SynthCalib::standard());
    let model = fixtures().join("generator.onnx");
    let m = model.to_str().unwrap();
    let lib = ort_lib();
    let equi = |extra: &[&str], o: &Path| {
        let mut args = vec!["--style", m];
        args.extend_from_slice(extra);
        let out = Command::new(env!("CARGO_BIN_EXE_panoconv"))
            .args(["kitti", "--to", "equirect", "--quiet", "--ort-lib"])
            .arg(&lib)
            .arg("--input")
            .arg(&k)
            .arg("--output")
            .arg(o)
            .args(&args)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        std::fs::read(o.join("training/image_2/000000.png")).unwrap()
    };
    let before = equi(&[], &tmp.path().join("a"));
    let after = equi(&["--style-after-warp"], &tmp.path().join("b"));
    assert_ne!(before, after, "the order must matter for a spatial network");
    let manifest = std::fs::read_to_string(tmp.path().join("b/panoconv.json")).unwrap();
    assert!(manifest.contains("\"after_warp\""));
}
