//! A rig output of a subset of its cameras (`--cameras`) labels only what those cameras see:
//! on the synthetic nuScenes scene, CAM_BACK alone as a 360° panorama leaves most of it black
//! (`source_2` 255), and no scene object whose exact 2D box lies on black is written; they
//! are counted `uncovered` in the summary and the `objects/` records. With every camera, no
//! object is `uncovered`.

use crate::common::{self, assert_success, panoconv, read_text};
use crate::kitti360_command::{exact_box, truths, written, Written};
use crate::nuscenes_command::scene;
use panoconv::tools::synth360::scene::FIRST_FRAME;
use std::path::Path;

/// `panoconv nuscenes` of the offset-rig scene into a 720 px equirect, with `extra`.
fn convert(out: &Path, extra: &[&str]) -> common::Run {
    let root = scene(false);
    let mut args = vec![
        "nuscenes",
        "--input",
        root.to_str().unwrap(),
        "--version",
        "v1.0-mini",
        "--output",
        out.to_str().unwrap(),
        "--to",
        "equirect",
        "--pano-width",
        "720",
    ];
    args.extend(extra);
    let run = panoconv(&args);
    assert_success(&run);
    run
}

/// The share of `bounds`' pixels (their squares, rounded outwards) where `source_2` is 255.
fn black_share(source: &common::Png, bounds: [f64; 4]) -> f64 {
    let (w, h) = (source.width as usize, source.height as usize);
    let (u0, v0) = (bounds[0].floor() as usize, bounds[1].floor() as usize);
    let (u1, v1) = (
        (bounds[2].ceil() as usize).min(w - 1),
        (bounds[3].ceil() as usize).min(h - 1),
    );
    let mut black = 0usize;
    for v in v0..=v1 {
        black += source.data[v * w + u0..=v * w + u1]
            .iter()
            .filter(|&&s| s == 255)
            .count();
    }
    black as f64 / ((u1 - u0 + 1) * (v1 - v0 + 1)) as f64
}

/// The `dropped` reasons of a frame's `objects/` record.
fn reasons(out: &Path, id: &str) -> Vec<String> {
    let text = read_text(&out.join(format!("training/objects/{id}.json")));
    let record: serde_json::Value = serde_json::from_str(&text).unwrap();
    record["objects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| o["dropped"].as_str().unwrap_or("written").to_string())
        .collect()
}

/// Whether a label of `w` stands at `location` (to the labels' centimetre).
fn labelled(w: &Written, location: &nalgebra::Vector3<f64>) -> bool {
    w.labels
        .labels
        .iter()
        .any(|l| l.kind != "DontCare" && (l.location - location).norm() < 0.02)
}

#[test]
fn a_camera_subset_writes_no_object_its_cameras_do_not_see() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("back");
    let run = convert(&out, &["--cameras", "CAM_BACK", "--min-visible", "2,0.1"]);
    let (mut on_black, mut seen, mut uncovered) = (0, 0, 0);
    for (frame, id) in ["000000", "000001"].iter().enumerate() {
        let w = written(&out, id);
        let source = common::read_png(&out.join(format!("training/source_2/{id}.png")));
        for t in truths(&w, FIRST_FRAME + frame as u32) {
            let Some(bounds) = exact_box(&w, &t.corners) else {
                continue;
            };
            // an object wholly on black (the stitch gives none of its pixels) is no label
            let black = black_share(&source, bounds);
            if black > 0.99 {
                on_black += 1;
                assert!(!labelled(&w, &t.location), "{id}: {} on black", t.kind);
            }
        }
        // every written object is where the camera gives the image
        for l in w.labels.labels.iter().filter(|l| l.kind != "DontCare") {
            seen += 1;
            let black = black_share(&source, l.bbox);
            assert!(
                black < 0.9,
                "{id}: {} {:?}: {black} on black",
                l.kind,
                l.bbox
            );
        }
        uncovered += reasons(&out, id)
            .iter()
            .filter(|r| *r == "uncovered")
            .count();
    }
    assert!(
        on_black >= 10 && seen >= 3,
        "{on_black} on black, {seen} seen"
    );
    assert!(uncovered >= on_black, "{uncovered} uncovered, {on_black}");
    let line = format!("panoconv: {uncovered} objects dropped: on no pixel");
    assert!(run.stderr.contains(&line), "{}", run.stderr);
}

#[test]
fn with_every_camera_no_object_is_uncovered() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("all");
    let run = convert(&out, &[]);
    for id in ["000000", "000001"] {
        let reasons = reasons(&out, id);
        assert!(reasons.iter().any(|r| r == "written"));
        assert!(!reasons.iter().any(|r| r == "uncovered"), "{reasons:?}");
    }
    assert!(!run.stderr.contains("on no pixel"), "{}", run.stderr);
}
