//! A synthetic KITTI-360 sequence in the official layout, rendered exactly: the analytic scene
//! of `tools/synth.rs` (textured ground, sky, textured boxes) seen by KITTI-360's four cameras
//! with its published calibration (`calibration.rs`; images optionally scaled down, and a
//! zero-baseline variant with all four camera centres at image_00's), a vehicle that drives and
//! turns (`scene.rs`), objects all around it, one of them moving, and a 360° Velodyne scan.
//!
//! What is written, under ROOT:
//!
//! ```text
//! calibration/{calib_cam_to_pose.txt, perspective.txt, image_02.yaml, image_03.yaml,
//!              calib_cam_to_velo.txt}
//! data_2d_raw/SEQ/image_0{0,1}/data_rect/%010d.png     rectified pinholes
//! data_2d_raw/SEQ/image_0{2,3}/data_rgb/%010d.png      MEI fisheyes, black outside 185°
//! data_3d_raw/SEQ/velodyne_points/data/%010d.bin       HDL-64E-like sweep, uncompensated
//! data_poses/SEQ/poses.txt
//! data_3d_bboxes/train/SEQ.xml                         static and dynamic boxes, world
//! ```
//!
//! Every camera ray is the one kitti360Scripts' transforms give (rectified cameras through
//! `cam_to_pose · R_rect⁻¹`, fisheyes through `cam_to_pose`), so a reader that follows them
//! sees each object exactly where the boxes say. The scan is measured along the moving rig as
//! the sweep model of `kitti360::velodyne::SweepMotion` assumes, uncompensated as KITTI-360's
//! raw scans are ([`lidar_sweep_moving`]).

mod calibration;
pub mod scene;

use crate::camera::{CameraModel, ImageSize, ProjectionReject};
use crate::codec::png::{encode_rgb8, PngCompression};
use crate::error::{Error, Result};
use crate::fs::write_atomic;
use crate::image::RgbImage;
use crate::kitti360::velodyne::SweepMotion;
use calibration::{join, row_3x4, Rig};
use nalgebra::{Matrix3, Matrix4, Point2, Vector3};
use rayon::prelude::*;
use scene::{objects, scene_at, world_from_pose, world_to_scene, world_transform, FIRST_FRAME};
use std::f64::consts::TAU;
use std::path::Path;

/// The sequence name the synthetic drive is written under.
pub const SEQUENCE: &str = "2013_05_28_drive_0000_sync";

/// What to generate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Synth360Options {
    /// Number of frames (numbered from [`scene::FIRST_FRAME`]).
    pub frames: u32,
    /// Image scale: 1 gives the official sizes (1408x376, 1400x1400).
    pub scale: f64,
    /// All four camera centres at image_00's.
    pub zero_baseline: bool,
}

impl Default for Synth360Options {
    fn default() -> Self {
        Self {
            frames: 3,
            scale: 1.0,
            zero_baseline: false,
        }
    }
}

/// A camera model whose bearings are in the scene's axes: `scene_from_camera` may be off
/// orthonormal by a rectification's rounding, so directions are normalised after the map.
#[derive(Debug)]
struct InScene<'a> {
    model: &'a dyn CameraModel,
    scene_from_camera: Matrix3<f64>,
    camera_from_scene: Matrix3<f64>,
    /// For a MEI lens: its intrinsics and a bound on the distorted radius of its field of
    /// view, beyond which a pixel is refused at once (the lens's own inverse would refuse it
    /// too, after a long Newton search that fails).
    circle: Option<(crate::camera::Intrinsics, f64)>,
}

/// A bound on the distorted radius (normalised units) of a MEI lens's field of view: the
/// radial image of max_theta plus the largest tangential term there, with a 2 % margin.
fn mei_circle(model: &crate::camera::Lens) -> Option<(crate::camera::Intrinsics, f64)> {
    let m = model.downcast::<crate::camera::MeiModel>()?;
    let t = m.max_theta;
    let r = t.sin() / (t.cos() + m.model.xi);
    if !(r > 0.0 && r.is_finite()) {
        return None;
    }
    let d = &m.model.distortion;
    let r2 = r * r;
    let radial = r * (1.0 + d.k1 * r2 + d.k2 * r2 * r2).abs();
    let tangential = 3.0 * (d.p1.abs() + d.p2.abs()) * r2;
    Some((m.k, (radial + tangential) * 1.02))
}

impl CameraModel for InScene<'_> {
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        self.model.project_point(&(self.camera_from_scene * d))
    }

    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        if let Some((k, limit)) = self.circle {
            let (x, y) = ((p.x - k.cu) / k.fu, (p.y - k.cv) / k.fv);
            if x.hypot(y) > limit {
                return Err(ProjectionReject::OutsideDomain);
            }
        }
        let d = self.scene_from_camera * self.model.unproject(p)?;
        Ok(d.normalize())
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        p.norm()
    }

    fn size(&self) -> ImageSize {
        self.model.size()
    }
}

/// The camera a synthetic image is rendered with.
#[derive(Debug, Clone, Copy)]
pub enum RenderCamera<'a> {
    /// A rectified pinhole.
    Perspective(&'a crate::camera::Perspective),
    /// A fisheye lens.
    Fisheye(&'a crate::camera::Lens),
}

/// Renders `camera` whose image axes are `world_from_image` (4x4) at frame `frame`.
pub fn render_camera(
    camera: RenderCamera,
    world_from_image: &Matrix4<f64>,
    frame: u32,
) -> RgbImage {
    render_camera_with(camera, world_from_image, frame, RENDER_SAMPLES)
}

/// Samples per side of the grid over each pixel's Gaussian footprint (σ = 0.55 px, ±1.5 px).
/// Ten (0.3 px apart) keep a step edge's response smooth as it moves across a pixel: the
/// coarser grid of the KITTI sample (6, 0.5 px apart) moves it in steps of up to a third of
/// the edge's contrast, an error no resampling can reproduce (it cost image_00's region of a
/// stitched panorama 5 dB against a direct render).
pub const RENDER_SAMPLES: usize = 10;

/// [`render_camera`] with the Gaussian footprint (σ = 0.55 px) sampled on an n×n grid.
pub fn render_camera_with(
    camera: RenderCamera,
    world_from_image: &Matrix4<f64>,
    frame: u32,
    samples: usize,
) -> RgbImage {
    let (model, circle): (&dyn CameraModel, _) = match camera {
        RenderCamera::Perspective(p) => (p, None),
        RenderCamera::Fisheye(l) => (l, mei_circle(l)),
    };
    let ws = scene::world_from_scene();
    let r = world_from_image.fixed_view::<3, 3>(0, 0).into_owned();
    let scene_from_camera = ws.transpose() * r;
    let camera = InScene {
        model,
        scene_from_camera,
        camera_from_scene: scene_from_camera
            .try_inverse()
            .unwrap_or_else(|| scene_from_camera.transpose()),
        circle,
    };
    let centre = world_to_scene(&world_from_image.fixed_view::<3, 1>(0, 3).into_owned());
    scene_at(frame).render_with(&camera, &centre, 0.55, samples)
}

/// A 360° sweep like the HDL-64E's (64 beams from +2° to −24.8°, azimuths at the centres of
/// steps of `step_deg` from −180°, so none is exactly forwards or backwards; 80 m range) from a
/// Velodyne at `world_from_velo`, taken at one instant: points in the Velodyne frame (x forward,
/// y left, z up) with the hit surface's red channel as reflectance.
pub fn lidar_sweep(
    world_from_velo: &Matrix4<f64>,
    frame: u32,
    step_deg: f64,
) -> Vec<(Vector3<f64>, f32)> {
    lidar_sweep_moving(world_from_velo, None, frame, step_deg)
}

/// The sweep of [`lidar_sweep`] measured by a moving Velodyne, uncompensated as KITTI-360's raw
/// scans are: the beam at azimuth a leaves the Velodyne where the sweep model
/// ([`SweepMotion`]) puts it at that azimuth, `world_from_velo · frame_from_measured(a / 2π)`
/// (`world_from_velo` at the frame's time, when the sensor faces forwards), and its point is
/// written in the Velodyne frame of that instant. The scene itself is the frame's (the moving
/// object does not move during the sweep), so a compensated sweep lies exactly on it.
pub fn lidar_sweep_moving(
    world_from_velo: &Matrix4<f64>,
    motion: Option<&SweepMotion>,
    frame: u32,
    step_deg: f64,
) -> Vec<(Vector3<f64>, f32)> {
    let scene = scene_at(frame);
    let ws = scene::world_from_scene();
    let steps = (360.0 / step_deg).round() as usize;
    // per azimuth: world_from_measured, its inverse, its origin in the scene
    let poses: Vec<_> = (0..steps)
        .map(|i| {
            let a = ((i as f64 + 0.5) * step_deg - 180.0).to_radians();
            let world_from_measured = match motion {
                Some(m) => world_from_velo * m.frame_from_measured(a / TAU).to_matrix4(),
                None => *world_from_velo,
            };
            let inverse = world_from_measured.try_inverse().expect("a rigid mounting");
            let origin = world_from_measured.fixed_view::<3, 1>(0, 3).into_owned();
            (a, world_from_measured, inverse, origin)
        })
        .collect();
    (0..64)
        .into_par_iter()
        .flat_map_iter(|beam| {
            let elevation = (2.0 - 26.8 * beam as f64 / 63.0).to_radians();
            let (scene, poses) = (&scene, &poses);
            poses
                .iter()
                .filter_map(move |(a, world_from_measured, inverse, origin)| {
                    let d_velo = Vector3::new(
                        elevation.cos() * a.cos(),
                        elevation.cos() * a.sin(),
                        elevation.sin(),
                    );
                    let r = world_from_measured.fixed_view::<3, 3>(0, 0);
                    let d_world = (r * d_velo).normalize();
                    let origin_scene = world_to_scene(origin);
                    let (t, c) = scene.first_hit(&origin_scene, &(ws.transpose() * d_world))?;
                    if !(t < 80.0) {
                        return None;
                    }
                    let hit = (origin + d_world * t).push(1.0);
                    let p = (inverse * hit).xyz();
                    Some((p, (c[0] / 255.0).clamp(0.0, 1.0) as f32))
                })
        })
        .collect()
}

/// The unit cube's vertices in KITTI-360's order, and the 12 triangles of its faces.
const VERTICES: [[f64; 3]; 8] = [
    [0.5, 0.5, 0.5],
    [0.5, 0.5, -0.5],
    [0.5, -0.5, 0.5],
    [0.5, -0.5, -0.5],
    [-0.5, 0.5, -0.5],
    [-0.5, 0.5, 0.5],
    [-0.5, -0.5, -0.5],
    [-0.5, -0.5, 0.5],
];
const FACES: [[u32; 3]; 12] = [
    [0, 2, 1],
    [1, 2, 3],
    [4, 6, 5],
    [5, 6, 7],
    [0, 1, 5],
    [1, 4, 5],
    [2, 7, 3],
    [3, 7, 6],
    [0, 5, 2],
    [2, 5, 7],
    [1, 3, 4],
    [3, 6, 4],
];

fn opencv_matrix(name: &str, rows: usize, cols: usize, dt: char, data: &str) -> String {
    format!(
        "  <{name} type_id=\"opencv-matrix\">\n    <rows>{rows}</rows>\n    <cols>{cols}</cols>\n    \
         <dt>{dt}</dt>\n    <data>{data}</data></{name}>\n"
    )
}

/// `data_3d_bboxes/train/SEQ.xml` for frames `first..first + n`: one element per static
/// object, one per frame for the moving one.
pub fn boxes_xml(first: u32, n: u32) -> String {
    let vertices = join(&VERTICES.concat());
    let faces = FACES
        .iter()
        .flatten()
        .map(u32::to_string)
        .collect::<Vec<_>>()
        .join(" ");
    let mut out = String::from("<?xml version=\"1.0\"?>\n<opencv_storage>\n");
    let mut index = 0;
    let last = first + n.max(1) - 1;
    for object in objects() {
        let entries: Vec<(i64, u32, u32, u32)> = match object.motion {
            scene::Motion::Static { frames, .. } => {
                vec![(-1, frames[0], frames[1], frames[0].max(first))]
            }
            scene::Motion::Moving { .. } => {
                (first..=last).map(|f| (f as i64, first, last, f)).collect()
            }
        };
        for (timestamp, start, end, at) in entries {
            let Some(b) = object.at(at) else { continue };
            let t = world_transform(&b);
            let transform: Vec<f64> = (0..16).map(|i| t[(i / 4, i % 4)]).collect();
            index += 1;
            out.push_str(&format!("<object{index}>\n"));
            out.push_str(&opencv_matrix("transform", 4, 4, 'd', &join(&transform)));
            out.push_str(&format!(
                "  <index>{}</index>\n  <label>{}</label>\n  <semanticId>{}</semanticId>\n  \
                 <instanceId>{}</instanceId>\n",
                index - 1,
                object.label,
                object.kitti_id,
                object.instance_id
            ));
            out.push_str(&opencv_matrix("vertices", 8, 3, 'f', &vertices));
            out.push_str(&opencv_matrix("faces", 12, 3, 'u', &faces));
            out.push_str(&format!(
                "  <start_frame>{start}</start_frame>\n  <end_frame>{end}</end_frame>\n  \
                 <timestamp>{timestamp}</timestamp>\n  <dynamic>{}</dynamic>\n</object{index}>\n",
                u8::from(object.is_dynamic())
            ));
        }
    }
    out.push_str("</opencv_storage>\n");
    out
}

/// The sweep model of `frame` from the poses of its neighbours among `frames`, by the rule the
/// reader follows (`kitti360::Sequence::sweep_motion`): the frame before, else the frame after,
/// else none (an instantaneous sweep).
fn sweep_motion(rig: &Rig, frame: u32, frames: &[u32]) -> Option<SweepMotion> {
    let velo = |f: u32| world_from_pose(f - FIRST_FRAME) * rig.pose_from_velo();
    let (later, earlier) = if frames.contains(&(frame.wrapping_sub(1))) {
        (frame, frame - 1)
    } else if frames.contains(&(frame + 1)) {
        (frame + 1, frame)
    } else {
        return None;
    };
    let motion = velo(later).try_inverse()? * velo(earlier);
    Some(SweepMotion::from_frame_motion(
        &crate::source::Pose::from_matrix4(&motion),
    ))
}

fn write(root: &Path, relative: &str, bytes: &[u8]) -> Result<()> {
    let path = root.join(relative);
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    write_atomic(&path, bytes)
}

/// The rig's calibration folder, in KITTI-360's files.
fn write_calibration(root: &Path, rig: &Rig) -> Result<()> {
    let files = [
        ("calib_cam_to_pose.txt", rig.cam_to_pose_text()),
        ("perspective.txt", rig.perspective_text()),
        ("image_02.yaml", rig.fisheye_yaml(0)),
        ("image_03.yaml", rig.fisheye_yaml(1)),
        ("calib_cam_to_velo.txt", rig.cam_to_velo_text()),
    ];
    for (name, text) in files {
        write(root, &format!("calibration/{name}"), text.as_bytes())?;
    }
    Ok(())
}

/// Writes the synthetic sequence under `root` (created; it must be empty unless `overwrite`).
pub fn write_sequence(
    root: &Path,
    options: &Synth360Options,
    overwrite: bool,
    progress: &dyn crate::run::Progress,
) -> Result<()> {
    super::synth::require_empty(root, overwrite)?;
    if options.frames == 0 {
        return Err(Error::Setup("a sequence needs at least one frame".into()));
    }
    let rig = Rig::new(options.scale, options.zero_baseline)?;
    write_calibration(root, &rig)?;
    let frames: Vec<u32> = (0..options.frames).map(|i| FIRST_FRAME + i).collect();
    let poses: String = frames
        .iter()
        .map(|&f| format!("{f} {}\n", row_3x4(&world_from_pose(f - FIRST_FRAME))))
        .collect();
    write(
        root,
        &format!("data_poses/{SEQUENCE}/poses.txt"),
        poses.as_bytes(),
    )?;
    write(
        root,
        &format!("data_3d_bboxes/train/{SEQUENCE}.xml"),
        boxes_xml(FIRST_FRAME, options.frames).as_bytes(),
    )?;
    let perspective = rig.perspective();
    let fisheye = [rig.fisheye_lens(0)?, rig.fisheye_lens(1)?];
    // The sweep's density follows the images' scale (0.2° at the official size).
    let step_deg = 0.2 / options.scale.min(1.0);
    progress.start(frames.len());
    for &frame in &frames {
        let pose = world_from_pose(frame - FIRST_FRAME);
        for k in 0..4 {
            let model = match k {
                0 | 1 => RenderCamera::Perspective(&perspective),
                _ => RenderCamera::Fisheye(&fisheye[k - 2]),
            };
            let image = render_camera(model, &(pose * rig.pose_from_image(k)), frame);
            let sub = if k < 2 { "data_rect" } else { "data_rgb" };
            write(
                root,
                &format!("data_2d_raw/{SEQUENCE}/image_0{k}/{sub}/{frame:010}.png"),
                &encode_rgb8(&image, PngCompression::Best),
            )?;
        }
        let world_from_velo = pose * rig.pose_from_velo();
        let motion = sweep_motion(&rig, frame, &frames);
        let scan = lidar_sweep_moving(&world_from_velo, motion.as_ref(), frame, step_deg);
        write(
            root,
            &format!("data_3d_raw/{SEQUENCE}/velodyne_points/data/{frame:010}.bin"),
            &crate::kitti360::velodyne::encode_scan(&scan),
        )?;
        progress.frame_done();
    }
    progress.finish();
    Ok(())
}
