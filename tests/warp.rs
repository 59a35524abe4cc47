//! The warp against exact renders: the synthetic scene rendered by the source pinhole camera,
//! warped, and compared with the same scene rendered directly in the target projection.

use crate::common::psnr;
use nalgebra::{Matrix3, Point2};
use panoconv::camera::{rotation_ypr, CameraModel, ImageSize, Intrinsics, Perspective, Projection};
use panoconv::geometry::{output_camera, Canvas, OutputSpec, Scale};
use panoconv::image::RgbImage;
use panoconv::tools::synth::{frames, SynthCalib};
use panoconv::warp::{Kernel, RemapTable, Wrap};

/// PSNR the issue asks for inside the source field of view (bilinear alone reaches ~54 dB).
const MIN_PSNR_DB: f64 = 50.0;
/// Share of the in-view output pixels the PSNR must cover.
const MIN_COVERAGE: f64 = 0.995;

/// Output pixels whose centre sees the source image.
fn in_view<'a>(
    out: &'a dyn CameraModel,
    src: &'a dyn CameraModel,
) -> impl Fn(u32, u32) -> bool + 'a {
    move |u, v| {
        out.unproject(&Point2::new(u as f64, v as f64))
            .and_then(|d| src.project(&d))
            .is_ok_and(|p| src.contains(&p))
    }
}

fn check(spec: OutputSpec, calib: &SynthCalib, frame: usize) -> f64 {
    let scene = &frames()[frame].scene;
    let src = Perspective::new(calib.intrinsics(), calib.size);
    let source_image = scene.render(&src, &calib.centre());
    let out = output_camera(&spec, calib.intrinsics(), &src).unwrap();
    let table = RemapTable::build(out.as_ref(), &src, &Matrix3::identity(), Wrap::None);
    let warped = table.apply(&source_image);
    let view = in_view(out.as_ref(), &src);
    // `Scene::render` where compared
    let compared = |u, v| view(u, v) && table.is_inside(u, v);
    let exact =
        crate::common::render_where(scene, out.as_ref(), &calib.centre(), 0.55, 6, compared);
    let total = (0..out.size().height)
        .flat_map(|v| (0..out.size().width).map(move |u| (u, v)))
        .filter(|&(u, v)| view(u, v))
        .count();
    // Pixels whose footprint straddles the source border mix in black: leave those out.
    let (db, n) = psnr(&warped, &exact, compared);
    let coverage = n as f64 / total as f64;
    eprintln!(
        "{:?} {:?} {}x{}: PSNR {db:.2} dB over {:.3} % of the {total} in-view pixels",
        spec.projection,
        spec.scale,
        out.size().width,
        out.size().height,
        coverage * 100.0
    );
    assert!(coverage >= MIN_COVERAGE, "coverage {coverage}");
    assert!(db >= MIN_PSNR_DB, "PSNR {db:.2} dB < {MIN_PSNR_DB}");
    db
}

#[test]
fn equirect_matches_the_exact_render() {
    check(
        OutputSpec::new(Projection::Equirect),
        &SynthCalib::standard(),
        0,
    );
}

#[test]
fn cylindrical_matches_the_exact_render() {
    check(
        OutputSpec::new(Projection::Cylindrical),
        &SynthCalib::standard(),
        2,
    );
}

#[test]
fn equirect_of_the_second_calibration_matches() {
    check(
        OutputSpec::new(Projection::Equirect),
        &SynthCalib::narrow(),
        1,
    );
}

#[test]
fn perspective_at_other_intrinsics_matches() {
    let spec = OutputSpec {
        projection: Projection::Perspective,
        scale: Scale::PixelsPerDegree(14.0),
        canvas: Canvas::Tight,
        ..OutputSpec::new(Projection::Perspective)
    };
    check(spec, &SynthCalib::standard(), 0);
}

#[test]
fn perspective_identity_is_exact() {
    let calib = SynthCalib::standard();
    let src = Perspective::new(calib.intrinsics(), calib.size);
    let image = frames()[0].scene.render(&src, &calib.centre());
    let out = output_camera(
        &OutputSpec::new(Projection::Perspective),
        calib.intrinsics(),
        &src,
    )
    .unwrap();
    assert_eq!(out.intrinsics(), calib.intrinsics());
    assert_eq!(out.size(), calib.size);
    let table = RemapTable::build(out.as_ref(), &src, &Matrix3::identity(), Wrap::None);
    assert!(table.apply(&image) == image, "identity warp changed pixels");
}

/// A grating near the source's Nyquist limit, viewed 2.2x coarser (the paper's 2048-px
/// panorama): point sampling folds it into strong moiré; the antialiased table must not.
#[test]
fn coarse_output_does_not_alias() {
    let calib = SynthCalib::standard();
    let src = Perspective::new(calib.intrinsics(), calib.size);
    let (w, h) = (calib.size.width, calib.size.height);
    let mut grating = RgbImage::new(w, h);
    for v in 0..h {
        for u in 0..w {
            // period 2.3 px horizontally and 2.6 px vertically
            let s = (u as f64 * std::f64::consts::TAU / 2.3).sin()
                * (v as f64 * std::f64::consts::TAU / 2.6).sin();
            let g = (127.5 + 120.0 * s).round() as u8;
            grating.put_pixel(u, v, [g, g, g]);
        }
    }
    let spec = OutputSpec {
        projection: Projection::Equirect,
        scale: Scale::PanoWidth(2048),
        canvas: Canvas::Tight,
        ..OutputSpec::new(Projection::Equirect)
    };
    let out = output_camera(&spec, calib.intrinsics(), &src).unwrap();
    let k: Intrinsics = out.intrinsics();
    assert!(
        (k.fu - 325.949).abs() < 1e-3,
        "2048 px panorama scale: {}",
        k.fu
    );
    let size = out.size();
    // The tight canvas, computed independently: longitude extremes at the left/right image
    // edges, latitude extremes where the top/bottom edges cross the principal column.
    let kk = calib.intrinsics();
    let f = 2048.0 / std::f64::consts::TAU;
    let lon = (w as f64 - 0.5 - kk.cu).atan2(kk.fu) - (-0.5 - kk.cu).atan2(kk.fu);
    let lat = ((h as f64 - 0.5 - kk.cv) / kk.fv).atan() - ((-0.5 - kk.cv) / kk.fv).atan();
    let expect = (
        (f * lon - 1e-6).ceil() as u32,
        (f * lat - 1e-6).ceil() as u32,
    );
    eprintln!(
        "2048-px scale canvas: {}x{} covering {:.2}°x{:.2}° (the paper quotes ~469x168, 82.5°x29.7°)",
        size.width,
        size.height,
        lon.to_degrees(),
        lat.to_degrees()
    );
    assert_eq!((size.width, size.height), expect);
    let stddev = |img: &RgbImage, table: &RemapTable| {
        let vals: Vec<f64> = (0..size.height)
            .flat_map(|v| (0..size.width).map(move |u| (u, v)))
            .filter(|&(u, v)| table.is_inside(u, v))
            .map(|(u, v)| img.pixel(u, v)[0] as f64)
            .collect();
        let mean = vals.iter().sum::<f64>() / vals.len() as f64;
        (vals.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / vals.len() as f64).sqrt()
    };
    let aa = RemapTable::build(out.as_ref(), &src, &Matrix3::identity(), Wrap::None);
    let point = RemapTable::build_with(out.as_ref(), &src, &Matrix3::identity(), Wrap::None, 1);
    let (s_aa, s_point) = (
        stddev(&aa.apply(&grating), &aa),
        stddev(&point.apply(&grating), &point),
    );
    eprintln!(
        "grating after warp: stddev {s_aa:.1} antialiased vs {s_point:.1} point-sampled (input 60)"
    );
    // The true average of the grating over an output pixel is ~flat grey.
    assert!(
        s_aa < 12.0,
        "antialiased output still shows moiré: stddev {s_aa:.1}"
    );
    assert!(
        s_point > 3.0 * s_aa,
        "the test grating does not alias without prefiltering"
    );
}

/// A small deterministic generator (xorshift), so failures reproduce.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    fn image(&mut self, w: u32, h: u32) -> RgbImage {
        let data = (0..w as usize * h as usize * 3)
            .map(|_| self.next() as u8)
            .collect();
        RgbImage::from_raw(w, h, data).unwrap()
    }
}

/// Random tables: output projections, rotations, scales (up to 8x supersampled) and sources
/// (KITTI-sized, tiny, one pixel wide or high, and a wrapping 360° panorama).
fn random_tables(seed: u64, n: usize) -> Vec<(RemapTable, RgbImage)> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|i| {
            let (sw, sh) = match i % 5 {
                0 => (1242, 375),
                1 => (1 + rng.next() % 9, 1 + rng.next() % 9),
                2 => (1, 2 + rng.next() % 30),
                3 => (2 + rng.next() % 30, 1),
                _ => (64 + rng.next() % 200, 32 + rng.next() % 100),
            };
            let (sw, sh) = (sw as u32, sh as u32);
            let panorama = i % 7 == 4;
            let src: Box<dyn CameraModel> = if panorama {
                let k = Intrinsics::new(
                    sw as f64 / std::f64::consts::TAU,
                    sh as f64 / std::f64::consts::PI,
                    sw as f64 / 2.0 - 0.5,
                    sh as f64 / 2.0 - 0.5,
                );
                Projection::Equirect.camera(k, ImageSize::new(sw, sh))
            } else {
                let f = rng.range(0.3, 1.5) * sw.max(sh) as f64;
                let k = Intrinsics::new(f, f, sw as f64 / 2.0, sh as f64 / 2.0);
                Projection::Perspective.camera(k, ImageSize::new(sw, sh))
            };
            // every few tables a tiny output: runs of 1 to 7 pixels, the kernels' tail cases
            let ow = if i % 4 == 1 {
                1 + rng.next() as u32 % 7
            } else {
                8 + rng.next() as u32 % 300
            };
            let oh = 8 + rng.next() as u32 % 120;
            let projection = [
                Projection::Equirect,
                Projection::Cylindrical,
                Projection::Perspective,
            ][rng.next() as usize % 3];
            let f = rng.range(0.05, 1.5) * ow as f64;
            let k = Intrinsics::new(f, f, ow as f64 / 2.0, oh as f64 / 2.0);
            let out = projection.camera(k, ImageSize::new(ow, oh));
            let rot = rotation_ypr(
                rng.range(-0.5, 0.5),
                rng.range(-0.3, 0.3),
                rng.range(-0.2, 0.2),
            );
            let wrap = if panorama {
                Wrap::Horizontal
            } else {
                Wrap::None
            };
            let ss = 1 + rng.next() as u32 % 8;
            let table = RemapTable::build_with(out.as_ref(), src.as_ref(), &rot, wrap, ss);
            (table, rng.image(sw, sh))
        })
        .collect()
}

#[test]
fn simd_and_scalar_kernels_give_the_same_bytes() {
    // Auto is the fastest the CPU has, Avx2 AVX2 where the CPU has it; Sse2 is the x86_64
    // baseline (scalar elsewhere).
    let run = |table: &RemapTable, image: &RgbImage, kernel| {
        let mut out = RgbImage::new(1, 1);
        table.apply_with(image, &mut out, kernel);
        out
    };
    for (table, image) in random_tables(0x5eed_1234, 40) {
        let scalar = run(&table, &image, Kernel::Scalar);
        // row by row, as the pipeline warps while encoding
        let w = table.size().width as usize * 3;
        let mut rows = vec![0u8; w * table.size().height as usize];
        for (v, row) in rows.chunks_exact_mut(w).enumerate() {
            table.apply_row(&image, v, row);
        }
        assert!(
            rows == *scalar.as_raw(),
            "apply_row differs from the scalar kernel"
        );
        for kernel in [Kernel::Auto, Kernel::Avx2, Kernel::Sse2] {
            assert!(
                run(&table, &image, kernel) == scalar,
                "{kernel:?} differs from the scalar kernel for a {:?} table from {:?}",
                table.size(),
                table.source_size()
            );
        }
    }
}

#[test]
fn output_does_not_depend_on_the_thread_count() {
    let pool = |n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
    };
    let (one, three) = (pool(1), pool(3));
    for (table, image) in random_tables(0xfeed_0042, 15) {
        let a = one.install(|| table.apply(&image));
        let b = three.install(|| table.apply(&image));
        assert!(a == b, "thread counts differ for {:?}", table.size());
        // and a reused, differently sized buffer is fully overwritten
        let mut reused = RgbImage::from_raw(1, 1, vec![7, 7, 7]).unwrap();
        table.apply_into(&image, &mut reused);
        let mut same = a.clone();
        same.as_raw_mut().fill(99);
        table.apply_into(&image, &mut same);
        assert!(reused == a && same == a, "apply_into differs from apply");
    }
}

#[test]
fn parallel_build_equals_serial_build() {
    let mut rng = Rng(0xabcd);
    for (i, calib) in [SynthCalib::standard(), SynthCalib::narrow()]
        .iter()
        .enumerate()
    {
        let src = Perspective::new(calib.intrinsics(), calib.size);
        for spec in [
            OutputSpec::new(Projection::Equirect),
            OutputSpec::new(Projection::Cylindrical),
            OutputSpec {
                projection: Projection::Equirect,
                scale: Scale::PanoWidth(2048),
                canvas: Canvas::Tight,
                ..OutputSpec::new(Projection::Equirect)
            },
        ] {
            let out = output_camera(&spec, calib.intrinsics(), &src).unwrap();
            let rot = if i == 0 {
                Matrix3::identity()
            } else {
                rotation_ypr(rng.range(-0.3, 0.3), rng.range(-0.2, 0.2), 0.0)
            };
            for ss in [1, 8] {
                let serial = RemapTable::build_with(out.as_ref(), &src, &rot, Wrap::None, ss);
                let parallel = RemapTable::build_parallel(out.as_ref(), &src, &rot, Wrap::None, ss);
                assert!(serial == parallel, "{spec:?} supersample {ss}");
            }
        }
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap();
    for seed in 0..8 {
        let mut rng = Rng(0x1000 + seed);
        let (sw, sh) = (40 + rng.next() as u32 % 50, 20 + rng.next() as u32 % 30);
        let k = Intrinsics::new(
            sw as f64 / std::f64::consts::TAU,
            sh as f64 / std::f64::consts::PI,
            sw as f64 / 2.0,
            sh as f64 / 2.0,
        );
        let src = Projection::Equirect.camera(k, ImageSize::new(sw, sh));
        let (ow, oh) = (5 + rng.next() as u32 % 90, 3 + rng.next() as u32 % 40);
        let f = rng.range(0.1, 1.0) * ow as f64;
        let out = Projection::Perspective.camera(
            Intrinsics::new(f, f, ow as f64 / 2.0, oh as f64 / 2.0),
            ImageSize::new(ow, oh),
        );
        let rot = rotation_ypr(
            rng.range(-3.0, 3.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        let serial = RemapTable::build_with(out.as_ref(), src.as_ref(), &rot, Wrap::Horizontal, 8);
        let parallel = pool.install(|| {
            RemapTable::build_parallel(out.as_ref(), src.as_ref(), &rot, Wrap::Horizontal, 8)
        });
        assert!(serial == parallel, "panorama source, seed {seed}");
    }
}

#[test]
fn flat_sources_stay_flat_and_tiny_sources_work() {
    // Weights of a pixel wholly inside sum to exactly one: a flat source warps to the same
    // flat value wherever the table is inside, whatever the supersampling.
    for (table, image) in random_tables(0x0f1a_7000, 30) {
        let s = table.source_size();
        let flat = RgbImage::from_raw(
            s.width,
            s.height,
            [17u8, 128, 254].repeat(image.as_raw().len() / 3),
        )
        .unwrap();
        let warped = table.apply(&flat);
        for v in 0..table.size().height {
            for u in 0..table.size().width {
                if table.is_inside(u, v) {
                    assert_eq!(
                        warped.pixel(u, v),
                        [17, 128, 254],
                        "({u}, {v}) of {:?}",
                        table.size()
                    );
                }
            }
        }
    }
}

/// The KITTI targets' table (`kitti --to ...`): taps below 2 source pixels a pixel, the
/// source's pyramid above. Against the exact render, on the targets of the checks above and
/// the coarser 2048-px panorama, its PSNR is the per-tap table's within 0.2 dB or better, and
/// the pixels it has wholly inside the source (the `--mask`) are the per-tap table's.
#[test]
fn kitti_targets_through_the_pyramid_above_2_source_pixels_match_the_exact_render_as_the_taps_do() {
    let pano = |projection| OutputSpec {
        projection,
        scale: Scale::PanoWidth(2048),
        canvas: Canvas::Tight,
        ..OutputSpec::new(projection)
    };
    let cases = [
        (
            OutputSpec::new(Projection::Equirect),
            SynthCalib::standard(),
            0,
        ),
        (
            OutputSpec::new(Projection::Cylindrical),
            SynthCalib::standard(),
            2,
        ),
        (
            OutputSpec::new(Projection::Equirect),
            SynthCalib::narrow(),
            1,
        ),
        (pano(Projection::Equirect), SynthCalib::standard(), 0),
        (pano(Projection::Cylindrical), SynthCalib::standard(), 2),
    ];
    let mut sampled_levels = 1;
    for (spec, calib, frame) in cases {
        let scene = &frames()[frame].scene;
        let src = Perspective::new(calib.intrinsics(), calib.size);
        let image = scene.render(&src, &calib.centre());
        let out = output_camera(&spec, calib.intrinsics(), &src).unwrap();
        let id = Matrix3::identity();
        let taps = RemapTable::build(out.as_ref(), &src, &id, Wrap::None);
        let pyr = RemapTable::build_pyramid_above(out.as_ref(), &src, &id, 2.0, false);
        let size = out.size();
        for v in 0..size.height {
            for u in 0..size.width {
                assert_eq!(
                    taps.is_inside(u, v),
                    pyr.is_inside(u, v),
                    "{spec:?} ({u}, {v})"
                );
            }
        }
        let view = in_view(out.as_ref(), &src);
        let compared = |u, v| view(u, v) && taps.is_inside(u, v);
        let exact =
            crate::common::render_where(scene, out.as_ref(), &calib.centre(), 0.55, 6, compared);
        let (db_taps, n) = psnr(&taps.apply(&image), &exact, compared);
        let (db_pyr, _) = psnr(&pyr.apply(&image), &exact, compared);
        eprintln!(
            "{:?} {:?} {}x{}: PSNR taps {db_taps:.2} dB, pyramid above 2 px {db_pyr:.2} dB \
             ({} levels) over {n} px",
            spec.projection,
            spec.scale,
            size.width,
            size.height,
            pyr.levels()
        );
        assert!(
            db_pyr >= db_taps - 0.2,
            "{spec:?}: {db_pyr:.2} < {db_taps:.2} - 0.2 dB"
        );
        sampled_levels = sampled_levels.max(pyr.levels());
    }
    // the figures above compare the pyramid, not the taps twice
    assert!(sampled_levels > 1, "no case samples the pyramid");
}

/// [`coarse_output_does_not_alias`]'s grating near the source's Nyquist limit, 2.2x coarser,
/// through the KITTI targets' pyramid above 2 source pixels: within that test's bound (a
/// standard deviation under 12 grey levels, input 60, a third of point sampling's). The 2×2
/// box of level 1 passes more of a 2.3-px period than 8×8 taps do (3.40 against 1.47); on
/// the checkerboard of `tests/table_parts.rs` the pyramid shows less moiré than the taps.
#[test]
fn the_kitti_targets_pyramid_keeps_the_grating_within_the_antialiasing_bound() {
    let calib = SynthCalib::standard();
    let src = Perspective::new(calib.intrinsics(), calib.size);
    let (w, h) = (calib.size.width, calib.size.height);
    let mut grating = RgbImage::new(w, h);
    for v in 0..h {
        for u in 0..w {
            let s = (u as f64 * std::f64::consts::TAU / 2.3).sin()
                * (v as f64 * std::f64::consts::TAU / 2.6).sin();
            let g = (127.5 + 120.0 * s).round() as u8;
            grating.put_pixel(u, v, [g, g, g]);
        }
    }
    let spec = OutputSpec {
        projection: Projection::Equirect,
        scale: Scale::PanoWidth(2048),
        canvas: Canvas::Tight,
        ..OutputSpec::new(Projection::Equirect)
    };
    let out = output_camera(&spec, calib.intrinsics(), &src).unwrap();
    let size = out.size();
    let stddev = |table: &RemapTable| {
        let img = table.apply(&grating);
        let vals: Vec<f64> = (0..size.height)
            .flat_map(|v| (0..size.width).map(move |u| (u, v)))
            .filter(|&(u, v)| table.is_inside(u, v))
            .map(|(u, v)| img.pixel(u, v)[0] as f64)
            .collect();
        let mean = vals.iter().sum::<f64>() / vals.len() as f64;
        (vals.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / vals.len() as f64).sqrt()
    };
    let id = Matrix3::identity();
    let taps = RemapTable::build(out.as_ref(), &src, &id, Wrap::None);
    let point = RemapTable::build_with(out.as_ref(), &src, &id, Wrap::None, 1);
    let pyr = RemapTable::build_pyramid_above(out.as_ref(), &src, &id, 2.0, false);
    let (s_taps, s_pyr, s_point) = (stddev(&taps), stddev(&pyr), stddev(&point));
    eprintln!(
        "grating: stddev {s_pyr:.2} through the pyramid above 2 px ({} levels), {s_taps:.2} \
         taps, {s_point:.2} point-sampled",
        pyr.levels()
    );
    assert!(pyr.levels() > 1, "the grating's view samples the pyramid");
    assert!(s_pyr < 12.0, "moiré through the pyramid: stddev {s_pyr:.2}");
    assert!(s_point > 3.0 * s_pyr, "{s_point:.2} <= 3 x {s_pyr:.2}");
}

/// A table that samples the source's pyramid (the 2048-px panorama of a KITTI target), warped
/// as the conversion writes it: streamed from the source PNG as the encoder takes the rows
/// (the pyramid built once, from the whole source) and row by row from a decoded image, both
/// the PNG of `apply`'s image, byte for byte.
#[test]
fn a_pyramid_tables_streamed_warp_is_its_applied_image() {
    use panoconv::codec::png::{encode_rgb8, PngCompression};
    use panoconv::warp::{warp_encode, PngSource};
    let calib = SynthCalib::standard();
    let src = Perspective::new(calib.intrinsics(), calib.size);
    let image = frames()[0].scene.render(&src, &calib.centre());
    let spec = OutputSpec {
        projection: Projection::Cylindrical,
        scale: Scale::PanoWidth(2048),
        canvas: Canvas::Tight,
        ..OutputSpec::new(Projection::Cylindrical)
    };
    let out = output_camera(&spec, calib.intrinsics(), &src).unwrap();
    let table =
        RemapTable::build_pyramid_above(out.as_ref(), &src, &Matrix3::identity(), 2.0, false);
    assert!(table.levels() > 1, "the view samples the pyramid");
    let c = PngCompression::Fast;
    let want = encode_rgb8(&table.apply(&image), c);
    assert!(warp_encode(&table, &image, c) == want, "row by row");
    let path = std::path::Path::new("source.png");
    let mut source = PngSource::new(encode_rgb8(&image, c), path).expect("reads");
    assert!(
        source.warp_encode(&table, c).expect("warps") == want,
        "streamed"
    );
    // a second view of the same source warps the kept image
    assert!(
        source.warp_encode(&table, c).expect("warps") == want,
        "kept"
    );
}
