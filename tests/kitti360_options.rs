//! `panoconv kitti360 --style` and `--augment` through the binary, on the synthetic offset rig:
//! the style pass is the stitch of the individually styled camera images (labels, calib, depth
//! and the source map untouched), and every augmented view keeps exact labels, calib and depth.

use crate::common::{self, assert_success, iou, ort_lib, panoconv, read_manifest};
use crate::kitti360_command::{
    check_depth_share, exact_box, kitti360, labels_back_through_unproject, sequence, truths, wrap,
    written, LIDAR_STEP, MIN_IOU, ROUNDING,
};
use nalgebra::Vector3;
use panoconv::kitti::LabelFile;
use panoconv::kitti360::{Options, Sequence};
use panoconv::style::{Device, StyleModel, StyleOptions};
use panoconv::tools::synth360::SEQUENCE;
use std::path::{Path, PathBuf};

fn model() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/style/generator.onnx")
}

/// The files of an output under `training/FOLDER/`, by name.
fn folder(out: &Path, name: &str) -> std::collections::BTreeMap<String, Vec<u8>> {
    common::tree_bytes(&out.join("training").join(name))
}

#[test]
fn style_is_the_stitch_of_the_styled_cameras_and_leaves_the_labels_alone() {
    let root = sequence(false);
    let tmp = tempfile::tempdir().unwrap();
    let (lib, model) = (ort_lib(), model());
    let (lib_s, model_s) = (lib.to_str().unwrap(), model.to_str().unwrap());
    let base = [
        "--to",
        "equirect",
        "--pano-width",
        "360",
        "--depth",
        "--lidar-azimuth-step",
        LIDAR_STEP,
    ];
    let convert = |input: &Path, out: &Path, extra: &[&str]| {
        let mut args = base.to_vec();
        args.extend(extra);
        let run = kitti360(input, out, &args);
        assert_success(&run);
        run
    };
    let plain = tmp.path().join("plain");
    convert(root, &plain, &[]);
    let (one, two) = (tmp.path().join("one"), tmp.path().join("two"));
    let styled = ["--style", model_s, "--ort-lib", lib_s];
    let run = convert(root, &one, &[&styled[..], &["--jobs", "1"]].concat());
    assert!(run.stderr.contains("style pass: "), "{}", run.stderr);
    convert(root, &two, &[&styled[..], &["--jobs", "2"]].concat());

    // deterministic whatever the thread count
    let (a, b) = (common::tree_bytes(&one), common::tree_bytes(&two));
    assert_eq!(a.len(), b.len());
    for (name, bytes) in &a {
        if name != "panoconv.json" {
            assert!(b[name] == *bytes, "{name} differs between --jobs 1 and 2");
        }
    }
    // the manifest records the model by its hash
    let style = &read_manifest(&one)["parameters"]["style"];
    let hash = blake3::hash(&std::fs::read(&model).unwrap()).to_hex();
    assert_eq!(style["blake3"], hash.as_str(), "{style}");
    assert_eq!(style["name"], "generator.onnx");
    assert!(read_manifest(&plain)["parameters"].get("style").is_none());

    // labels, calib, depth and the source map are the unstyled run's
    for name in ["label_2", "calib", "depth_2", "source_2"] {
        assert_eq!(folder(&one, name), folder(&plain, name), "{name}");
    }
    // the image differs where a camera gives the pixel, and only there
    for id in ["000250", "000251"] {
        let image = |out: &Path| common::read_rgb8(&out.join(format!("training/image_2/{id}.png")));
        let (s, p) = (image(&one), image(&plain));
        let source = common::read_png(&one.join(format!("training/source_2/{id}.png")));
        let (mut covered, mut changed) = (0usize, 0usize);
        for (i, cam) in source.data.iter().enumerate() {
            let differs = s.data[i * 3..i * 3 + 3] != p.data[i * 3..i * 3 + 3];
            if *cam == 255 {
                assert!(!differs, "{id}: pixel {i} has no camera but changed");
            } else {
                covered += 1;
                changed += usize::from(differs);
            }
        }
        eprintln!("style, frame {id}: {changed} of {covered} covered pixels changed");
        assert!(
            covered > 0 && changed * 10 > covered * 9,
            "{changed} of {covered}"
        );
    }

    // the same as styling each camera's image on its own, then stitching without --style
    let copy = tmp.path().join("styled_input");
    common::copy_tree(root, &copy);
    let style_model = StyleModel::load(&StyleOptions {
        model: model.clone(),
        ort_lib: Some(lib.clone()),
        device: Device::Cpu,
        intra_threads: 1,
    })
    .unwrap();
    let seq = Sequence::open(
        &copy,
        SEQUENCE,
        Options {
            lidar: false,
            ..Options::default()
        },
    )
    .unwrap();
    for number in [250, 251] {
        for camera in &seq.frame(number).unwrap().rig {
            let png = common::read_rgb8(&camera.image);
            let image =
                panoconv::image::RgbImage::from_raw(png.width, png.height, png.data).unwrap();
            let out = style_model.stylize(&image).unwrap();
            common::write_png(
                &camera.image,
                &common::Png {
                    width: out.width(),
                    height: out.height(),
                    color: png::ColorType::Rgb,
                    depth: png::BitDepth::Eight,
                    data: out.as_raw().to_vec(),
                },
            );
        }
    }
    let restitched = tmp.path().join("restitched");
    convert(&copy, &restitched, &[]);
    for name in ["image_2", "objects", "label_2", "depth_2", "source_2"] {
        assert!(
            folder(&restitched, name) == folder(&one, name),
            "{name}: --style differs from the stitch of the styled cameras"
        );
    }

    // a missing runtime library or model is a set-up error before anything is written
    let missing = tmp.path().join("no_ort");
    let run = kitti360(
        root,
        &missing,
        &[
            &base[..],
            &[
                "--style",
                model_s,
                "--ort-lib",
                "/nonexistent/libonnxruntime.so",
            ],
        ]
        .concat(),
    );
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr.contains("libonnxruntime") && !run.stderr.contains("panicked"),
        "{}",
        run.stderr
    );
    assert!(!missing.exists());
    let run = kitti360(
        root,
        &missing,
        &[&base[..], &["--style", "/nonexistent/model.onnx"]].concat(),
    );
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("no such model file"), "{}", run.stderr);
    assert!(!missing.exists());
}

#[test]
fn augmented_views_keep_exact_labels_calib_and_depth() {
    let root = sequence(false);
    let tmp = tempfile::tempdir().unwrap();
    let (one, two) = (tmp.path().join("one"), tmp.path().join("two"));
    let args = [
        "--to",
        "equirect",
        "--pano-width",
        "720",
        "--frames",
        "250",
        "--augment",
        "3",
        "--seed",
        "7",
        "--scale-range",
        "0.9,1.2",
        "--crop-size",
        "480x240",
        "--min-objects",
        "3",
        "--depth",
        "--lidar-azimuth-step",
        LIDAR_STEP,
    ];
    for (out, jobs) in [(&one, "1"), (&two, "2")] {
        assert_success(&kitti360(
            root,
            out,
            &[&args[..], &["--jobs", jobs]].concat(),
        ));
    }
    let (a, b) = (common::tree_bytes(&one), common::tree_bytes(&two));
    let files: Vec<&String> = a.keys().filter(|k| *k != "panoconv.json").collect();
    // three views of six files each
    assert_eq!(files.len(), 3 * 6, "{files:?}");
    for f in files {
        assert!(a[f] == b[f], "{f} differs between --jobs 1 and --jobs 2");
    }
    let m = read_manifest(&one);
    assert_eq!(m["frames"], read_manifest(&two)["frames"]);
    assert_eq!(m["parameters"]["augment"]["count"], 3);
    let record = &m["frames"][0];
    assert_eq!(record["id"], "000250");
    let views = record["views"].as_array().unwrap();
    let ids: Vec<&str> = views.iter().map(|v| v["id"].as_str().unwrap()).collect();
    // frame × count + view
    assert_eq!(ids, ["000750", "000751", "000752"]);
    let mut scales = Vec::new();
    for (view, id) in views.iter().zip(&ids) {
        let scale = view["scale"].as_f64().unwrap();
        assert!((0.9..=1.2).contains(&scale), "{view}");
        scales.push(scale);
        let w = written(&one, id);
        assert_eq!(w.camera.size(), panoconv::camera::ImageSize::new(480, 240));
        let what = format!("augmented view {id} (scale {scale:.3})");
        // every written object is one of the scene's, exactly; every object whose box lies in
        // the view (more than a sliver) is written
        let truth: Vec<_> = truths(&w, 250)
            .into_iter()
            .filter(|t| (t.corners.iter().sum::<Vector3<f64>>() / 8.0 - w.centre).norm() <= 80.0)
            .collect();
        // objects, and the regions of those too little visible to be objects (--min-visible)
        let (regions, objects): (Vec<_>, Vec<_>) =
            w.labels.labels.iter().partition(|l| l.kind == "DontCare");
        assert!(objects.len() >= 3, "{what}: --min-objects 3");
        for l in objects {
            let t = truth
                .iter()
                .min_by(|a, b| {
                    (a.location - l.location)
                        .norm()
                        .total_cmp(&(b.location - l.location).norm())
                })
                .unwrap();
            assert_eq!(l.kind, t.kind, "{what}");
            assert!(
                (0..3).all(|i| (l.location[i] - t.location[i]).abs() <= ROUNDING),
                "{what}: {} vs {}",
                l.location,
                t.location
            );
            assert!(
                wrap(l.rotation_y - t.rotation_y).abs() <= ROUNDING,
                "{what}"
            );
            let exact = exact_box(&w, &t.corners).expect("a written object is in the view");
            // (a sliver at the view's edge, a fraction of a pixel wide, is held to the labels'
            // rounding instead: its IoU measures the rounding)
            let score = iou(l.bbox, exact);
            let off = (0..4)
                .map(|i| (l.bbox[i] - exact[i]).abs())
                .fold(0.0, f64::max);
            assert!(
                score >= MIN_IOU || off <= 0.01,
                "{what}: {:?} vs {exact:?}: {score}",
                l.bbox
            );
        }
        for t in &truth {
            let Some(b) = exact_box(&w, &t.corners) else {
                continue;
            };
            if (b[2] - b[0]) * (b[3] - b[1]) >= 4.0 {
                let written = w
                    .labels
                    .labels
                    .iter()
                    .any(|l| (l.location - t.location).norm() <= 2.0 * ROUNDING);
                let region = regions
                    .iter()
                    .any(|r| (0..4).all(|i| (r.bbox[i] - b[i]).abs() <= 0.01));
                assert!(
                    written || region,
                    "{what}: the {} at {} ({b:?}) is missing",
                    t.kind,
                    t.location
                );
            }
        }
        eprintln!("{what}: {} objects", w.labels.labels.len());
        // (the 99.5 % holds over a whole panorama; a view drawn to hold three objects
        // is mostly their edges, where a LiDAR step's mixed pixels fall: 99 % of its pixels)
        check_depth_share(&one, id, &w, 250, &what, 0.99, false);
    }
    assert!(
        scales.windows(2).any(|s| s[0] != s[1]),
        "the views are drawn: {scales:?}"
    );

    // labels-to-pixels, then unproject: the boxes come back in each view's level frame, and
    // through Tr_rect_to_world at the scene's world boxes
    let results = labels_back_through_unproject(&one, tmp.path());
    for id in &ids {
        let w = written(&one, id);
        let back = LabelFile::read(&results.join(format!("{id}.txt"))).unwrap();
        // (DontCare regions have no 3D box to take back)
        let objects: Vec<_> = w
            .labels
            .labels
            .iter()
            .filter(|l| l.kind != "DontCare")
            .collect();
        assert_eq!(back.labels.len(), objects.len());
        let truth = truths(&w, 250);
        for (r, l) in back.labels.iter().zip(objects) {
            assert!((r.location - l.location).norm() < 0.01, "{id}");
            let centre = r.location - Vector3::new(0.0, r.dimensions[0] / 2.0, 0.0);
            let world = w.world_rotation * centre + w.world_translation;
            let nearest = truth
                .iter()
                .map(|t| (t.world_centre - world).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(
                nearest < 0.02,
                "{id}: world centre {world} is {nearest} m off"
            );
        }
    }
    assert_success(&panoconv(["verify", one.to_str().unwrap()]));
}
