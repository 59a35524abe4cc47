//! The depth-guided stitch of the realistic-offset rig (the published camera offsets, C2 the
//! mean of the four centres) against the scene rendered exactly from C2: over the pixels some
//! camera sees, the PSNR of the whole panorama, of each camera's region and of each object's
//! own pixels, and the misregistration of every pixel, beside the same figures at the fixed
//! proxy distance (which the depth-guided stitch replaces).

use super::*;
use crate::common::Truth;
use nalgebra::Vector3;
use panoconv::camera::Rotated;
use panoconv::convert::rig::{frame_stitch, StitchMode};
use panoconv::kitti360::Options;
use panoconv::tools::synth360::scene::{scene_at, world_from_scene, world_to_scene};
use panoconv::tools::synth360::SEQUENCE;
use panoconv::warp::{Stitch, StitchOptions};

/// The bars: the whole panorama, each camera's region, each object's pixels (dB), and the
/// 95th percentile of the per-pixel misregistration (mrad).
const MIN_OVERALL_DB: f64 = 40.0;
const MIN_REGION_DB: f64 = 35.0;
const MIN_OBJECT_DB: f64 = 35.0;
const MAX_P95_MRAD: f64 = 0.5;
/// An object's pixels are reported when it covers at least this many; those more than a pixel
/// from its silhouette are held to [`MIN_OBJECT_DB`], and all of them from [`MIN_HELD_PX`]: on
/// the smaller ones most pixels are silhouette,
/// where a camera's own blur mixes in the background it sees beside the edge, which C2 sees
/// elsewhere, and a roof seen at a grazing angle is foreshortened differently by each camera
/// (a far car of 131 px reads 34.0 dB, 54.3 dB more than a pixel inside its silhouette).
const MIN_OBJECT_PX: usize = 20;
const MIN_HELD_PX: usize = 300;
/// Reference samples per pixel side, per camera's region (as `direct_render.rs`).
const GRID: [usize; 4] = [16, 16, 8, 8];

#[test]
fn the_depth_guided_stitch_of_the_offset_rig_matches_the_render_from_c2() {
    let root = crate::kitti360_command::sequence(false);
    // every class's box, as `panoconv kitti360` reads them for a depth-guided stitch
    let seq = Sequence::open(
        root,
        SEQUENCE,
        Options {
            all_classes: true,
            ..Options::default()
        },
    )
    .unwrap();
    let number = seq.frames()[0];
    let frame = seq.frame(number).unwrap();
    let size = ImageSize::new(720, 360);
    let (k, output) = full_equirect(size);
    let cameras = stitch_cameras(&frame, &seq);
    let eyes: Vec<Vector3<f64>> = frame.rig.iter().map(|c| c.centre()).collect();
    let centre = eyes.iter().sum::<Vector3<f64>>() / 4.0;
    assert!(centre.norm() > 0.1, "an offset rig: C2 {centre}");
    let options = StitchOptions {
        distance: 10.0,
        blend_width: 5f64.to_radians(),
        even_exposure: false,
    };
    let images: Vec<RgbImage> = frame.rig.iter().map(|c| rgb(&c.image)).collect();
    let refs: Vec<&RgbImage> = images.iter().collect();
    let fixed = Stitch::build(&output, &centre, &cameras, options);
    let (guided, mode) = frame_stitch(
        &frame,
        &output,
        &centre,
        (&cameras, eyes.clone()),
        &[],
        options,
        StitchMode::Depth,
    )
    .unwrap();
    assert_eq!(mode, StitchMode::Depth);
    // the scene in its own axes, seen from C2
    let world = frame.world_from_reference.unwrap();
    let scene_from_level = world_from_scene().transpose() * world.rotation;
    let to_scene = |p: &Vector3<f64>| world_to_scene(&(world.rotation * p + world.translation));
    let direct_camera = Rotated::new(Equirect::new(k, size), scene_from_level);
    let scene = scene_at(number);
    let lenses = &seq.calibration.fisheye;
    let sigma = |cam: usize| {
        let source_px_per_rad = match cam {
            0 | 1 => seq.calibration.perspective[cam].model.k.fu,
            _ => lenses[cam - 2].centre_intrinsics().fu,
        };
        (0.55f64 * 0.55 + 1.0 / 6.0).sqrt() * k.fu / source_px_per_rad
    };
    let truth = Truth {
        scene: &scene,
        scene_from_level,
        centre: (centre, to_scene(&centre)),
        eyes: eyes.iter().map(|e| (*e, to_scene(e))).collect(),
        output: &output,
        direct: &direct_camera,
        sigma: (0..4).map(sigma).collect(),
        grid: GRID.to_vec(),
    };
    let depth = guided.distances().unwrap().to_vec();
    let at_depth = truth.figures(&guided, &refs, &|i| depth[i], MIN_OBJECT_PX);
    let at_proxy = truth.figures(&fixed, &refs, &|_| options.distance, MIN_OBJECT_PX);
    let text = format!(
        "{}\n{}",
        truth.report("fixed 10 m", &at_proxy),
        truth.report("depth-guided", &at_depth)
    );
    eprintln!("offset rig vs render from C2, frame {number}:\n{text}");
    assert!(at_depth.overall_db >= MIN_OVERALL_DB, "{text}");
    assert!(
        at_depth.region_db.iter().all(|d| *d >= MIN_REGION_DB),
        "{text}"
    );
    assert!(at_depth.p95_mrad <= MAX_P95_MRAD, "{text}");
    assert!(at_depth.objects.len() >= 5, "{text}");
    let held: Vec<_> = at_depth
        .objects
        .iter()
        .filter(|o| o.pixels >= MIN_HELD_PX)
        .collect();
    assert!(held.len() >= 5, "{text}");
    assert!(held.iter().all(|o| o.db >= MIN_OBJECT_DB), "{text}");
    assert!(
        at_depth.objects.iter().all(|o| o.inner_db >= MIN_OBJECT_DB),
        "{text}"
    );
    // no object appears twice: two pixels or more from every outline the stitch shows the
    // surface C2 sees (within resampling), where the fixed distance shows misplaced copies
    assert_eq!(at_depth.ghost_px, 0, "{text}");
    assert!(at_proxy.ghost_px > 1000, "{text}");
    // the fixed distance is what the depth replaces: far from the render where objects are
    // near the rig
    assert!(at_proxy.p95_mrad > 2.0 * MAX_P95_MRAD, "{text}");
    assert!(at_proxy.overall_db < at_depth.overall_db - 3.0, "{text}");
}

/// The bars of the coarse panorama (its pixels 2 or more source pixels wide, where the tables
/// sample the pyramid on one surface and keep taps, at most 4×4, by a depth edge): 49.12 dB
/// overall, regions [41.43, 46.24, 51.04, 49.20], objects' inner pixels 43.9 dB or more; with
/// the taps everywhere (up to 8×8) 49.08 dB, [41.52, 46.44, 51.07, 49.04]; with the pyramid
/// everywhere (across depth edges too) 43.87 dB, [39.19, 39.57, 45.30, 43.38].
const COARSE_MIN_OVERALL_DB: f64 = 48.5;
const COARSE_MIN_REGION_DB: f64 = 40.5;
const COARSE_MIN_OBJECT_DB: f64 = 43.0;
const COARSE_MAX_P95_MRAD: f64 = 0.5;

#[test]
fn a_coarse_depth_guided_stitch_of_the_offset_rig_matches_the_render_from_c2() {
    // the offset rig at 360×180, twice as coarse as the test above: every camera's pixels
    // under an output pixel are 2 or more along both axes, where a table samples the pyramid
    let root = crate::kitti360_command::sequence(false);
    let options = Options {
        all_classes: true,
        ..Options::default()
    };
    let seq = Sequence::open(root, SEQUENCE, options).unwrap();
    let number = seq.frames()[0];
    let frame = seq.frame(number).unwrap();
    let size = ImageSize::new(360, 180);
    let (k, output) = full_equirect(size);
    let cameras = stitch_cameras(&frame, &seq);
    let eyes: Vec<Vector3<f64>> = frame.rig.iter().map(|c| c.centre()).collect();
    let centre = eyes.iter().sum::<Vector3<f64>>() / 4.0;
    let options = StitchOptions {
        distance: 10.0,
        blend_width: 5f64.to_radians(),
        even_exposure: false,
    };
    let images: Vec<RgbImage> = frame.rig.iter().map(|c| rgb(&c.image)).collect();
    let refs: Vec<&RgbImage> = images.iter().collect();
    let (guided, _) = frame_stitch(
        &frame,
        &output,
        &centre,
        (&cameras, eyes.clone()),
        &[],
        options,
        StitchMode::Depth,
    )
    .unwrap();
    let world = frame.world_from_reference.unwrap();
    let scene_from_level = world_from_scene().transpose() * world.rotation;
    let to_scene = |p: &Vector3<f64>| world_to_scene(&(world.rotation * p + world.translation));
    let direct_camera = Rotated::new(Equirect::new(k, size), scene_from_level);
    let scene = scene_at(number);
    let lenses = &seq.calibration.fisheye;
    let sigma = |cam: usize| {
        let source_px_per_rad = match cam {
            0 | 1 => seq.calibration.perspective[cam].model.k.fu,
            _ => lenses[cam - 2].centre_intrinsics().fu,
        };
        (0.55f64 * 0.55 + 1.0 / 6.0).sqrt() * k.fu / source_px_per_rad
    };
    let truth = Truth {
        scene: &scene,
        scene_from_level,
        centre: (centre, to_scene(&centre)),
        eyes: eyes.iter().map(|e| (*e, to_scene(e))).collect(),
        output: &output,
        direct: &direct_camera,
        sigma: (0..4).map(sigma).collect(),
        grid: GRID.to_vec(),
    };
    let depth = guided.distances().unwrap().to_vec();
    let at_depth = truth.figures(&guided, &refs, &|i| depth[i], MIN_OBJECT_PX);
    let text = truth.report("depth-guided 360x180", &at_depth);
    eprintln!("coarse offset rig vs render from C2, frame {number}:\n{text}");
    assert!(at_depth.overall_db >= COARSE_MIN_OVERALL_DB, "{text}");
    assert!(
        at_depth
            .region_db
            .iter()
            .all(|d| *d >= COARSE_MIN_REGION_DB),
        "{text}"
    );
    assert!(at_depth.p95_mrad <= COARSE_MAX_P95_MRAD, "{text}");
    assert_eq!(at_depth.ghost_px, 0, "{text}");
    assert!(
        at_depth
            .objects
            .iter()
            .all(|o| o.inner_db >= COARSE_MIN_OBJECT_DB),
        "{text}"
    );
}
