//! `panoconv kitti360 --style` with a model that refuses one camera's image: the failed frame's
//! error names the image that was refused, whichever camera of `--cameras` it belongs to, and
//! the frame writes nothing.
//!
//! The model is a real ONNX file, written here: y = x + c with c of shape [1, 1, 96, 1], so
//! ONNX Runtime runs it on an image padded to 96 rows (the fixture's perspective cameras,
//! 352x94) and refuses one of 352 rows (its fisheye cameras, 350x350: the shapes do not
//! broadcast).

use crate::common::{ort_lib, read_manifest, Run};
use crate::kitti360_command::kitti360;
use std::path::{Path, PathBuf};

/// Protobuf's base-128 varint.
fn varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// A varint field.
fn int(out: &mut Vec<u8>, field: u64, v: u64) {
    varint(out, field << 3);
    varint(out, v);
}

/// A length-delimited field (bytes, string or message).
fn bytes(out: &mut Vec<u8>, field: u64, b: &[u8]) {
    varint(out, (field << 3) | 2);
    varint(out, b.len() as u64);
    out.extend_from_slice(b);
}

/// A message of the fields `f` writes.
fn message(f: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut m = Vec::new();
    f(&mut m);
    m
}

/// ONNX's ValueInfoProto of a float32 tensor [1, 3, h, w] (h and w dynamic).
fn image_value(name: &str) -> Vec<u8> {
    let shape = message(|s| {
        bytes(s, 1, &message(|d| int(d, 1, 1)));
        bytes(s, 1, &message(|d| int(d, 1, 3)));
        bytes(s, 1, &message(|d| bytes(d, 2, b"h")));
        bytes(s, 1, &message(|d| bytes(d, 2, b"w")));
    });
    let tensor = message(|t| {
        int(t, 1, 1); // FLOAT
        bytes(t, 2, &shape);
    });
    message(|v| {
        bytes(v, 1, name.as_bytes());
        bytes(v, 2, &message(|t| bytes(t, 1, &tensor)));
    })
}

/// The ONNX model y = x + c, c zeros of shape [1, 1, rows, 1].
fn add_model(rows: u64) -> Vec<u8> {
    let constant = message(|t| {
        for d in [1, 1, rows, 1] {
            int(t, 1, d);
        }
        int(t, 2, 1); // FLOAT
        bytes(t, 8, b"c");
        bytes(t, 9, &vec![0u8; 4 * rows as usize]);
    });
    let node = message(|n| {
        bytes(n, 1, b"x");
        bytes(n, 1, b"c");
        bytes(n, 2, b"y");
        bytes(n, 3, b"add");
        bytes(n, 4, b"Add");
    });
    let graph = message(|g| {
        bytes(g, 1, &node);
        bytes(g, 2, b"refuses_other_heights");
        bytes(g, 5, &constant);
        bytes(g, 11, &image_value("x"));
        bytes(g, 12, &image_value("y"));
    });
    message(|m| {
        int(m, 1, 8); // IR version
        bytes(m, 2, b"panoconv tests");
        bytes(m, 7, &graph);
        bytes(m, 8, &message(|o| int(o, 2, 17)));
    })
}

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/kitti360")
}

fn kitti360_styled(output: &Path, model: &Path, cameras: &str) -> Run {
    let lib = ort_lib();
    let args = [
        "--frames",
        "250",
        "--cameras",
        cameras,
        "--to",
        "equirect",
        "--pano-width",
        "360",
        "--style",
        model.to_str().unwrap(),
        "--ort-lib",
        lib.to_str().unwrap(),
        "--jobs",
        "1",
    ];
    kitti360(&fixture(), output, &args)
}

#[test]
fn a_style_failure_names_the_image_the_model_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let model = tmp.path().join("refuses_other_heights.onnx");
    std::fs::write(&model, add_model(96)).unwrap();
    let refused = "image_02/data_rgb/0000000250.png";
    let accepted = "image_00/data_rect/0000000250.png";
    // the refused image second, then first
    for (k, cameras) in ["00,02", "02,00"].into_iter().enumerate() {
        let out = tmp.path().join(format!("out{k}"));
        let run = kitti360_styled(&out, &model, cameras);
        assert_eq!(run.code, 1, "--cameras {cameras}: {}", run.stderr);
        let failures = run.frame_failures();
        assert_eq!(failures.len(), 1, "--cameras {cameras}: {}", run.stderr);
        let line = failures[0];
        assert!(
            line.contains(refused) && line.contains("style pass") && !line.contains(accepted),
            "--cameras {cameras}: {line}"
        );
        let manifest = read_manifest(&out);
        let frames = manifest["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 1, "{manifest}");
        let error = frames[0]["error"].as_str().unwrap();
        assert!(error.contains(refused), "--cameras {cameras}: {error}");
        assert!(frames[0]["outputs"]
            .as_array()
            .is_none_or(|outputs| outputs.is_empty()));
        let image = out.join("training/image_2/000250.png");
        assert!(
            !image.exists(),
            "--cameras {cameras}: the failed frame wrote its image"
        );
    }
    // the same model styles the other camera's image: the refusal is the image's, not the model's
    let out = tmp.path().join("accepted");
    let run = kitti360_styled(&out, &model, "00");
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert!(out.join("training/image_2/000250.png").is_file());
}
