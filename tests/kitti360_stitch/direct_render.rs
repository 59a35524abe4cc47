//! The stitch of a zero-baseline rig against the scene rendered directly in the panorama: each
//! camera's region to the resampling limit, the geometric misregistration, the exposure gains.

use super::*;
use nalgebra::{Point2, Vector3};
use panoconv::camera::{CameraModel, MeiModel, Rotated};
use panoconv::kitti360::Options;
use panoconv::tools::synth360::scene::{scene_at, world_from_scene, world_to_scene};
use panoconv::tools::synth360::SEQUENCE;
use panoconv::warp::{Stitch, StitchOptions};

/// The largest local misregistration allowed, milliradians (0.057 px of the 720 px panorama).
const MAX_MISREGISTRATION_MRAD: f64 = 0.5;

/// Camera `cam`'s exact pixel of a point `q` in its axes, written here from the calibration's
/// published values alone: `P_rect`'s pinhole for image_00/01, the MEI model (ξ, k1, k2, p1,
/// p2, γ1, γ2, u0, v0) of the yaml for the fisheyes.
fn exact_pixel(seq: &Sequence, cam: usize, q: &Vector3<f64>) -> Point2<f64> {
    if cam < 2 {
        let p = &seq.calibration.perspective[cam].p_rect;
        let z = q.z;
        return Point2::new(
            (p[0] * q.x + p[1] * q.y + p[2] * q.z) / z,
            (p[4] * q.x + p[5] * q.y + p[6] * q.z) / z,
        );
    }
    let Some(m) = seq.calibration.fisheye[cam - 2].downcast::<MeiModel>() else {
        panic!("KITTI-360's fisheyes are MEI cameras");
    };
    let s = q.normalize();
    let (x, y) = (s.x / (s.z + m.model.xi), s.y / (s.z + m.model.xi));
    let d = m.model.distortion;
    let r2 = x * x + y * y;
    let radial = 1.0 + d.k1 * r2 + d.k2 * r2 * r2;
    let xd = x * radial + 2.0 * d.p1 * x * y + d.p2 * (r2 + 2.0 * x * x);
    let yd = y * radial + d.p1 * (r2 + 2.0 * y * y) + 2.0 * d.p2 * x * y;
    Point2::new(
        m.k.fu * xd + m.model.skew * yd + m.k.cu,
        m.k.fv * yd + m.k.cv,
    )
}

/// The geometric misregistration of the stitch, per camera region: where the stitch samples
/// each camera against where the exact model puts the output ray's proxy point.
///
/// The stitch's sample positions are read through the stitch itself: camera i alone is
/// stitched from ramp images (red = 4·(x − a), green = 4·(y − a), clamped, for offsets a every
/// 56 px), whose bilinear samples are linear in the sample position, so a pixel's value gives
/// the source coordinate it was sampled at (to 1/8 px after the output's rounding). Against
/// the exact pixel of the proxy point, the difference is taken to output pixels through the
/// exact mapping's Jacobian and averaged over 60 x 60 px windows (30°) of camera i's region
/// (those holding at least 1000 of its pixels) and over the whole region, then converted to an
/// angle. Returns the worst, per camera, and the windows measured.
fn geometric_misregistration(
    seq: &Sequence,
    cameras: &[StitchCamera],
    output: &Equirect,
    k: Intrinsics,
    source: &[u8],
) -> ([f64; 4], usize) {
    const SLOPE: f64 = 4.0;
    const STEP: u32 = 56;
    const WINDOW: u32 = 60;
    let size = output.size();
    let options = StitchOptions {
        distance: 10.0,
        blend_width: 5f64.to_radians(),
        even_exposure: false,
    };
    // the output ray of pixel (u, v), from the equirect's definition
    let bearing = |u: f64, v: f64| {
        let (lon, lat) = ((u - k.cu) / k.fu, (v - k.cv) / k.fv);
        Vector3::new(lat.cos() * lon.sin(), lat.sin(), lat.cos() * lon.cos())
    };
    let d = output.unproject(&Point2::new(100.0, 70.0)).unwrap();
    assert!((d - bearing(100.0, 70.0)).norm() < 1e-12, "equirect axes");
    // a mean shift in output pixels to an angle: k.fv pixels per radian of latitude, k.fu per
    // radian of longitude, which is cos(latitude) radians of angle
    let to_mrad = |mean: nalgebra::Vector2<f64>, v0: u32| {
        let latitude = ((v0 as f64 + (WINDOW as f64 - 1.0) / 2.0) - k.cv) / k.fv;
        (mean.x * latitude.cos() / k.fu).hypot(mean.y / k.fv) * 1e3
    };
    let mut worst = [0.0; 4];
    let mut windows = 0;
    for (cam, camera) in cameras.iter().enumerate() {
        let alone = Stitch::build(output, &Vector3::zeros(), &[*camera], options);
        let src = camera.model.size();
        let runs = src.width.max(src.height).div_ceil(STEP) + 1;
        let ramps: Vec<RgbImage> = (0..runs)
            .map(|r| {
                let a = (r * STEP) as f64;
                let ramp = |c: u32| (SLOPE * (c as f64 - a)).clamp(0.0, 255.0) as u8;
                let mut image = RgbImage::new(src.width, src.height);
                for y in 0..src.height {
                    for x in 0..src.width {
                        image.put_pixel(x, y, [ramp(x), ramp(y), 0]);
                    }
                }
                alone.apply(&[&image]).image
            })
            .collect();
        // the sample coordinate from the run whose ramp holds it with a pixel to spare
        let decode = |u: u32, v: u32, channel: usize| {
            (0..runs as usize).find_map(|r| {
                let value = ramps[r].pixel(u, v)[channel] as f64 / SLOPE;
                (1.5..=62.0)
                    .contains(&value)
                    .then(|| value + (r as u32 * STEP) as f64)
            })
        };
        let project = |u: f64, v: f64| {
            let q = camera.rotation * (bearing(u, v) * options.distance) + camera.translation;
            exact_pixel(seq, cam, &q)
        };
        let mut whole = Vec::new();
        for v0 in (0..size.height).step_by(WINDOW as usize) {
            for u0 in (0..size.width).step_by(WINDOW as usize) {
                let (mut sum, mut n) = (nalgebra::Vector2::<f64>::zeros(), 0usize);
                for v in v0..(v0 + WINDOW).min(size.height) {
                    for u in u0..(u0 + WINDOW).min(size.width) {
                        if source[(v * size.width + u) as usize] != cam as u8
                            || alone.weight(0, u, v) <= 0.0
                        {
                            continue;
                        }
                        let (Some(x), Some(y)) = (decode(u, v, 0), decode(u, v, 1)) else {
                            continue;
                        };
                        let (uf, vf) = (u as f64, v as f64);
                        let exact = project(uf, vf);
                        // source pixels per output pixel, to take the error to output pixels
                        let du = (project(uf + 0.5, vf) - project(uf - 0.5, vf)).into_owned();
                        let dv = (project(uf, vf + 0.5) - project(uf, vf - 0.5)).into_owned();
                        let jacobian = nalgebra::Matrix2::from_columns(&[du, dv]);
                        let error = nalgebra::Vector2::new(x - exact.x, y - exact.y);
                        sum += jacobian.try_inverse().unwrap() * error;
                        n += 1;
                    }
                }
                whole.push((sum, n, v0));
                if n < 1000 {
                    continue;
                }
                worst[cam] = f64::max(worst[cam], to_mrad(sum / n as f64, v0));
                windows += 1;
            }
        }
        // the whole region (image_01's 63 px fill no window)
        let (sum, n) = whole
            .iter()
            .fold((nalgebra::Vector2::zeros(), 0), |(s, m), (w, n, _)| {
                (s + w, m + n)
            });
        assert!(n > 50, "camera {cam}: {n} px measured");
        let mean = sum / n as f64;
        // (longitude's pixels counted as radians of angle: an upper bound)
        let mrad = mean.x.hypot(mean.y) / k.fu * 1e3;
        worst[cam] = f64::max(worst[cam], mrad);
    }
    (worst, windows)
}

/// The reference render's samples per pixel, per camera's region: a grid of this many squared
/// over the Gaussian footprint. A coarser grid moves a step edge by a part of its contrast, so
/// it can only lower the measured PSNR: image_00's region, dense with the silhouettes of the
/// objects ahead, needs 16 (46.0 dB with 8); the fisheyes' regions read 54.5 and 53.9 dB with 8
/// (55.7 and 55.6 with 16), which keeps their reference 4x cheaper.
const REFERENCE_GRID: [usize; 4] = [16, 16, 8, 8];

/// PSNR the stitch must reach in every camera's region.
const MIN_PSNR_DB: f64 = 50.0;

#[test]
fn a_zero_baseline_stitch_matches_the_direct_panorama_render() {
    // the zero-baseline sequence of tests/kitti360_command.rs (scale 0.25), made once per build
    let root = crate::kitti360_command::sequence(true);
    let seq = Sequence::open(
        root,
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
    // Image-based misregistration: the shift (du, dv) that best explains panorama − direct as
    // the direct render's gradient times the shift (least squares, Lucas–Kanade), over the
    // region's pixels; None where the region has too little structure to measure it (the
    // structure tensor's smaller eigenvalue under 1e4 DN²). Over 30° windows it reads the
    // aliasing of the ground's texture near the horizon (up to 1.26 mrad) more than any shift:
    // the windows are measured geometrically instead (`geometric_misregistration`).
    let shift = |direct: &RgbImage, cam: u8| {
        let [mut a11, mut a12, mut a22, mut b1, mut b2] = [0.0f64; 5];
        for v in 1..size.height - 1 {
            for u in 1..size.width - 1 {
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
    let mut worst_mrad: f64 = 0.0;
    for cam in 0..4u8 {
        // the reference over the camera's region only (its bounding box, a pixel around for
        // the gradients), pasted into a panorama-sized image
        let (mut lo, mut hi) = ((size.width, size.height), (0, 0));
        for v in 0..size.height {
            for u in 0..size.width {
                if in_region(u, v, cam) {
                    lo = (lo.0.min(u), lo.1.min(v));
                    hi = (hi.0.max(u), hi.1.max(v));
                }
            }
        }
        let (u0, v0) = (lo.0.saturating_sub(1), lo.1.saturating_sub(1));
        let window = crate::common::Window {
            inner: &direct_camera,
            origin: Point2::new(u0 as f64, v0 as f64),
            size: ImageSize::new(
                (hi.0 + 2).min(size.width) - u0,
                (hi.1 + 2).min(size.height) - v0,
            ),
        };
        let grid = REFERENCE_GRID[cam as usize];
        let part = scene.render_with(&window, &centre, sigma(cam as usize), grid);
        let mut direct = RgbImage::new(size.width, size.height);
        for v in 0..window.size.height {
            for u in 0..window.size.width {
                direct.put_pixel(u0 + u, v0 + v, part.pixel(u, v));
            }
        }
        let (mse, n) = region_mse(&direct, cam);
        assert!(n > 50, "camera {cam} supplies only {n} px");
        db[cam as usize] = psnr(mse);
        // the whole region (longitude's pixels counted as radians of angle: an upper bound)
        let (du, dv) = shift(&direct, cam).unwrap_or_default();
        let whole = du.hypot(dv) / k.fu * 1e3;
        worst_mrad = worst_mrad.max(whole);
        report.push(format!(
            "{}: {:.2} dB over {n} px, image-based misregistration {whole:.3} mrad",
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
    assert!(
        worst_mrad < MAX_MISREGISTRATION_MRAD,
        "{}",
        report.join("; ")
    );
    // every 30° window of every region, and every whole region, measured geometrically
    let (geometric, geometric_windows) =
        geometric_misregistration(&seq, &cameras, &output, k, source);
    eprintln!(
        "geometric misregistration, worst window or region per camera: {geometric:.3?} mrad \
         ({geometric_windows} windows)"
    );
    assert!(geometric_windows >= 40, "only {geometric_windows} windows");
    assert!(
        geometric.iter().all(|m| *m < MAX_MISREGISTRATION_MRAD),
        "{geometric:?} mrad"
    );
    // the whole sphere is covered by the fisheyes' 185° each
    assert!(source.iter().all(|s| *s < 4), "a pixel without a camera");

    // Exposure: image_02 darkened by a known gain (0.8, rounded) is brought most of the way
    // back to 1/0.8 (relative to its gain undarkened) while the others keep theirs, and the
    // panorama comes nearer the undarkened one. Not all the way: the gains' prior holds each
    // gain near 1 unless the overlaps agree, and a pair's ratio far from 1 weighs less (real
    // overlaps that show different things give such ratios): a 0.8 exposure comes back 73 %
    // of the way in ln (0.163 of 0.223).
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
    let recovered = (g[2] / agreed[2]).ln() / (1.0 / DARKEN).ln();
    assert!((0.65..=1.0).contains(&recovered), "gains {g:?}");
    for k in [1, 3] {
        assert!((g[k] - agreed[k]).abs() < 0.015, "gains {g:?}");
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
        evened_db >= 32.0 && plain_db < 30.0,
        "{evened_db} {plain_db}"
    );
}
