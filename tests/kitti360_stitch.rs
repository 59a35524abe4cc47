//! The stitch (`warp::stitch`) of the four KITTI-360 cameras on a zero-baseline synthetic rig
//! (all four centres at image_00's) against the scene rendered directly in the panorama: the
//! remap is then exact, so each camera's region of the panorama must match the direct render
//! to the resampling limit.

use crate::common;
use nalgebra::{Point2, Vector3};
use panoconv::camera::{CameraModel, Equirect, ImageSize, Intrinsics, Rotated};
use panoconv::image::RgbImage;
use panoconv::kitti360::{Options, Sequence};
use panoconv::tools::synth360::scene::{scene_at, world_from_scene, world_to_scene};
use panoconv::tools::synth360::{write_sequence, Synth360Options, SEQUENCE};
use panoconv::warp::{EgoMask, Stitch, StitchCamera, StitchOptions};
use std::f64::consts::PI;

/// A full-sphere equirect camera of `size` (pixel centres at integers) and its intrinsics.
fn full_equirect(size: ImageSize) -> (Intrinsics, Equirect) {
    let k = Intrinsics::new(
        size.width as f64 / (2.0 * PI),
        size.height as f64 / PI,
        size.width as f64 / 2.0 - 0.5,
        size.height as f64 / 2.0 - 0.5,
    );
    (k, Equirect::new(k, size))
}

/// The frame's four rig cameras as the stitch takes them (the fisheyes with their field of
/// view).
fn stitch_cameras<'a>(frame: &'a panoconv::source::Frame, seq: &Sequence) -> Vec<StitchCamera<'a>> {
    let lenses = &seq.calibration.fisheye;
    frame
        .rig
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let inv = c.reference_from_camera.inverse().unwrap();
            StitchCamera {
                model: c.model.as_ref(),
                rotation: inv.rotation,
                translation: inv.translation,
                max_theta: (i >= 2).then(|| lenses[i - 2].max_theta()),
            }
        })
        .collect()
}

/// PSNR the stitch must reach in every camera's region.
const MIN_PSNR_DB: f64 = 50.0;

fn rgb(path: &std::path::Path) -> RgbImage {
    let png = common::read_rgb8(path);
    RgbImage::from_raw(png.width, png.height, png.data).unwrap()
}

#[test]
fn a_zero_baseline_stitch_matches_the_direct_panorama_render() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("zero");
    let options = Synth360Options {
        frames: 1,
        scale: 0.25,
        zero_baseline: true,
    };
    write_sequence(&root, &options, false, &panoconv::run::Silent).unwrap();
    let seq = Sequence::open(
        &root,
        SEQUENCE,
        Options {
            lidar: false,
            ..Options::default()
        },
    )
    .unwrap();
    let number = seq.frames()[0];
    let frame = seq.frame(number).unwrap();
    // two pixels per degree (114.6 px/rad): 1.2x coarser than image_00/01 (138.1 px/rad), below
    // the 1.5x at which the remap supersamples
    let size = ImageSize::new(720, 360);
    let (k, output) = full_equirect(size);
    let lenses = &seq.calibration.fisheye;
    let cameras = stitch_cameras(&frame, &seq);
    // the resampling is compared without exposure evening (which moves the fisheyes by 0.27 %
    // on this rig, below)
    let build = |even_exposure| {
        Stitch::build(
            &output,
            &Vector3::zeros(),
            &cameras,
            StitchOptions {
                distance: 10.0,
                blend_width: 5f64.to_radians(),
                even_exposure,
            },
        )
    };
    let stitch = build(false);
    let images: Vec<RgbImage> = frame.rig.iter().map(|c| rgb(&c.image)).collect();
    let refs: Vec<&RgbImage> = images.iter().collect();
    let stitched = stitch.apply(&refs);
    assert!(stitched.gains.iter().all(|g| *g == 1.0));
    let (panorama, source) = (&stitched.image, &stitched.source);
    // the direct render: the panorama's level axes in the scene
    let world = frame.world_from_reference.unwrap();
    let scene_from_level = world_from_scene().transpose() * world.rotation;
    let direct_camera = Rotated::new(Equirect::new(k, size), scene_from_level);
    let centre = world_to_scene(&world.translation);
    assert_eq!(direct_camera.size(), size);
    let scene = scene_at(number);
    // Each camera's region against the scene rendered directly, exactly (a 16x16 grid over the
    // Gaussian footprint), with the blur the stitch gives: the source's (σ = 0.55 of its pixels
    // at its optical axis) and the bilinear interpolation's, whose tent has a variance of
    // t(1 − t) source px² at a fraction t between taps, 1/6 on average; in output pixels.
    let sigma = |cam: usize| {
        let source_px_per_rad = match cam {
            0 | 1 => seq.calibration.perspective[cam].model.k.fu,
            _ => lenses[cam - 2].centre_intrinsics().fu,
        };
        (0.55f64 * 0.55 + 1.0 / 6.0).sqrt() * k.fu / source_px_per_rad
    };
    let in_region = |u: u32, v: u32, cam: u8| source[(v * size.width + u) as usize] == cam;
    let region_mse = |direct: &RgbImage, cam: u8| {
        let (mut se, mut n) = (0.0, 0usize);
        for v in 0..size.height {
            for u in 0..size.width {
                if in_region(u, v, cam) {
                    let (a, b) = (panorama.pixel(u, v), direct.pixel(u, v));
                    se += (0..3)
                        .map(|c| (a[c] as f64 - b[c] as f64).powi(2))
                        .sum::<f64>();
                    n += 3;
                }
            }
        }
        (se / n as f64, n / 3)
    };
    // Misregistration: the shift (du, dv) that best explains panorama − direct as the direct
    // render's gradient times the shift (least squares, Lucas–Kanade), over the region's pixels
    // in a window; None where the window has too little structure to measure it (the
    // structure tensor's smaller eigenvalue under 1e4 DN²).
    let shift = |direct: &RgbImage, cam: u8, us: std::ops::Range<u32>, vs: std::ops::Range<u32>| {
        let [mut a11, mut a12, mut a22, mut b1, mut b2] = [0.0f64; 5];
        for v in vs.start.max(1)..vs.end.min(size.height - 1) {
            for u in us.start.max(1)..us.end.min(size.width - 1) {
                if !in_region(u, v, cam) {
                    continue;
                }
                let (p, d) = (panorama.pixel(u, v), direct.pixel(u, v));
                let (r, l) = (direct.pixel(u + 1, v), direct.pixel(u - 1, v));
                let (dn, up) = (direct.pixel(u, v + 1), direct.pixel(u, v - 1));
                for c in 0..3 {
                    let e = p[c] as f64 - d[c] as f64;
                    let gx = (r[c] as f64 - l[c] as f64) / 2.0;
                    let gy = (dn[c] as f64 - up[c] as f64) / 2.0;
                    a11 += gx * gx;
                    a12 += gx * gy;
                    a22 += gy * gy;
                    b1 += gx * e;
                    b2 += gy * e;
                }
            }
        }
        let det = a11 * a22 - a12 * a12;
        let min_eigen = (a11 + a22) / 2.0 - (((a11 - a22) / 2.0).powi(2) + a12 * a12).sqrt();
        (min_eigen > 1e4).then(|| ((a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det))
    };
    let psnr = |mse: f64| 10.0 * (255.0f64 * 255.0 / mse).log10();
    let mut report = Vec::new();
    let mut db = [0.0; 4];
    let (mut worst_mrad, mut worst_local): (f64, f64) = (0.0, 0.0);
    let mut windows = 0;
    let mut renders: Vec<(f64, RgbImage)> = Vec::new();
    for cam in 0..4u8 {
        // image_00 and image_01 share their intrinsics, and so one render
        let direct = match renders.iter().find(|(s, _)| *s == sigma(cam as usize)) {
            Some((_, image)) => image.clone(),
            None => {
                let image = scene.render_with(&direct_camera, &centre, sigma(cam as usize), 16);
                renders.push((sigma(cam as usize), image.clone()));
                image
            }
        };
        let (mse, n) = region_mse(&direct, cam);
        assert!(n > 50, "camera {cam} supplies only {n} px");
        db[cam as usize] = psnr(mse);
        // local: 60x60 px windows (about 30° square)
        let mut local: f64 = 0.0;
        for v0 in (0..size.height).step_by(60) {
            for u0 in (0..size.width).step_by(60) {
                if let Some((du, dv)) = shift(&direct, cam, u0..u0 + 60, v0..v0 + 60) {
                    // pixels to mrad: k.fv pixels per radian of latitude, k.fu per radian of
                    // longitude, which is cos(latitude) radians of angle
                    let latitude = ((v0 as f64 + 29.5) - k.cv) / k.fv;
                    let mrad = (du * latitude.cos() / k.fu).hypot(dv / k.fv) * 1e3;
                    if mrad > local {
                        local = mrad;
                        eprintln!(
                            "{cam} window ({u0}, {v0}): ({du:.4}, {dv:.4}) px, {mrad:.3} mrad"
                        );
                    }
                    windows += 1;
                }
            }
        }
        worst_local = worst_local.max(local);
        // the whole region (longitude's pixels counted as radians of angle: an upper bound)
        let (du, dv) = shift(&direct, cam, 0..size.width, 0..size.height).unwrap_or_default();
        let whole = du.hypot(dv) / k.fu * 1e3;
        worst_mrad = worst_mrad.max(whole);
        report.push(format!(
            "{}: {:.2} dB over {n} px, misregistration {whole:.3} mrad (windows up to {local:.3})",
            frame.rig[cam as usize].name, db[cam as usize]
        ));
    }
    eprintln!(
        "zero-baseline stitch vs direct render: {}",
        report.join("; ")
    );
    // every region at the bilinear ceiling, registered to a small fraction of a pixel (0.5 mrad
    // is 0.057 output px)
    assert!(
        db.iter().all(|d| *d >= MIN_PSNR_DB),
        "{}",
        report.join("; ")
    );
    assert!(windows >= 20, "only {windows} windows to measure");
    assert!(worst_mrad < 0.5, "{}", report.join("; "));
    // 30° windows: those that hold the horizon measure the aliasing of the ground's texture,
    // compressed without limit towards it, more than any shift (up to 1.26 mrad, 0.14 px)
    assert!(worst_local < 1.5, "{}", report.join("; "));
    // the whole sphere is covered by the fisheyes' 185° each
    assert!(source.iter().all(|s| *s < 4), "a pixel without a camera");

    // Exposure: image_02 darkened by a known gain (0.8, rounded) is brought back by 1/0.8
    // (relative to its gain undarkened) while the others keep theirs, and the panorama is the
    // undarkened one again.
    const DARKEN: f64 = 0.8;
    let mut dark = images[2].clone();
    for c in dark.as_raw_mut() {
        *c = (*c as f64 * DARKEN).round() as u8;
    }
    let mut darkened = refs.clone();
    darkened[2] = &dark;
    let evening = build(true);
    // the cameras agree: their gains are 1 to within the resampling's differences
    let agreed = evening.apply(&refs).gains;
    assert!(agreed.iter().all(|g| (g - 1.0).abs() < 0.003), "{agreed:?}");
    let evened = evening.apply(&darkened);
    // deterministic: the same gains and image on one thread
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| evening.apply(&darkened));
    assert!(one.gains == evened.gains && one.image == evened.image);
    let g = &evened.gains;
    assert_eq!(g[0], 1.0);
    assert!((g[2] * DARKEN - agreed[2]).abs() < 1e-3, "gains {g:?}");
    for k in [1, 3] {
        assert!((g[k] - agreed[k]).abs() < 1e-3, "gains {g:?}");
    }
    let whole = |a: &RgbImage, b: &RgbImage| {
        let se: f64 = a
            .as_raw()
            .iter()
            .zip(b.as_raw())
            .map(|(x, y)| (*x as f64 - *y as f64).powi(2))
            .sum();
        psnr(se / a.as_raw().len() as f64)
    };
    let evened_db = whole(&evened.image, panorama);
    let plain = stitch.apply(&darkened);
    let plain_db = whole(&plain.image, panorama);
    eprintln!(
        "gains {agreed:?}; image_02 darkened by {DARKEN}: gains {g:?}, panorama vs undarkened {evened_db:.2} dB \
         evened, {plain_db:.2} dB not"
    );
    assert!(
        evened_db >= 45.0 && plain_db < 30.0,
        "{evened_db} {plain_db}"
    );
}

#[test]
fn an_ego_mask_keeps_the_cars_body_out_of_the_stitch() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/kitti360");
    let seq = Sequence::open(
        &root,
        SEQUENCE,
        Options {
            lidar: false,
            ..Options::default()
        },
    )
    .unwrap();
    let frame = seq.frame(250).unwrap();
    let size = ImageSize::new(360, 180);
    let (_, output) = full_equirect(size);
    let cameras = stitch_cameras(&frame, &seq);
    // the lower third of image_02 (350x350 here) is the car's side, as a grey PNG (any
    // non-zero value is the body)
    let fisheye = frame.rig[2].model.size();
    let (w, h) = (fisheye.width, fisheye.height);
    let body = |x: u32, y: u32| y >= 2 * h / 3 && x > 40 && x < w - 40;
    let tmp = tempfile::tempdir().unwrap();
    let mask_path = tmp.path().join("image_02_mask.png");
    let grey = common::Png {
        width: w,
        height: h,
        color: png::ColorType::Grayscale,
        depth: png::BitDepth::Eight,
        data: (0..h)
            .flat_map(|y| (0..w).map(move |x| if body(x, y) { 200 } else { 0 }))
            .collect(),
    };
    common::write_png(&mask_path, &grey);
    let mask = EgoMask::read(&mask_path, fisheye).unwrap();
    assert_eq!(
        mask.count() as u32,
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| body(x, y))
            .count() as u32
    );
    let options = StitchOptions::default();
    let plain = Stitch::build(&output, &Vector3::zeros(), &cameras, options);
    let masked = Stitch::build_masked(
        &output,
        &Vector3::zeros(),
        &cameras,
        &[None, None, Some(&mask)],
        options,
    )
    .unwrap();
    let mut images: Vec<RgbImage> = frame.rig.iter().map(|c| rgb(&c.image)).collect();
    let before = masked.apply(&images.iter().collect::<Vec<_>>());
    let unmasked = plain.apply(&images.iter().collect::<Vec<_>>());
    // paint the body magenta: the masked stitch does not change, the plain one does
    for y in 0..h {
        for x in 0..w {
            if body(x, y) {
                images[2].put_pixel(x, y, [255, 0, 255]);
            }
        }
    }
    let refs: Vec<&RgbImage> = images.iter().collect();
    let after = masked.apply(&refs);
    assert!(after.image == before.image && after.source == before.source);
    assert!(
        plain.apply(&refs).image != unmasked.image,
        "the body is not in the plain stitch"
    );
    // the pixels image_02 supplied over its body now come from the others or stay black
    let (mut moved, mut black) = (0, 0);
    for v in 0..size.height {
        for u in 0..size.width {
            let i = (v * size.width + u) as usize;
            if after.source[i] == 2 {
                // image_02's bilinear taps there (through the proxy point at 10 m) miss the body
                let d = output.unproject(&Point2::new(u as f64, v as f64)).unwrap();
                let q = cameras[2].rotation * (d * 10.0) + cameras[2].translation;
                let p = cameras[2].model.project_point(&q).unwrap();
                assert!(!mask.touches(&p, 1.0), "image_02's body at ({u}, {v})");
            }
            if unmasked.source[i] == 2 && masked.weight(2, u, v) == 0.0 {
                moved += 1;
                if after.source[i] == 255 {
                    black += 1;
                    assert_eq!(after.image.pixel(u, v), [0, 0, 0]);
                }
            } else {
                // elsewhere the weights that lead are untouched
                assert_eq!(after.source[i], unmasked.source[i], "({u}, {v})");
            }
        }
    }
    // ... but only there: image_02 still supplies the rest of its view
    let left = after.source.iter().filter(|s| **s == 2).count();
    eprintln!("ego mask: {moved} px moved off image_02 ({black} black), it supplies {left}");
    assert!(
        moved > 500 && black < moved && left > 5000,
        "{moved} {black} {left}"
    );
    // a mask of another size is refused, naming the file
    let e = EgoMask::read(&mask_path, ImageSize::new(w + 1, h)).unwrap_err();
    assert!(
        e.to_string().contains("image_02_mask.png") && e.to_string().contains("350x350"),
        "{e}"
    );
    let small = EgoMask::new(ImageSize::new(2, 2), vec![true; 4]).unwrap();
    let e = Stitch::build_masked(
        &output,
        &Vector3::zeros(),
        &cameras,
        &[Some(&small)],
        options,
    )
    .unwrap_err();
    assert!(e.to_string().contains("camera 0"), "{e}");
}
