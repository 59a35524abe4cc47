//! The faults of real scans, each as a small synthetic scene: a scan's rings with gaps between
//! them, a window that returns nothing, a road whose slope changes (off any one plane), a
//! noisy scan with a stray return, and a surface's edge against the sky seen with parallax.
//! The vehicle's own returns are the readers' ([`crate::source::VehicleBox`]).

use super::*;

/// The shared scene tests' frame of `points` alone.
fn frame(points: Vec<Vector3<f64>>) -> Frame {
    super::tests::frame(points, Vec::new())
}

/// A scanner at the origin (y down, z ahead): rings `ring_deg` apart in elevation from -10°
/// to +10°, 0.2° apart in azimuth over ±40°, each ray meeting `surface` (None: no return).
fn scan(ring_deg: f64, surface: impl Fn(&Vector3<f64>) -> Option<f64>) -> Vec<Vector3<f64>> {
    scan_within((-10.0, 10.0), ring_deg, 40.0, surface)
}

/// [`scan`] with rings from `elevations.0` to `elevations.1` degrees, over ±`azimuth_deg`.
fn scan_within(
    elevations: (f64, f64),
    ring_deg: f64,
    azimuth_deg: f64,
    surface: impl Fn(&Vector3<f64>) -> Option<f64>,
) -> Vec<Vector3<f64>> {
    let mut points = Vec::new();
    let rings = ((elevations.1 - elevations.0) / ring_deg + 1e-9) as i32;
    let steps = (azimuth_deg / 0.2).round() as i32;
    for r in 0..=rings {
        let elevation = (elevations.0 + r as f64 * ring_deg).to_radians();
        for a in -steps..=steps {
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

/// Degrees between the rays from `eye` to `x` and to `y`.
fn parallax_deg(eye: &Vector3<f64>, x: &Vector3<f64>, y: &Vector3<f64>) -> f64 {
    let (a, b) = ((x - eye).normalize(), (y - eye).normalize());
    a.dot(&b).clamp(-1.0, 1.0).acos().to_degrees()
}

#[test]
fn a_road_falling_away_beyond_a_crest_is_stitched_at_its_own_distance() {
    // the road 1.8 m below, flat behind and beside, falling away 5 % beyond 12 m ahead (a
    // crest); a 32-ring scan all around, down to -25° (no return within 3.9 m)
    let height = |x: &Vector3<f64>| 1.8 + 0.05 * (x.z - 12.0).max(0.0);
    let road = |d: &Vector3<f64>| {
        if d.y <= 0.0 {
            return None;
        }
        let flat = 1.8 / d.y;
        if flat * d.z <= 12.0 {
            return Some(flat);
        }
        // y = 1.2 + 0.05 z along the ray
        let t = 1.2 / (d.y - 0.05 * d.z);
        (t > 0.0 && t < 80.0).then_some(t)
    };
    let points = scan_within((-25.0, 5.0), 1.0, 180.0, road);
    // a camera 1 m beside and half a metre ahead of the output centre
    let eye = Vector3::new(1.0, 0.0, 0.5);
    let scene = SceneDepth::new(&frame(points), Vector3::zeros(), vec![eye]);
    let (mut worst_far, mut worst_near, mut worst_deg) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..60 {
        let azimuth = -15.0 + k as f64 * 0.5;
        // beyond the crest (13-22 m ahead, returns out to 32 m): the falling road
        let d = bearing(azimuth, -6.0 - (k % 8) as f64 * 0.25);
        let (t, exact) = (scene.distance(&d), road(&d).unwrap());
        assert!(exact * d.z > 12.0 && exact < 40.0);
        worst_far = worst_far.max((t / exact - 1.0).abs());
        worst_deg = worst_deg.max(parallax_deg(&eye, &(d * t), &(d * exact)));
        assert!((height(&(d * exact)) - (d * exact).y).abs() < 1e-9);
        // near the car, where the scan has no returns: the flat road
        let down = bearing(azimuth * 6.0, -30.0 - (k % 6) as f64 * 10.0);
        let (t, exact) = (scene.distance(&down), 1.8 / down.y);
        worst_near = worst_near.max((t / exact - 1.0).abs());
    }
    // one plane puts the road beyond the crest metres nearer: the camera's sample of it lies
    // about 0.8° (4 px of a 2048 px panorama) off; the local ground within 6 % (at a grazing
    // 1° between the ray and the road), 0.25° (1.4 px)
    assert!(
        worst_far < 0.06 && worst_deg < 0.25 && worst_near < 0.005,
        "beyond the crest {:.2} %, {worst_deg:.3}°; near {:.2} %",
        worst_far * 100.0,
        worst_near * 100.0
    );
}

/// A deterministic jitter in [-1, 1] of bearing `d`.
fn jitter(d: &Vector3<f64>) -> f64 {
    let x = (d.dot(&Vector3::new(12.9898, 78.233, 37.719)) * 43758.5453).sin() * 1e4;
    (x - x.floor()) * 2.0 - 1.0
}

#[test]
fn a_noisy_scan_and_a_stray_return_do_not_hide_a_surface_from_a_camera() {
    // a wall 20 m ahead scanned by 0.5° rings, every range off by up to 3 cm, and one stray
    // return (dust) 6 m out on the camera's way to the wall
    let eye = Vector3::new(0.5, 0.0, 0.3);
    let target = Vector3::new(2.0, -0.5, 20.0);
    let stray = eye + (target - eye).normalize() * 6.0;
    let mut points = scan(0.5, |d| wall(d).map(|t| t * 20.0 / 15.0 + 0.03 * jitter(d)));
    points.push(stray);
    let scene = SceneDepth::new(&frame(points), Vector3::zeros(), vec![eye]);
    // the ring spacing measured from the scan
    assert!((scene.noise.spacing.to_degrees() - 0.5).abs() < 0.01);
    // the wall around the stray's bearing, and everywhere: seen despite the noise
    let (mut seen, mut tested) = (0, 0);
    for k in 0..121 {
        let (i, j) = ((k % 11) as f64 - 5.0, (k / 11) as f64 - 5.0);
        let on_wall = target + Vector3::new(i * 0.03, j * 0.03, 0.0);
        let far_on_wall = Vector3::new(i * 1.1, j * 0.25, 20.0);
        tested += 2;
        seen += usize::from(scene.sees(0, &on_wall)) + usize::from(scene.sees(0, &far_on_wall));
    }
    // and the output centre's distance there is the wall's
    let d = stray.normalize();
    let t = scene.distance(&d);
    assert!(
        seen == tested && (t - 20.0 / d.z).abs() < 0.1,
        "{seen} of {tested} seen; {t} m along the stray's bearing"
    );
}

#[test]
fn the_sky_above_a_walls_edge_is_sampled_through_the_edge_by_a_camera_with_parallax() {
    // a wall 15 m ahead, 2 m above the scanner; above it nothing returns (the sky, or above
    // the scan's top ring); a camera half a metre lower and ahead sees its top 1.9° higher
    let tall = |d: &Vector3<f64>| wall(d).filter(|t| d.y * t >= -2.0);
    let eye = Vector3::new(0.3, 0.5, 0.5);
    let scene = SceneDepth::new(&frame(scan(0.5, tall)), Vector3::zeros(), vec![eye]);
    let top = (2.0f64 / 15.0).atan().to_degrees();
    let (mut seen, mut tested) = (0, 0);
    for k in 0..40 {
        // between the centre's splats' edge and the camera's view of the top
        let d = bearing(-20.0 + k as f64, top + 0.8 + (k % 5) as f64 * 0.2);
        let x = d * scene.distance(&d);
        tested += 1;
        seen += usize::from(scene.sees(0, &x));
    }
    assert!(seen == tested, "{seen} of {tested}");
}
