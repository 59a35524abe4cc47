//! Remap tables built through the cameras' batch paths (a linear output unprojected by columns
//! and rows, `Separable`; a linear source projecting many bearings in one call, `project_all`)
//! equal the tables of the per-pixel path, every quad, count, reach and cover value: the
//! per-pixel path is the same cameras seen through a wrapper that only forwards `project` and
//! `unproject`, so the builder cannot take the batch paths.

use nalgebra::{Matrix3, Point2, Vector3};
use panoconv::camera::{
    rotation_ypr, CameraModel, Fisheye, FisheyeCamera, ImageSize, Intrinsics, Lens, Perspective,
    Projection, ProjectionReject, RadialModel,
};
use panoconv::warp::{Footprint, Kernel, RemapTable, Wrap};
use std::f64::consts::{PI, TAU};

/// `inner` with only the per-pixel methods: no `separable`, the default `project_all`.
#[derive(Debug)]
struct PerPixel<'a>(&'a dyn CameraModel);

impl CameraModel for PerPixel<'_> {
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        self.0.project(d)
    }

    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        self.0.unproject(p)
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.0.distance(p)
    }

    fn size(&self) -> ImageSize {
        self.0.size()
    }
}

/// Builds `dst` from `src` both ways, serial and parallel, at full and at no supersampling, and
/// checks all four equal the per-pixel serial table.
fn check(name: &str, dst: &dyn CameraModel, src: &dyn CameraModel, rot: &Matrix3<f64>, wrap: Wrap) {
    let (pdst, psrc) = (PerPixel(dst), PerPixel(src));
    for ss in [1, 8] {
        let reference = RemapTable::build_within(&pdst, &psrc, rot, wrap, ss, None, false);
        for parallel in [false, true] {
            let table = RemapTable::build_within(dst, src, rot, wrap, ss, None, parallel);
            assert!(
                table == reference,
                "{name}: the batch table differs (supersampling {ss}, parallel {parallel})"
            );
        }
    }
}

/// KITTI's camera 2 (frame 000000's P2) and image size.
fn kitti() -> Perspective {
    Perspective::new(
        Intrinsics::new(721.5377, 721.5377, 609.5593, 172.854),
        ImageSize::new(1242, 375),
    )
}

#[test]
fn linear_outputs_of_a_pinhole_source_equal_the_per_pixel_tables() {
    let src = kitti();
    let turns = [rotation_ypr(0.0, 0.0, 0.0), rotation_ypr(0.3, -0.15, 0.05)];
    for projection in [
        Projection::Equirect,
        Projection::Cylindrical,
        Projection::Perspective,
    ] {
        // KITTI's scale (up to 2x1 taps at the edges), a coarse one (up to 8x8 taps) and a
        // view wider than the source, whose edge pixels have no image
        for (fu, w, h) in [(721.5, 300, 120), (90.0, 160, 60), (150.0, 400, 200)] {
            let fv = if projection == Projection::Equirect {
                fu
            } else {
                fu * 0.97
            };
            let k = Intrinsics::new(fu, fv, w as f64 / 2.0 - 0.3, h as f64 / 2.0 + 0.2);
            let dst = projection.camera(k, ImageSize::new(w, h));
            for (i, rot) in turns.iter().enumerate() {
                let name = format!("{projection} f {fu}, turn {i}");
                check(&name, dst.as_ref(), &src, rot, Wrap::None);
            }
        }
    }
}

#[test]
fn outputs_of_a_panorama_source_equal_the_per_pixel_tables() {
    let (sw, sh) = (720, 360);
    let k = Intrinsics::new(
        sw as f64 / TAU,
        sh as f64 / PI,
        sw as f64 / 2.0,
        sh as f64 / 2.0,
    );
    let src = Projection::Equirect.camera(k, ImageSize::new(sw, sh));
    let rot = rotation_ypr(2.5, 0.4, -0.3);
    for projection in [
        Projection::Equirect,
        Projection::Cylindrical,
        Projection::Perspective,
    ] {
        // a full turn at half the source's scale (2x2 taps), and a narrow view that is not
        let (w, h, fu) = match projection {
            Projection::Perspective => (200, 150, 120.0),
            _ => (360, 180, 360.0 / TAU),
        };
        let dst = projection.camera(
            Intrinsics::new(fu, fu, w as f64 / 2.0, h as f64 / 2.0),
            ImageSize::new(w, h),
        );
        check(
            &projection.to_string(),
            dst.as_ref(),
            src.as_ref(),
            &rot,
            Wrap::Horizontal,
        );
        // the rows beyond the poles of an equirect output that is taller than the sphere
        let tall = projection.camera(
            Intrinsics::new(fu, fu * 1.3, w as f64 / 2.0, h as f64 / 2.0),
            ImageSize::new(w, h),
        );
        let name = format!("{projection}, taller than the sphere");
        check(&name, tall.as_ref(), src.as_ref(), &rot, Wrap::Horizontal);
    }
}

#[test]
fn a_fisheye_output_equals_the_per_pixel_table_with_and_without_its_footprint() {
    let src = kitti();
    let size = ImageSize::new(300, 240);
    let k = Intrinsics::new(80.0, 80.5, 149.7, 120.2);
    let model = RadialModel::KannalaBrandt([0.04, -0.012, 0.002, -0.0002]);
    let lens = Lens::from(Fisheye::new(model, k, size, 190f64.to_radians()).unwrap());
    let camera = FisheyeCamera {
        lens,
        rect_from_camera: rotation_ypr(0.2, -0.17, 0.01),
    };
    let id = Matrix3::identity();
    check("fisheye", &camera, &src, &id, Wrap::None);
    let blind = camera.rect_from_camera * -Vector3::z();
    let seen = Footprint::new(&camera, &src, &id, &blind).expect("a footprint");
    let (pdst, psrc) = (PerPixel(&camera), PerPixel(&src));
    let reference = RemapTable::build_within(&pdst, &psrc, &id, Wrap::None, 8, None, false);
    for parallel in [false, true] {
        let within =
            RemapTable::build_within(&camera, &src, &id, Wrap::None, 8, Some(&seen), parallel);
        assert!(
            within == reference,
            "fisheye within its footprint (parallel {parallel})"
        );
    }
}

#[test]
fn wide_linear_views_within_their_footprint_equal_the_full_tables() {
    // the Python package's drawn cameras: a turned equirect or cylindrical view much wider
    // than a KITTI camera (most of its rows and columns outside the footprint), built at one
    // tap a pixel row by row (serial) and through the general bands (parallel)
    let src = kitti();
    let back = -Vector3::z();
    for projection in [Projection::Equirect, Projection::Cylindrical] {
        for (fov_deg, turn) in [(100.0, (0.1, -0.05, 0.03)), (140.0, (-0.15, 0.08, -0.07))] {
            let (w, h) = (320, 240);
            let fu = w as f64 / f64::to_radians(fov_deg);
            let k = Intrinsics::new(fu, fu, w as f64 / 2.0 + 3.7, h as f64 / 2.0 - 2.2);
            let dst = projection.camera(k, ImageSize::new(w, h));
            let rot = rotation_ypr(turn.0, turn.1, turn.2);
            let seen = Footprint::new(dst.as_ref(), &src, &rot, &back).expect("a footprint");
            let name = format!("{projection} {fov_deg}°");
            for ss in [1, 8] {
                let full = RemapTable::build_within(
                    &PerPixel(dst.as_ref()),
                    &PerPixel(&src),
                    &rot,
                    Wrap::None,
                    ss,
                    None,
                    true,
                );
                assert!(full.coverage() > 0.05 && full.coverage() < 0.5, "{name}");
                for parallel in [false, true] {
                    let within = RemapTable::build_within(
                        dst.as_ref(),
                        &src,
                        &rot,
                        Wrap::None,
                        ss,
                        Some(&seen),
                        parallel,
                    );
                    assert!(
                        within == full,
                        "{name}: the table within the footprint differs (supersampling {ss}, parallel {parallel})"
                    );
                }
            }
        }
    }
}

/// RMS deviation from the mean (grey levels) of a fine checkerboard warped to a view 3.3
/// times coarser, over the view's pixels 2 or more from its border: the checkerboard's period
/// is 1.2 output pixels, beyond what the output can show, so an ideal prefilter gives flat
/// grey and all of the deviation is aliasing (moiré).
fn moire(max_supersample: u32) -> f64 {
    let (w, h) = (800u32, 600u32);
    let src = Perspective::new(
        Intrinsics::new(600.0, 600.0, 399.5, 299.5),
        ImageSize::new(w, h),
    );
    let out = Perspective::new(
        Intrinsics::new(180.0, 180.0, 119.5, 89.5),
        ImageSize::new(240, 180),
    );
    let mut image = panoconv::image::RgbImage::new(w, h);
    for (i, px) in image.as_raw_mut().chunks_mut(3).enumerate() {
        let (x, y) = ((i as u32 % w) as f64, (i as u32 / w) as f64);
        // squares of 2 source pixels turned by atan(3/4) (exact products, no sine)
        let (a, b) = (x * 0.8 + y * 0.6, -x * 0.6 + y * 0.8);
        let white = ((a / 2.0).floor() + (b / 2.0).floor()).rem_euclid(2.0) == 0.0;
        px.fill(if white { 255 } else { 0 });
    }
    let id = Matrix3::identity();
    let table = RemapTable::build_with(&out, &src, &id, Wrap::None, max_supersample);
    let warped = table.apply(&image);
    let values: Vec<f64> = (2..178)
        .flat_map(|v| (2..238).map(move |u| (u, v)))
        .map(|(u, v)| warped.pixel(u, v)[0] as f64)
        .collect();
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let se: f64 = values.iter().map(|x| (x - mean) * (x - mean)).sum();
    (se / values.len() as f64).sqrt()
}

#[test]
fn a_fine_checkerboard_warped_coarser_shows_no_more_moire_than_the_per_tap_builder() {
    // 26.58 is the per-tap builder's figure (9f0cced, the Python package's
    // `Warp(src, dst, supersample=8)` of the same cameras and image; supersample 1 gives 90.77,
    // 2 gives 38.39); 0.3 grey level of slack for the taps' interpolation (under 0.01 source
    // pixel) and the weights' rounding.
    const PER_TAP: f64 = 26.58;
    let antialiased = moire(8);
    let plain = moire(1);
    eprintln!("moiré: {antialiased:.2} grey levels RMS at supersample 8, {plain:.2} at 1");
    assert!(
        antialiased <= PER_TAP + 0.3,
        "{antialiased:.2} > {PER_TAP} + 0.3"
    );
    // the measure sees aliasing: the plain lookup fails the bound above by far
    assert!(plain > 3.0 * (PER_TAP + 0.3), "{plain:.2}");
}

/// The pyramid's moiré on [`moire`]'s checkerboard and cameras.
fn moire_pyramid() -> f64 {
    moire_through(None)
}

/// [`moire_pyramid`], the table built by [`RemapTable::build_pyramid_within`] or, with
/// `taps_below`, by [`RemapTable::build_pyramid_above`] (as the fixed stitch builds its tables).
fn moire_through(taps_below: Option<f64>) -> f64 {
    let (w, h) = (800u32, 600u32);
    let src = Perspective::new(
        Intrinsics::new(600.0, 600.0, 399.5, 299.5),
        ImageSize::new(w, h),
    );
    let out = Perspective::new(
        Intrinsics::new(180.0, 180.0, 119.5, 89.5),
        ImageSize::new(240, 180),
    );
    let mut image = panoconv::image::RgbImage::new(w, h);
    for (i, px) in image.as_raw_mut().chunks_mut(3).enumerate() {
        let (x, y) = ((i as u32 % w) as f64, (i as u32 / w) as f64);
        let (a, b) = (x * 0.8 + y * 0.6, -x * 0.6 + y * 0.8);
        let white = ((a / 2.0).floor() + (b / 2.0).floor()).rem_euclid(2.0) == 0.0;
        px.fill(if white { 255 } else { 0 });
    }
    let id = Matrix3::identity();
    let table = match taps_below {
        None => RemapTable::build_pyramid_within(&out, &src, &id, Wrap::None, 8, None, false),
        Some(t) => RemapTable::build_pyramid_above(&out, &src, &id, t, false),
    };
    assert!(table.levels() > 1, "the view samples the pyramid");
    let warped = table.apply(&image);
    let values: Vec<f64> = (2..178)
        .flat_map(|v| (2..238).map(move |u| (u, v)))
        .map(|(u, v)| warped.pixel(u, v)[0] as f64)
        .collect();
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let se: f64 = values.iter().map(|x| (x - mean) * (x - mean)).sum();
    (se / values.len() as f64).sqrt()
}

#[test]
fn the_pyramid_shows_no_more_moire_than_the_per_tap_builder() {
    // 26.58: the per-tap builder's figure (the test above)
    let pyramid = moire_pyramid();
    eprintln!("moiré: {pyramid:.2} grey levels RMS through the pyramid");
    assert!(pyramid <= 26.58, "{pyramid:.2}");
}

#[test]
fn the_stitchs_pyramid_above_2_source_pixels_shows_the_pyramids_moire_and_the_taps_below() {
    // 3.3 source pixels an output pixel: the pyramid's level and taps (15.21 grey levels, the
    // taps' 26.58)
    let above = moire_through(Some(2.0));
    eprintln!("moiré: {above:.2} grey levels RMS through the pyramid above 2 source pixels");
    assert!(above <= 15.21 + 0.3, "{above:.2}");
    // 1.7 source pixels an output pixel (a pinhole of a pinhole: everywhere): the taps, entry
    // for entry, serially and in parallel
    let src = Perspective::new(
        Intrinsics::new(600.0, 600.0, 399.5, 299.5),
        ImageSize::new(800, 600),
    );
    let out = Perspective::new(
        Intrinsics::new(353.0, 353.0, 235.5, 176.5),
        ImageSize::new(472, 354),
    );
    let id = Matrix3::identity();
    let taps = RemapTable::build_within(&out, &src, &id, Wrap::None, 8, None, false);
    for parallel in [false, true] {
        let hybrid = RemapTable::build_pyramid_above(&out, &src, &id, 2.0, parallel);
        assert!(
            hybrid == taps,
            "parallel {parallel}: the table differs from the taps'"
        );
        // through the pyramid from 1.5 it samples level 1
        let below = RemapTable::build_pyramid_above(&out, &src, &id, 1.5, parallel);
        assert_eq!(below.levels(), 2, "parallel {parallel}");
    }
}

/// PSNR (dB) against the exact render of a synthetic KITTI frame warped to coarser 640×480
/// views (a 190° fisheye, an equirect crop of 120°, a cylindrical view of 100°, turned as a
/// drawn camera is), per-tap supersampled and through the pyramid, over the pixels both
/// tables have wholly inside the source.
#[test]
fn coarse_views_through_the_pyramid_match_the_exact_render_as_the_taps_do() {
    use crate::common::{psnr, render_where};
    use panoconv::tools::synth::{frames, SynthCalib};
    let calib = SynthCalib::standard();
    let scene = &frames()[0].scene;
    let src = Perspective::new(calib.intrinsics(), calib.size);
    let image = scene.render(&src, &calib.centre());
    let lens = Fisheye::new(
        RadialModel::Equidistant,
        Intrinsics::new(150.0, 150.0, 321.3, 238.6),
        ImageSize::new(640, 480),
        190f64.to_radians(),
    )
    .expect("lens");
    let crop = Projection::Equirect.camera(
        Intrinsics::new(305.6, 305.6, 317.2, 241.9),
        ImageSize::new(640, 480),
    );
    let cylinder = Projection::Cylindrical.camera(
        Intrinsics::new(366.7, 366.7, 322.1, 236.4),
        ImageSize::new(640, 480),
    );
    let turn = rotation_ypr(0.05, -0.04, 0.03);
    let cases: [(&str, &dyn CameraModel); 3] = [
        ("fisheye 190°", &lens),
        ("equirect crop 120°", crop.as_ref()),
        ("cylindrical 100°", cylinder.as_ref()),
    ];
    for (name, dst) in cases {
        let taps = RemapTable::build_within(dst, &src, &turn, Wrap::None, 8, None, false);
        let pyr = RemapTable::build_pyramid_within(dst, &src, &turn, Wrap::None, 8, None, false);
        let plain = RemapTable::build_within(dst, &src, &turn, Wrap::None, 1, None, false);
        let kept = |u, v| taps.is_inside(u, v) && pyr.is_inside(u, v);
        // the render in the output's axes: the source's bearings turned back
        let turned = Turned(dst, turn.transpose());
        let exact = render_where(scene, &turned, &calib.centre(), 0.55, 6, kept);
        let (db_taps, n) = psnr(&taps.apply(&image), &exact, kept);
        let (db_pyr, _) = psnr(&pyr.apply(&image), &exact, kept);
        let (db_plain, _) = psnr(&plain.apply(&image), &exact, kept);
        eprintln!(
            "{name}: PSNR taps {db_taps:.2} dB, pyramid {db_pyr:.2} dB ({} levels), \
             bilinear {db_plain:.2} dB over {n} px",
            pyr.levels()
        );
        assert!(pyr.levels() > 1, "{name}: the view samples the pyramid");
        assert!(n > 5000, "{name}: {n} px compared");
        // the same table from bands built in parallel, the same bytes from every kernel
        let parallel =
            RemapTable::build_pyramid_within(dst, &src, &turn, Wrap::None, 8, None, true);
        assert!(parallel == pyr, "{name}: the parallel build differs");
        let want = pyr.apply(&image);
        for kernel in [Kernel::Scalar, Kernel::Sse2, Kernel::Avx2] {
            let mut got = panoconv::image::RgbImage::new(1, 1);
            pyr.apply_with(&image, &mut got, kernel);
            assert!(got == want, "{name}: {kernel:?} gives other bytes");
        }
        // row by row from the input buffer, as the Python package applies it
        let input = pyr.input(image.as_raw());
        let w3 = dst.size().width as usize * 3;
        let mut rows = vec![0u8; want.as_raw().len()];
        for (v, row) in rows.chunks_mut(w3).enumerate() {
            pyr.apply_row_data(&input, v, row);
        }
        assert!(rows == *want.as_raw(), "{name}: apply_row_data differs");
        assert!(
            db_pyr >= db_taps - 0.2,
            "{name}: {db_pyr:.2} < {db_taps:.2} - 0.2"
        );
    }
}

/// `inner` whose bearings are turned by `1` (its own axes to the source's), for a reference
/// render in the source's axes.
#[derive(Debug)]
struct Turned<'a>(&'a dyn CameraModel, Matrix3<f64>);

impl CameraModel for Turned<'_> {
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        self.0.project(&(self.1 * d))
    }

    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        self.0.unproject(p).map(|d| self.1.transpose() * d)
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.0.distance(&(self.1 * p))
    }

    fn size(&self) -> ImageSize {
        self.0.size()
    }
}
