//! `unproject` writes predictions that KITTI's own benchmark scores as meant: labels converted
//! to a panorama, turned into pixel objects and unprojected back score 100 against the
//! original `label_2` with the official protocol (2D AP, AOS, BEV and 3D AP, R40, the
//! easy/moderate/hard filters). The protocol is written out here in float64, after
//! `devkit_object/cpp/evaluate_object.cpp` (and its Python port in OpenPCDet,
//! `kitti_object_eval_python/eval.py`): class and neighbour classes, the height, occlusion and
//! truncation filters, greedy matching with ignored detections, DontCare regions in 2D, the
//! rotated bird's-eye intersection times the height overlap in 3D, and the 40-point
//! interpolated precision.

use crate::common::*;
use std::ffi::OsStr;
use std::path::Path;

/// One KITTI label or result line.
#[derive(Debug, Clone)]
struct Obj {
    kind: String,
    truncated: f64,
    occluded: i64,
    alpha: f64,
    bbox: [f64; 4],
    /// h, w, l
    dims: [f64; 3],
    loc: [f64; 3],
    ry: f64,
    score: f64,
}

fn parse(text: &str) -> Vec<Obj> {
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let t: Vec<f64> = l
                .split_whitespace()
                .skip(1)
                .map(|x| x.parse().unwrap())
                .collect();
            Obj {
                kind: l.split_whitespace().next().unwrap().to_owned(),
                truncated: t[0],
                occluded: t[1] as i64,
                alpha: t[2],
                bbox: [t[3], t[4], t[5], t[6]],
                dims: [t[7], t[8], t[9]],
                loc: [t[10], t[11], t[12]],
                ry: t[13],
                score: t.get(14).copied().unwrap_or(1.0),
            }
        })
        .collect()
}

#[derive(Clone, Copy, PartialEq)]
enum Metric {
    Box2d,
    Bev,
    Box3d,
}

const MIN_HEIGHT: [f64; 3] = [40.0, 25.0, 25.0];
const MAX_OCCLUSION: [i64; 3] = [0, 1, 2];
const MAX_TRUNCATION: [f64; 3] = [0.15, 0.3, 0.5];

fn min_overlap(class: &str, metric: Metric) -> f64 {
    match (class, metric) {
        ("Car", _) => 0.7,
        _ => 0.5,
    }
}

fn neighbour(class: &str) -> &'static str {
    match class {
        "Car" => "Van",
        "Pedestrian" => "Person_sitting",
        _ => "",
    }
}

fn iou_2d(a: [f64; 4], b: [f64; 4]) -> f64 {
    let iw = (a[2].min(b[2]) - a[0].max(b[0])).max(0.0);
    let ih = (a[3].min(b[3]) - a[1].max(b[1])).max(0.0);
    let inter = iw * ih;
    let area = |r: [f64; 4]| (r[2] - r[0]) * (r[3] - r[1]);
    inter / (area(a) + area(b) - inter)
}

/// The bird's-eye rectangle (x, z plane) of a box: corners counter-clockwise.
fn bev_corners(o: &Obj) -> Vec<[f64; 2]> {
    let (l, w) = (o.dims[2], o.dims[1]);
    let (c, s) = (o.ry.cos(), o.ry.sin());
    [
        [l / 2.0, w / 2.0],
        [-l / 2.0, w / 2.0],
        [-l / 2.0, -w / 2.0],
        [l / 2.0, -w / 2.0],
    ]
    .iter()
    .map(|&[x, z]| [o.loc[0] + c * x + s * z, o.loc[2] - s * x + c * z])
    .collect()
}

fn polygon_area(p: &[[f64; 2]]) -> f64 {
    let mut a = 0.0;
    for i in 0..p.len() {
        let (q, r) = (p[i], p[(i + 1) % p.len()]);
        a += q[0] * r[1] - r[0] * q[1];
    }
    a.abs() / 2.0
}

/// Sutherland–Hodgman: the part of `subject` inside the convex polygon `clip`.
fn clip_polygon(subject: &[[f64; 2]], clip: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let orient = {
        let mut a = 0.0;
        for i in 0..clip.len() {
            let (q, r) = (clip[i], clip[(i + 1) % clip.len()]);
            a += q[0] * r[1] - r[0] * q[1];
        }
        a.signum()
    };
    let mut out = subject.to_vec();
    for i in 0..clip.len() {
        let (a, b) = (clip[i], clip[(i + 1) % clip.len()]);
        let side =
            |p: [f64; 2]| orient * ((b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]));
        let input = std::mem::take(&mut out);
        for j in 0..input.len() {
            let (p, q) = (input[j], input[(j + 1) % input.len()]);
            let (sp, sq) = (side(p), side(q));
            if sp >= 0.0 {
                out.push(p);
            }
            if (sp >= 0.0) != (sq >= 0.0) {
                let t = sp / (sp - sq);
                out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
            }
        }
        if out.is_empty() {
            break;
        }
    }
    out
}

fn bev_intersection(a: &Obj, b: &Obj) -> f64 {
    let inter = clip_polygon(&bev_corners(a), &bev_corners(b));
    if inter.len() < 3 {
        0.0
    } else {
        polygon_area(&inter)
    }
}

fn overlap(det: &Obj, gt: &Obj, metric: Metric) -> f64 {
    match metric {
        Metric::Box2d => iou_2d(det.bbox, gt.bbox),
        Metric::Bev => {
            let inter = bev_intersection(det, gt);
            let area = |o: &Obj| o.dims[1] * o.dims[2];
            inter / (area(det) + area(gt) - inter)
        }
        Metric::Box3d => {
            // y down: a box spans [y - h, y]
            let top = (det.loc[1] - det.dims[0]).max(gt.loc[1] - gt.dims[0]);
            let bottom = det.loc[1].min(gt.loc[1]);
            let inter = bev_intersection(det, gt) * (bottom - top).max(0.0);
            let vol = |o: &Obj| o.dims[0] * o.dims[1] * o.dims[2];
            inter / (vol(det) + vol(gt) - inter)
        }
    }
}

/// (score, is a true positive, orientation similarity) of each counted detection, and the
/// number of ground-truth objects to find.
struct Stats {
    dets: Vec<(f64, bool, f64)>,
    gt: usize,
}

/// The official statistics of one frame for `class` at `difficulty` (0 easy, 1 moderate, 2
/// hard), every detection above threshold (`compute_fp`).
fn frame_stats(gts: &[Obj], dets: &[Obj], class: &str, d: usize, metric: Metric, s: &mut Stats) {
    // ground truth: 0 counted, 1 ignored, -1 not this class
    let ignored_gt: Vec<i8> = gts
        .iter()
        .map(|g| {
            let valid = if g.kind == class {
                1
            } else if g.kind == neighbour(class) {
                0
            } else {
                -1
            };
            let height = g.bbox[3] - g.bbox[1];
            let ignore = height < MIN_HEIGHT[d]
                || g.occluded > MAX_OCCLUSION[d]
                || g.truncated > MAX_TRUNCATION[d];
            match (valid, ignore) {
                (1, false) => 0,
                (0, _) | (1, true) => 1,
                _ => -1,
            }
        })
        .collect();
    let dont_care: Vec<&Obj> = gts.iter().filter(|g| g.kind == "DontCare").collect();
    let ignored_det: Vec<i8> = dets
        .iter()
        .map(|o| {
            if o.bbox[3] - o.bbox[1] < MIN_HEIGHT[d] {
                1
            } else if o.kind == class {
                0
            } else {
                -1
            }
        })
        .collect();
    s.gt += ignored_gt.iter().filter(|&&g| g == 0).count();
    let min = min_overlap(class, metric);
    let mut assigned = vec![false; dets.len()];
    for (i, g) in gts.iter().enumerate() {
        if ignored_gt[i] == -1 {
            continue;
        }
        let (mut best, mut max_overlap, mut to_ignored) = (None, 0.0, false);
        for (j, o) in dets.iter().enumerate() {
            if ignored_det[j] == -1 || assigned[j] {
                continue;
            }
            let ov = overlap(o, g, metric);
            if ov > min && (ov > max_overlap || to_ignored) && ignored_det[j] == 0 {
                (best, max_overlap, to_ignored) = (Some(j), ov, false);
            } else if ov > min && best.is_none() && ignored_det[j] == 1 {
                (best, to_ignored) = (Some(j), true);
            }
        }
        match best {
            None => {}
            Some(j) if ignored_gt[i] == 1 || ignored_det[j] == 1 => assigned[j] = true,
            Some(j) => {
                assigned[j] = true;
                let similarity = (1.0 + (g.alpha - dets[j].alpha).cos()) / 2.0;
                s.dets.push((dets[j].score, true, similarity));
            }
        }
    }
    for (j, o) in dets.iter().enumerate() {
        if assigned[j] || ignored_det[j] != 0 {
            continue;
        }
        // a detection inside a DontCare region is no false positive (2D only)
        let in_dont_care = metric == Metric::Box2d
            && dont_care.iter().any(|dc| {
                let iw = (o.bbox[2].min(dc.bbox[2]) - o.bbox[0].max(dc.bbox[0])).max(0.0);
                let ih = (o.bbox[3].min(dc.bbox[3]) - o.bbox[1].max(dc.bbox[1])).max(0.0);
                iw * ih / ((o.bbox[2] - o.bbox[0]) * (o.bbox[3] - o.bbox[1])) > min
            });
        if !in_dont_care {
            s.dets.push((o.score, false, 0.0));
        }
    }
}

/// AP and AOS (R40, percent) over frames (ground truth, detections).
fn evaluate(frames: &[(Vec<Obj>, Vec<Obj>)], class: &str, d: usize, metric: Metric) -> (f64, f64) {
    let mut s = Stats {
        dets: Vec::new(),
        gt: 0,
    };
    for (gts, dets) in frames {
        frame_stats(gts, dets, class, d, metric, &mut s);
    }
    assert!(s.gt > 0, "no {class} to evaluate");
    s.dets.sort_by(|a, b| b.0.total_cmp(&a.0));
    let (mut tp, mut fp, mut sim) = (0.0, 0.0, 0.0);
    // (recall, precision, orientation precision) at each score threshold: detections of
    // equal score are taken together
    let mut curve = Vec::new();
    for (k, &(score, is_tp, similarity)) in s.dets.iter().enumerate() {
        if is_tp {
            tp += 1.0;
            sim += similarity;
        } else {
            fp += 1.0;
        }
        if s.dets.get(k + 1).is_none_or(|next| next.0 != score) {
            curve.push((tp / s.gt as f64, tp / (tp + fp), sim / (tp + fp)));
        }
    }
    let at = |r: f64, pick: fn(&(f64, f64, f64)) -> f64| {
        curve
            .iter()
            .filter(|c| c.0 >= r - 1e-12)
            .map(pick)
            .fold(0.0, f64::max)
    };
    let points = (1..=40).map(|i| i as f64 / 40.0);
    let ap = points.clone().map(|r| at(r, |c| c.1)).sum::<f64>() / 40.0 * 100.0;
    let aos = points.map(|r| at(r, |c| c.2)).sum::<f64>() / 40.0 * 100.0;
    (ap, aos)
}

fn read_frames(gt_dir: &Path, det_dir: &Path) -> Vec<(Vec<Obj>, Vec<Obj>)> {
    let mut ids: Vec<String> = std::fs::read_dir(det_dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".txt"))
        .collect();
    ids.sort();
    ids.iter()
        .map(|n| {
            (
                parse(&read_text(&gt_dir.join(n))),
                parse(&read_text(&det_dir.join(n))),
            )
        })
        .collect()
}

/// Converts `input` to an equirect panorama at the paper's 2048 px for 360°, turns its labels
/// into pixel objects and unprojects them with `extra`; returns the result folder.
fn round_trip(input: &Path, work: &Path, extra: &[&str]) -> std::path::PathBuf {
    let out = work.join("equi");
    if !out.exists() {
        assert_success(&kitti(
            "equirect",
            input,
            &out,
            &["--pano-width", "2048", "--split", "training"],
        ));
        assert_success(&panoconv([
            OsStr::new("labels-to-pixels"),
            OsStr::new("--input"),
            out.as_os_str(),
            OsStr::new("--output"),
            work.join("pixels").as_os_str(),
        ]));
    }
    let results = work.join(format!("results{}", extra.len()));
    let mut args: Vec<std::ffi::OsString> = vec![
        "unproject".into(),
        "--calib".into(),
        out.join("training/calib").into(),
        "--input".into(),
        work.join("pixels").into(),
        "--output".into(),
        results.clone().into(),
    ];
    args.extend(extra.iter().map(|a| a.into()));
    assert_success(&panoconv(args));
    results
}

const MODERATE: usize = 1;

#[test]
fn unprojected_labels_score_100_with_the_official_protocol() {
    let tmp = tempfile::tempdir().unwrap();
    let input = synth_source();
    let results = round_trip(input, tmp.path(), &[]);
    let frames = read_frames(&input.join("training/label_2"), &results);
    assert_eq!(frames.len(), 3);
    for class in ["Car", "Pedestrian"] {
        for d in 0..3 {
            for metric in [Metric::Box2d, Metric::Bev, Metric::Box3d] {
                let (ap, aos) = evaluate(&frames, class, d, metric);
                assert!(
                    (ap - 100.0).abs() < 1e-9,
                    "{class} difficulty {d} {}: AP {ap:.4}",
                    ["2D", "BEV", "3D"][metric as usize]
                );
                if metric == Metric::Box2d {
                    assert!(aos > 99.99, "{class} difficulty {d}: AOS {aos:.4}");
                }
            }
        }
    }
    // every result's 2D box is the source box of its label, to the label's two decimals
    for (gts, dets) in &frames {
        for d in dets {
            let g = gts
                .iter()
                .find(|g| g.kind == d.kind && (g.loc[2] - d.loc[2]).abs() < 1e-3)
                .expect("a label for each result");
            for k in 0..4 {
                assert!(
                    (g.bbox[k] - d.bbox[k]).abs() <= 0.02,
                    "{}: box {:?} vs label {:?}",
                    d.kind,
                    d.bbox,
                    g.bbox
                );
            }
        }
    }

    // the converted image's boxes, the other choice, are not what the benchmark scores
    let converted = round_trip(input, tmp.path(), &["--box", "converted"]);
    let frames = read_frames(&input.join("training/label_2"), &converted);
    let (ap, _) = evaluate(&frames, "Car", MODERATE, Metric::Box2d);
    assert!(ap < 50.0, "converted-image boxes scored {ap:.2} in 2D");
}

#[test]
fn unprojected_real_kitti_labels_score_100_in_3d_despite_the_smaller_panorama() {
    let tmp = tempfile::tempdir().unwrap();
    let input = real_kitti();
    let results = round_trip(&input, tmp.path(), &[]);
    let frames = read_frames(&input.join("training/label_2"), &results);
    for metric in [Metric::Bev, Metric::Box3d] {
        let (ap, _) = evaluate(&frames, "Car", MODERATE, metric);
        assert!(
            (ap - 100.0).abs() < 1e-9,
            "Car moderate {}: AP {ap:.4}",
            ["2D", "BEV", "3D"][metric as usize]
        );
    }
}

#[test]
fn the_protocol_counts_misses_and_false_positives() {
    let car = |x: f64, z: f64| Obj {
        kind: "Car".into(),
        truncated: 0.0,
        occluded: 0,
        alpha: 0.0,
        bbox: [100.0, 100.0, 200.0, 160.0],
        dims: [1.5, 1.6, 3.9],
        loc: [x, 1.6, z],
        ry: 0.3,
        score: 1.0,
    };
    // rotated boxes: IoU of a box with itself moved along its length by a quarter
    let a = car(0.0, 10.0);
    let mut b = a.clone();
    b.loc[0] += 3.9 / 4.0 * 0.3f64.cos();
    b.loc[2] -= 3.9 / 4.0 * 0.3f64.sin();
    let iou = overlap(&b, &a, Metric::Bev);
    assert!((iou - 0.75 / 1.25).abs() < 1e-9, "{iou}");
    // one of two found, one false positive: precision 1/2 up to recall 1/2
    let mut far = car(5.0, 30.0);
    far.bbox = [300.0, 100.0, 400.0, 160.0];
    let mut wrong = car(-5.0, 20.0);
    wrong.bbox = [500.0, 100.0, 600.0, 160.0];
    let frames = vec![(vec![a.clone(), far], vec![a, wrong])];
    let (ap, _) = evaluate(&frames, "Car", MODERATE, Metric::Box3d);
    assert!((ap - 50.0 * 20.0 / 40.0).abs() < 1e-9, "{ap}");
}
