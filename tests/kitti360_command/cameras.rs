//! Per-camera options: one camera converted alone is a plain conversion of it, and an ego mask
//! keeps its camera out of the masked pixels.

use super::{exact_box, kitti360, sequence, truths, written, MIN_IOU, WIDTH};
use crate::common::{self, assert_success, iou, panoconv, read_manifest, read_text};
use nalgebra::Point2;
use panoconv::kitti360::{Options, Sequence};
use panoconv::tools::synth360::SEQUENCE;
use std::path::Path;

#[test]
fn one_camera_is_a_plain_conversion_of_it() {
    let root = sequence(false);
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let run = kitti360(
        root,
        &out,
        &[
            "--to",
            "cylindrical",
            "--cameras",
            "02",
            "--frames",
            "250",
            "--pano-width",
            WIDTH,
        ],
    );
    assert_success(&run);
    let source = common::read_png(&out.join("training/source_2/000250.png"));
    assert!(source.data.iter().all(|&s| s == 2 || s == 255));
    let seen = source.data.iter().filter(|&&s| s == 2).count();
    // the tight cylinder around a 185° lens: its circle fills a little over half of it
    assert!(
        seen * 2 > source.data.len(),
        "{seen} of {} px",
        source.data.len()
    );
    let w = written(&out, "000250");
    // C2 is image_02's centre
    let seq = Sequence::open(root, SEQUENCE, Options::default()).unwrap();
    let frame = seq.frame(250).unwrap();
    assert!((w.centre - frame.rig[2].centre()).norm() < 1e-9);
    assert_eq!(
        read_text(&out.join("training/calib/000250.txt"))
            .lines()
            .find(|l| l.starts_with("projection:")),
        Some("projection: cylindrical")
    );
    // the objects on the left of the rig are in it, with exact boxes
    assert!(w.labels.labels.len() >= 2, "{:?}", w.labels.labels);
    let truth = truths(&w, 250);
    for l in &w.labels.labels {
        let t = truth
            .iter()
            .min_by(|a, b| {
                (a.location - l.location)
                    .norm()
                    .total_cmp(&(b.location - l.location).norm())
            })
            .unwrap();
        assert!((t.location - l.location).norm() < 0.01);
        let exact = exact_box(&w, &t.corners).unwrap();
        assert!(iou(l.bbox, exact) >= MIN_IOU, "{:?} vs {exact:?}", l.bbox);
    }
    assert_success(&panoconv(["verify", out.to_str().unwrap()]));
}

#[test]
fn an_ego_mask_keeps_its_camera_out_of_the_masked_pixels() {
    let root = sequence(false);
    let tmp = tempfile::tempdir().unwrap();
    let seq = Sequence::open(root, SEQUENCE, Options::default()).unwrap();
    let frame = seq.frame(250).unwrap();
    let lens = &frame.rig[2];
    let size = lens.model.size();
    // the car's body: the lower third of image_02 (a side fisheye sees the doors there)
    let body = |x: i64, y: i64| {
        x >= 0 && x < size.width as i64 && y >= 2 * size.height as i64 / 3 && y < size.height as i64
    };
    let mut data = vec![0u8; (size.width * size.height) as usize];
    for y in 0..size.height as i64 {
        for x in 0..size.width as i64 {
            if body(x, y) {
                data[(y * size.width as i64 + x) as usize] = 200;
            }
        }
    }
    let mask = tmp.path().join("image_02_mask.png");
    common::write_png(
        &mask,
        &common::Png {
            width: size.width,
            height: size.height,
            color: png::ColorType::Grayscale,
            depth: png::BitDepth::Eight,
            data,
        },
    );
    let flag = format!("02={}", mask.display());
    let base = ["--to", "equirect", "--pano-width", "360", "--frames", "250"];
    let plain = tmp.path().join("plain");
    assert_success(&kitti360(root, &plain, &base));
    let masked = tmp.path().join("masked");
    let mut args = base.to_vec();
    args.extend(["--ego-mask", &flag]);
    assert_success(&kitti360(root, &masked, &args));

    // an output pixel whose image_02 sample (through the proxy point, s = 10 m) lands on the
    // body: from image_02 without the mask, never from it with the mask
    let w = written(&masked, "000250");
    let sources = |out: &Path| common::read_png(&out.join("training/source_2/000250.png")).data;
    let (before, after) = (sources(&plain), sources(&masked));
    let width = 360usize;
    let (mut on_body, mut was_02) = (0, 0);
    for (i, (&b, &a)) in before.iter().zip(&after).enumerate() {
        let p = Point2::new((i % width) as f64, (i / width) as f64);
        let Ok(d) = w.camera.unproject(&p) else {
            continue;
        };
        let Some(q) = lens.project(&(w.centre + d * 10.0)) else {
            continue;
        };
        if body(q.x.round() as i64, q.y.round() as i64) {
            on_body += 1;
            was_02 += usize::from(b == 2);
            assert_ne!(a, 2, "pixel {p} takes image_02's body at {q}");
        }
    }
    assert!(
        was_02 > 100,
        "{was_02} of {on_body} body pixels came from image_02"
    );
    // the other pixels of image_02 are still its own
    let kept = after.iter().filter(|&&s| s == 2).count();
    assert!(kept > 1000, "{kept}");

    // the manifest records the mask with its hash
    let m = read_manifest(&masked);
    let rec = &m["parameters"]["ego_masks"][0];
    assert_eq!(rec["camera"], "image_02");
    assert_eq!(rec["hash"], common::hash_file(&mask));
    assert!(read_manifest(&plain)["parameters"]
        .get("ego_masks")
        .is_none());

    // a mask of another size: a set-up error naming the file, nothing written
    let small = tmp.path().join("small.png");
    common::write_png(
        &small,
        &common::Png {
            width: 8,
            height: 8,
            color: png::ColorType::Grayscale,
            depth: png::BitDepth::Eight,
            data: vec![0; 64],
        },
    );
    let flag = format!("02={}", small.display());
    let bad = tmp.path().join("bad");
    let mut args = base.to_vec();
    args.extend(["--ego-mask", &flag]);
    let run = kitti360(root, &bad, &args);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("small.png"), "{}", run.stderr);
    assert!(!bad.exists());
    // a mask for a camera not used, and a malformed flag
    let flag = format!("01={}", mask.display());
    let mut args = base.to_vec();
    args.extend(["--cameras", "02,03", "--ego-mask", &flag]);
    let run = kitti360(root, &bad, &args);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("image_02_mask.png") && run.stderr.contains("image_01"));
    let mut args = base.to_vec();
    args.extend(["--ego-mask", "image_02.png"]);
    let run = kitti360(root, &bad, &args);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("CAMERA=PATH"), "{}", run.stderr);
}
