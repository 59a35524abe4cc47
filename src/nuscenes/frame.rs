//! A sample as a neutral [`Frame`] in its level frame, with what nuScenes adds to each object.
//!
//! Time: each camera of a sample fires at its own time, with the ego pose of its own
//! `sample_data`; the LiDAR keyframe's ego pose is the sample's reference (its annotations hold
//! at that time). Each rig camera carries its time from the LiDAR keyframe's, each box the
//! devkit's velocity (`velocity.rs`), so that a stitch sees a moving object where each
//! camera saw it. Sensor → global is `ego_pose · calibrated_sensor` of the sensor's own
//! reading. The level frame: origin at the reference camera's (CAM_FRONT's) optical centre at
//! the reference pose, y = −(global z), z = that camera's optical axis made horizontal,
//! x = y × z.

use super::classes::{kitti_type, occlusion};
use super::dataset::{NuScenes, SceneEntry};
use super::lidar::parse_points;
use super::tables::{Annotation, SampleData};
use super::token::Token;
use super::velocity::sweep_time;
use crate::camera::{CameraModel, ImageSize, Intrinsics, Perspective};
use crate::error::{Error, Result};
use crate::source::world_from_level;
use crate::source::{Frame, LidarPoint, Pose, RigCamera, SourceBox, VehicleBox};
use nalgebra::Matrix3;
use std::sync::Arc;

/// What to read of a sample besides the cameras.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Read the LiDAR keyframe's points.
    pub lidar: bool,
    /// Keep objects of categories KITTI has no type for (named by their category).
    pub all_classes: bool,
    /// Keep objects with no LiDAR and no radar point (the nuScenes evaluation leaves them out).
    pub keep_unseen: bool,
    /// The LiDAR returns dropped as the vehicle's own (LIDAR_TOP's frame).
    pub vehicle_box: VehicleBox,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            lidar: true,
            all_classes: false,
            keep_unseen: false,
            vehicle_box: VehicleBox::NUSCENES,
        }
    }
}

/// Seconds from microsecond time `from` to `to` (negative: `to` is earlier).
fn microseconds_between(from: u64, to: u64) -> f64 {
    (to as i128 - from as i128) as f64 * 1e-6
}

/// One output frame: a sample of a selected scene.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Item {
    /// The scene's index in [`NuScenes::scenes`].
    pub scene: usize,
    /// The sample's index in its scene.
    pub sample: usize,
    /// The frame id: the scene's position in `scene.json` times 1000 plus the sample's index,
    /// six digits (more past 999 999), so ids follow scene order then sample order and do not
    /// depend on the selection.
    pub id: String,
}

/// What nuScenes says of an object beside its box.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ObjectInfo {
    /// The category (`vehicle.car`).
    pub category: String,
    /// The attributes' names.
    pub attributes: Vec<String>,
    /// The instance token.
    pub instance: String,
    /// The annotation token.
    pub annotation: String,
    /// LiDAR points in the box.
    pub lidar_points: u64,
    /// Radar points in the box.
    pub radar_points: u64,
    /// The visibility level (`v80-100`), where given.
    pub visibility: Option<String>,
}

/// A sample read: the neutral frame and nuScenes' own parts.
#[derive(Debug, Clone)]
pub struct NuScenesFrame {
    /// The frame in its level frame.
    pub frame: Frame,
    /// The scene's name.
    pub scene: String,
    /// The sample's token.
    pub sample_token: String,
    /// The reference time (the LiDAR keyframe's), microseconds.
    pub timestamp: u64,
    /// Each rig camera's reading time, microseconds (the rig's order).
    pub camera_timestamps: Vec<u64>,
    /// `frame.objects`' nuScenes facts, in the same order.
    pub objects: Vec<ObjectInfo>,
    /// level_from_lidar: the LiDAR at its keyframe in the level frame.
    pub reference_from_lidar: Pose,
}

impl NuScenes {
    /// The selected samples, in scene order then sample order.
    pub fn items(&self) -> Result<Vec<Item>> {
        let mut out = Vec::new();
        for (s, scene) in self.scenes.iter().enumerate() {
            if scene.samples.len() > 1000 {
                return Err(Error::file(
                    &self.table("scene"),
                    format!(
                        "scene {} has {} samples; frame ids allow 1000",
                        scene.name,
                        scene.samples.len()
                    ),
                ));
            }
            for k in 0..scene.samples.len() {
                out.push(Item {
                    scene: s,
                    sample: k,
                    id: format!("{:06}", scene.position * 1000 + k),
                });
            }
        }
        Ok(out)
    }

    /// The keyframe reading of `channel` at `sample`.
    pub fn keyframe(&self, sample: &Token, channel: &str) -> Result<&SampleData> {
        self.keyframes
            .get(&(sample.clone(), channel.to_owned()))
            .ok_or_else(|| {
                Error::file(
                    &self.table("sample_data"),
                    format!("sample {sample} has no {channel} keyframe"),
                )
            })
    }

    /// global_from_ego at a reading's time.
    pub fn ego_pose(&self, data: &SampleData) -> Result<&Pose> {
        self.ego_poses.get(&data.ego_pose).ok_or_else(|| {
            Error::file(
                &self.table("ego_pose"),
                format!(
                    "no ego_pose {} (named by sample_data {})",
                    data.ego_pose, data.token
                ),
            )
        })
    }

    /// global_from_sensor of a reading: its ego pose · its calibration.
    pub fn world_from_sensor(&self, data: &SampleData) -> Result<Pose> {
        Ok(self
            .ego_pose(data)?
            .compose(&self.calibrated[&data.calibrated_sensor].ego_from_sensor))
    }

    /// The pinhole camera of a camera reading, shared.
    pub fn camera_model(&self, data: &SampleData) -> Result<Arc<dyn CameraModel>> {
        Ok(Arc::new(self.pinhole(data)?))
    }

    /// The pinhole camera of a camera reading: `camera_intrinsic` and the image's size.
    pub fn pinhole(&self, data: &SampleData) -> Result<Perspective> {
        let path = self.table("calibrated_sensor");
        let c = &self.calibrated[&data.calibrated_sensor];
        let at = |field: &str, m: String| {
            Error::file(
                &path,
                format!("record {}: {field}: {m}", data.calibrated_sensor),
            )
        };
        let Some(k) = c.camera_intrinsic else {
            return Err(at(
                "camera_intrinsic",
                "a camera needs its 3x3 matrix".into(),
            ));
        };
        let pinhole = k[0][1] == 0.0 && k[1][0] == 0.0 && k[2] == [0.0, 0.0, 1.0];
        if !(pinhole && k[0][0] > 0.0 && k[1][1] > 0.0) {
            return Err(at(
                "camera_intrinsic",
                format!(
                    "{k:?} is not a pinhole matrix [[fx 0 cx] [0 fy cy] [0 0 1]] with fx, fy > 0"
                ),
            ));
        }
        let [w, h] = data.size;
        if w == 0 || h == 0 {
            return Err(Error::file(
                &self.table("sample_data"),
                format!(
                    "record {}: width, height: a camera image needs its size",
                    data.token
                ),
            ));
        }
        Ok(Perspective::new(
            Intrinsics::new(k[0][0], k[1][1], k[0][2], k[1][2]),
            ImageSize::new(w, h),
        ))
    }

    /// world_from_level of a sample: the reference camera at the LiDAR keyframe's ego pose.
    pub fn world_from_level(&self, sample: &Token) -> Result<Pose> {
        let lidar = self.keyframe(sample, &self.lidar)?;
        let camera = self.keyframe(sample, &self.reference_camera)?;
        let ego = self.ego_pose(lidar)?;
        let world_from_camera =
            ego.compose(&self.calibrated[&camera.calibrated_sensor].ego_from_sensor);
        world_from_level(&world_from_camera).ok_or_else(|| {
            Error::file(
                &self.table("calibrated_sensor"),
                format!(
                    "record {}: rotation: {} looks straight up or down; no level frame",
                    camera.calibrated_sensor, self.reference_camera
                ),
            )
        })
    }

    /// The sample `item` in its level frame.
    pub fn frame(&self, item: &Item, options: &Options) -> Result<NuScenesFrame> {
        let scene: &SceneEntry = &self.scenes[item.scene];
        let sample = &scene.samples[item.sample];
        let world_from_level = self.world_from_level(sample)?;
        let level_from_world = world_from_level.inverse().expect("a rotation");
        let mut provenance = Vec::new();
        let mut rig = Vec::with_capacity(self.cameras.len());
        let mut camera_timestamps = Vec::with_capacity(self.cameras.len());
        let lidar_data = self.keyframe(sample, &self.lidar)?;
        for channel in &self.cameras {
            let data = self.keyframe(sample, channel)?;
            let image = self.dataroot.join(&data.filename);
            provenance.push(image.clone());
            camera_timestamps.push(data.timestamp);
            rig.push(RigCamera {
                name: channel.clone(),
                model: self.camera_model(data)?,
                reference_from_camera: level_from_world.compose(&self.world_from_sensor(data)?),
                image,
                time: Some(microseconds_between(lidar_data.timestamp, data.timestamp)),
            });
        }
        let reference_from_lidar = level_from_world.compose(&self.world_from_sensor(lidar_data)?);
        let mut lidar = Vec::new();
        let mut input_hashes = Vec::new();
        if options.lidar {
            let path = self.dataroot.join(&lidar_data.filename);
            let bytes = crate::fs::read_file(&path)?;
            input_hashes.push((path.clone(), crate::fs::hash_hex(&bytes)));
            lidar = parse_points(&bytes, &path)?
                .into_iter()
                .filter(|(p, _)| !options.vehicle_box.holds(p))
                .map(|(p, intensity)| LidarPoint {
                    position: reference_from_lidar.apply(&p),
                    intensity,
                })
                .collect();
            provenance.push(path);
        }
        let (mut objects, infos) = self.objects(sample, &level_from_world, options)?;
        for o in &mut objects {
            o.time = sweep_time(&rig, &reference_from_lidar, &o.centre);
        }
        Ok(NuScenesFrame {
            frame: Frame {
                id: item.id.clone(),
                provenance,
                rig,
                objects,
                regions: Vec::new(),
                lidar,
                world_from_reference: Some(world_from_level),
                reference_from_lidar: Some(reference_from_lidar),
                // the ego frame is the vehicle's pose frame (KITTI's IMU)
                lidar_from_imu: self.calibrated[&lidar_data.calibrated_sensor]
                    .ego_from_sensor
                    .inverse(),
                input_hashes,
            },
            scene: scene.name.clone(),
            sample_token: sample.to_string(),
            timestamp: lidar_data.timestamp,
            camera_timestamps,
            objects: infos,
            reference_from_lidar,
        })
    }

    fn objects(
        &self,
        sample: &Token,
        level_from_world: &Pose,
        options: &Options,
    ) -> Result<(Vec<SourceBox>, Vec<ObjectInfo>)> {
        let mut boxes = Vec::new();
        let mut infos = Vec::new();
        let table = self.table("sample_annotation");
        for a in self.annotations.of(sample) {
            let info = self.object_info(a)?;
            if !options.keep_unseen && a.lidar_points + a.radar_points == 0 {
                continue;
            }
            let names: Vec<&str> = info.attributes.iter().map(String::as_str).collect();
            let kind = kitti_type(&info.category, &names);
            if kind.is_none() && !options.all_classes {
                continue;
            }
            boxes.push(SourceBox {
                centre: level_from_world.apply(&a.global_from_box.translation),
                size: nalgebra::Vector3::new(a.size[1], a.size[2], a.size[0]),
                rotation: level_from_world.rotation
                    * a.global_from_box.rotation
                    * KITTI_AXES_IN_BOX,
                class: kind.map_or_else(|| info.category.clone(), str::to_owned),
                dataset_class: info.category.clone(),
                instance: Some(a.instance.number()),
                truncation: None,
                occlusion: Some(occlusion(info.visibility.as_deref())),
                sensor_points: Some(a.lidar_points + a.radar_points),
                velocity: self
                    .tracks
                    .velocity(&table, a, sample)?
                    .map(|v| level_from_world.rotation * v),
                time: None,
            });
            infos.push(info);
        }
        Ok((boxes, infos))
    }

    fn object_info(&self, a: &Annotation) -> Result<ObjectInfo> {
        let path = self.table("sample_annotation");
        let missing = |field: &str, table: &str, token: &Token| {
            Error::file(
                &path,
                format!("record {}: {field}: no {table} {token}", a.token),
            )
        };
        let category = self
            .instances
            .get(&a.instance)
            .ok_or_else(|| missing("instance_token", "instance", &a.instance))?;
        let category = self.categories.get(category).ok_or_else(|| {
            Error::file(
                &self.table("instance"),
                format!(
                    "record {}: category_token: no category {category}",
                    a.instance
                ),
            )
        })?;
        let attributes = a
            .attributes
            .iter()
            .map(|t| {
                self.attributes
                    .get(t)
                    .cloned()
                    .ok_or_else(|| missing("attribute_tokens", "attribute", t))
            })
            .collect::<Result<_>>()?;
        let visibility = match &a.visibility {
            None => None,
            Some(t) => Some(
                self.visibility
                    .get(t)
                    .cloned()
                    .ok_or_else(|| missing("visibility_token", "visibility", t))?,
            ),
        };
        Ok(ObjectInfo {
            category: category.clone(),
            attributes,
            instance: a.instance.to_string(),
            annotation: a.token.to_string(),
            lidar_points: a.lidar_points,
            radar_points: a.radar_points,
            visibility,
        })
    }
}

/// The KITTI box axes (x length, y down, z width) in nuScenes' box axes (x length, y width,
/// z up): box_from_kitti.
const KITTI_AXES_IN_BOX: Matrix3<f64> = Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0);
