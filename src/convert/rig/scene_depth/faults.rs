//! The faults of real scans, each as a small synthetic scene: a scan's rings with gaps between
//! them, a window that returns nothing, and a road whose slope changes (off any one plane).
//! The vehicle's own returns are the readers' ([`crate::source::VehicleBox`]).

use super::*;
use crate::source::LidarPoint;

fn frame(points: Vec<Vector3<f64>>) -> Frame {
    Frame {
        id: "0".into(),
        provenance: Vec::new(),
        rig: Vec::new(),
        objects: Vec::new(),
        regions: Vec::new(),
        lidar: points
            .into_iter()
            .map(|position| LidarPoint {
                position,
                intensity: 0.0,
            })
            .collect(),
        world_from_reference: None,
        reference_from_lidar: None,
        lidar_from_imu: None,
        input_hashes: Vec::new(),
    }
}

/// A scanner at the origin (y down, z ahead): rings `ring_deg` apart in elevation from -10°
/// to +10°, 0.2° apart in azimuth over ±40°, each ray meeting `surface` (None: no return).
fn scan(ring_deg: f64, surface: impl Fn(&Vector3<f64>) -> Option<f64>) -> Vec<Vector3<f64>> {
    let mut points = Vec::new();
    let rings = (20.0 / ring_deg) as i32;
    for r in 0..=rings {
        let elevation = (-10.0 + r as f64 * ring_deg).to_radians();
        for a in -200..=200 {
            let azimuth = (a as f64 * 0.2).to_radians();
            let d = Vector3::new(
                azimuth.sin() * elevation.cos(),
                -elevation.sin(),
                azimuth.cos() * elevation.cos(),
            );
            if let Some(t) = surface(&d) {
                points.push(d * t);
            }
        }
    }
    points
}

/// A wall 15 m ahead, facing the scanner.
fn wall(d: &Vector3<f64>) -> Option<f64> {
    (d.z > 0.0).then(|| 15.0 / d.z)
}

/// The unit bearing at `elevation_deg` above the horizon, `azimuth_deg` right of ahead.
fn bearing(azimuth_deg: f64, elevation_deg: f64) -> Vector3<f64> {
    let (a, e) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    Vector3::new(a.sin() * e.cos(), -e.sin(), a.cos() * e.cos())
}

#[test]
fn the_gaps_between_a_scans_rings_take_the_surfaces_distance() {
    // nuScenes' HDL-32E: 1.33° between rings, wider than a splat (0.5° radius)
    let scene = SceneDepth::new(&frame(scan(1.33, wall)), Vector3::zeros(), vec![]);
    // the bearings halfway between two rings, 0.17° beyond either's splat
    for k in 0..40 {
        let d = bearing(-20.0 + k as f64, -10.0 + 1.33 * (k % 14) as f64 + 0.665);
        let t = scene.distance(&d);
        let exact = 15.0 / d.z;
        assert!(
            (t - exact).abs() < 0.02 * exact,
            "{d}: {t} m, the wall at {exact}"
        );
    }
}

#[test]
fn a_window_that_returns_nothing_takes_the_walls_distance_and_the_sky_stays_far() {
    // a 2° × 2° window ahead; above +10° the scan ends (the sky)
    let window = |d: &Vector3<f64>| {
        let (az, el) = (d.x.atan2(d.z).to_degrees(), (-d.y).asin().to_degrees());
        if az.abs() < 1.0 && el.abs() < 1.0 {
            None
        } else {
            wall(d)
        }
    };
    let scene = SceneDepth::new(&frame(scan(0.4, window)), Vector3::zeros(), vec![]);
    let t = scene.distance(&bearing(0.0, 0.0));
    assert!((t - 15.0).abs() < 0.1, "{t}");
    assert_eq!(scene.distance(&bearing(0.0, 20.0)), FAR);
}

#[test]
fn a_camera_beside_the_scanner_sees_a_road_whose_slope_changes() {
    // the road 1.8 m below, flat for 10 m, then climbing 6 % (its far part is off the fitted
    // plane, so its returns are splats): seen at a grazing angle from both viewpoints
    let road = |d: &Vector3<f64>| {
        if d.y <= 0.0 {
            return None;
        }
        let flat = 1.8 / d.y;
        if flat * d.z <= 10.0 {
            return Some(flat);
        }
        // y = 1.8 − 0.06·(z − 10) along the ray
        Some((1.8 + 0.6) / (d.y + 0.06 * d.z))
    };
    let points = scan(1.33, road);
    let eye = Vector3::new(1.0, 0.3, -0.5);
    let scene = SceneDepth::new(&frame(points), Vector3::zeros(), vec![eye]);
    let (mut seen, mut tested) = (0, 0);
    for k in 0..60 {
        let d = bearing(-20.0 + k as f64 * 0.7, -3.0 - (k % 6) as f64 * 0.5);
        let t = scene.distance(&d);
        if !(t < 60.0) {
            continue;
        }
        tested += 1;
        seen += usize::from(scene.sees(0, &(d * t)));
    }
    assert!(tested > 40 && seen == tested, "{seen} of {tested}");
}
