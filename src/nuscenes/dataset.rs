//! [`NuScenes`]: the tables of one version (`DATAROOT/VERSION/*.json`), indexed for a
//! selection of scenes and cameras.
//!
//! Only what the selection needs is kept: the scenes asked for, their samples, the keyframe
//! `sample_data` of the chosen cameras, the reference camera and the LiDAR of those samples,
//! the ego poses these name, the samples' annotations (and their previous and next, for the
//! objects' velocities) and the instances, categories, attributes and visibility levels they
//! name. The large tables (`sample_data`, `ego_pose`,
//! `sample_annotation`, `instance`) are streamed and filtered record by record, so a version of
//! millions of records is indexed in the memory of the selection.

use super::listed::read_listed;
use super::records::stream;
use super::tables::{
    self, key, raw, read_ego_pose, read_instance, read_named, read_visibility, Annotation,
    CalibratedSensor, Sample, SampleData, Scene, Sensor,
};
use super::token::Token;
use super::velocity::Tracks;
use crate::error::{Error, Result};
use crate::source::Pose;
use serde::Deserialize;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// nuScenes' six cameras, clockwise from the front: the order of a rig by default.
pub const NUSCENES_CAMERAS: [&str; 6] = [
    "CAM_FRONT",
    "CAM_FRONT_RIGHT",
    "CAM_BACK_RIGHT",
    "CAM_BACK",
    "CAM_BACK_LEFT",
    "CAM_FRONT_LEFT",
];

/// The camera whose optical centre and heading define the level frame, when the dataset has it.
pub const REFERENCE_CAMERA: &str = "CAM_FRONT";

/// The LiDAR whose keyframe times a sample, when the dataset has it.
pub const REFERENCE_LIDAR: &str = "LIDAR_TOP";

/// Scenes and cameras to read.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Selection {
    /// Scene names; None: every scene, in `scene.json`'s order.
    pub scenes: Option<Vec<String>>,
    /// Camera channels, in the rig's order; None: every camera channel of the dataset
    /// (nuScenes' six clockwise from the front, then the others by name).
    pub cameras: Option<Vec<String>>,
}

/// A selected scene: its name, its position in `scene.json` and its samples in order.
#[derive(Debug, Clone)]
pub struct SceneEntry {
    /// The scene's name.
    pub name: String,
    /// The scene's token.
    pub token: Token,
    /// Its position in `scene.json` (the frame ids' first part).
    pub position: usize,
    /// Its samples, first to last.
    pub samples: Vec<Token>,
}

/// The tables of a version, indexed for a selection.
#[derive(Debug)]
pub struct NuScenes {
    /// The data root (the folder holding `samples/`, `sweeps/` and the version folder).
    pub dataroot: PathBuf,
    /// The version folder's name (`v1.0-mini`).
    pub version: String,
    /// The selected scenes, in `scene.json`'s order.
    pub scenes: Vec<SceneEntry>,
    /// The rig's camera channels.
    pub cameras: Vec<String>,
    /// The channel that defines the level frame.
    pub reference_camera: String,
    /// The LiDAR channel.
    pub lidar: String,
    pub(super) calibrated: HashMap<Token, CalibratedSensor>,
    /// Keyframe readings by (sample, channel).
    pub(super) keyframes: HashMap<(Token, String), SampleData>,
    pub(super) ego_poses: HashMap<Token, Pose>,
    pub(super) annotations: Annotations,
    /// The annotations' neighbours and the samples' times, for velocities.
    pub(super) tracks: Tracks,
    pub(super) instances: HashMap<Token, Token>,
    pub(super) categories: HashMap<Token, String>,
    pub(super) attributes: HashMap<Token, String>,
    pub(super) visibility: HashMap<Token, String>,
}

impl NuScenes {
    /// The path of table `name` (`sample_data`) of the version.
    pub fn table(&self, name: &str) -> PathBuf {
        table_path(&self.dataroot, &self.version, name)
    }

    /// The sample annotations of the selected scenes.
    pub fn annotation_count(&self) -> usize {
        self.annotations.all().count()
    }

    /// The names of category.json's categories, sorted.
    pub fn category_names(&self) -> Vec<String> {
        let mut names: Vec<String> = self.categories.values().cloned().collect();
        names.sort();
        names
    }

    /// Reads the tables of `version` under `dataroot` for `selection`.
    pub fn open(dataroot: &Path, version: &str, selection: &Selection) -> Result<Self> {
        if version.is_empty() || version.contains(['/', '\\']) || version == ".." {
            return Err(Error::Setup(format!(
                "version {version:?} must be a folder name such as v1.0-mini"
            )));
        }
        let dir = dataroot.join(version);
        if !dir.is_dir() {
            return Err(Error::file(&dir, no_version(dataroot)));
        }
        let path = |name: &str| table_path(dataroot, version, name);
        let (sensors, calibrated) = read_sensors(&path("sensor"), &path("calibrated_sensor"))?;
        let channels = Channels::choose(&path("sensor"), &sensors, selection)?;
        let scenes_path = path("scene");
        let samples_path = path("sample");
        let all_scenes: Vec<Scene> = read_records(&scenes_path, Scene::read)?
            .into_iter()
            .map(|(_, scene)| scene)
            .collect();
        let samples: HashMap<Token, Sample> = read_records(&samples_path, Sample::read)?
            .into_iter()
            .collect();
        let scenes = select_scenes(
            &scenes_path,
            &samples_path,
            &all_scenes,
            &samples,
            selection,
        )?;
        let sample_times = samples
            .iter()
            .map(|(t, s)| (t.clone(), s.timestamp))
            .collect();
        drop(samples);
        let wanted: HashSet<Token> = scenes
            .iter()
            .flat_map(|s| s.samples.iter().cloned())
            .collect();
        let keyframes = read_keyframes(
            &path("sample_data"),
            &wanted,
            &channels,
            &calibrated,
            &sensors,
        )?;
        let pose_tokens: HashSet<Token> = keyframes.values().map(|d| d.ego_pose.clone()).collect();
        let ego_poses = read_listed(&path("ego_pose"), &pose_tokens, read_ego_pose)?;
        let annotations = read_annotations(&path("sample_annotation"), &wanted)?;
        let tracks = Tracks::read(&path("sample_annotation"), annotations.all(), sample_times)?;
        let instance_tokens: HashSet<Token> =
            annotations.all().map(|a| a.instance.clone()).collect();
        let instances = read_listed(&path("instance"), &instance_tokens, read_instance)?;
        let named = |name: &str| -> Result<HashMap<Token, String>> {
            let p = path(name);
            Ok(read_records(&p, read_named)?.into_iter().collect())
        };
        let visibility = read_records(&path("visibility"), read_visibility)?
            .into_iter()
            .collect();
        Ok(NuScenes {
            dataroot: dataroot.to_path_buf(),
            version: version.to_owned(),
            scenes,
            cameras: channels.cameras,
            reference_camera: channels.reference,
            lidar: channels.lidar,
            calibrated,
            keyframes,
            ego_poses,
            annotations,
            tracks,
            instances,
            categories: named("category")?,
            attributes: named("attribute")?,
            visibility,
        })
    }
}

/// The folders of `dataroot` that hold a version's tables (a `sample.json`), sorted.
pub fn versions(dataroot: &Path) -> Vec<String> {
    crate::fs::folders_holding(dataroot, "sample.json")
}

/// The error of a missing version folder: the versions `dataroot` holds, or that it holds none.
fn no_version(dataroot: &Path) -> String {
    let versions = versions(dataroot);
    let present = match versions.len() {
        0 => format!("{} holds no version folder", dataroot.display()),
        _ => format!(
            "the versions in {}: {}",
            dataroot.display(),
            versions.join(", ")
        ),
    };
    format!("no such version folder (expected DATAROOT/VERSION/*.json); {present}")
}

/// `DATAROOT/VERSION/NAME.json`.
pub fn table_path(dataroot: &Path, version: &str, name: &str) -> PathBuf {
    dataroot.join(version).join(format!("{name}.json"))
}

type SensorTables = (HashMap<Token, Sensor>, HashMap<Token, CalibratedSensor>);

fn read_sensors(sensor_path: &Path, calibrated_path: &Path) -> Result<SensorTables> {
    let sensors: HashMap<Token, Sensor> = read_records(sensor_path, Sensor::read)?
        .into_iter()
        .collect();
    let mut calibrated = HashMap::new();
    for (token, c) in read_records(calibrated_path, CalibratedSensor::read)? {
        if !sensors.contains_key(&c.sensor) {
            return Err(tables::missing(
                sensor_path,
                "sensor",
                &c.sensor,
                &format!("calibrated_sensor {token}"),
            ));
        }
        calibrated.insert(token, c);
    }
    Ok((sensors, calibrated))
}

/// Every record of a table, each read from its raw form by `read` (in parallel, in the
/// file's order).
fn read_records<R, T>(path: &Path, read: fn(&Path, usize, &R) -> Result<T>) -> Result<Vec<T>>
where
    R: for<'de> Deserialize<'de>,
    T: Send,
{
    let mut all = Vec::new();
    stream(
        path,
        |r| read(path, r.index, &r.parse::<R>()?).map(Some),
        |_, t| {
            all.push(t);
            Ok(())
        },
    )?;
    Ok(all)
}

/// Annotations in the file's order, held in chunks of a fixed size (a large version keeps over
/// a million: a growing `Vec` per sample would leave a third of its room empty), and each
/// sample's positions among them.
#[derive(Debug, Default)]
pub(super) struct Annotations {
    chunks: Vec<Vec<Annotation>>,
    by_sample: HashMap<Token, Vec<u32>>,
}

/// Annotations per chunk of `Annotations`.
const ANNOTATION_CHUNK: usize = 4096;

impl Annotations {
    fn push(&mut self, sample: Token, a: Annotation) -> Result<()> {
        let position = match self.chunks.last() {
            Some(last) => (self.chunks.len() - 1) * ANNOTATION_CHUNK + last.len(),
            None => 0,
        };
        let Ok(position32) = u32::try_from(position) else {
            return Err(Error::Setup(format!(
                "more than {} annotations selected",
                u32::MAX
            )));
        };
        if position % ANNOTATION_CHUNK == 0 {
            self.chunks.push(Vec::with_capacity(ANNOTATION_CHUNK));
        }
        self.chunks.last_mut().expect("a chunk").push(a);
        self.by_sample.entry(sample).or_default().push(position32);
        Ok(())
    }

    /// The annotations of `sample`, in the file's order.
    pub(super) fn of<'a>(&'a self, sample: &Token) -> impl Iterator<Item = &'a Annotation> + 'a {
        let positions = self.by_sample.get(sample).map_or(&[][..], Vec::as_slice);
        positions.iter().map(|&p| {
            let p = p as usize;
            &self.chunks[p / ANNOTATION_CHUNK][p % ANNOTATION_CHUNK]
        })
    }

    /// Every annotation kept.
    fn all(&self) -> impl Iterator<Item = &Annotation> {
        self.chunks.iter().flatten()
    }
}

/// The annotations of the `wanted` samples.
fn read_annotations(path: &Path, wanted: &HashSet<Token>) -> Result<Annotations> {
    let mut out = Annotations::default();
    stream(
        path,
        |r| {
            let k = r.parse::<key::Annotation>()?;
            if !Annotation::sample_of(&k).is_some_and(|s| wanted.contains(&s)) {
                return Ok(None);
            }
            Annotation::read(path, r.index, &r.parse::<raw::Annotation>()?).map(Some)
        },
        |_, (sample, a)| out.push(sample, a),
    )?;
    Ok(out)
}

/// The channels a selection reads.
struct Channels {
    cameras: Vec<String>,
    reference: String,
    lidar: String,
}

impl Channels {
    fn choose(
        sensor_path: &Path,
        sensors: &HashMap<Token, Sensor>,
        selection: &Selection,
    ) -> Result<Self> {
        let of = |modality: &str| -> Vec<String> {
            let mut v: Vec<String> = sensors
                .values()
                .filter(|s| s.modality == modality)
                .map(|s| s.channel.clone())
                .collect();
            v.sort_by_key(|c| {
                (
                    NUSCENES_CAMERAS
                        .iter()
                        .position(|n| n == c)
                        .unwrap_or(usize::MAX),
                    c.clone(),
                )
            });
            v.dedup();
            v
        };
        let all_cameras = of("camera");
        let lidars = of("lidar");
        let Some(first_camera) = all_cameras.first() else {
            return Err(Error::file(sensor_path, "no sensor of modality \"camera\""));
        };
        let lidar = match lidars
            .iter()
            .find(|c| *c == REFERENCE_LIDAR)
            .or(lidars.first())
        {
            Some(l) => l.clone(),
            None => {
                return Err(Error::file(
                    sensor_path,
                    "no sensor of modality \"lidar\": a sample's time is its LiDAR keyframe's",
                ))
            }
        };
        let cameras = match &selection.cameras {
            None => all_cameras.clone(),
            Some(names) => {
                let mut seen = HashSet::new();
                for n in names {
                    if !all_cameras.contains(n) {
                        return Err(Error::Setup(format!(
                            "camera {n} is not a camera channel of {} (it has {})",
                            sensor_path.display(),
                            all_cameras.join(", ")
                        )));
                    }
                    if !seen.insert(n) {
                        return Err(Error::Setup(format!("camera {n} is named twice")));
                    }
                }
                if names.is_empty() {
                    return Err(Error::Setup("no camera chosen".into()));
                }
                names.clone()
            }
        };
        let reference = if all_cameras.iter().any(|c| c == REFERENCE_CAMERA) {
            REFERENCE_CAMERA.to_owned()
        } else {
            first_camera.clone()
        };
        Ok(Channels {
            cameras,
            reference,
            lidar,
        })
    }

    fn wanted(&self, channel: &str) -> bool {
        channel == self.lidar
            || channel == self.reference
            || self.cameras.iter().any(|c| c == channel)
    }
}

fn select_scenes(
    scenes_path: &Path,
    samples_path: &Path,
    all: &[Scene],
    samples: &HashMap<Token, Sample>,
    selection: &Selection,
) -> Result<Vec<SceneEntry>> {
    if let Some(names) = &selection.scenes {
        for n in names {
            if !all.iter().any(|s| &s.name == n) {
                return Err(Error::Setup(format!(
                    "scene {n} is not in {}",
                    scenes_path.display()
                )));
            }
        }
    }
    let mut out = Vec::new();
    for (position, scene) in all.iter().enumerate() {
        if selection
            .scenes
            .as_ref()
            .is_some_and(|n| !n.contains(&scene.name))
        {
            continue;
        }
        let mut chain = Vec::new();
        let mut next = Some(scene.first_sample.clone());
        while let Some(token) = next {
            let Some(sample) = samples.get(&token) else {
                return Err(tables::missing(
                    samples_path,
                    "sample",
                    &token,
                    &format!("scene {}'s chain", scene.name),
                ));
            };
            if sample.scene != scene.token {
                return Err(Error::file(
                    samples_path,
                    format!(
                        "record {token}: scene_token: {} is not scene {} whose chain holds it",
                        sample.scene, scene.name
                    ),
                ));
            }
            if chain.len() >= samples.len() {
                return Err(Error::file(
                    samples_path,
                    format!(
                        "record {token}: next: the samples of scene {} form a loop",
                        scene.name
                    ),
                ));
            }
            chain.push(token);
            next = sample.next.clone();
        }
        out.push(SceneEntry {
            name: scene.name.clone(),
            token: scene.token.clone(),
            position,
            samples: chain,
        });
    }
    Ok(out)
}

fn read_keyframes(
    path: &Path,
    wanted: &HashSet<Token>,
    channels: &Channels,
    calibrated: &HashMap<Token, CalibratedSensor>,
    sensors: &HashMap<Token, Sensor>,
) -> Result<HashMap<(Token, String), SampleData>> {
    let mut out: HashMap<(Token, String), SampleData> = HashMap::new();
    stream(
        path,
        |r| {
            if !SampleData::is_wanted(&r.parse::<key::SampleData>()?, |s| wanted.contains(s)) {
                return Ok(None);
            }
            let d = SampleData::read(path, r.index, &r.parse::<raw::SampleData>()?)?;
            let Some(c) = calibrated.get(&d.calibrated_sensor) else {
                return Err(Error::file(
                    path,
                    format!(
                        "record {}: calibrated_sensor_token: no calibrated_sensor {}",
                        d.token, d.calibrated_sensor
                    ),
                ));
            };
            let channel = &sensors[&c.sensor].channel;
            Ok(channels.wanted(channel).then(|| (d, channel.clone())))
        },
        |_, (d, channel)| {
            let key = (d.sample.clone(), channel);
            if let Some(other) = out.get(&key) {
                return Err(Error::file(
                    path,
                    format!(
                        "record {}: sample {} has two {} keyframes ({} and this one)",
                        d.token, d.sample, key.1, other.token
                    ),
                ));
            }
            out.insert(key, d);
            Ok(())
        },
    )?;
    Ok(out)
}
