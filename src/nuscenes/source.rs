//! nuScenes as a [`RigSource`]: the selected scenes of a version opened, their samples with
//! their output ids, the class table and the unseen-object rule applied, and what the manifest
//! and the objects records say of them.
//!
//! A frame's id is the scene's position in `scene.json` times 1000 plus the sample's place in
//! its scene, six digits (`scene.json`'s third scene, its fifth sample → `002004`): ids follow
//! scene order then sample order, whatever the scenes selected, the shard or a resume.

use super::dataset::{NuScenes, Selection};
use super::frame::{Item, Options};
use crate::camera::CameraModel;
use crate::error::{Error, Result};
use crate::source::{
    record_value, CameraInfo, RigItem, RigItems, RigSource, SourceBox, SourceCamera, SourceFrame,
    VehicleBox,
};
use serde::Serialize;
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};

/// Which categories' objects are written (KITTI types: docs/nuscenes.md's class table).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NuScenesClasses {
    /// The categories with a KITTI type only.
    Kitti,
    /// Every category; those without a KITTI type named by their category.
    All,
    /// The KITTI types and these categories (named by their category).
    Also(Vec<String>),
}

impl NuScenesClasses {
    /// Whether a box of `category`, written as `class`, is kept.
    pub fn keeps(&self, class: &str, category: &str) -> bool {
        let kitti_type = class != category;
        match self {
            NuScenesClasses::Kitti => kitti_type,
            NuScenesClasses::All => true,
            NuScenesClasses::Also(names) => kitti_type || names.iter().any(|n| n == category),
        }
    }
}

/// What of a nuScenes data root is converted.
#[derive(Debug, Clone, PartialEq)]
pub struct NuScenesSelection {
    /// The data root (the folder holding `samples/` and the version folder).
    pub input: PathBuf,
    /// The version folder (`v1.0-mini`).
    pub version: String,
    /// Scene names; None: every scene.
    pub scenes: Option<Vec<String>>,
    /// Camera channels in the rig's order; None: every camera of the dataset.
    pub cameras: Option<Vec<String>>,
    /// Which classes are written.
    pub classes: NuScenesClasses,
    /// Read each sample's LiDAR keyframe (depth maps, or the objects' LiDAR check).
    pub lidar: bool,
    /// Keep the objects with no LiDAR and no radar point.
    pub keep_unseen: bool,
    /// The LiDAR returns dropped as the vehicle's own.
    pub vehicle_box: VehicleBox,
}

impl NuScenesSelection {
    /// Every scene and camera of `version` under `input`, KITTI classes, with scans.
    pub fn new(input: PathBuf, version: String) -> Self {
        Self {
            input,
            version,
            scenes: None,
            cameras: None,
            classes: NuScenesClasses::Kitti,
            lidar: true,
            keep_unseen: false,
            vehicle_box: VehicleBox::NUSCENES,
        }
    }
}

/// The selected scenes of a nuScenes version, indexed.
#[derive(Debug)]
pub struct NuScenesSource {
    selection: NuScenesSelection,
    dataset: NuScenes,
    /// Each scene's camera set (from its first sample's readings).
    cameras: Vec<Vec<SourceCamera>>,
}

impl NuScenesSource {
    /// Indexes the selected scenes: every problem of the tables is a set-up error naming its
    /// file, record and field.
    pub fn open(selection: NuScenesSelection) -> Result<Self> {
        if !selection.input.is_dir() {
            return Err(Error::Setup(format!(
                "input {} is not a directory",
                selection.input.display()
            )));
        }
        let dataset = NuScenes::open(
            &selection.input,
            &selection.version,
            &Selection {
                scenes: selection.scenes.clone(),
                cameras: selection.cameras.clone(),
            },
        )?;
        let mut cameras = Vec::new();
        for scene in &dataset.scenes {
            let Some(first) = scene.samples.first() else {
                return Err(Error::file(
                    &dataset.table("scene"),
                    format!("scene {} has no sample", scene.name),
                ));
            };
            let mut set = Vec::new();
            for channel in &dataset.cameras {
                let model = dataset.pinhole(dataset.keyframe(first, channel)?)?;
                set.push(SourceCamera {
                    name: channel.clone(),
                    info: CameraInfo {
                        focal: model.k,
                        max_theta: None,
                    },
                    size: model.size(),
                });
            }
            cameras.push(set);
        }
        Ok(Self {
            selection,
            dataset,
            cameras,
        })
    }

    /// The same source, reading each sample's LiDAR keyframe or not (depth maps, a
    /// depth-guided stitch, the objects' LiDAR check need it).
    pub fn with_lidar(mut self, lidar: bool) -> Self {
        self.selection.lidar = lidar;
        self
    }

    /// The indexed tables.
    pub fn dataset(&self) -> &NuScenes {
        &self.dataset
    }

    /// Every annotation is read: the class table and the unseen rule are the run's verdicts
    /// ([`RigSource::keeps`], [`RigSource::drops_unseen`]), so that the summary counts them.
    fn options(&self) -> Options {
        Options {
            lidar: self.selection.lidar,
            all_classes: true,
            keep_unseen: true,
            vehicle_box: self.selection.vehicle_box,
        }
    }

    fn item(&self, item: &RigItem) -> Item {
        Item {
            scene: item.part,
            sample: item.index as usize,
            id: item.id.clone(),
        }
    }
}

/// The order of the manifest's parameters of a `nuscenes` run.
const PARAMETER_ORDER: &[&str] = &[
    "input",
    "version",
    "scenes",
    "frame_ids",
    "output_spec",
    "cameras",
    "stitch_distance",
    "blend_width_deg",
    "exposure_gains",
    "centre",
    "objects",
    "classes",
    "keep_unseen",
    "vehicle_box",
    "depth",
    "shard",
    "png_compression",
    "ego_masks",
    "style",
    "augment",
];

impl RigSource for NuScenesSource {
    fn command(&self) -> &'static str {
        "nuscenes"
    }

    fn root(&self) -> &Path {
        &self.selection.input
    }

    fn parts(&self) -> usize {
        self.dataset.scenes.len()
    }

    fn cameras(&self, part: usize) -> &[SourceCamera] {
        &self.cameras[part]
    }

    fn items(&self, _cameras: &[usize]) -> Result<RigItems> {
        let items: Vec<RigItem> = self
            .dataset
            .items()?
            .into_iter()
            .map(|i| RigItem {
                id: i.id,
                part: i.scene,
                index: i.sample as u64,
            })
            .collect();
        if items.is_empty() {
            return Err(Error::Setup("the selection holds no sample".into()));
        }
        // a sample lacking a chosen camera fails as a frame, naming the table and channel
        Ok(RigItems {
            items,
            not_frames: Vec::new(),
        })
    }

    fn read(&self, item: &RigItem) -> Result<SourceFrame> {
        let read = self.dataset.frame(&self.item(item), &self.options())?;
        let mut record = Map::new();
        record.insert("scene".into(), Value::from(read.scene));
        record.insert("sample_token".into(), Value::from(read.sample_token));
        // each object of the frame (in its order): what nuScenes says of it
        record.insert("annotations".into(), record_value(read.objects));
        Ok(SourceFrame {
            frame: read.frame,
            record,
        })
    }

    fn keeps(&self, b: &SourceBox) -> bool {
        self.selection.classes.keeps(&b.class, &b.dataset_class)
    }

    fn label_types(&self) -> Vec<String> {
        let named = match &self.selection.classes {
            NuScenesClasses::Kitti => return Vec::new(),
            NuScenesClasses::All => self.dataset().category_names(),
            NuScenesClasses::Also(names) => names.clone(),
        };
        // a category that always has a KITTI type is written as that type
        let typed = |c: &String| super::classes::CLASSES.iter().any(|(k, _)| k == c);
        named.into_iter().filter(|c| !typed(c)).collect()
    }

    fn drops_unseen(&self, b: &SourceBox) -> bool {
        !self.selection.keep_unseen && b.sensor_points == Some(0)
    }

    fn parameters(&self) -> Map<String, Value> {
        let s = &self.selection;
        let mut m = Map::new();
        m.insert("input".into(), record_value(&s.input));
        m.insert("version".into(), record_value(&s.version));
        m.insert("scenes".into(), record_value(&s.scenes));
        m.insert("frame_ids".into(), record_value("scene_sample"));
        m.insert("classes".into(), record_value(&s.classes));
        m.insert("keep_unseen".into(), record_value(s.keep_unseen));
        // recorded when not the default, so that default runs keep their manifests
        if s.vehicle_box != VehicleBox::NUSCENES {
            m.insert("vehicle_box".into(), record_value(s.vehicle_box));
        }
        m
    }

    fn parameter_order(&self) -> &'static [&'static str] {
        PARAMETER_ORDER
    }

    fn frame_folder(&self, _item: &RigItem) -> PathBuf {
        self.selection.input.join("samples")
    }

    fn scan_file(&self, item: &RigItem) -> Option<(PathBuf, String)> {
        if !self.selection.lidar {
            return None;
        }
        let d = &self.dataset;
        let sample = d.scenes.get(item.part)?.samples.get(item.index as usize)?;
        let data = d.keyframe(sample, &d.lidar).ok()?;
        let what = format!("sample {sample}'s {} sweep", d.lidar);
        Some((d.dataroot.join(&data.filename), what))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_keep_kitti_types_and_named_categories() {
        let also = NuScenesClasses::Also(vec!["movable_object.barrier".into()]);
        assert!(also.keeps("Car", "vehicle.car"));
        assert!(also.keeps("movable_object.barrier", "movable_object.barrier"));
        assert!(!also.keeps("vehicle.bicycle", "vehicle.bicycle"));
        assert!(NuScenesClasses::Kitti.keeps("Cyclist", "vehicle.bicycle"));
        assert!(!NuScenesClasses::Kitti.keeps("vehicle.bicycle", "vehicle.bicycle"));
        assert!(NuScenesClasses::All.keeps("animal", "animal"));
    }
}
