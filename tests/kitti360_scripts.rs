//! KITTI-360's own devkit (`kitti360scripts` from PyPI, run by tests/kitti360_scripts.py) reads
//! the synthetic sequence the project ships, and panoconv's reader must agree with it: the
//! calibration, the fisheye YAML and the 3D boxes to the same numbers, each camera's pose in
//! the world, and the boxes' projections into image_00/01 and the fisheyes (the devkit drops
//! MEI's p1/p2: its fisheye projection is compared with panoconv's lens without them, and the
//! full lens with cv2.omnidir).

use crate::opencv_ref::test_python;
use nalgebra::{Matrix4, Point2, Vector3};
use panoconv::camera::{CameraModel, MeiDistortion, MeiModel, Unified};
use panoconv::kitti360::{Options, Sequence};
use panoconv::tools::synth360::SEQUENCE;
use serde_json::Value;
use std::path::Path;
use std::process::Command;

const FRAME: u32 = 251;

fn devkit(root: &Path) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("devkit.json");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/kitti360_scripts.py");
    let run = Command::new(test_python())
        .arg(&script)
        .arg(root)
        .arg(SEQUENCE)
        .arg(FRAME.to_string())
        .arg(&out)
        .output()
        .expect("cannot run the test python");
    assert!(
        run.status.success(),
        "kitti360scripts failed: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap()
}

fn matrix(v: &Value) -> Matrix4<f64> {
    let rows: Vec<Vec<f64>> = serde_json::from_value(v.clone()).unwrap();
    let mut m = Matrix4::identity();
    for (r, row) in rows.iter().enumerate() {
        for (c, x) in row.iter().enumerate() {
            m[(r, c)] = *x;
        }
    }
    m
}

fn numbers(v: &Value) -> Vec<f64> {
    serde_json::from_value(v.clone()).unwrap()
}

#[test]
fn kitti360scripts_reads_the_synthetic_sequence_to_panoconvs_numbers() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/kitti360");
    let dk = devkit(&root);
    let seq = Sequence::open(&root, SEQUENCE, Options::default()).unwrap();
    let calib = &seq.calibration;
    // calibration: the same doubles
    for k in 0..4 {
        let theirs = matrix(&dk["cam_to_pose"][format!("image_0{k}")]);
        assert_eq!(
            theirs,
            calib.cam_to_pose[k].to_matrix4(),
            "cam_to_pose image_0{k}"
        );
    }
    assert_eq!(matrix(&dk["cam_to_velo"]), calib.cam_to_velo.to_matrix4());
    for k in 0..2 {
        let p = matrix(&dk["perspective"][format!("P_rect_0{k}")]);
        let ours = &calib.perspective[k];
        for i in 0..12 {
            assert_eq!(p[(i / 4, i % 4)], ours.p_rect[i], "P_rect_0{k}[{i}]");
        }
        let r = matrix(&dk["perspective"][format!("R_rect_0{k}")]);
        assert_eq!(r.fixed_view::<3, 3>(0, 0).into_owned(), ours.r_rect);
    }
    for (i, lens) in calib.fisheye.iter().enumerate() {
        let Some(m) = lens.downcast::<MeiModel>() else {
            panic!("not MEI")
        };
        let y = &dk["fisheye"][i];
        let f = |a: &str, b: &str| y[a][b].as_f64().unwrap();
        assert_eq!(f("mirror_parameters", "xi"), m.model.xi);
        let d = m.model.distortion;
        let dist = ["k1", "k2", "p1", "p2"].map(|k| f("distortion_parameters", k));
        assert_eq!(dist, [d.k1, d.k2, d.p1, d.p2]);
        let proj = ["gamma1", "gamma2", "u0", "v0"].map(|k| f("projection_parameters", k));
        assert_eq!(proj, [m.k.fu, m.k.fv, m.k.cu, m.k.cv]);
        assert_eq!(y["image_width"].as_u64().unwrap(), m.size.width as u64);
    }
    // each camera's pose in the world at FRAME, directly and through the level frame
    let frame = seq.frame(FRAME).unwrap();
    let world_from_level = frame.world_from_reference.unwrap();
    for k in 0..4 {
        let theirs = matrix(&dk["cam2world"][k]);
        let direct = seq.world_from_image(FRAME, k).unwrap().to_matrix4();
        let via_level = world_from_level
            .compose(&frame.rig[k].reference_from_camera)
            .to_matrix4();
        for (name, ours) in [("direct", direct), ("via the level frame", via_level)] {
            let d = theirs - ours;
            let rotation = d.fixed_view::<3, 3>(0, 0).abs().max();
            let translation = d.fixed_view::<3, 1>(0, 3).abs().max();
            assert!(
                rotation < 1e-12 && translation < 1e-9,
                "camera {k} {name}: rotation {rotation:e}, translation {translation:e} m"
            );
        }
    }
    // boxes: the same set, the same world vertices
    let boxes = dk["boxes"].as_array().unwrap();
    assert_eq!(boxes.len(), seq.boxes.len());
    let level_from_world = world_from_level.inverse().unwrap();
    let mut projected = [0usize; 4];
    let (mut p_effect, mut omnidir_worst, mut devkit_fisheye_worst): (f64, f64, f64) =
        (0.0, 0.0, 0.0);
    for b in boxes {
        let ours = seq
            .boxes
            .iter()
            .find(|w| {
                w.class_name() == b["name"].as_str().unwrap()
                    && w.instance_id == b["instance"].as_i64().unwrap()
                    && w.timestamp == b["timestamp"].as_i64().unwrap()
            })
            .unwrap_or_else(|| panic!("panoconv lacks {b}"));
        assert_eq!(ours.start_frame, b["start"].as_i64().unwrap());
        assert_eq!(ours.end_frame, b["end"].as_i64().unwrap());
        let vertices: Vec<Vector3<f64>> = b["vertices"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| Vector3::from_vec(numbers(v)))
            .collect();
        for (a, w) in ours.world_vertices().iter().zip(&vertices) {
            assert!((a - w).norm() < 1e-9, "{a} vs {w}");
        }
        assert_eq!(ours.in_frame(FRAME), b.get("projections").is_some());
        let Some(projections) = b.get("projections") else {
            continue;
        };
        // the neutral box's corners are the devkit's vertices
        let neutral = ours.to_source(&level_from_world);
        for c in neutral.corners() {
            let w = world_from_level.apply(&c);
            let nearest = vertices
                .iter()
                .map(|v| (v - w).norm())
                .fold(f64::MAX, f64::min);
            assert!(
                nearest < 1e-8,
                "corner {nearest} m from the devkit's vertices"
            );
        }
        for k in 0..4 {
            let p = &projections[k];
            let (u, v, depth) = (numbers(&p["u"]), numbers(&p["v"]), numbers(&p["depth"]));
            let camera = &frame.rig[k];
            let camera_from_level = camera.reference_from_camera.inverse().unwrap();
            for (i, vertex) in vertices.iter().enumerate() {
                let level = level_from_world.apply(vertex);
                let ours = camera.project(&level);
                if k < 2 {
                    // The devkit rounds pinhole pixels to integers, and inverts cam2world by
                    // transposing it, off by R_rect's six-digit rounding (~1e-4 px here).
                    if depth[i] > 0.0 {
                        let px = ours.expect("in front of the camera");
                        let tol = 0.5 + 1e-3;
                        assert!(
                            (px.x - u[i]).abs() <= tol && (px.y - v[i]).abs() <= tol,
                            "camera {k}: {px} vs ({}, {})",
                            u[i],
                            v[i]
                        );
                        projected[k] += 1;
                    } else {
                        assert!(ours.is_none());
                    }
                    continue;
                }
                let Some(m) = seq.calibration.fisheye[k - 2].downcast::<MeiModel>() else {
                    unreachable!()
                };
                // the devkit's model: no p1/p2 and no field-of-view limit
                let no_p = MeiDistortion {
                    p1: 0.0,
                    p2: 0.0,
                    ..m.model.distortion
                };
                let limit = Unified::fov_limit(m.model.xi, &no_p).0;
                let bare = Unified::new(m.model.xi, no_p, m.k, 0.0, m.size, limit).unwrap();
                let local = camera_from_level.apply(&level);
                if let Ok(px) = bare.project_point(&local) {
                    let e = (px - Point2::new(u[i], v[i])).norm();
                    devkit_fisheye_worst = devkit_fisheye_worst.max(e);
                    projected[k] += 1;
                }
                // panoconv's full lens against cv2.omnidir, inside the 185° field of view
                if let Some(px) = ours {
                    let cv = numbers(&p["omnidir"][i]);
                    omnidir_worst = omnidir_worst.max((px - Point2::new(cv[0], cv[1])).norm());
                    p_effect = p_effect.max((px - Point2::new(u[i], v[i])).norm());
                }
            }
        }
    }
    eprintln!(
        "compared vertices per camera {projected:?}; devkit fisheye {devkit_fisheye_worst:e} px, \
         cv2.omnidir {omnidir_worst:e} px, p1/p2 effect {p_effect} px"
    );
    assert!(
        devkit_fisheye_worst < 1e-6,
        "devkit fisheye projection off by {devkit_fisheye_worst} px"
    );
    assert!(
        omnidir_worst < 1e-6,
        "cv2.omnidir off by {omnidir_worst} px"
    );
    // p1/p2 move pixels visibly (0.3 px at this quarter scale, 1.2 px at the full one)
    assert!(
        p_effect > 0.05 && p_effect < 1.0,
        "p1/p2 effect {p_effect} px"
    );
    assert!(
        projected.iter().all(|n| *n >= 8),
        "too few vertices compared per camera: {projected:?}"
    );
}
