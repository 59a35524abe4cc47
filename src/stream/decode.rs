//! The peer's answers (JSON headers and raw LiDAR arrays) as world-frame rig types, every field
//! checked: an error names the field (`boxes[3].rotation`) and what is wrong with its value.

use super::source::WorldRig;
use super::world::{box_from_yaw, WorldBox, WorldCamera, WorldFrame};
use crate::camera::description::CameraDescription;
use crate::camera::{CameraModel, ImageSize, Intrinsics, Perspective};
use crate::source::{CameraInfo, LidarPoint, Pose, SourceCamera};
use nalgebra::{Matrix3, Matrix4, Vector3};
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A field's error: the field's name, and what is wrong.
pub type FieldError = (String, String);
type Checked<T> = std::result::Result<T, FieldError>;

/// Largest |RᵀR − I| of a rotation given as numbers (a float32 matrix passes).
const ROTATION_TOLERANCE: f64 = 1e-5;

fn err<T>(field: &str, message: impl Into<String>) -> Checked<T> {
    Err((field.to_owned(), message.into()))
}

fn get<'a>(m: &'a Map<String, Value>, key: &str) -> Option<&'a Value> {
    m.get(key).filter(|v| !v.is_null())
}

fn number(v: &Value, field: &str) -> Checked<f64> {
    match v.as_f64() {
        Some(x) if x.is_finite() => Ok(x),
        _ => err(field, format!("{v} is not a finite number")),
    }
}

fn numbers(v: &Value, field: &str, n: usize) -> Checked<Vec<f64>> {
    match v.as_array() {
        Some(a) if a.len() == n => (a.iter().enumerate())
            .map(|(i, x)| number(x, &format!("{field}[{i}]")))
            .collect(),
        _ => err(field, format!("{} expected {n} numbers", shape_of(v))),
    }
}

/// `[2, 3]` for a 2x3 nested list, `[]` for a scalar: what a wrong value looks like.
fn shape_of(v: &Value) -> String {
    let mut dims = Vec::new();
    let mut at = v;
    while let Some(a) = at.as_array() {
        dims.push(a.len().to_string());
        match a.first() {
            Some(first) => at = first,
            None => break,
        }
    }
    if dims.is_empty() {
        format!("{v}:")
    } else {
        format!("an array of shape ({}):", dims.join(", "))
    }
}

fn matrix(v: &Value, field: &str, n: usize) -> Checked<Vec<f64>> {
    let rows = match v.as_array() {
        Some(a) if a.len() == n && a.iter().all(|r| r.as_array().is_some_and(|r| r.len() == n)) => {
            a
        }
        _ => return err(field, format!("{} expected {n} x {n} numbers", shape_of(v))),
    };
    let mut out = Vec::with_capacity(n * n);
    for (i, row) in rows.iter().enumerate() {
        out.extend(numbers(row, &format!("{field}[{i}]"), n)?);
    }
    Ok(out)
}

fn rotation(values: &[f64], field: &str) -> Checked<Matrix3<f64>> {
    let r = Matrix3::from_row_slice(values);
    let off = (r.transpose() * r - Matrix3::identity()).abs().max();
    if !(off <= ROTATION_TOLERANCE && r.determinant() > 0.0) {
        return err(
            field,
            format!(
                "not a rotation (|RᵀR − I| = {off:.3e}, det = {:.6})",
                r.determinant()
            ),
        );
    }
    Ok(r)
}

fn pose(v: &Value, field: &str) -> Checked<Pose> {
    let m = Matrix4::from_row_slice(&matrix(v, field, 4)?);
    if m.fixed_view::<1, 4>(3, 0)
        .iter()
        .ne([0.0, 0.0, 0.0, 1.0].iter())
    {
        return err(field, "the last row must be [0, 0, 0, 1]");
    }
    let r: Vec<f64> = (0..9).map(|i| m[(i / 3, i % 3)]).collect();
    rotation(&r, field)?;
    Ok(Pose::from_matrix4(&m))
}

fn string(v: Option<&Value>, field: &str) -> Checked<String> {
    match v.and_then(Value::as_str) {
        Some(s) if !s.is_empty() => Ok(s.to_owned()),
        _ => err(field, "a non-empty string expected"),
    }
}

fn object<'a>(v: &'a Value, field: &str) -> Checked<&'a Map<String, Value>> {
    v.as_object()
        .ok_or_else(|| (field.to_owned(), format!("{v} is not an object")))
}

fn list<'a>(m: &'a Map<String, Value>, key: &str) -> Checked<&'a [Value]> {
    match get(m, key) {
        None => Ok(&[]),
        Some(Value::Array(a)) => Ok(a),
        Some(v) => err(key, format!("{v} is not a list")),
    }
}

/// A camera of the wire: `{"model": "pinhole", width, height, fx, fy, cx, cy}` or a camera
/// description (docs/fisheye.md) of a fisheye lens, in the camera's own axes.
pub fn camera(v: &Value, field: &str) -> Checked<(Arc<dyn CameraModel>, CameraInfo)> {
    let m = object(v, field)?;
    if m.contains_key("rotation") {
        return err(
            field,
            "a rig camera is in its own axes (no yaw, pitch or roll): turn it with world_from_camera",
        );
    }
    if get(m, "model").and_then(Value::as_str) == Some("pinhole") {
        let at = |k: &str| -> Checked<f64> {
            number(get(m, k).unwrap_or(&Value::Null), &format!("{field}.{k}"))
        };
        let size = |k: &str| -> Checked<u32> {
            match get(m, k).and_then(Value::as_u64) {
                Some(n) if n > 0 && n <= u32::MAX as u64 => Ok(n as u32),
                _ => err(&format!("{field}.{k}"), "a positive image size expected"),
            }
        };
        let k = Intrinsics::new(at("fx")?, at("fy")?, at("cx")?, at("cy")?);
        if !(k.fu > 0.0 && k.fv > 0.0) {
            return err(field, "fx and fy must be positive");
        }
        let model = Perspective::new(k, ImageSize::new(size("width")?, size("height")?));
        let info = CameraInfo {
            focal: model.k,
            max_theta: None,
        };
        return Ok((Arc::new(model), info));
    }
    let text = v.to_string();
    let desc = CameraDescription::parse(&text, Path::new(field))
        .map_err(|e| (field.to_owned(), e.to_string()))?;
    let lens = desc.camera;
    let info = CameraInfo {
        focal: lens.centre_intrinsics(),
        max_theta: Some(lens.max_theta()),
    };
    Ok((Arc::new(lens), info))
}

/// The open answer: `name`, `root`, `frames`, `not_frames`, `cameras` (name and camera each),
/// `lidar_azimuth_step_deg`.
pub fn rig(m: &Map<String, Value>) -> Checked<WorldRig> {
    let strings = |key: &str| -> Checked<Vec<String>> {
        (list(m, key)?.iter().enumerate())
            .map(|(i, v)| string(Some(v), &format!("{key}[{i}]")))
            .collect()
    };
    let mut cameras = Vec::new();
    for (k, c) in list(m, "cameras")?.iter().enumerate() {
        let field = format!("cameras[{k}]");
        let c = object(c, &field)?;
        let name = string(get(c, "name"), &format!("{field}.name"))?;
        let (model, info) = camera(
            get(c, "camera").unwrap_or(&Value::Null),
            &format!("{field}.camera"),
        )?;
        cameras.push(SourceCamera {
            name,
            info,
            size: model.size(),
        });
    }
    let step = match get(m, "lidar_azimuth_step_deg") {
        None => None,
        Some(v) => Some(number(v, "lidar_azimuth_step_deg")?),
    };
    Ok(WorldRig {
        name: string(get(m, "name"), "name")?,
        root: PathBuf::from(string(get(m, "root"), "root")?),
        frames: strings("frames")?,
        not_frames: strings("not_frames")?,
        cameras,
        lidar_azimuth_step_deg: step,
    })
}

fn world_camera(v: &Value, field: &str) -> Checked<WorldCamera> {
    let c = object(v, field)?;
    let (model, _) = camera(
        get(c, "camera").unwrap_or(&Value::Null),
        &format!("{field}.camera"),
    )?;
    let image = PathBuf::from(string(get(c, "image"), &format!("{field}.image"))?);
    if !image.is_file() {
        return err(
            &format!("{field}.image"),
            format!("{} is not a file", image.display()),
        );
    }
    Ok(WorldCamera {
        name: string(get(c, "name"), &format!("{field}.name"))?,
        model,
        world_from_camera: pose(
            get(c, "world_from_camera").unwrap_or(&Value::Null),
            &format!("{field}.world_from_camera"),
        )?,
        image,
        time: optional_number(get(c, "time"), &format!("{field}.time"))?,
    })
}

/// An optional finite number (absent or null: None).
fn optional_number(v: Option<&Value>, field: &str) -> Checked<Option<f64>> {
    v.map(|v| number(v, field)).transpose()
}

fn count(v: Option<&Value>, field: &str) -> Checked<Option<u64>> {
    match v {
        None => Ok(None),
        Some(v) => match v.as_u64() {
            Some(n) => Ok(Some(n)),
            None => err(field, format!("{v} is not a count (an integer ≥ 0)")),
        },
    }
}

fn world_box(v: &Value, field: &str) -> Checked<WorldBox> {
    let b = object(v, field)?;
    let f = |k: &str| format!("{field}.{k}");
    let at = |k: &str| get(b, k).unwrap_or(&Value::Null);
    let centre = numbers(at("centre"), &f("centre"), 3)?;
    let size = numbers(at("size"), &f("size"), 3)?;
    if size.iter().any(|s| !(*s > 0.0)) {
        return err(
            &f("size"),
            format!("{size:?}: length, width and height must be positive"),
        );
    }
    let world_from_box = match (get(b, "yaw"), get(b, "rotation")) {
        (Some(y), None) => box_from_yaw(number(y, &f("yaw"))?),
        (None, Some(r)) => rotation(&matrix(r, &f("rotation"), 3)?, &f("rotation"))?,
        _ => return err(field, "give either yaw or rotation"),
    };
    let class = string(get(b, "type"), &f("type"))?;
    let label = match get(b, "label") {
        None => class.clone(),
        Some(_) => string(get(b, "label"), &f("label"))?,
    };
    Ok(WorldBox {
        class,
        label,
        centre: Vector3::from_column_slice(&centre),
        size: Vector3::from_column_slice(&size),
        world_from_box,
        points: count(get(b, "points"), &f("points"))?,
        instance: count(get(b, "instance"), &f("instance"))?,
        time: optional_number(get(b, "time"), &f("time"))?,
        velocity: match get(b, "velocity") {
            None => None,
            Some(v) => Some(Vector3::from_column_slice(&numbers(v, &f("velocity"), 3)?)),
        },
    })
}

/// The LiDAR of a read answer: `lidar: {"shape": [N, 3 or 4]}` over the payload (little-endian
/// f64, row-major).
fn lidar(m: &Map<String, Value>, payload: &[u8]) -> Checked<Vec<LidarPoint>> {
    let Some(l) = get(m, "lidar") else {
        return Ok(Vec::new());
    };
    let shape = get(object(l, "lidar")?, "shape").unwrap_or(&Value::Null);
    let dims: Vec<u64> = shape
        .as_array()
        .map(|a| a.iter().filter_map(Value::as_u64).collect())
        .unwrap_or_default();
    let (rows, cols) = match dims[..] {
        [rows, cols @ (3 | 4)] => (rows as usize, cols as usize),
        _ => {
            return err(
                "lidar",
                format!("an array of shape {shape}: N x 3 or N x 4 expected"),
            )
        }
    };
    if payload.len() != rows * cols * 8 {
        return err(
            "lidar",
            format!("{} bytes for {rows} x {cols} numbers", payload.len()),
        );
    }
    let mut points = Vec::with_capacity(rows);
    for (i, row) in payload.chunks_exact(cols * 8).enumerate() {
        let v: Vec<f64> = (0..cols)
            .map(|c| f64::from_le_bytes(row[c * 8..c * 8 + 8].try_into().expect("8 bytes")))
            .collect();
        if v.iter().any(|x| !x.is_finite()) {
            return err(&format!("lidar[{i}]"), format!("{v:?} is not finite"));
        }
        points.push(LidarPoint {
            position: Vector3::new(v[0], v[1], v[2]),
            intensity: v.get(3).map_or(0.0, |x| *x as f32),
        });
    }
    Ok(points)
}

/// A read answer: `cameras`, `boxes`, `lidar` (and the payload), `world_from_lidar`,
/// `record`, `inputs`.
pub fn frame(m: &Map<String, Value>, payload: &[u8]) -> Checked<WorldFrame> {
    let cameras = (list(m, "cameras")?.iter().enumerate())
        .map(|(k, c)| world_camera(c, &format!("cameras[{k}]")))
        .collect::<Checked<Vec<_>>>()?;
    let boxes = (list(m, "boxes")?.iter().enumerate())
        .map(|(k, b)| world_box(b, &format!("boxes[{k}]")))
        .collect::<Checked<Vec<_>>>()?;
    let world_from_lidar = match get(m, "world_from_lidar") {
        None => None,
        Some(v) => Some(pose(v, "world_from_lidar")?),
    };
    let record = match get(m, "record") {
        None => Map::new(),
        Some(v) => object(v, "record")?.clone(),
    };
    let mut inputs = Vec::new();
    for (i, v) in list(m, "inputs")?.iter().enumerate() {
        let path = PathBuf::from(string(Some(v), &format!("inputs[{i}]"))?);
        if !path.is_file() {
            return err(
                &format!("inputs[{i}]"),
                format!("{} is not a file", path.display()),
            );
        }
        inputs.push(path);
    }
    Ok(WorldFrame {
        cameras,
        boxes,
        lidar: lidar(m, payload)?,
        world_from_lidar,
        record,
        inputs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn boxed(velocity: Value) -> Value {
        json!({"type": "Car", "centre": [1, 2, 3], "size": [4, 2, 1.5], "yaw": 0.5,
               "velocity": velocity})
    }

    #[test]
    fn a_boxs_velocity_is_three_finite_numbers_and_may_be_left_out() {
        let b = world_box(&boxed(json!([1.5, -2, 0])), "boxes[3]").unwrap();
        assert_eq!(b.velocity, Some(Vector3::new(1.5, -2.0, 0.0)));
        let b = world_box(&boxed(Value::Null), "boxes[3]").unwrap();
        assert_eq!(b.velocity, None);
        // the Python side sends a non-finite number as its text
        let (field, message) = world_box(&boxed(json!([1, "nan", 0])), "boxes[3]").unwrap_err();
        assert_eq!(field, "boxes[3].velocity[1]", "{message}");
        let (field, message) = world_box(&boxed(json!([1, 2])), "boxes[3]").unwrap_err();
        assert!(
            field == "boxes[3].velocity" && message.contains("3 numbers"),
            "{message}"
        );
    }

    #[test]
    fn a_cameras_time_is_a_finite_number_and_may_be_left_out() {
        assert_eq!(optional_number(None, "cameras[1].time"), Ok(None));
        assert_eq!(
            optional_number(Some(&json!(-0.04)), "cameras[1].time"),
            Ok(Some(-0.04))
        );
        let (field, _) = optional_number(Some(&json!("inf")), "cameras[1].time").unwrap_err();
        assert_eq!(field, "cameras[1].time");
    }
}
