//! nuScenes' own devkit (`nuscenes-devkit` from PyPI, run by tests/nuscenes_devkit.py) reads the
//! synthetic scene the project ships, and panoconv's reader must agree with it: every sensor
//! reading's time, ego pose and calibration, each camera's pinhole matrix, and every box's
//! corners in every camera (the devkit's `get_sample_data` moves the box from the global frame
//! through the camera's own ego pose, `view_points` projects it) against panoconv's projection
//! of its `SourceBox` through the rig camera, to 0.01 px.

use crate::nuscenes::fixture;
use crate::opencv_ref::test_python;
use nalgebra::{Matrix4, Vector3};
use panoconv::nuscenes::{NuScenes, Options, Selection};
use panoconv::tools::synth_nuscenes::VERSION;
use serde_json::Value;
use std::path::Path;
use std::process::Command;

fn devkit(root: &Path) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("devkit.json");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/nuscenes_devkit.py");
    let run = Command::new(test_python())
        .arg(&script)
        .arg(root)
        .arg(VERSION)
        .arg(&out)
        .output()
        .expect("cannot run the test python");
    assert!(
        run.status.success(),
        "nuscenes-devkit failed: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap()
}

fn matrix(v: &Value) -> Matrix4<f64> {
    let rows: Vec<Vec<f64>> = serde_json::from_value(v.clone()).unwrap();
    Matrix4::from_fn(|r, c| rows[r][c])
}

#[test]
fn nuscenes_devkit_agrees_with_panoconvs_poses_calibrations_and_projections() {
    let dk = devkit(&fixture());
    let ds = NuScenes::open(&fixture(), VERSION, &Selection::default()).unwrap();
    let all = Options {
        all_classes: true,
        keep_unseen: true,
        ..Options::default()
    };
    let scenes = dk["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 1);
    let samples = scenes[0]["samples"].as_array().unwrap();
    let items = ds.items().unwrap();
    assert_eq!(samples.len(), items.len());
    let (mut corners, mut worst) = (0, 0.0f64);
    for (item, theirs) in items.iter().zip(samples) {
        let f = ds.frame(item, &all).unwrap();
        assert_eq!(theirs["token"], f.sample_token.as_str());
        let world_from_level = f.frame.world_from_reference.unwrap();
        let lidar = &theirs["sensors"]["LIDAR_TOP"];
        let want = matrix(&lidar["global_from_ego"]) * matrix(&lidar["ego_from_sensor"]);
        let got = world_from_level
            .compose(&f.reference_from_lidar)
            .to_matrix4();
        assert!((got - want).abs().max() < 1e-9, "LIDAR_TOP: {got} {want}");
        assert_eq!(lidar["timestamp"], f.timestamp);
        for (k, camera) in f.frame.rig.iter().enumerate() {
            let s = &theirs["sensors"][camera.name.as_str()];
            assert_eq!(s["timestamp"], f.camera_timestamps[k], "{}", camera.name);
            assert_eq!(
                f.frame.rig[k].image,
                fixture().join(s["filename"].as_str().unwrap())
            );
            let want = matrix(&s["global_from_ego"]) * matrix(&s["ego_from_sensor"]);
            let got = world_from_level
                .compose(&camera.reference_from_camera)
                .to_matrix4();
            assert!(
                (got - want).abs().max() < 1e-9,
                "{}: {got} {want}",
                camera.name
            );
            // the pinhole matrix
            let k_dk: Vec<Vec<f64>> = serde_json::from_value(s["intrinsic"].clone()).unwrap();
            let model = ds
                .pinhole(
                    ds.keyframe(
                        &panoconv::nuscenes::Token::new(&f.sample_token),
                        &camera.name,
                    )
                    .unwrap(),
                )
                .unwrap();
            assert_eq!(
                [k_dk[0][0], k_dk[1][1], k_dk[0][2], k_dk[1][2]],
                [model.k.fu, model.k.fv, model.k.cu, model.k.cv]
            );
            // each box in front of the camera: its eight corners
            for b in s["boxes"].as_array().unwrap() {
                let i = f
                    .objects
                    .iter()
                    .position(|o| o.annotation == b["annotation"].as_str().unwrap())
                    .expect("the devkit's box is one of panoconv's objects");
                let ours: Vec<(f64, f64)> = f.frame.objects[i]
                    .corners()
                    .iter()
                    .map(|c: &Vector3<f64>| {
                        let p = camera.project(c).expect("in front of the camera");
                        (p.x, p.y)
                    })
                    .collect();
                for c in b["corners"].as_array().unwrap() {
                    let (u, v) = (c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
                    let d = ours
                        .iter()
                        .map(|(x, y)| (x - u).hypot(y - v))
                        .fold(f64::INFINITY, f64::min);
                    worst = worst.max(d);
                    corners += 1;
                }
            }
        }
    }
    assert!(corners >= 3 * 6 * 8, "{corners} corners compared");
    assert!(worst < 0.01, "worst corner {worst} px");
    eprintln!("nuscenes-devkit: {corners} box corners, worst {worst:.2e} px");
}
