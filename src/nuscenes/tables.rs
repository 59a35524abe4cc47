//! The records of the nuScenes tables that a conversion reads, each checked from its raw form
//! (`raw::*`: every field a `serde_json::Value`, unknown fields ignored) with errors that name
//! the table file, the record's token and the field.
//!
//! Conventions of the format: translations are metres, rotations quaternions `[w, x, y, z]`,
//! `calibrated_sensor` is ego_from_sensor, `ego_pose` is global_from_ego, a box's `size` is
//! `[width, length, height]` and its rotation global_from_box (x along its length, y its width,
//! z up); timestamps are microseconds.

use super::json::Fields;
use super::records::Loose;
use super::token::Token;
use crate::error::{Error, Result};
use crate::source::Pose;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use std::path::Path;

/// The raw records: each field as written, absent fields `None`.
pub mod raw {
    use serde::Deserialize;
    use serde_json::Value;

    macro_rules! raw_record {
        ($(#[$doc:meta])* $name:ident { $($field:ident),* $(,)? }) => {
            $(#[$doc])*
            #[derive(Debug, Deserialize)]
            #[allow(missing_docs)]
            pub struct $name {
                $(#[serde(default)] pub $field: Option<Value>,)*
            }
        };
    }

    raw_record!(/// `scene.json`
        Scene { token, name, first_sample_token });
    raw_record!(/// `sample.json`
        Sample { token, scene_token, timestamp, next });
    raw_record!(/// `sensor.json`
        Sensor { token, channel, modality });
    raw_record!(/// `calibrated_sensor.json`
        CalibratedSensor { token, sensor_token, translation, rotation, camera_intrinsic });
    raw_record!(/// `sample_data.json`
        SampleData { token, sample_token, ego_pose_token, calibrated_sensor_token, timestamp,
            is_key_frame, filename, width, height });
    raw_record!(/// `ego_pose.json`
        EgoPose { token, translation, rotation, timestamp });
    raw_record!(/// `sample_annotation.json`
        Annotation { token, sample_token, instance_token, visibility_token, attribute_tokens,
            translation, size, rotation, num_lidar_pts, num_radar_pts, prev, next });
    raw_record!(/// `instance.json`
        Instance { token, category_token });
    raw_record!(/// `category.json`, `attribute.json`
        Named { token, name });
    raw_record!(/// `visibility.json`
        Visibility { token, level });
}

/// The fields the filters of the large tables read, borrowed from a record's text (the
/// others skipped unread).
pub mod key {
    use super::super::records::Loose;
    use serde::Deserialize;

    /// A record's token.
    #[derive(Debug, Deserialize)]
    pub struct Listed<'a> {
        /// `token`.
        #[serde(borrow, default)]
        pub token: Option<Loose<'a>>,
    }

    /// `sample_data.json`'s filter: the sample and whether the reading is its keyframe.
    #[derive(Debug, Deserialize)]
    pub struct SampleData<'a> {
        /// `sample_token`.
        #[serde(borrow, default)]
        pub sample_token: Option<Loose<'a>>,
        /// `is_key_frame`.
        #[serde(borrow, default)]
        pub is_key_frame: Option<Loose<'a>>,
    }

    /// `sample_annotation.json`'s filter: the sample.
    #[derive(Debug, Deserialize)]
    pub struct Annotation<'a> {
        /// `sample_token`.
        #[serde(borrow, default)]
        pub sample_token: Option<Loose<'a>>,
    }
}

/// A scene: a named drive of about 20 s.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Its token.
    pub token: Token,
    /// Its name (`scene-0061`).
    pub name: String,
    /// Its first keyframe.
    pub first_sample: Token,
}

/// A sample: a keyframe (about 2 Hz) of a scene.
#[derive(Debug, Clone)]
pub struct Sample {
    /// Its scene.
    pub scene: Token,
    /// The next sample of the scene.
    pub next: Option<Token>,
    /// Microseconds (its LiDAR keyframe's time).
    pub timestamp: u64,
}

/// A sensor: a channel (`CAM_FRONT`, `LIDAR_TOP`) and its modality.
#[derive(Debug, Clone)]
pub struct Sensor {
    /// The channel's name.
    pub channel: String,
    /// `camera`, `lidar` or `radar`.
    pub modality: String,
}

/// A sensor's calibration: ego_from_sensor, and a camera's pinhole matrix.
#[derive(Debug, Clone)]
pub struct CalibratedSensor {
    /// The sensor.
    pub sensor: Token,
    /// ego_from_sensor.
    pub ego_from_sensor: Pose,
    /// The 3x3 intrinsic matrix of a camera (None for other sensors).
    pub camera_intrinsic: Option<[[f64; 3]; 3]>,
}

/// One sensor reading.
#[derive(Debug, Clone)]
pub struct SampleData {
    /// Its token.
    pub token: Token,
    /// The sample it belongs to.
    pub sample: Token,
    /// The ego's pose at its time.
    pub ego_pose: Token,
    /// The sensor's calibration.
    pub calibrated_sensor: Token,
    /// Microseconds.
    pub timestamp: u64,
    /// The file, relative to the data root.
    pub filename: String,
    /// The image's width and height (0 for other sensors).
    pub size: [u32; 2],
}

/// A box annotation of a sample, in the global frame.
#[derive(Debug, Clone)]
pub struct Annotation {
    /// Its token.
    pub token: Token,
    /// The object.
    pub instance: Token,
    /// The visibility level's token (None when not given).
    pub visibility: Option<Token>,
    /// The attributes' tokens.
    pub attributes: Vec<Token>,
    /// global_from_box (box axes: x along its length, y its width, z up).
    pub global_from_box: Pose,
    /// width, length, height, metres.
    pub size: [f64; 3],
    /// LiDAR points inside the box.
    pub lidar_points: u64,
    /// Radar points inside the box.
    pub radar_points: u64,
    /// The same object's annotation in an earlier sample (None: its first).
    pub prev: Option<Token>,
    /// The same object's annotation in a later sample (None: its last).
    pub next: Option<Token>,
}

/// A pose of the format: `translation` and the quaternion `rotation` ([w, x, y, z], normalised
/// as the devkit's pyquaternion does).
pub fn pose(
    fields: &Fields,
    translation: &Option<serde_json::Value>,
    rotation: &Option<serde_json::Value>,
) -> Result<Pose> {
    let t = fields.numbers::<3>("translation", translation)?;
    let [w, x, y, z] = fields.numbers::<4>("rotation", rotation)?;
    let q = Quaternion::new(w, x, y, z);
    if !(q.norm() > 1e-6) {
        return Err(fields.error("rotation", "not a rotation (a quaternion of norm 0)"));
    }
    let r = UnitQuaternion::from_quaternion(q)
        .to_rotation_matrix()
        .into_inner();
    Ok(Pose::new(r, Vector3::from(t)))
}

impl Scene {
    /// Checks a raw record.
    pub fn read(path: &Path, index: usize, r: &raw::Scene) -> Result<(Token, Self)> {
        let (f, token) = Fields::new(path, index, &r.token)?;
        Ok((
            token.clone(),
            Scene {
                token,
                name: f.string("name", &r.name)?,
                first_sample: f.token("first_sample_token", &r.first_sample_token)?,
            },
        ))
    }
}

impl Sample {
    /// Checks a raw record.
    pub fn read(path: &Path, index: usize, r: &raw::Sample) -> Result<(Token, Self)> {
        let (f, token) = Fields::new(path, index, &r.token)?;
        Ok((
            token,
            Sample {
                scene: f.token("scene_token", &r.scene_token)?,
                next: f.link("next", &r.next)?,
                timestamp: f.integer("timestamp", &r.timestamp)?,
            },
        ))
    }
}

impl Sensor {
    /// Checks a raw record.
    pub fn read(path: &Path, index: usize, r: &raw::Sensor) -> Result<(Token, Self)> {
        let (f, token) = Fields::new(path, index, &r.token)?;
        Ok((
            token,
            Sensor {
                channel: f.string("channel", &r.channel)?,
                modality: f.string("modality", &r.modality)?,
            },
        ))
    }
}

impl CalibratedSensor {
    /// Checks a raw record.
    pub fn read(path: &Path, index: usize, r: &raw::CalibratedSensor) -> Result<(Token, Self)> {
        let (f, token) = Fields::new(path, index, &r.token)?;
        Ok((
            token,
            CalibratedSensor {
                sensor: f.token("sensor_token", &r.sensor_token)?,
                ego_from_sensor: pose(&f, &r.translation, &r.rotation)?,
                camera_intrinsic: f.matrix3("camera_intrinsic", &r.camera_intrinsic)?,
            },
        ))
    }
}

impl SampleData {
    /// Whether a raw record is a keyframe of a sample that `wanted` accepts (checked
    /// loosely: a record that is not is skipped unread).
    pub fn is_wanted(k: &key::SampleData, wanted: impl Fn(&Token) -> bool) -> bool {
        let key_frame = matches!(k.is_key_frame, Some(Loose::Bool(true)));
        let sample = k.sample_token.as_ref().and_then(Loose::token);
        key_frame && sample.is_some_and(|s| wanted(&s))
    }

    /// Checks a raw record.
    pub fn read(path: &Path, index: usize, r: &raw::SampleData) -> Result<Self> {
        let (f, token) = Fields::new(path, index, &r.token)?;
        f.boolean("is_key_frame", &r.is_key_frame)?;
        let dimension = |field: &str, v: &Option<serde_json::Value>| -> Result<u32> {
            match v {
                None | Some(serde_json::Value::Null) => Ok(0),
                _ => u32::try_from(f.integer(field, v)?).map_err(|_| f.error(field, "too large")),
            }
        };
        Ok(SampleData {
            token,
            sample: f.token("sample_token", &r.sample_token)?,
            ego_pose: f.token("ego_pose_token", &r.ego_pose_token)?,
            calibrated_sensor: f.token("calibrated_sensor_token", &r.calibrated_sensor_token)?,
            timestamp: f.integer("timestamp", &r.timestamp)?,
            filename: f.string("filename", &r.filename)?,
            size: [
                dimension("width", &r.width)?,
                dimension("height", &r.height)?,
            ],
        })
    }
}

/// Checks a raw ego pose: its token and global_from_ego.
pub fn read_ego_pose(path: &Path, index: usize, r: &raw::EgoPose) -> Result<(Token, Pose)> {
    let (f, token) = Fields::new(path, index, &r.token)?;
    f.integer("timestamp", &r.timestamp)?;
    Ok((token, pose(&f, &r.translation, &r.rotation)?))
}

impl Annotation {
    /// The sample of a raw record, read loosely for the filter.
    pub fn sample_of(k: &key::Annotation) -> Option<Token> {
        k.sample_token.as_ref().and_then(Loose::token)
    }

    /// Checks a raw record.
    pub fn read(path: &Path, index: usize, r: &raw::Annotation) -> Result<(Token, Self)> {
        let (f, token) = Fields::new(path, index, &r.token)?;
        let sample = f.token("sample_token", &r.sample_token)?;
        let size = f.numbers::<3>("size", &r.size)?;
        if let Some(i) = size.iter().position(|s| !(*s > 0.0)) {
            return Err(f.error(
                &format!("size[{i}]"),
                format!("{} is not a positive size", size[i]),
            ));
        }
        Ok((
            sample,
            Annotation {
                token,
                instance: f.token("instance_token", &r.instance_token)?,
                visibility: f.link("visibility_token", &r.visibility_token)?,
                attributes: f.tokens("attribute_tokens", &r.attribute_tokens)?,
                global_from_box: pose(&f, &r.translation, &r.rotation)?,
                size,
                lidar_points: f.integer("num_lidar_pts", &r.num_lidar_pts)?,
                radar_points: f.integer("num_radar_pts", &r.num_radar_pts)?,
                prev: f.link("prev", &r.prev)?,
                next: f.link("next", &r.next)?,
            },
        ))
    }
}

/// Checks a raw instance: its token and its category's.
pub fn read_instance(path: &Path, index: usize, r: &raw::Instance) -> Result<(Token, Token)> {
    let (f, token) = Fields::new(path, index, &r.token)?;
    Ok((token, f.token("category_token", &r.category_token)?))
}

/// Checks a raw category or attribute: its token and name.
pub fn read_named(path: &Path, index: usize, r: &raw::Named) -> Result<(Token, String)> {
    let (f, token) = Fields::new(path, index, &r.token)?;
    Ok((token, f.string("name", &r.name)?))
}

/// Checks a raw visibility: its token and level (`v0-40` .. `v80-100`).
pub fn read_visibility(path: &Path, index: usize, r: &raw::Visibility) -> Result<(Token, String)> {
    let (f, token) = Fields::new(path, index, &r.token)?;
    Ok((token, f.string("level", &r.level)?))
}

/// An error about a record of `path` that another record names but the table lacks.
pub fn missing(path: &Path, what: &str, token: &Token, named_by: &str) -> Error {
    Error::file(path, format!("no {what} {token} (named by {named_by})"))
}
