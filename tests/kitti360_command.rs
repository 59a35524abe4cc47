//! `panoconv kitti360` through the real binary on synthetic sequences (`panoconv synth
//! --kitti360`): the zero-baseline rig's panorama against the scene rendered directly, every
//! visible object with its exact location and 2D box, the depth map against the scene, the
//! realistic-offset rig's labels and depth, the round trip through `labels-to-pixels` and
//! `unproject` into the level frame and the world, the tools on the output, bad input, thread
//! counts, and one camera converted alone.

use crate::common::{self, assert_success, iou, panoconv, read_manifest, read_text, BIN};
use nalgebra::{Matrix3, Point2, Vector3};
use panoconv::camera::{Equirect, ImageSize, OutputCamera, Rotated};
use panoconv::image::RgbImage;
use panoconv::kitti::{Calib, Cam, LabelFile};
use panoconv::kitti360::classes::kitti_type;
use panoconv::kitti360::{Options, Sequence};
use panoconv::tools::synth360::scene::{
    objects, scene_at, world_from_scene, world_to_scene, world_transform,
};
use panoconv::tools::synth360::SEQUENCE;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The bars of the issue.
const MIN_PSNR_DB: f64 = 50.0;
pub(crate) const MIN_IOU: f64 = 0.99;
/// Labels are written with two decimals.
pub(crate) const ROUNDING: f64 = 0.005 + 1e-6;
const DEPTH_TOLERANCE: f64 = 0.05;
const MIN_DEPTH_CORRECT: f64 = 0.995;
const MAX_DEPTH_LEAKS: f64 = 0.002;
/// Panorama width of the tests: two pixels per degree.
const WIDTH: &str = "720";
/// The synthetic sweep's azimuth step at scale 0.25 (0.2° / 0.25).
pub(crate) const LIDAR_STEP: &str = "0.8";

/// A synthetic sequence (scale 0.25, two frames), made once per binary build.
pub(crate) fn sequence(zero_baseline: bool) -> &'static Path {
    static ZERO: OnceLock<PathBuf> = OnceLock::new();
    static OFFSET: OnceLock<PathBuf> = OnceLock::new();
    let cell = if zero_baseline { &ZERO } else { &OFFSET };
    cell.get_or_init(|| {
        let bin = std::fs::read(BIN).expect("read the panoconv binary");
        let key = &blake3::hash(&bin).to_hex()[..16];
        let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("panoconv-kitti360");
        std::fs::create_dir_all(&root).unwrap();
        let name = if zero_baseline { "zero" } else { "offset" };
        let dir = root.join(format!("{name}-{key}"));
        if dir.is_dir() {
            return dir;
        }
        for e in std::fs::read_dir(&root).unwrap().flatten() {
            if e.file_name()
                .to_string_lossy()
                .starts_with(&format!("{name}-"))
            {
                let _ = std::fs::remove_dir_all(e.path());
            }
        }
        let tmp = root.join(format!("tmp-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&tmp);
        let mut args = vec!["synth", "--kitti360", "--scale", "0.25", "--frames", "2"];
        if zero_baseline {
            args.push("--zero-baseline");
        }
        let tmp_s = tmp.to_str().unwrap().to_owned();
        args.extend(["--output", &tmp_s]);
        assert_success(&panoconv(&args));
        if std::fs::rename(&tmp, &dir).is_err() {
            let _ = std::fs::remove_dir_all(&tmp);
            assert!(dir.is_dir(), "synthetic sequence cache missing");
        }
        dir
    })
}

/// `panoconv kitti360 --input ROOT --sequence SEQ --output OUT EXTRA...`
pub(crate) fn kitti360(root: &Path, output: &Path, extra: &[&str]) -> common::Run {
    let mut args = vec![
        "kitti360",
        "--input",
        root.to_str().unwrap(),
        "--sequence",
        SEQUENCE,
        "--output",
        output.to_str().unwrap(),
    ];
    args.extend(extra);
    panoconv(&args)
}

/// One converted frame read back through its written files only.
pub(crate) struct Written {
    pub(crate) camera: Box<dyn OutputCamera>,
    pub(crate) centre: Vector3<f64>,
    /// Tr_rect_to_world: level frame → world.
    pub(crate) world_rotation: Matrix3<f64>,
    pub(crate) world_translation: Vector3<f64>,
    pub(crate) labels: LabelFile,
}

pub(crate) fn written(out: &Path, id: &str) -> Written {
    let split = out.join("training");
    let calib = Calib::read(&split.join(format!("calib/{id}.txt"))).unwrap();
    let image = common::read_rgb8(&split.join(format!("image_2/{id}.png")));
    let (camera, centre) = calib
        .output_camera(Cam::C2, ImageSize::new(image.width, image.height))
        .unwrap();
    let text = read_text(&split.join(format!("calib/{id}.txt")));
    let w = common::calib_values(&text, "Tr_rect_to_world").expect("a Tr_rect_to_world: line");
    assert_eq!(w.len(), 12);
    assert_eq!(calib.r0_rect, Some(Matrix3::identity()));
    Written {
        camera,
        centre,
        world_rotation: Matrix3::new(w[0], w[1], w[2], w[4], w[5], w[6], w[8], w[9], w[10]),
        world_translation: Vector3::new(w[3], w[7], w[11]),
        labels: LabelFile::read(&split.join(format!("label_2/{id}.txt"))).unwrap(),
    }
}

/// A scene object at a frame, in the written frame's level frame.
pub(crate) struct Truth {
    pub(crate) kind: &'static str,
    /// Bottom centre (KITTI's location), level frame.
    pub(crate) location: Vector3<f64>,
    pub(crate) rotation_y: f64,
    /// The box's corners, level frame.
    pub(crate) corners: [Vector3<f64>; 8],
    /// Centre, world.
    pub(crate) world_centre: Vector3<f64>,
}

pub(crate) fn wrap(a: f64) -> f64 {
    (a + PI).rem_euclid(2.0 * PI) - PI
}

pub(crate) fn truths(w: &Written, frame: u32) -> Vec<Truth> {
    let level_from_world = w.world_rotation.try_inverse().unwrap();
    let to_level = |p: Vector3<f64>| level_from_world * (p - w.world_translation);
    objects()
        .iter()
        .filter_map(|o| {
            let kind = kitti_type(o.kitti_id)?;
            let b = o.at(frame)?;
            let m = world_transform(&b);
            let r = m.fixed_view::<3, 3>(0, 0).into_owned();
            let t = m.fixed_view::<3, 1>(0, 3).into_owned();
            let corners = std::array::from_fn(|i| {
                let s = |bit: usize| if i >> bit & 1 == 1 { 0.5 } else { -0.5 };
                to_level(r * Vector3::new(s(0), s(1), s(2)) + t)
            });
            // the length axis (the box's X) in the level frame
            let x = level_from_world * r.column(0).normalize();
            // KITTI's location: the centre moved down by half the height (for an upright box
            // its bottom face's centre; a tilted box, the leaning bicycle, keeps its centre)
            let height = r.column(2).norm();
            let location = to_level(t) + Vector3::new(0.0, height / 2.0, 0.0);
            Some(Truth {
                kind,
                location,
                rotation_y: (-x.z).atan2(x.x),
                corners,
                world_centre: t,
            })
        })
        .collect()
}

/// The exact 2D box of a box (level-frame corners) in the written camera: its faces sampled
/// densely, unwrapped about the centroid's column on a panorama, clipped as KITTI's.
pub(crate) fn exact_box(w: &Written, corners: &[Vector3<f64>; 8]) -> Option<[f64; 4]> {
    let size = w.camera.size();
    let centroid = corners.iter().sum::<Vector3<f64>>() / 8.0 - w.centre;
    let ref_u = w.camera.project_point(&centroid).ok()?.x;
    let period = w.camera.horizontal_period();
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    const N: usize = 80;
    // faces: fix one bit of the corner index
    for axis in 0..3 {
        for side in 0..2 {
            let pick = |i: usize, j: usize| -> Vector3<f64> {
                let mut idx = [0usize; 3];
                idx[axis] = side;
                let others: Vec<usize> = (0..3).filter(|&a| a != axis).collect();
                idx[others[0]] = i;
                idx[others[1]] = j;
                corners[idx[0] | idx[1] << 1 | idx[2] << 2]
            };
            let (p00, p10, p01) = (pick(0, 0), pick(1, 0), pick(0, 1));
            for a in 0..=N {
                for c in 0..=N {
                    let (s, t) = (a as f64 / N as f64, c as f64 / N as f64);
                    let p = p00 + (p10 - p00) * s + (p01 - p00) * t - w.centre;
                    let Ok(mut px) = w.camera.project_point(&p) else {
                        continue;
                    };
                    if let Some(per) = period {
                        px.x = ref_u + (px.x - ref_u + per / 2.0).rem_euclid(per) - per / 2.0;
                    }
                    b = [
                        b[0].min(px.x),
                        b[1].min(px.y),
                        b[2].max(px.x),
                        b[3].max(px.y),
                    ];
                }
            }
        }
    }
    let (wm, hm) = ((size.width - 1) as f64, (size.height - 1) as f64);
    let c = [b[0].max(0.0), b[1].max(0.0), b[2].min(wm), b[3].min(hm)];
    (c[0] <= c[2] && c[1] <= c[3]).then_some(c)
}

/// Every object of the scene with a KITTI type within 80 m is written once, at its exact
/// location and heading (to the labels' rounding), with its exact 2D box. Returns the count.
fn check_labels(w: &Written, frame: u32, what: &str) -> usize {
    let truth: Vec<Truth> = truths(w, frame)
        .into_iter()
        .filter(|t| {
            let c = t.corners.iter().sum::<Vector3<f64>>() / 8.0;
            (c - w.centre).norm() <= 80.0
        })
        .collect();
    assert!(
        truth.len() >= 8,
        "{what}: the scene holds {} objects",
        truth.len()
    );
    assert_eq!(
        w.labels.labels.len(),
        truth.len(),
        "{what}: every visible object, once"
    );
    let mut worst_iou: f64 = 1.0;
    for t in &truth {
        let l = w
            .labels
            .labels
            .iter()
            .min_by(|a, b| {
                (a.location - t.location)
                    .norm()
                    .total_cmp(&(b.location - t.location).norm())
            })
            .unwrap();
        assert_eq!(
            l.kind, t.kind,
            "{what}: class of the object at {}",
            t.location
        );
        for i in 0..3 {
            assert!(
                (l.location[i] - t.location[i]).abs() <= ROUNDING,
                "{what}: {} location {} vs truth {}",
                t.kind,
                l.location,
                t.location
            );
        }
        assert!(
            wrap(l.rotation_y - t.rotation_y).abs() <= ROUNDING,
            "{what}: rotation_y {} vs {}",
            l.rotation_y,
            t.rotation_y
        );
        let exact = exact_box(w, &t.corners).expect("a visible object has a box");
        let got = l.bbox;
        let score = iou(got, exact);
        worst_iou = worst_iou.min(score);
        assert!(
            score >= MIN_IOU,
            "{what}: {} box {got:?} vs exact {exact:?}: IoU {score}",
            t.kind
        );
    }
    eprintln!(
        "{what}: {} objects, worst 2D box IoU {worst_iou:.5}",
        truth.len()
    );
    truth.len()
}

/// `labels-to-pixels` of a converted output `out`, then `unproject --box converted` of those
/// pixels with its calibs: the folder of the boxes it gives back (in `work`).
pub(crate) fn labels_back_through_unproject(out: &Path, work: &Path) -> PathBuf {
    let pixels = work.join("pixels");
    let results = work.join("results");
    assert_success(&panoconv([
        "labels-to-pixels",
        "--input",
        out.to_str().unwrap(),
        "--output",
        pixels.to_str().unwrap(),
    ]));
    assert_success(&panoconv([
        "unproject",
        "--calib",
        out.join("training/calib").to_str().unwrap(),
        "--input",
        pixels.to_str().unwrap(),
        "--output",
        results.to_str().unwrap(),
        "--box",
        "converted",
    ]));
    results
}

/// The depth map against the scene seen from C2 through each pixel's centre: (pixels, share
/// within 5 %, share farther than the truth by more than 5 %).
pub(crate) fn check_depth(out: &Path, id: &str, w: &Written, frame: u32, what: &str) {
    check_depth_share(out, id, w, frame, what, MIN_DEPTH_CORRECT);
}

/// [`check_depth`] with `min_correct` the share of pixels that must be within 5 %.
pub(crate) fn check_depth_share(
    out: &Path,
    id: &str,
    w: &Written,
    frame: u32,
    what: &str,
    min_correct: f64,
) {
    let depth = common::read_png(&out.join(format!("training/depth_2/{id}.png")));
    assert_eq!(depth.depth, png::BitDepth::Sixteen);
    let scene = scene_at(frame);
    let scene_from_level = world_from_scene().transpose() * w.world_rotation;
    let origin = world_to_scene(&(w.world_rotation * w.centre + w.world_translation));
    let (mut n, mut correct, mut leaks) = (0usize, 0usize, 0usize);
    for v in 0..depth.height {
        for u in 0..depth.width {
            let i = ((v * depth.width + u) * 2) as usize;
            let d = u16::from_be_bytes([depth.data[i], depth.data[i + 1]]) as f64 / 256.0;
            if d <= 0.0 {
                continue;
            }
            n += 1;
            let ray = w
                .camera
                .unproject(&Point2::new(u as f64, v as f64))
                .unwrap();
            let Some((t, _)) = scene.first_hit(&origin, &(scene_from_level * ray).normalize())
            else {
                continue;
            };
            let truth = w.camera.distance(&(ray.normalize() * t));
            if (d - truth).abs() <= DEPTH_TOLERANCE * truth {
                correct += 1;
            } else if d > truth {
                leaks += 1;
            }
        }
    }
    let (ok, leak) = (correct as f64 / n as f64, leaks as f64 / n as f64);
    eprintln!(
        "{what}: {n} depth pixels, {:.3} % within 5 %, {:.3} % occlusion leaks",
        100.0 * ok,
        100.0 * leak
    );
    assert!(n > 2000, "{what}: only {n} depth pixels");
    assert!(ok >= min_correct, "{what}: {ok} within 5 %");
    assert!(leak <= MAX_DEPTH_LEAKS, "{what}: {leak} leaks");
}

#[test]
fn the_zero_baseline_panorama_matches_the_direct_render_with_exact_labels_and_depth() {
    let root = sequence(true);
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    // the resampling is compared without exposure gains (they move the fisheyes by 0.27 %)
    let run = kitti360(
        root,
        &out,
        &[
            "--to",
            "equirect",
            "--pano-width",
            WIDTH,
            "--frames",
            "250",
            "--depth",
            "--lidar-azimuth-step",
            LIDAR_STEP,
            "--no-exposure-gains",
        ],
    );
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

    // the panorama against the scene rendered directly, each camera's region with its blur
    let split = out.join("training");
    let pano = common::read_rgb8(&split.join("image_2/000250.png"));
    let source = common::read_png(&split.join("source_2/000250.png"));
    assert_eq!(
        (source.color, source.depth),
        (png::ColorType::Grayscale, png::BitDepth::Eight)
    );
    assert!(source.data.iter().all(|&s| s < 4), "the sphere is covered");
    let seq = Sequence::open(
        root,
        SEQUENCE,
        Options {
            lidar: false,
            ..Options::default()
        },
    )
    .unwrap();
    let k = w.camera.intrinsics();
    let size = w.camera.size();
    let scene_from_level = world_from_scene().transpose() * w.world_rotation;
    let direct_camera = Rotated::new(Equirect::new(k, size), scene_from_level);
    let centre = world_to_scene(&w.world_translation);
    let scene = scene_at(250);
    let lenses = &seq.calibration.fisheye;
    let mut report = Vec::new();
    let mut db = [0.0; 4];
    for cam in 0..4u8 {
        let source_fu = match cam {
            0 | 1 => seq.calibration.perspective[cam as usize].model.k.fu,
            _ => lenses[cam as usize - 2].centre_intrinsics().fu,
        };
        // the sources' blur (0.55 source px) plus the bilinear tent's own (variance 1/6 px²),
        // on the renderer's fine grid: as tests/kitti360_stitch.rs; over the camera's region only
        let direct: RgbImage = common::render_where(
            &scene,
            &direct_camera,
            &centre,
            (0.55f64 * 0.55 + 1.0 / 6.0).sqrt() * k.fu / source_fu,
            16,
            |u, v| source.data[(v * size.width + u) as usize] == cam,
        );
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
        db[cam as usize] = 10.0 * (255.0f64 * 255.0 / (se / (3 * n) as f64)).log10();
        report.push(format!(
            "image_0{cam}: {:.2} dB over {n} px",
            db[cam as usize]
        ));
    }
    eprintln!(
        "kitti360 --to equirect, zero baseline, vs direct render: {}",
        report.join("; ")
    );
    for region in &db {
        assert!(*region >= MIN_PSNR_DB, "{}", report.join("; "));
    }
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
fn bad_input_is_named_with_its_file_and_counted() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("in");
    common::copy_tree(sequence(false), &root);
    // a frame without a pose, and a frame whose scan is malformed: both failed, counted
    let scan = root.join(format!(
        "data_3d_raw/{SEQUENCE}/velodyne_points/data/0000000251.bin"
    ));
    let bytes = std::fs::read(&scan).unwrap();
    std::fs::write(&scan, &bytes[..bytes.len() - 3]).unwrap();
    let out = tmp.path().join("out");
    let run = kitti360(
        &root,
        &out,
        &[
            "--to",
            "equirect",
            "--pano-width",
            "360",
            "--frames",
            "250,251,400",
        ],
    );
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert!(
        run.stderr.contains("poses.txt") && run.stderr.contains("frame 400 has no pose"),
        "{}",
        run.stderr
    );
    assert!(run.stderr.contains("0000000251.bin"), "{}", run.stderr);
    let m = read_manifest(&out);
    let frames = m["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    let failed: Vec<&str> = frames
        .iter()
        .filter(|f| f["status"] == "failed")
        .map(|f| f["id"].as_str().unwrap())
        .collect();
    assert_eq!(failed, ["000251", "000400"]);
    assert!(!out.join("training/image_2/000251.png").exists());
    assert!(out.join("training/image_2/000250.png").exists());
    assert_success(&panoconv(["verify", out.to_str().unwrap()]));

    // a malformed poses file: a set-up error naming file, line and field, nothing written
    let poses = root.join(format!("data_poses/{SEQUENCE}/poses.txt"));
    let text = read_text(&poses);
    let broken: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 1 {
                l.replacen(' ', " x", 2)
            } else {
                l.to_owned()
            }
        })
        .collect();
    std::fs::write(&poses, broken.join("\n") + "\n").unwrap();
    let out2 = tmp.path().join("out2");
    let run = kitti360(&root, &out2, &["--to", "equirect", "--pano-width", "360"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("poses.txt:2"), "{}", run.stderr);
    assert!(!out2.exists());

    // an output camera too large for any frame: a set-up error, nothing written
    let huge = tmp.path().join("huge");
    let run = kitti360(
        sequence(false),
        &huge,
        &["--to", "equirect", "--pano-width", "200000"],
    );
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("too large"), "{}", run.stderr);
    assert!(!huge.exists());

    // options kitti360 does not take say so
    let run = kitti360(
        &root,
        &tmp.path().join("o3"),
        &["--to", "equirect", "--style-after-warp"],
    );
    assert_eq!(run.code, 2);
    assert!(
        run.stderr
            .contains("--style-after-warp is not supported by kitti360"),
        "{}",
        run.stderr
    );
}

/// A copy of the offset sequence under another drive number.
fn rename_sequence(root: &Path, to: &str) {
    for dir in ["data_2d_raw", "data_3d_raw", "data_poses"] {
        std::fs::rename(root.join(dir).join(SEQUENCE), root.join(dir).join(to)).unwrap();
    }
    let boxes = root.join("data_3d_bboxes/train");
    std::fs::rename(
        boxes.join(format!("{SEQUENCE}.xml")),
        boxes.join(format!("{to}.xml")),
    )
    .unwrap();
}

#[test]
fn resume_shards_export_and_several_sequences_work_as_for_kitti() {
    let tmp = tempfile::tempdir().unwrap();
    let small = ["--to", "equirect", "--pano-width", "360"];
    // --resume keeps every frame of a finished run, and the files stay the same
    let out = tmp.path().join("out");
    let mut args = small.to_vec();
    args.extend(["--export", "coco,yolo"]);
    assert_success(&kitti360(sequence(false), &out, &args));
    assert!(out.join("annotations/instances_train.json").is_file());
    assert!(tmp.path().join("out_yolo/data.yaml").is_file());
    let before = common::tree_bytes(&out.join("training"));
    let mut again = small.to_vec();
    again.push("--resume");
    let run = kitti360(sequence(false), &out, &again);
    assert_success(&run);
    assert_eq!(common::tree_bytes(&out.join("training")), before);
    assert_success(&panoconv(["verify", out.to_str().unwrap()]));
    // other parameters are refused by --resume
    let mut other = again.clone();
    other.extend(["--max-distance", "20"]);
    assert_eq!(kitti360(sequence(false), &out, &other).code, 2);

    // two shards, merged, are the whole run
    let sharded = tmp.path().join("sharded");
    for k in ["0/2", "1/2"] {
        let mut a = small.to_vec();
        a.extend(["--shard", k]);
        assert_success(&kitti360(sequence(false), &sharded, &a));
    }
    assert_success(&panoconv(["merge", sharded.to_str().unwrap()]));
    assert_success(&panoconv(["verify", sharded.to_str().unwrap()]));
    assert_eq!(common::tree_bytes(&sharded.join("training")), before);

    // two sequences: ids with the drive number first, recorded in the manifest
    let root = tmp.path().join("two");
    common::copy_tree(sequence(false), &root);
    let other_seq = "2013_05_28_drive_0003_sync";
    let both = tmp.path().join("both");
    {
        let three = tmp.path().join("three");
        common::copy_tree(sequence(false), &three);
        rename_sequence(&three, other_seq);
        for dir in ["data_2d_raw", "data_3d_raw", "data_poses"] {
            std::fs::rename(
                three.join(dir).join(other_seq),
                root.join(dir).join(other_seq),
            )
            .unwrap();
        }
        std::fs::rename(
            three.join(format!("data_3d_bboxes/train/{other_seq}.xml")),
            root.join(format!("data_3d_bboxes/train/{other_seq}.xml")),
        )
        .unwrap();
    }
    let mut a = vec!["kitti360", "--input", root.to_str().unwrap(), "--sequence"];
    let sequences = format!("{SEQUENCE},{other_seq}");
    a.push(&sequences);
    a.extend(["--output", both.to_str().unwrap()]);
    a.extend(small);
    assert_success(&panoconv(&a));
    let ids: Vec<String> = common::tree_files(&both.join("training/image_2"))
        .into_iter()
        .collect();
    assert_eq!(
        ids,
        [
            "0000000250.png",
            "0000000251.png",
            "0003000250.png",
            "0003000251.png"
        ]
    );
    let m = read_manifest(&both);
    assert_eq!(m["parameters"]["frame_ids"], "drive_frame");
    // the same frame of the same scene: the same files whatever the sequence's name
    for (a, b) in [("0000000250", "0003000250"), ("0000000251", "0003000251")] {
        let f = |id: &str| std::fs::read(both.join(format!("training/label_2/{id}.txt"))).unwrap();
        assert_eq!(f(a), f(b));
        assert_eq!(
            f(a),
            std::fs::read(out.join(format!("training/label_2/{}.txt", &a[4..]))).unwrap()
        );
    }
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
