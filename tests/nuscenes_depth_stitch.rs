//! The depth-guided stitch of nuScenes' six cameras with their real offsets and firing times
//! (`panoconv synth --nuscenes`: each camera at its own ego pose, up to 43 ms and 0.43 m of
//! travel before the LiDAR keyframe) against the scene rendered exactly from C2 (the mean of
//! the six centres) at the keyframe: over the pixels some camera sees, the PSNR of the whole
//! panorama, of each camera's region and of each object's own pixels, and the misregistration
//! of every pixel, beside the misregistration at the fixed proxy distance.

use crate::common::{self, Truth};
use nalgebra::Vector3;
use panoconv::camera::{Equirect, ImageSize, Intrinsics, Rotated};
use panoconv::convert::rig::{frame_stitch, StitchMode};
use panoconv::image::RgbImage;
use panoconv::nuscenes::{NuScenes, Options, Selection};
use panoconv::source::Pose;
use panoconv::tools::synth360::scene::{scene_at, world_from_scene, world_to_scene, FIRST_FRAME};
use panoconv::tools::synth_nuscenes::{world_from_ego, Rig, SynthNuScenesOptions, VERSION};
use panoconv::warp::{Stitch, StitchCamera, StitchOptions};
use std::f64::consts::PI;

/// The bars: the whole panorama, each camera's region, each object's pixels (dB), and the
/// 95th percentile of the per-pixel misregistration (mrad).
const MIN_OVERALL_DB: f64 = 40.0;
const MIN_REGION_DB: f64 = 35.0;
const MIN_OBJECT_DB: f64 = 35.0;
const MAX_P95_MRAD: f64 = 0.5;
/// Objects covering at least this many pixels are measured. Each is held to
/// [`MIN_OBJECT_DB`] over its pixels more than one pixel from its silhouette; its whole figure
/// is reported. On its outline each camera sees the background beside it displaced from C2's
/// view by the parallax between them (CAM_FRONT is 3 cm lower than C2: a third of a pixel at
/// 19 m), and its blur (σ 0.55 px, the bilinear taps) mixes that background into the edge
/// pixels in another proportion than C2's: the pedestrian (944 px) reads 34.9 dB whole, 53.8 dB
/// inside.
const MIN_OBJECT_PX: usize = 20;
/// Reference samples per pixel side.
const GRID: usize = 8;

#[test]
fn the_depth_guided_stitch_of_the_offset_rig_matches_the_render_from_c2() {
    let root = crate::nuscenes_command::scene(false);
    let ds = NuScenes::open(root, VERSION, &Selection::default()).unwrap();
    let item = &ds.items().unwrap()[0];
    // every annotation, as `panoconv nuscenes` reads them for a depth-guided stitch
    let read = ds
        .frame(
            item,
            &Options {
                lidar: true,
                all_classes: true,
                keep_unseen: true,
                ..Options::default()
            },
        )
        .unwrap();
    let frame = &read.frame;
    let world = frame.world_from_reference.unwrap();
    // each camera at its own firing time's ego pose: the rig the stitch samples is the one
    // the synthesiser rendered, not the cameras' mountings at the keyframe
    let rig = Rig::new(&SynthNuScenesOptions {
        samples: 2,
        scale: 0.25,
        zero_baseline: false,
    })
    .unwrap();
    let keyframe = Pose::from_matrix4(&world_from_ego(0.0));
    let mut travel = Vec::new();
    for (k, c) in frame.rig.iter().enumerate() {
        let at = panoconv::tools::synth_nuscenes::seconds(read.camera_timestamps[k]);
        assert_eq!(
            read.camera_timestamps[k],
            rig.camera_time(k, 0),
            "{}",
            c.name
        );
        let mounting = rig.cameras[k].mounting.ego_from_sensor();
        let fired = Pose::from_matrix4(&(world_from_ego(at) * mounting));
        let read_pose = world.compose(&c.reference_from_camera);
        assert!(
            (read_pose.translation - fired.translation).norm() < 1e-6
                && (read_pose.rotation - fired.rotation).norm() < 1e-6,
            "{}: read {read_pose:?}, fired {fired:?}",
            c.name
        );
        let at_keyframe = keyframe.compose(&Pose::from_matrix4(&mounting));
        travel.push((fired.translation - at_keyframe.translation).norm());
    }
    assert!(
        travel.iter().cloned().fold(0.0, f64::max) > 0.4,
        "{travel:?} m"
    );
    // 1.2x coarser than the five long lenses' 316.6 px/rad at their axes, as the zero-baseline
    // test
    let size = ImageSize::new(1656, 828);
    let k = Intrinsics::new(
        size.width as f64 / (2.0 * PI),
        size.height as f64 / PI,
        size.width as f64 / 2.0 - 0.5,
        size.height as f64 / 2.0 - 0.5,
    );
    let output = Equirect::new(k, size);
    let inverses: Vec<Pose> = frame
        .rig
        .iter()
        .map(|c| c.reference_from_camera.inverse().unwrap())
        .collect();
    let cameras: Vec<StitchCamera> = frame
        .rig
        .iter()
        .zip(&inverses)
        .map(|(c, inv)| StitchCamera {
            model: c.model.as_ref(),
            rotation: inv.rotation,
            translation: inv.translation,
            max_theta: None,
        })
        .collect();
    let eyes: Vec<Vector3<f64>> = frame.rig.iter().map(|c| c.centre()).collect();
    let centre = eyes.iter().sum::<Vector3<f64>>() / eyes.len() as f64;
    let options = StitchOptions {
        distance: 10.0,
        blend_width: 5f64.to_radians(),
        even_exposure: false,
    };
    let (guided, mode) = frame_stitch(
        frame,
        &output,
        &centre,
        (&cameras, eyes.clone()),
        &[],
        options,
        StitchMode::Depth,
    )
    .unwrap();
    assert_eq!(mode, StitchMode::Depth);
    let fixed = Stitch::build(&output, &centre, &cameras, options);
    let images: Vec<RgbImage> = frame
        .rig
        .iter()
        .map(|c| {
            let png = common::read_rgb8(&c.image);
            RgbImage::from_raw(png.width, png.height, png.data).unwrap()
        })
        .collect();
    let refs: Vec<&RgbImage> = images.iter().collect();
    // the scene in its own axes at the keyframe, seen from C2
    let scene_from_level = world_from_scene().transpose() * world.rotation;
    let to_scene = |p: &Vector3<f64>| world_to_scene(&(world.rotation * p + world.translation));
    let direct = Rotated::new(Equirect::new(k, size), scene_from_level);
    let scene = scene_at(FIRST_FRAME);
    // the source's footprint (σ = 0.55 px) and the bilinear tent's mean variance (1/6 px²) at
    // each camera's axis, in output pixels
    let sigma = |c: &panoconv::source::RigCamera| {
        let source_px_per_rad = c.model.project(&Vector3::new(1e-3, 0.0, 1.0)).unwrap().x
            - c.model.project(&Vector3::new(0.0, 0.0, 1.0)).unwrap().x;
        (0.55f64 * 0.55 + 1.0 / 6.0).sqrt() * k.fu / (source_px_per_rad * 1e3)
    };
    let truth = Truth {
        scene: &scene,
        scene_from_level,
        centre: (centre, to_scene(&centre)),
        eyes: eyes.iter().map(|e| (*e, to_scene(e))).collect(),
        output: &output,
        direct: &direct,
        sigma: frame.rig.iter().map(sigma).collect(),
        grid: vec![GRID; eyes.len()],
    };
    let depth = guided.distances().unwrap().to_vec();
    let at_depth = truth.figures(&guided, &refs, &|i| depth[i], MIN_OBJECT_PX);
    let proxy_mrad = truth.p95_mrad(&fixed, &|_| options.distance);
    let text = format!(
        "fixed 10 m: misregistration p95 {proxy_mrad:.3} mrad\n{}",
        truth.report("depth-guided", &at_depth)
    );
    eprintln!("nuScenes offset rig vs render from C2, sample 0:\n{text}");
    assert!(at_depth.overall_db >= MIN_OVERALL_DB, "{text}");
    assert!(
        at_depth.region_db.iter().all(|d| *d >= MIN_REGION_DB),
        "{text}"
    );
    assert!(at_depth.p95_mrad <= MAX_P95_MRAD, "{text}");
    assert!(at_depth.objects.len() >= 5, "{text}");
    assert!(
        at_depth.objects.iter().all(|o| o.inner_db >= MIN_OBJECT_DB),
        "{text}"
    );
    // no object appears twice: two pixels or more from every outline the stitch shows the
    // surface C2 sees, within resampling
    assert_eq!(at_depth.ghost_px, 0, "{text}");
    assert!(at_depth.interior > 200_000, "{text}");
    // the fixed distance is what the depth replaces: far from the render where objects are
    // near the rig
    assert!(proxy_mrad > 2.0 * MAX_P95_MRAD, "{text}");
}
