//! The weights pass's unit tests.

use super::*;
use crate::camera::{Equirect, ImageSize, Intrinsics, Perspective};

#[test]
fn the_reach_bound_changes_no_table_entry_and_no_weight() {
    let wide = Perspective::new(
        Intrinsics::new(60.0, 60.0, 99.5, 49.5),
        ImageSize::new(200, 100),
    );
    let narrow = Perspective::new(
        Intrinsics::new(300.0, 300.0, 70.0, 40.0),
        ImageSize::new(150, 90),
    );
    let turn =
        |deg: f64| *nalgebra::Rotation3::from_euler_angles(0.1, deg.to_radians(), 0.0).matrix();
    let cameras = [
        StitchCamera {
            model: &wide,
            rotation: turn(80.0),
            translation: Vector3::new(0.3, 0.0, -0.2),
            max_theta: Some(1.0),
        },
        StitchCamera {
            model: &narrow,
            rotation: Matrix3::identity(),
            translation: Vector3::new(-0.5, 0.1, 0.0),
            max_theta: None,
        },
        StitchCamera {
            model: &wide,
            rotation: turn(-100.0),
            translation: Vector3::new(0.0, 0.0, 0.4),
            max_theta: None,
        },
    ];
    let output = Equirect::new(
        Intrinsics::new(
            320.0 / (2.0 * std::f64::consts::PI),
            320.0 / (2.0 * std::f64::consts::PI),
            160.0,
            80.0,
        ),
        ImageSize::new(320, 160),
    );
    let centre = Vector3::new(0.05, -0.02, 0.1);
    let options = StitchOptions::default();
    let build = |bounded| {
        let t = Stitch::tables_and_weights(&output, &centre, &cameras, &[], options, bounded, None);
        (t.tables, t.weights)
    };
    let (bounded, every) = (build(true), build(false));
    for i in 0..cameras.len() {
        assert!(bounded.0[i] == every.0[i], "camera {i}: tables differ");
        let bits = |w: &[f32]| w.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&bounded.1[i]),
            bits(&every.1[i]),
            "camera {i}: weights"
        );
        // the camera is seen somewhere, and not everywhere
        let seen = every.1[i].iter().filter(|w| **w > 0.0).count();
        assert!(
            seen > 100 && seen < every.1[i].len() / 2,
            "camera {i}: {seen}"
        );
    }
}

#[test]
fn the_probe_turn_is_nalgebras_to_the_bit() {
    // axes over the sphere, as the margins' perpendiculars give them
    let mut differ = 0;
    for k in 0..20000 {
        let z = 1.0 - 2.0 * (k as f64 + 0.5) / 20000.0;
        let phi = k as f64 * 2.399963229728653;
        let r = (1.0 - z * z).sqrt();
        let n = Vector3::new(r * phi.cos(), r * phi.sin(), z);
        let (a, b) = perpendiculars(&n);
        for axis in [a, b] {
            let axis = Unit::new_normalize(axis);
            let ours = probe_turn(&axis) * n;
            let theirs = Rotation3::from_axis_angle(&axis, SCALE_PROBE) * n;
            let bits = |v: Vector3<f64>| v.map(f64::to_bits);
            differ += usize::from(bits(ours) != bits(theirs));
        }
    }
    assert_eq!(differ, 0);
}

#[test]
fn a_saturated_pinhole_weight_is_the_measured_one() {
    // a wide and a narrow pinhole, off-centre principal points, points over the whole
    // image and beyond it
    let b = 5f64.to_radians();
    let (mut shortcut, mut measured) = (0, 0);
    for k in [
        Intrinsics::new(400.0, 380.0, 300.5, 170.0),
        Intrinsics::new(1500.0, 1500.0, 959.5, 539.5),
    ] {
        let model = Perspective::new(k, ImageSize::new(640 + k.fu as u32, 360));
        let camera = StitchCamera {
            model: &model,
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
            max_theta: None,
        };
        let s = Saturation { width: b, k };
        for i in 0..40000 {
            let (x, y) = (
                (i % 200) as f64 / 100.0 - 1.0,
                (i / 200) as f64 / 100.0 - 1.0,
            );
            let q = Vector3::new(x * 1.3, y * 0.9, 1.0) * (1.0 + (i % 3) as f64);
            let w = |m: Option<f64>| m.map(|m| smoothstep(m / b).to_bits());
            let fast = margin_capped(&camera, &q, None, Some(&s));
            assert_eq!(w(fast), w(margin(&camera, &q)), "{q}");
            if fast == Some(b) {
                shortcut += 1;
            } else {
                measured += 1;
            }
        }
    }
    assert!(shortcut > 5000 && measured > 5000, "{shortcut} {measured}");
}

#[test]
fn the_saturation_test_decides_as_with_the_hypotenuse() {
    // the test as written with libm's hypot, against the borders at its threshold and one
    // step either side of it, over the image and beyond r = 3
    let k = Intrinsics::new(1000.0, 990.0, 959.5, 539.5);
    let s = Saturation { width: 0.05, k };
    let reference = |p: &Point2<f64>, border: f64| {
        let r = ((p.x - k.cu) / k.fu).hypot((p.y - k.cv) / k.fv);
        let most = k.fu.abs().max(k.fv.abs()) * (1.0 + (r + 0.01).powi(2)) * 1.001;
        r <= 3.0 && border >= s.width * most
    };
    let (mut yes, mut no) = (0, 0);
    for i in 0..40_000 {
        let p = Point2::new(
            (i % 200) as f64 * 25.0 - 1500.0,
            (i / 200) as f64 * 20.0 - 1500.0,
        );
        let r = ((p.x - k.cu) / k.fu).hypot((p.y - k.cv) / k.fv);
        let at = s.width * k.fu * (1.0 + (r + 0.01).powi(2)) * 1.001;
        for border in [at, at.next_up(), at.next_down(), at * 0.5, at * 2.0] {
            let want = reference(&p, border);
            assert_eq!(saturated(&s, &p, border), want, "{p} {border}");
            yes += usize::from(want);
            no += usize::from(!want);
        }
    }
    assert!(yes > 20_000 && no > 20_000, "{yes} {no}");
}

#[test]
fn the_cosine_shortcuts_decide_as_the_angle_does() {
    let model = crate::camera::Unified::new(
        2.0,
        crate::camera::MeiDistortion {
            k1: 0.01,
            k2: 0.3,
            p1: 4e-4,
            p2: 4e-4,
        },
        Intrinsics::new(300.0, 300.0, 349.5, 349.5),
        0.0,
        ImageSize::new(700, 700),
        92.5f64.to_radians(),
    )
    .unwrap();
    let t = 92.5f64.to_radians();
    let camera = StitchCamera {
        model: &model,
        rotation: Matrix3::identity(),
        translation: Vector3::zeros(),
        max_theta: Some(t),
    };
    let proxy = Proxy::new(camera, Vector3::zeros(), 10.0);
    let b = 5f64.to_radians();
    let deep = Some(((t - b - FOV_SLACK).cos(), b));
    let (mut inside, mut outside, mut saturated) = (0, 0, 0);
    // angles on both sides of the field of view's edge and of the blend band's, down to
    // 1e-9 rad away, at several azimuths
    for k in 0..4000 {
        let offset = (k as f64 / 4000.0 - 0.5) * 2e-3 * (1e-6f64).powf((k % 7) as f64 / 6.0);
        let edge = if k % 2 == 0 { t } else { t - b };
        let theta = edge + offset;
        let phi = k as f64 * 0.37;
        let q = Vector3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        ) * (0.5 + (k % 5) as f64);
        let exact = !(q.x.hypot(q.y).atan2(q.z) > t);
        assert_eq!(proxy.within(&q), exact, "θ = {theta}");
        if exact {
            inside += 1;
        } else {
            outside += 1;
        }
        let w = |m: Option<f64>| m.map(|m| smoothstep(m / b).to_bits());
        let full = margin(&camera, &q);
        assert_eq!(
            w(margin_capped(&camera, &q, deep, None)),
            w(full),
            "θ = {theta}"
        );
        saturated += usize::from(full.is_some_and(|m| m >= b));
    }
    assert!(
        inside > 1000 && outside > 500 && saturated > 100,
        "{inside} {outside} {saturated}"
    );
}

#[test]
fn a_pyramid_sample_with_a_weight_reads_no_masked_pixel() {
    // a 640x480 pinhole (400 px/rad) into a panorama of 1 px a degree: 7 source pixels an
    // output pixel, sampled at level 3 of the pyramid, whose bilinear tap reads up to 12
    // source pixels from the sample's position (1 + rho/2 is 4.5)
    let size = ImageSize::new(640, 480);
    let model = Perspective::new(Intrinsics::new(400.0, 400.0, 319.5, 239.5), size);
    let (w, h) = (360u32, 180u32);
    let k = Intrinsics::new(
        w as f64 / std::f64::consts::TAU,
        h as f64 / std::f64::consts::PI,
        w as f64 / 2.0 - 0.5,
        h as f64 / 2.0 - 0.5,
    );
    let output = Equirect::new(k, ImageSize::new(w, h));
    let camera = StitchCamera {
        model: &model,
        rotation: Matrix3::identity(),
        translation: Vector3::zeros(),
        max_theta: None,
    };
    // masked (and black in the image): a block left of the centre; white elsewhere
    let masked = |x: u32, y: u32| (250..300).contains(&x) && (200..280).contains(&y);
    let mask = EgoMask::new(
        size,
        (0..size.height)
            .flat_map(|y| (0..size.width).map(move |x| masked(x, y)))
            .collect(),
    )
    .expect("mask");
    let mut image = crate::image::RgbImage::new(size.width, size.height);
    for y in 0..size.height {
        for x in 0..size.width {
            let v = if masked(x, y) { 0 } else { 255 };
            image.put_pixel(x, y, [v, v, v]);
        }
    }
    let options = StitchOptions {
        distance: 10.0,
        blend_width: 5f64.to_radians(),
        even_exposure: false,
    };
    let stitch = Stitch::build_masked(
        &output,
        &Vector3::zeros(),
        &[camera],
        &[Some(&mask)],
        options,
    )
    .expect("stitch");
    assert!(
        stitch.tables[0].levels() > 3,
        "{}",
        stitch.tables[0].levels()
    );
    let out = stitch.apply(&[&image]).image;
    // every pixel the camera weighs is white: no masked pixel is under its sample; and
    // the mask's rim is near (a tap per source pixel would let 1 + rho/2 suffice)
    let (mut weighed, mut near_rim) = (0, 0);
    for v in 0..h {
        for u in 0..w {
            if stitch.weight(0, u, v) <= 0.0 {
                continue;
            }
            weighed += 1;
            assert_eq!(out.pixel(u, v), [255, 255, 255], "({u}, {v})");
            let d = output.unproject(&Point2::new(u as f64, v as f64)).unwrap();
            if let Ok(p) = model.project_point(&d) {
                let gap_x = (250.0 - p.x).max(p.x - 299.0).max(0.0);
                let gap_y = (200.0 - p.y).max(p.y - 279.0).max(0.0);
                near_rim += usize::from(gap_x.max(gap_y) < 30.0);
            }
        }
    }
    assert!(weighed > 1000 && near_rim > 10, "{weighed} {near_rim}");
}

#[test]
fn weights_fall_off_towards_the_edges_and_the_proxy_inverts() {
    let model = Perspective::new(
        Intrinsics::new(100.0, 100.0, 99.5, 49.5),
        ImageSize::new(200, 100),
    );
    let camera = StitchCamera {
        model: &model,
        rotation: Matrix3::identity(),
        translation: Vector3::new(-0.5, 0.0, 0.0),
        max_theta: None,
    };
    // at the image centre: 50 px to the top and bottom edges at 100 px/rad
    let m = margin(&camera, &Vector3::z()).unwrap();
    assert!((m - 0.5).abs() < 1e-6, "{m}");
    // near the right edge the margin shrinks to the pixel distance over the local scale
    let q = Vector3::new(0.95, 0.0, 1.0);
    let m = margin(&camera, &q).unwrap();
    let p = model.project_point(&q).unwrap();
    let want = (199.5 - p.x) / (100.0 * (1.0 + 0.95f64.powi(2)));
    assert!((m - want).abs() < 1e-3 * want, "{m} vs {want}");
    assert_eq!(smoothstep(-1.0), 0.0);
    assert_eq!(smoothstep(0.5), 0.5);
    assert_eq!(smoothstep(2.0), 1.0);
    let defaults = StitchOptions::default();
    assert!(defaults.even_exposure && defaults.distance == 10.0);
    // the proxy's unproject is its project's inverse, with a baseline
    let proxy = Proxy::new(camera, Vector3::new(0.1, 0.2, 0.0), 7.0);
    let d = Vector3::new(0.2, -0.1, 1.0).normalize();
    let px = proxy.project(&d).unwrap();
    let back = proxy.unproject(&px).unwrap();
    assert!((back - d).norm() < 1e-12, "{back} vs {d}");
}
