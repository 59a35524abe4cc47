//! The tables of the synthetic scene, as the official ones are written: every record with
//! the fields the devkit reads, tokens 32 hex digits (a hash of what the record is).

use super::calibration::{Mounting, LIDAR};
use super::{lidar_time, sample_file, seconds, world_from_ego, Rig, LOG, SCENE};
use crate::tools::synth360::scene::{objects, world_transform, Object, FIRST_FRAME};
use nalgebra::{Matrix3, Matrix4, UnitQuaternion, Vector3};
use serde_json::{json, Value};

/// The token of `what`: 32 hex digits of its hash.
pub fn token(what: &str) -> String {
    blake3::hash(what.as_bytes()).to_hex()[..32].to_owned()
}

/// A nuScenes category, its attributes and its visibility level's token for a synthetic object.
fn category(o: &Object) -> (&'static str, &'static [&'static str], &'static str) {
    match (o.label, o.is_dynamic()) {
        ("car", true) => ("vehicle.car", &["vehicle.moving"], "4"),
        ("car", false) => ("vehicle.car", &["vehicle.parked"], "4"),
        ("caravan", _) => ("vehicle.trailer", &["vehicle.parked"], "3"),
        ("pedestrian", _) => ("human.pedestrian.adult", &["pedestrian.standing"], "2"),
        ("bicycle", _) => ("vehicle.bicycle", &["cycle.with_rider"], "3"),
        ("truck", _) => ("vehicle.truck", &["vehicle.parked"], "1"),
        _ => ("movable_object.barrier", &[], "4"),
    }
}

const CATEGORIES: [&str; 7] = [
    "vehicle.car",
    "vehicle.trailer",
    "human.pedestrian.adult",
    "vehicle.bicycle",
    "vehicle.truck",
    "movable_object.barrier",
    "human.pedestrian.child",
];
const ATTRIBUTES: [&str; 5] = [
    "vehicle.moving",
    "vehicle.parked",
    "pedestrian.standing",
    "cycle.with_rider",
    "cycle.without_rider",
];
const VISIBILITY: [(&str, &str); 4] = [
    ("1", "v0-40"),
    ("2", "v40-60"),
    ("3", "v60-80"),
    ("4", "v80-100"),
];

/// A child annotated 95 m ahead of the start, beyond the LiDAR's range and in no image: an
/// annotation with no LiDAR and no radar point, which a conversion leaves out by default.
const UNSEEN: ([f64; 3], [f64; 3]) = ([1043.25, 3911.5, 114.75], [0.5, 0.6, 1.3]);

fn pose_record(m: &Matrix4<f64>) -> (Value, Value) {
    let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
    let q = UnitQuaternion::from_matrix(&r);
    let t = m.fixed_view::<3, 1>(0, 3);
    (json!([t[0], t[1], t[2]]), json!([q.w, q.i, q.j, q.k]))
}

fn link(tokens: &[String], i: usize, step: isize) -> String {
    let j = i as isize + step;
    if j < 0 || j as usize >= tokens.len() {
        String::new()
    } else {
        tokens[j as usize].clone()
    }
}

fn calibrated(m: &Mounting, intrinsic: Value) -> Value {
    json!({
        "token": token(&format!("calibrated_sensor {}", m.channel)),
        "sensor_token": token(&format!("sensor {}", m.channel)),
        "translation": m.translation,
        "rotation": m.rotation,
        "camera_intrinsic": intrinsic,
    })
}

/// The sample_data and ego_pose records: one of each per sensor reading, the LiDAR's first.
fn readings(rig: &Rig, samples: u32, sample_tokens: &[String]) -> (Vec<Value>, Vec<Value>) {
    let mut sample_data = Vec::new();
    let mut ego_poses = Vec::new();
    let mut channels: Vec<(&str, [u32; 2], Vec<u64>)> = vec![(
        LIDAR.channel,
        [0, 0],
        (0..samples).map(lidar_time).collect(),
    )];
    for (k, c) in rig.cameras.iter().enumerate() {
        channels.push((
            c.mounting.channel,
            rig.size,
            (0..samples).map(|s| rig.camera_time(k, s)).collect(),
        ));
    }
    for (channel, size, times) in &channels {
        let tokens: Vec<String> = times
            .iter()
            .map(|t| token(&format!("sample_data {channel} {t}")))
            .collect();
        for (s, &time) in times.iter().enumerate() {
            let pose = token(&format!("ego_pose {channel} {time}"));
            let (translation, rotation) = pose_record(&world_from_ego(seconds(time)));
            ego_poses.push(json!({"token": pose, "timestamp": time, "rotation": rotation, "translation": translation}));
            let camera = channel.starts_with("CAM_");
            sample_data.push(json!({
                "token": tokens[s], "sample_token": sample_tokens[s], "ego_pose_token": pose,
                "calibrated_sensor_token": token(&format!("calibrated_sensor {channel}")),
                "timestamp": time, "fileformat": if camera { "png" } else { "pcd" }, "is_key_frame": true,
                "height": size[1], "width": size[0], "filename": sample_file(channel, time),
                "prev": link(&tokens, s, -1), "next": link(&tokens, s, 1),
            }));
        }
    }
    (sample_data, ego_poses)
}

/// Every table as (name, JSON text). `sweeps` holds each sample's world_from_lidar and points.
pub fn tables(rig: &Rig, samples: u32, sweeps: Points) -> Vec<(&'static str, String)> {
    let log = token("log");
    let scene = token("scene");
    let sample_tokens: Vec<String> = (0..samples)
        .map(|s| token(&format!("sample {s}")))
        .collect();
    let mut sensors = vec![
        json!({"token": token("sensor LIDAR_TOP"), "channel": "LIDAR_TOP", "modality": "lidar"}),
    ];
    let mut calibrated_sensors = vec![calibrated(&LIDAR, json!([]))];
    for c in &rig.cameras {
        let ch = c.mounting.channel;
        sensors.push(
            json!({"token": token(&format!("sensor {ch}")), "channel": ch, "modality": "camera"}),
        );
        let [fx, fy, cx, cy] = c.intrinsics;
        calibrated_sensors.push(calibrated(
            &c.mounting,
            json!([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]]),
        ));
    }
    let sample_records: Vec<Value> = (0..samples as usize)
        .map(|s| {
            json!({"token": sample_tokens[s], "timestamp": lidar_time(s as u32), "prev": link(&sample_tokens, s, -1),
                   "next": link(&sample_tokens, s, 1), "scene_token": scene})
        })
        .collect();
    let (sample_data, ego_poses) = readings(rig, samples, &sample_tokens);
    let (annotations, instances) = annotations(samples, &sample_tokens, sweeps);
    let named = |kind: &str, names: &[&str]| -> Vec<Value> {
        names
            .iter()
            .map(|n| json!({"token": token(&format!("{kind} {n}")), "name": n, "description": ""}))
            .collect()
    };
    let visibility: Vec<Value> = VISIBILITY
        .iter()
        .map(|(t, level)| json!({"description": "", "token": t, "level": level}))
        .collect();
    let first = sample_tokens.first().cloned().unwrap_or_default();
    let last = sample_tokens.last().cloned().unwrap_or_default();
    let all: Vec<(&'static str, Value)> = vec![
        (
            "log",
            json!([{"token": log, "logfile": LOG, "vehicle": "n000", "date_captured": "2026-01-01", "location": "singapore-onenorth"}]),
        ),
        (
            "map",
            json!([{"category": "semantic_prior", "token": token("map"), "filename": "", "log_tokens": [log]}]),
        ),
        (
            "scene",
            json!([{"token": scene, "log_token": log, "nbr_samples": samples, "first_sample_token": first,
                          "last_sample_token": last, "name": SCENE, "description": "synthetic, rendered exactly"}]),
        ),
        ("sample", Value::Array(sample_records)),
        ("sensor", Value::Array(sensors)),
        ("calibrated_sensor", Value::Array(calibrated_sensors)),
        ("sample_data", Value::Array(sample_data)),
        ("ego_pose", Value::Array(ego_poses)),
        ("sample_annotation", Value::Array(annotations)),
        ("instance", Value::Array(instances)),
        ("category", Value::Array(named("category", &CATEGORIES))),
        ("attribute", Value::Array(named("attribute", &ATTRIBUTES))),
        ("visibility", Value::Array(visibility)),
    ];
    all.into_iter()
        .map(|(n, v)| (n, serde_json::to_string_pretty(&v).expect("JSON") + "\n"))
        .collect()
}

/// One annotation: world centre, size [w, l, h], world_from_box rotation.
struct Annotated {
    instance: String,
    category: &'static str,
    attributes: &'static [&'static str],
    visibility: &'static str,
    centre: Vector3<f64>,
    size: [f64; 3],
    rotation: Matrix3<f64>,
}

fn annotated_objects(sample: u32) -> Vec<Annotated> {
    let mut out: Vec<Annotated> = objects()
        .iter()
        .filter_map(|o| {
            let b = o.at(FIRST_FRAME + sample)?;
            let m = world_transform(&b);
            let [h, w, l] = b.dimensions;
            let scaled: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
            let (category, attributes, visibility) = category(o);
            Some(Annotated {
                instance: token(&format!("instance {} {}", o.label, o.instance_id)),
                category,
                attributes,
                visibility,
                centre: m.fixed_view::<3, 1>(0, 3).into_owned(),
                size: [w, l, h],
                rotation: scaled * Matrix3::from_diagonal(&Vector3::new(1.0 / l, 1.0 / w, 1.0 / h)),
            })
        })
        .collect();
    out.push(Annotated {
        instance: token("instance unseen child"),
        category: "human.pedestrian.child",
        attributes: &["pedestrian.standing"],
        visibility: "1",
        centre: Vector3::from(UNSEEN.0),
        size: UNSEEN.1,
        rotation: Matrix3::identity(),
    });
    out
}

type Points<'a> = &'a [(Matrix4<f64>, Vec<(Vector3<f64>, f32, u8)>)];

fn annotations(samples: u32, sample_tokens: &[String], sweeps: Points) -> (Vec<Value>, Vec<Value>) {
    let mut records = Vec::new();
    let mut by_instance: Vec<(String, &'static str, Vec<String>)> = Vec::new();
    for s in 0..samples {
        let (world_from_lidar, points) = &sweeps[s as usize];
        for a in annotated_objects(s) {
            let inside = points
                .iter()
                .filter(|(p, _, _)| {
                    let w = (world_from_lidar * p.push(1.0)).xyz();
                    let local = a.rotation.transpose() * (w - a.centre);
                    let half = [a.size[1] / 2.0, a.size[0] / 2.0, a.size[2] / 2.0];
                    (0..3).all(|i| local[i].abs() <= half[i])
                })
                .count();
            let t = token(&format!("sample_annotation {} {s}", a.instance));
            match by_instance.iter_mut().find(|(i, _, _)| *i == a.instance) {
                Some((_, _, list)) => list.push(t.clone()),
                None => by_instance.push((a.instance.clone(), a.category, vec![t.clone()])),
            }
            let q = UnitQuaternion::from_matrix(&a.rotation);
            records.push(json!({
                "token": t, "sample_token": sample_tokens[s as usize], "instance_token": a.instance,
                "visibility_token": a.visibility,
                "attribute_tokens": a.attributes.iter().map(|n| token(&format!("attribute {n}"))).collect::<Vec<_>>(),
                "translation": [a.centre.x, a.centre.y, a.centre.z], "size": a.size,
                "rotation": [q.w, q.i, q.j, q.k], "prev": "", "next": "",
                "num_lidar_pts": inside, "num_radar_pts": 0,
            }));
        }
    }
    // prev/next chains per instance
    for (_, _, list) in &by_instance {
        for (i, t) in list.iter().enumerate() {
            if let Some(r) = records.iter_mut().find(|r| r["token"] == *t) {
                r["prev"] = json!(link(list, i, -1));
                r["next"] = json!(link(list, i, 1));
            }
        }
    }
    let instances = by_instance
        .iter()
        .map(|(t, category, list)| {
            json!({"token": t, "category_token": token(&format!("category {category}")), "nbr_annotations": list.len(),
                   "first_annotation_token": list[0], "last_annotation_token": list[list.len() - 1]})
        })
        .collect();
    (records, instances)
}
