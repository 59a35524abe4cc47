//! The stitch of nuScenes' six cameras on the zero-baseline synthetic scene (`panoconv synth
//! --nuscenes --zero-baseline`: every camera at CAM_FRONT's mounting, firing at the LiDAR's
//! time, so the remap is exact): each camera's region of the panorama against the scene
//! rendered directly in the panorama, with the blur the stitch gives.

use crate::common;
use nalgebra::{Point2, Vector3};
use panoconv::camera::{CameraModel, Equirect, ImageSize, Intrinsics, Rotated};
use panoconv::image::RgbImage;
use panoconv::nuscenes::{NuScenes, Options, Selection};
use panoconv::tools::synth360::scene::{scene_at, world_from_scene, world_to_scene, FIRST_FRAME};
use panoconv::tools::synth_nuscenes::VERSION;
use panoconv::warp::{Stitch, StitchCamera, StitchOptions};
use std::f64::consts::PI;

/// PSNR every camera's region must reach (52.7 to 56.2 dB measured). The squared error left
/// is at the silhouettes (a bilinear tap's blur depends on its fraction between taps; the
/// reference's Gaussian is its mean).
const MIN_PSNR_DB: f64 = 50.0;

#[test]
fn a_zero_baseline_six_camera_stitch_matches_the_direct_panorama_render() {
    // 1.2x coarser than the 316.6 px/rad of the five long lenses (CAM_BACK: 202.3 px/rad)
    let figures = region_figures(ImageSize::new(1656, 828), 0.0);
    let report: Vec<String> = figures
        .iter()
        .map(|(c, db, n)| format!("{c}: {db:.2} dB over {n} px"))
        .collect();
    eprintln!(
        "nuScenes zero-baseline stitch vs direct render: {}",
        report.join("; ")
    );
    let worst = figures.iter().map(|f| f.1).fold(f64::INFINITY, f64::min);
    assert!(worst >= MIN_PSNR_DB, "{}", report.join("; "));
}

/// The per-tap tables' figures of the coarse stitch below
/// (measured with every pixel taking its taps, as the stitch did before it sampled the pyramid).
const TAPS_DB: [(u32, [f64; 6]); 2] = [
    (552, [40.66, 42.53, 42.12, 47.12, 45.40, 46.12]),
    (414, [41.42, 39.96, 42.46, 46.08, 44.64, 43.61]),
];

#[test]
fn a_coarse_zero_baseline_stitch_samples_the_pyramid_as_well_as_the_taps() {
    // 3.6x and 4.8x coarser than the long lenses (CAM_BACK 2.3x and 3.1x): their pixels take
    // the pyramid, CAM_BACK's partly
    for (width, taps) in TAPS_DB {
        let figures = region_figures(ImageSize::new(width, width / 2), 0.55);
        let report: Vec<String> = (figures.iter().zip(taps))
            .map(|((c, db, n), t)| format!("{c}: {db:.2} dB (taps {t:.2}) over {n} px"))
            .collect();
        eprintln!(
            "nuScenes zero-baseline stitch {width} px wide vs direct render: {}",
            report.join("; ")
        );
        for ((c, db, _), t) in figures.iter().zip(taps) {
            assert!(*db >= t - 0.2, "{width} px, {c}: {db:.2} dB < {t:.2} - 0.2");
        }
    }
}

/// Each camera's region of the zero-baseline stitch into a full panorama of `size` against
/// the scene rendered directly (name, PSNR dB, pixels): the reference's blur is the source's
/// (in output pixels) and `output_sigma` output pixels (the footprint an antialiased pixel
/// integrates over) in quadrature.
fn region_figures(size: ImageSize, output_sigma: f64) -> Vec<(String, f64, usize)> {
    // the command tests' zero-baseline scene (scale 0.25, 400x225 images), its first sample
    let root = crate::nuscenes_command::scene(true);
    let ds = NuScenes::open(root, VERSION, &Selection::default()).unwrap();
    let item = &ds.items().unwrap()[0];
    let frame = ds
        .frame(
            item,
            &Options {
                lidar: false,
                ..Options::default()
            },
        )
        .unwrap()
        .frame;
    // every camera at the level frame's origin
    for c in &frame.rig {
        assert!(c.centre().norm() < 1e-9, "{}: {}", c.name, c.centre());
    }
    let k = Intrinsics::new(
        size.width as f64 / (2.0 * PI),
        size.height as f64 / PI,
        size.width as f64 / 2.0 - 0.5,
        size.height as f64 / 2.0 - 0.5,
    );
    let output = Equirect::new(k, size);
    let cameras: Vec<StitchCamera> = frame
        .rig
        .iter()
        .map(|c| {
            let inv = c.reference_from_camera.inverse().unwrap();
            StitchCamera {
                model: c.model.as_ref(),
                rotation: inv.rotation,
                translation: inv.translation,
                max_theta: None,
            }
        })
        .collect();
    let stitch = Stitch::build(
        &output,
        &Vector3::zeros(),
        &cameras,
        StitchOptions {
            distance: 10.0,
            blend_width: 5f64.to_radians(),
            even_exposure: false,
        },
    );
    let images: Vec<RgbImage> = frame
        .rig
        .iter()
        .map(|c| {
            let png = common::read_rgb8(&c.image);
            RgbImage::from_raw(png.width, png.height, png.data).unwrap()
        })
        .collect();
    let refs: Vec<&RgbImage> = images.iter().collect();
    let stitched = stitch.apply(&refs);
    let (panorama, source) = (&stitched.image, &stitched.source);
    let world = frame.world_from_reference.unwrap();
    let direct_camera = Rotated::new(
        Equirect::new(k, size),
        world_from_scene().transpose() * world.rotation,
    );
    let centre = world_to_scene(&world.translation);
    let scene = scene_at(FIRST_FRAME);
    let mut figures = Vec::new();
    for (cam, c) in frame.rig.iter().enumerate() {
        let in_region = |u: u32, v: u32| source[(v * size.width + u) as usize] == cam as u8;
        let (mut lo, mut hi) = ((size.width, size.height), (0, 0));
        for v in 0..size.height {
            for u in 0..size.width {
                if in_region(u, v) {
                    lo = (lo.0.min(u), lo.1.min(v));
                    hi = (hi.0.max(u), hi.1.max(v));
                }
            }
        }
        assert!(hi.0 > lo.0, "{} supplies no pixel", c.name);
        // the source's footprint (σ = 0.55 px) and the bilinear tent's mean variance (1/6 px²),
        // in output pixels: a pinhole's pixels per radian grow off its axis (1/cos² radially,
        // 1/cos tangentially), so the reference is rendered in strips of 16 columns, each with
        // the blur at its centre's angle θ from the optical axis (the geometric mean, 1/cos^1.5)
        let data = ds.keyframe(&ds.scenes[0].samples[0], &c.name).unwrap();
        let source_fu = ds.pinhole(data).unwrap().k.fu;
        let axis = c.optical_axis();
        let (mut se, mut n) = (0.0, 0usize);
        let mut u0 = lo.0;
        while u0 <= hi.0 {
            let u1 = (u0 + 15).min(hi.0);
            let middle = output
                .unproject(&Point2::new((u0 + u1) as f64 / 2.0, k.cv))
                .unwrap();
            let cos = middle.normalize().dot(&axis).clamp(0.05, 1.0);
            let sigma = (0.55f64 * 0.55 + 1.0 / 6.0).sqrt() * k.fu / (source_fu / cos.powf(1.5));
            let sigma = sigma.hypot(output_sigma);
            let window = common::Window {
                inner: &direct_camera,
                origin: Point2::new(u0 as f64, lo.1 as f64),
                size: ImageSize::new(u1 + 1 - u0, hi.1 + 1 - lo.1),
            };
            // only the strip's pixels of this region are traced (a region's bounding box
            // holds others' pixels, and across the panorama's seam the whole width)
            let (su, sv) = (u0, lo.1);
            let direct = common::render_where(&scene, &window, &centre, sigma, 16, |u, v| {
                in_region(u + su, v + sv)
            });
            for v in lo.1..=hi.1 {
                for u in u0..=u1 {
                    if in_region(u, v) {
                        let (a, b) = (panorama.pixel(u, v), direct.pixel(u - u0, v - lo.1));
                        se += (0..3)
                            .map(|i| (a[i] as f64 - b[i] as f64).powi(2))
                            .sum::<f64>();
                        n += 3;
                    }
                }
            }
            u0 = u1 + 1;
        }
        let db = 10.0 * (255.0f64 * 255.0 / (se / n as f64)).log10();
        figures.push((c.name.clone(), db, n / 3));
    }
    figures
}
