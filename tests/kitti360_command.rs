//! `panoconv kitti360` through the real binary on synthetic sequences (`panoconv synth
//! --kitti360`): the zero-baseline rig's panorama against the scene rendered directly, every
//! visible object with its exact location and 2D box, the depth map against the scene, the
//! realistic-offset rig's labels and depth, the round trip through `labels-to-pixels` and
//! `unproject` into the level frame and the world, the tools on the output, bad input, thread
//! counts, and one camera converted alone. This file holds the sequences and the exact truths
//! (also used by `kitti360_options` and `kitti360_stitch`); each topic is a file of
//! `tests/kitti360_command/`.

mod bad_input;
mod cameras;
mod rigs;
mod runs;

use crate::common::{self, assert_success, iou, panoconv, read_text};
use nalgebra::{Matrix3, Point2, Vector3};
use panoconv::camera::{ImageSize, OutputCamera};
use panoconv::kitti::{Calib, Cam, LabelFile};
use panoconv::kitti360::classes::kitti_type;
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
        let mut args = vec!["--kitti360", "--scale", "0.25", "--frames", "2"];
        if zero_baseline {
            args.push("--zero-baseline");
        }
        let name = if zero_baseline { "zero" } else { "offset" };
        common::synth_cache("panoconv-kitti360", name, &args)
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
pub(crate) fn check_labels(w: &Written, frame: u32, what: &str) -> usize {
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
    check_depth_share(out, id, w, frame, what, MIN_DEPTH_CORRECT, false);
}

/// The scene's distance from C2 through the centre of pixel (u, v), or with `footprint` the
/// range of distances over the pixel's area (its centre, corners and edge midpoints): None
/// where the ray meets nothing.
pub(crate) fn scene_distance(
    scene: &panoconv::tools::synth::Scene,
    w: &Written,
    (u, v): (u32, u32),
    footprint: bool,
) -> Option<(f64, f64)> {
    let scene_from_level = world_from_scene().transpose() * w.world_rotation;
    let origin = world_to_scene(&(w.world_rotation * w.centre + w.world_translation));
    let offsets: &[f64] = if footprint { &[-0.5, 0.0, 0.5] } else { &[0.0] };
    let mut range: Option<(f64, f64)> = None;
    for dv in offsets {
        for du in offsets {
            let ray = w
                .camera
                .unproject(&Point2::new(u as f64 + du, v as f64 + dv))
                .unwrap();
            let Some((t, _)) = scene.first_hit(&origin, &(scene_from_level * ray).normalize())
            else {
                continue;
            };
            let d = w.camera.distance(&(ray.normalize() * t));
            range = Some(range.map_or((d, d), |(lo, hi)| (lo.min(d), hi.max(d))));
        }
    }
    range
}

/// [`check_depth`] with `min_correct` the share of pixels that must be within 5 %, of the
/// distance through the pixel's centre or (`footprint`) of the distances over its area.
pub(crate) fn check_depth_share(
    out: &Path,
    id: &str,
    w: &Written,
    frame: u32,
    what: &str,
    min_correct: f64,
    footprint: bool,
) {
    let depth = common::read_png(&out.join(format!("training/depth_2/{id}.png")));
    assert_eq!(depth.depth, png::BitDepth::Sixteen);
    let scene = scene_at(frame);
    let (mut n, mut correct, mut leaks) = (0usize, 0usize, 0usize);
    for v in 0..depth.height {
        for u in 0..depth.width {
            let i = ((v * depth.width + u) * 2) as usize;
            let d = u16::from_be_bytes([depth.data[i], depth.data[i + 1]]) as f64 / 256.0;
            if d <= 0.0 {
                continue;
            }
            n += 1;
            let Some((near, far)) = scene_distance(&scene, w, (u, v), footprint) else {
                continue;
            };
            if d >= near * (1.0 - DEPTH_TOLERANCE) && d <= far * (1.0 + DEPTH_TOLERANCE) {
                correct += 1;
            } else if d > far {
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
