//! The two synthetic rigs end to end: the zero-baseline panorama against the direct render with
//! exact labels and depth, and the offset rig's labels and depth, the same with any thread
//! count, read by the tools (verify, inspect, preview, export, labels-to-pixels, unproject).

use super::{
    check_depth, check_labels, kitti360, labels_back_through_unproject, sequence, truths, wrap,
    written, Truth, LIDAR_STEP, MIN_PSNR_DB, WIDTH,
};
use crate::common::{self, assert_success, panoconv, read_manifest, read_text};
use nalgebra::Vector3;
use panoconv::camera::{Equirect, ImageSize, Rotated};
use panoconv::image::RgbImage;
use panoconv::kitti::LabelFile;
use panoconv::kitti360::classes::kitti_type;
use panoconv::kitti360::{Options, Sequence};
use panoconv::tools::synth360::scene::{objects, scene_at, world_from_scene, world_to_scene};
use panoconv::tools::synth360::SEQUENCE;
use std::path::Path;

#[test]
fn the_zero_baseline_panorama_matches_the_direct_render_with_exact_labels_and_depth() {
    let root = sequence(true);
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    // the resampling is compared without exposure gains (they move the fisheyes by 0.27 %)
    let view = [
        "--to",
        "equirect",
        "--pano-width",
        WIDTH,
        "--frames",
        "250",
        "--no-exposure-gains",
    ];
    let depth = ["--depth", "--lidar-azimuth-step", LIDAR_STEP];
    let run = kitti360(root, &out, &[&view[..], &depth].concat());
    assert_success(&run);
    let w = written(&out, "000250");
    assert_eq!(w.camera.size(), ImageSize::new(720, 360));
    assert!(
        w.centre.norm() < 1e-9,
        "all centres at image_00's: C2 {}",
        w.centre
    );
    check_labels(&w, 250, "zero baseline");
    check_depth(&out, "000250", &w, 250, "zero baseline");

    // the fixed stitch of the same rig: at zero baseline the distance does not matter, so the
    // depth-guided default gives the same figures
    let fixed = tmp.path().join("fixed");
    let fixed_mode = ["--stitch-mode", "fixed"];
    assert_success(&kitti360(root, &fixed, &[&view[..], &fixed_mode].concat()));
    let w_fixed = written(&fixed, "000250");
    let [depth_db, fixed_db] =
        region_psnr(root, [(out.as_path(), &w), (fixed.as_path(), &w_fixed)]);
    for (d, f) in depth_db.iter().zip(&fixed_db) {
        assert!(
            (d - f).abs() <= 0.1,
            "depth-guided {depth_db:?} vs fixed {fixed_db:?} dB"
        );
    }
}

/// Each camera's region of zero-baseline panoramas of one frame (the same output camera)
/// against the scene rendered directly with the blur the stitch gives, dB; each at least
/// [`MIN_PSNR_DB`]. The reference is rendered once for all the panoramas.
fn region_psnr<const N: usize>(root: &Path, outs: [(&Path, &super::Written); N]) -> [[f64; 4]; N] {
    let read = |out: &Path| {
        let split = out.join("training");
        let pano = common::read_rgb8(&split.join("image_2/000250.png"));
        let source = common::read_png(&split.join("source_2/000250.png"));
        assert_eq!(
            (source.color, source.depth),
            (png::ColorType::Grayscale, png::BitDepth::Eight)
        );
        assert!(source.data.iter().all(|&s| s < 4), "the sphere is covered");
        (pano, source)
    };
    let images: Vec<_> = outs.iter().map(|(out, _)| read(out)).collect();
    let seq = Sequence::open(
        root,
        SEQUENCE,
        Options {
            lidar: false,
            ..Options::default()
        },
    )
    .unwrap();
    let w = outs[0].1;
    for (_, other) in &outs {
        assert_eq!(other.camera.intrinsics(), w.camera.intrinsics());
        assert_eq!(other.world_rotation, w.world_rotation);
    }
    let k = w.camera.intrinsics();
    let size = w.camera.size();
    let scene_from_level = world_from_scene().transpose() * w.world_rotation;
    let direct_camera = Rotated::new(Equirect::new(k, size), scene_from_level);
    let centre = world_to_scene(&w.world_translation);
    let scene = scene_at(250);
    let lenses = &seq.calibration.fisheye;
    let mut db = [[0.0; 4]; N];
    for cam in 0..4u8 {
        let source_fu = match cam {
            0 | 1 => seq.calibration.perspective[cam as usize].model.k.fu,
            _ => lenses[cam as usize - 2].centre_intrinsics().fu,
        };
        // the sources' blur (0.55 source px) plus the bilinear tent's own (variance 1/6 px²),
        // on the renderer's fine grid: as tests/kitti360_stitch/direct_render.rs; over the
        // camera's region in any of the panoramas
        let direct: RgbImage = common::render_where(
            &scene,
            &direct_camera,
            &centre,
            (0.55f64 * 0.55 + 1.0 / 6.0).sqrt() * k.fu / source_fu,
            16,
            |u, v| {
                let i = (v * size.width + u) as usize;
                images.iter().any(|(_, source)| source.data[i] == cam)
            },
        );
        for (o, (pano, source)) in images.iter().enumerate() {
            let (mut se, mut n) = (0.0, 0usize);
            for (i, &s) in source.data.iter().enumerate() {
                if s != cam {
                    continue;
                }
                let (u, v) = (i as u32 % size.width, i as u32 / size.width);
                let b = direct.pixel(u, v);
                for (c, want) in b.iter().enumerate() {
                    se += (pano.data[i * 3 + c] as f64 - *want as f64).powi(2);
                }
                n += 1;
            }
            assert!(n > 50, "camera {cam} supplies only {n} px");
            db[o][cam as usize] = 10.0 * (255.0f64 * 255.0 / (se / (3 * n) as f64)).log10();
        }
    }
    for (o, figures) in db.iter().enumerate() {
        let report: Vec<String> = (figures.iter().enumerate())
            .map(|(cam, d)| format!("image_0{cam}: {d:.2} dB"))
            .collect();
        eprintln!(
            "kitti360 --to equirect, zero baseline, vs direct render ({}): {}",
            outs[o].0.display(),
            report.join("; ")
        );
        for region in figures {
            assert!(*region >= MIN_PSNR_DB, "{}", report.join("; "));
        }
    }
    db
}

#[test]
fn the_offset_rig_has_exact_labels_and_depth_the_same_with_any_jobs_and_the_tools_read_it() {
    let root = sequence(false);
    let tmp = tempfile::tempdir().unwrap();
    let (one, two) = (tmp.path().join("one"), tmp.path().join("two"));
    let args = [
        "--to",
        "equirect",
        "--pano-width",
        WIDTH,
        "--depth",
        "--lidar-azimuth-step",
        LIDAR_STEP,
    ];
    let with_jobs = |out: &Path, jobs: &str| {
        let mut a = args.to_vec();
        a.extend(["--jobs", jobs]);
        let run = kitti360(root, out, &a);
        assert_success(&run);
        // every object is written, so the tilted count is the scene's leaning boxes
        let tilted: usize = [250, 251]
            .iter()
            .map(|&f| {
                objects()
                    .iter()
                    .filter(|o| kitti_type(o.kitti_id).is_some())
                    .filter(|o| o.at(f).is_some_and(|b| b.tilt.is_some()))
                    .count()
            })
            .sum();
        assert!(tilted > 0, "the synthetic scene has a leaning bicycle");
        assert!(
            run.stderr
                .contains(&format!("objects written ({tilted} tilted)")),
            "{}",
            run.stderr
        );
    };
    with_jobs(&one, "1");
    with_jobs(&two, "2");
    let (a, b) = (common::tree_bytes(&one), common::tree_bytes(&two));
    let files: Vec<&String> = a.keys().filter(|k| *k != "panoconv.json").collect();
    assert_eq!(files.len(), 2 * 6, "{files:?}");
    for f in files {
        assert!(a[f] == b[f], "{f} differs between --jobs 1 and --jobs 2");
    }
    assert_eq!(read_manifest(&one)["frames"], read_manifest(&two)["frames"]);
    let m = read_manifest(&one);
    assert_eq!(m["command"], "kitti360");
    assert_eq!(m["parameters"]["frame_ids"], "frame");
    for (id, frame) in [("000250", 250), ("000251", 251)] {
        let w = written(&one, id);
        // C2: the mean of the four centres, not image_00's
        assert!(w.centre.norm() > 0.1, "C2 {}", w.centre);
        check_labels(&w, frame, &format!("offset rig, frame {frame}"));
        check_depth(&one, id, &w, frame, &format!("offset rig, frame {frame}"));
        // the objects record counts what was written
        let rec: serde_json::Value =
            serde_json::from_str(&read_text(&one.join(format!("training/objects/{id}.json"))))
                .unwrap();
        assert_eq!(
            rec["counts"]["written"].as_u64().unwrap() as usize,
            w.labels.labels.len()
        );
    }

    // the tools on the output
    let verify = panoconv(["verify", one.to_str().unwrap()]);
    assert_success(&verify);
    let inspect = panoconv(["inspect", one.to_str().unwrap()]);
    assert_success(&inspect);
    assert!(
        inspect.stdout.contains("problems: none"),
        "{}",
        inspect.stdout
    );
    let preview = tmp.path().join("preview.png");
    assert_success(&panoconv([
        "preview",
        one.to_str().unwrap(),
        "--frame",
        "250",
        "--output",
        preview.to_str().unwrap(),
    ]));
    assert_eq!(common::read_rgb8(&preview).width, 720);
    for format in ["coco", "omni3d"] {
        assert_success(&panoconv([
            "export",
            one.to_str().unwrap(),
            "--format",
            format,
            "--output",
            one.join("annotations").to_str().unwrap(),
        ]));
    }
    let coco: serde_json::Value =
        serde_json::from_str(&read_text(&one.join("annotations/instances_train.json"))).unwrap();
    assert_eq!(coco["images"].as_array().unwrap().len(), 2);
    assert_eq!(coco["images"][0]["id"], 250);
    // Omni3D carries each box exactly, the leaning bicycle's pitch and roll too: its corners
    // (camera frame, from C2) are the scene's
    let omni: serde_json::Value =
        serde_json::from_str(&read_text(&one.join("annotations/Omni3D_train.json"))).unwrap();
    let mut tilted_annotations = 0;
    for a in omni["annotations"].as_array().unwrap() {
        let frame = a["image_id"].as_u64().unwrap() as u32;
        let w = written(&one, &format!("{frame:06}"));
        let corners: Vec<Vector3<f64>> = a["bbox3D_cam"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| {
                let v: Vec<f64> = c
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|x| x.as_f64().unwrap())
                    .collect();
                Vector3::new(v[0], v[1], v[2]) + w.centre
            })
            .collect();
        let centroid = corners.iter().sum::<Vector3<f64>>() / 8.0;
        let truth = truths(&w, frame)
            .into_iter()
            .min_by(|p, q| {
                let c = |t: &Truth| t.corners.iter().sum::<Vector3<f64>>() / 8.0;
                (c(p) - centroid)
                    .norm()
                    .total_cmp(&(c(q) - centroid).norm())
            })
            .unwrap();
        for c in &corners {
            let nearest = truth
                .corners
                .iter()
                .map(|t| (t - c).norm())
                .fold(f64::INFINITY, f64::min);
            // 6 decimals in the file, float32-free maths: far below a centimetre
            assert!(
                nearest < 1e-3,
                "{} corner {c} is {nearest} m off",
                truth.kind
            );
        }
        let r = &a["R_cam"];
        if r[1][1].as_f64().unwrap().abs() < (1e-3f64).cos() {
            tilted_annotations += 1;
        }
    }
    assert!(
        tilted_annotations > 0,
        "the leaning bicycle keeps its lean in Omni3D"
    );

    // labels-to-pixels, then unproject: the boxes come back in the level frame, and through
    // Tr_rect_to_world in the world
    let results = labels_back_through_unproject(&one, tmp.path());
    for (id, frame) in [("000250", 250u32), ("000251", 251)] {
        let w = written(&one, id);
        let back = LabelFile::read(&results.join(format!("{id}.txt"))).unwrap();
        assert_eq!(back.labels.len(), w.labels.labels.len());
        let truth = truths(&w, frame);
        for (r, l) in back.labels.iter().zip(&w.labels.labels) {
            assert!(
                (r.location - l.location).norm() < 0.01,
                "{} vs {}",
                r.location,
                l.location
            );
            assert!(wrap(r.rotation_y - l.rotation_y).abs() < 0.01);
            // the box centre in the world
            let centre = r.location - Vector3::new(0.0, r.dimensions[0] / 2.0, 0.0);
            let world = w.world_rotation * centre + w.world_translation;
            let t = truth
                .iter()
                .min_by(|a, b| {
                    (a.world_centre - world)
                        .norm()
                        .total_cmp(&(b.world_centre - world).norm())
                })
                .unwrap();
            assert!(
                (t.world_centre - world).norm() < 0.02,
                "world centre {world} vs {}",
                t.world_centre
            );
        }
    }
}
