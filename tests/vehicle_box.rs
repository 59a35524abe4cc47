//! The vehicle's own LiDAR returns (a roof sensor hits the car's roof, bonnet and boot) are
//! dropped by the rig readers before anything uses the scan: returns added on the bonnet of the
//! nuScenes fixture's first sample change no output of `panoconv nuscenes --depth`, and with
//! `--vehicle-box none` they become depth labels under 2 m.

use crate::common::{self, copy_tree};
use std::path::Path;

/// Points on a bonnet 1-2.5 m ahead of LIDAR_TOP and 0.6 m below it (its frame: x right, y
/// forward, z up), inside the default box, as nuScenes' five-float records.
fn bonnet() -> Vec<u8> {
    let mut bytes = Vec::new();
    for i in 0..40 {
        for j in 0..30 {
            let (x, y, z) = (-0.8 + i as f32 * 0.04, 1.0 + j as f32 * 0.05, -0.6f32);
            for v in [x, y, z, 10.0, 5.0] {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    bytes
}

fn convert(root: &Path, out: &Path, extra: &[&str]) -> Vec<u8> {
    let mut args = vec![
        "nuscenes",
        "--to",
        "equirect",
        "--input",
        root.to_str().unwrap(),
        "--version",
        "v1.0-mini",
        "--pano-width",
        "512",
        "--depth",
        "-q",
        "--output",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let run = common::panoconv(args);
    assert_eq!(run.code, 0, "{}", run.stderr);
    std::fs::read(out.join("training/depth_2/000000.png")).unwrap()
}

#[test]
fn the_vehicles_own_returns_never_become_depth() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("nuscenes");
    copy_tree(&crate::nuscenes::fixture(), &root);
    let lidar = root.join("samples/LIDAR_TOP");
    let mut scans: Vec<_> = std::fs::read_dir(&lidar)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    scans.sort();
    let original = convert(&crate::nuscenes::fixture(), &dir.path().join("a"), &[]);
    let mut bytes = std::fs::read(&scans[0]).unwrap();
    bytes.extend(bonnet());
    std::fs::write(&scans[0], bytes).unwrap();
    assert_eq!(
        convert(&root, &dir.path().join("b"), &[]),
        original,
        "the bonnet's returns changed the depth map"
    );
    // kept, they are the nearest surface of the rays that pass them
    convert(&root, &dir.path().join("c"), &["--vehicle-box", "none"]);
    let png = common::read_png(&dir.path().join("c/training/depth_2/000000.png"));
    let near = png
        .data
        .chunks(2)
        .map(|b| u16::from_be_bytes([b[0], b[1]]))
        .filter(|&d| d > 0 && d < 2 * 256)
        .count();
    assert!(
        near > 20,
        "{near} depth pixels under 2 m with the bonnet kept"
    );
}
