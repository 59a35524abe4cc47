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

/// The fixture's tables in a temporary root, the samples `spacing_s` seconds apart.
fn spaced_tables(spacing_s: f64) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let to = dir.path().join(VERSION);
    std::fs::create_dir_all(&to).unwrap();
    for entry in std::fs::read_dir(fixture().join(VERSION)).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_owned();
        let mut text = std::fs::read_to_string(&path).unwrap();
        if name == "sample.json" {
            let mut samples: Vec<Value> = serde_json::from_str(&text).unwrap();
            let first = samples[0]["timestamp"].as_u64().unwrap();
            for (k, s) in samples.iter_mut().enumerate() {
                s["timestamp"] = (first + (k as f64 * spacing_s * 1e6) as u64).into();
            }
            text = serde_json::to_string(&samples).unwrap();
        }
        std::fs::write(to.join(name), text).unwrap();
    }
    dir
}

/// Every box's velocity as the devkit's `box_velocity` gives it (the centres of the object's
/// previous and next annotations over their samples' time; unknown past 1.5 s, 3 s centred):
/// on the fixture (one car moving at 3 m/s, the others still), and on its tables with the
/// samples 1.6 s apart, where the devkit knows none. Global frame, to 1e-9 m/s.
#[test]
fn box_velocities_are_the_devkits() {
    for (spacing, known_at_least) in [(0.5, 20), (1.6, 0)] {
        let tables = spaced_tables(spacing);
        let dk = devkit(tables.path());
        let ds = NuScenes::open(tables.path(), VERSION, &Selection::default()).unwrap();
        let options = Options {
            lidar: false,
            all_classes: true,
            keep_unseen: true,
            ..Options::default()
        };
        let samples = dk["scenes"][0]["samples"].as_array().unwrap();
        let (mut known, mut moving, mut compared) = (0, 0, 0);
        for (item, theirs) in ds.items().unwrap().iter().zip(samples) {
            let f = ds.frame(item, &options).unwrap();
            let world = f.frame.world_from_reference.unwrap();
            for (o, info) in f.frame.objects.iter().zip(&f.objects) {
                let want = &theirs["velocities"][info.annotation.as_str()];
                let got = o.velocity.map(|v| world.rotation * v);
                match (got, want.as_array()) {
                    (None, None) => {}
                    (Some(v), Some(w)) => {
                        let w = Vector3::new(
                            w[0].as_f64().unwrap(),
                            w[1].as_f64().unwrap(),
                            w[2].as_f64().unwrap(),
                        );
                        assert!((v - w).norm() < 1e-9, "{}: {v} {w}", info.annotation);
                        known += 1;
                        moving += usize::from(w.norm() > 1.0);
                    }
                    _ => panic!("{}: panoconv {got:?}, devkit {want}", info.annotation),
                }
                compared += 1;
            }
        }
        assert_eq!(compared, 32, "every annotation compared");
        assert!(
            known >= known_at_least,
            "{known} velocities known at {spacing} s"
        );
        if spacing == 0.5 {
            assert_eq!(moving, 3, "the moving car in each sample");
        } else {
            assert_eq!(known, 0);
        }
    }
}
