//! A synthetic nuScenes scene in the official layout, rendered exactly: the analytic scene of
//! the KITTI-360 synthesiser (`synth360::scene`: textured ground, sky, boxes all around) seen
//! by nuScenes' six cameras with their published calibration (`calibration.rs`) from a moving
//! ego, each camera at its own firing time and ego pose, and a 32-beam LiDAR sweep.
//!
//! What is written, under ROOT:
//!
//! ```text
//! v1.0-mini/{scene, sample, sample_data, ego_pose, calibrated_sensor, sensor,
//!            sample_annotation, instance, category, attribute, visibility, log, map}.json
//! samples/CAM_*/LOG__CAM_*__TIMESTAMP.png        pinhole images (lossless PNG)
//! samples/LIDAR_TOP/LOG__LIDAR_TOP__TIMESTAMP.pcd.bin
//! ```
//!
//! The ego drives at 10 m/s and turns right at 6°/s, pitched 0.6° and rolled −0.4°; samples
//! are 0.5 s apart, each camera fires at its published offset from the LiDAR keyframe (up to
//! 43 ms before it: 0.43 m of travel). The objects stand still within a sample (the scene of
//! KITTI-360 frame 250 + k at sample k), so every camera sees each box where its annotation
//! puts it. The zero-baseline variant puts all six cameras at CAM_FRONT's mounting and fires
//! them at the LiDAR's time, so that all share one optical centre.

mod calibration;
mod tables;

pub use calibration::{CameraCalibration, Mounting, CAMERAS, IMAGE_SIZE, LIDAR};

use super::synth360::scene::{
    scene_at, world_from_scene, world_to_scene, FIRST_FRAME, WORLD_ORIGIN,
};
use super::synth360::{render_camera, RenderCamera};
use crate::camera::{ImageSize, Intrinsics, Perspective};
use crate::codec::png::{encode_rgb8, PngCompression};
use crate::error::{Error, Result};
use crate::fs::write_atomic;
use crate::tools::synth::GROUND_Y;
use nalgebra::{Matrix4, Rotation3, Vector3};
use rayon::prelude::*;
use std::path::Path;

/// The version folder written.
pub const VERSION: &str = "v1.0-mini";
/// The scene's name.
pub const SCENE: &str = "scene-0001";
/// The log's name (the files' prefix).
pub const LOG: &str = "n000-2026-01-01-00-00-00+0000";
/// The first LiDAR keyframe's time, microseconds.
pub const FIRST_TIMESTAMP: u64 = 1_532_402_927_647_951;
/// Time between samples, microseconds.
pub const SAMPLE_INTERVAL_US: u64 = 500_000;
/// Ego speed, m/s.
const SPEED: f64 = 10.0;
/// Ego yaw rate, rad/s (negative: turning right).
const YAW_RATE: f64 = -0.10471975511965977;
/// Where the ego starts, scene x and z (the KITTI-360 drive's objects stand around it).
const START: [f64; 2] = [0.0, -5.0];
/// LiDAR beams, from +10.67° to −30.67° (an HDL-32E's).
pub const BEAMS: usize = 32;
/// The sweep's range, metres.
pub const LIDAR_RANGE: f64 = 70.0;

/// What to generate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SynthNuScenesOptions {
    /// Number of samples (keyframes).
    pub samples: u32,
    /// Image scale: 1 gives the official 1600x900.
    pub scale: f64,
    /// All cameras at CAM_FRONT's mounting, firing at the LiDAR's time.
    pub zero_baseline: bool,
}

impl Default for SynthNuScenesOptions {
    fn default() -> Self {
        Self {
            samples: 3,
            scale: 1.0,
            zero_baseline: false,
        }
    }
}

/// global_from_ego at `t` seconds after the first LiDAR keyframe (ego axes: x forward, y left,
/// z up; origin on the ground).
pub fn world_from_ego(t: f64) -> Matrix4<f64> {
    let heading0 = std::f64::consts::FRAC_PI_2;
    let heading = heading0 + YAW_RATE * t;
    let r = SPEED / YAW_RATE;
    let start = world_from_scene() * Vector3::new(START[0], GROUND_Y, START[1])
        + Vector3::from(WORLD_ORIGIN);
    let p = start
        + Vector3::new(
            r * (heading.sin() - heading0.sin()),
            r * (heading0.cos() - heading.cos()),
            0.0,
        );
    let rotation = Rotation3::from_axis_angle(&Vector3::z_axis(), heading)
        * Rotation3::from_axis_angle(&Vector3::y_axis(), 0.6f64.to_radians())
        * Rotation3::from_axis_angle(&Vector3::x_axis(), (-0.4f64).to_radians());
    let mut m = Matrix4::identity();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(rotation.matrix());
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(&p);
    m
}

/// The synthetic rig: the cameras' calibrations as written (zero-baseline applied) and sizes.
#[derive(Debug, Clone)]
pub struct Rig {
    /// Each camera: its calibration as written in the tables.
    pub cameras: Vec<CameraCalibration>,
    /// The images' size.
    pub size: [u32; 2],
    /// The scale of the images.
    pub scale: f64,
}

impl Rig {
    /// The rig of `options`.
    pub fn new(options: &SynthNuScenesOptions) -> Result<Self> {
        if !(options.scale > 0.0 && options.scale <= 1.0) {
            return Err(Error::Setup(format!(
                "--scale {} must be in (0, 1]",
                options.scale
            )));
        }
        let size = IMAGE_SIZE.map(|n| (n as f64 * options.scale).round() as u32);
        if size.contains(&0) {
            return Err(Error::Setup(format!(
                "--scale {} leaves no pixel",
                options.scale
            )));
        }
        let front = CAMERAS[0].mounting;
        let cameras = CAMERAS
            .iter()
            .map(|c| {
                let mut c = *c;
                c.intrinsics = calibration::scaled_intrinsics(c.intrinsics, options.scale);
                if options.zero_baseline {
                    c.mounting.translation = front.translation;
                    c.offset_us = 0;
                }
                c
            })
            .collect();
        Ok(Rig {
            cameras,
            size,
            scale: options.scale,
        })
    }

    /// Camera `k`'s pinhole model.
    pub fn model(&self, k: usize) -> Perspective {
        let [fx, fy, cx, cy] = self.cameras[k].intrinsics;
        Perspective::new(
            Intrinsics::new(fx, fy, cx, cy),
            ImageSize::new(self.size[0], self.size[1]),
        )
    }

    /// Camera `k`'s firing time for sample `sample`, microseconds.
    pub fn camera_time(&self, k: usize, sample: u32) -> u64 {
        lidar_time(sample).saturating_add_signed(self.cameras[k].offset_us)
    }
}

/// The LiDAR keyframe's time of sample `sample`, microseconds.
pub fn lidar_time(sample: u32) -> u64 {
    FIRST_TIMESTAMP + sample as u64 * SAMPLE_INTERVAL_US
}

/// Seconds after the first LiDAR keyframe.
pub fn seconds(timestamp: u64) -> f64 {
    (timestamp as f64 - FIRST_TIMESTAMP as f64) * 1e-6
}

/// A 32-beam sweep from a LiDAR at `world_from_lidar`, taken at one instant at sample
/// `sample`: points in the LiDAR's frame, the hit surface's red channel (0 to 255) as intensity
/// and the beam as ring index. Azimuths at the centres of `step_deg` steps from −180°.
pub fn lidar_sweep(
    world_from_lidar: &Matrix4<f64>,
    sample: u32,
    step_deg: f64,
) -> Vec<(Vector3<f64>, f32, u8)> {
    let scene = scene_at(FIRST_FRAME + sample);
    let ws = world_from_scene();
    let steps = (360.0 / step_deg).round() as usize;
    let rotation = world_from_lidar.fixed_view::<3, 3>(0, 0).into_owned();
    let origin = world_from_lidar.fixed_view::<3, 1>(0, 3).into_owned();
    let inverse = world_from_lidar.try_inverse().expect("a rigid mounting");
    let origin_scene = world_to_scene(&origin);
    (0..BEAMS)
        .into_par_iter()
        .flat_map_iter(|beam| {
            let elevation = (10.67 - 41.34 * beam as f64 / (BEAMS - 1) as f64).to_radians();
            let (scene, ws, inverse) = (&scene, &ws, &inverse);
            (0..steps).filter_map(move |i| {
                let a = ((i as f64 + 0.5) * step_deg - 180.0).to_radians();
                let d = Vector3::new(
                    elevation.cos() * a.cos(),
                    elevation.cos() * a.sin(),
                    elevation.sin(),
                );
                let d_world = (rotation * d).normalize();
                let (t, c) = scene.first_hit(&origin_scene, &(ws.transpose() * d_world))?;
                if !(t < LIDAR_RANGE) {
                    return None;
                }
                let p = (inverse * (origin + d_world * t).push(1.0)).xyz();
                Some((p, c[0].clamp(0.0, 255.0) as f32, beam as u8))
            })
        })
        .collect()
}

fn write(root: &Path, relative: &str, bytes: &[u8]) -> Result<()> {
    let path = root.join(relative);
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    write_atomic(&path, bytes)
}

/// The file of camera or LiDAR `channel` at `timestamp`, relative to the data root.
pub fn sample_file(channel: &str, timestamp: u64) -> String {
    let ext = if channel.starts_with("CAM_") {
        "png"
    } else {
        "pcd.bin"
    };
    format!("samples/{channel}/{LOG}__{channel}__{timestamp}.{ext}")
}

/// Writes the synthetic scene under `root` (created; it must be empty unless `overwrite`).
pub fn write_scene(
    root: &Path,
    options: &SynthNuScenesOptions,
    overwrite: bool,
    progress: &dyn crate::run::Progress,
) -> Result<()> {
    super::synth::require_empty(root, overwrite)?;
    if options.samples == 0 {
        return Err(Error::Setup("a scene needs at least one sample".into()));
    }
    let rig = Rig::new(options)?;
    let step_deg = 0.2 / rig.scale;
    progress.start(options.samples as usize);
    let mut sweeps = Vec::new();
    for sample in 0..options.samples {
        for (k, camera) in rig.cameras.iter().enumerate() {
            let time = rig.camera_time(k, sample);
            let world_from_camera =
                world_from_ego(seconds(time)) * camera.mounting.ego_from_sensor();
            let model = rig.model(k);
            let image = render_camera(
                RenderCamera::Perspective(&model),
                &world_from_camera,
                FIRST_FRAME + sample,
            );
            write(
                root,
                &sample_file(camera.mounting.channel, time),
                &encode_rgb8(&image, PngCompression::Best),
            )?;
        }
        let time = lidar_time(sample);
        let world_from_lidar = world_from_ego(seconds(time)) * LIDAR.ego_from_sensor();
        let sweep = lidar_sweep(&world_from_lidar, sample, step_deg);
        write(
            root,
            &sample_file(LIDAR.channel, time),
            &crate::nuscenes::lidar::encode_points(&sweep),
        )?;
        sweeps.push((world_from_lidar, sweep));
        progress.frame_done();
    }
    for (name, json) in tables::tables(&rig, options.samples, &sweeps) {
        write(root, &format!("{VERSION}/{name}.json"), json.as_bytes())?;
    }
    progress.finish();
    Ok(())
}
