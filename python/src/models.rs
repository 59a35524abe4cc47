//! The constructors of `Camera` by model: the linear projections from K (turned by
//! yaw/pitch/roll when asked), every lens model through the camera description parser, so that
//! a camera built here is, bit for bit, the camera the command reads from a description file
//! with the same values (`--to fisheye --camera FILE`); and `read_camera`.

use crate::camera_core::Camera;
use crate::errors::{usage, IntoPy};
use crate::turned::Turned;
use nalgebra::{Matrix3, Vector3};
use panoconv::camera::description::CameraDescription;
use panoconv::camera::{
    rotation_ypr, FisheyeCamera, ImageSize, Intrinsics, OutputCamera, Projection,
};
use pyo3::prelude::*;
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};

/// Yaw, pitch and roll in degrees (docs/fisheye.md's convention).
pub type Angles = (f64, f64, f64);

/// A camera's optical centre in rect: the one given, or the origin.
pub fn centre_of(centre: Option<Vector3<f64>>) -> Vector3<f64> {
    centre.unwrap_or_else(Vector3::zeros)
}

/// A linear projection with intrinsics (fx, fy, cx, cy) and an image `size`, turned by
/// `angles` (none: rect's axes, the command's output cameras).
pub fn linear(
    projection: Projection,
    size: (u32, u32),
    k: (f64, f64, f64, f64),
    angles: Angles,
    centre: Option<Vector3<f64>>,
) -> PyResult<Camera> {
    let (fx, fy, cx, cy) = k;
    if size.0 == 0 || size.1 == 0 {
        return Err(usage(format!(
            "image size {}x{} must be positive",
            size.0, size.1
        )));
    }
    if !([fx, fy, cx, cy].iter().all(|v| v.is_finite()) && fx > 0.0 && fy > 0.0) {
        return Err(usage(format!(
            "intrinsics must be finite with positive focal lengths, not fx={fx} fy={fy} cx={cx} cy={cy}"
        )));
    }
    let camera = projection
        .camera(
            Intrinsics::new(fx, fy, cx, cy),
            ImageSize::new(size.0, size.1),
        )
        .boxed_output();
    let centre = centre_of(centre);
    let (yaw, pitch, roll) = angles;
    if [yaw, pitch, roll].iter().any(|a| !a.is_finite()) {
        return Err(usage("yaw_deg, pitch_deg and roll_deg must be finite"));
    }
    if (yaw, pitch, roll) == (0.0, 0.0, 0.0) {
        return Ok(Camera::new(camera, centre));
    }
    let turn = rotation_ypr(yaw.to_radians(), pitch.to_radians(), roll.to_radians());
    Ok(Camera::turned(
        Box::new(Turned {
            inner: camera,
            rect_from_camera: turn,
        }),
        centre,
        turn,
    ))
}

/// A lens of `model` as the camera description with these values describes it: `fields` are
/// the model's own (`k`, `xi`, `alpha`, `beta`, `p`, `skew`).
#[allow(clippy::too_many_arguments)]
pub fn lens(
    model: &str,
    size: (u32, u32),
    k: (f64, f64, f64, f64),
    fields: Map<String, Value>,
    max_fov_deg: f64,
    angles: Angles,
    centre: Option<Vector3<f64>>,
) -> PyResult<Camera> {
    let (fx, fy, cx, cy) = k;
    let mut d = Map::new();
    d.insert("version".into(), json!(1));
    d.insert("model".into(), json!(model));
    d.insert("width".into(), json!(size.0));
    d.insert("height".into(), json!(size.1));
    d.insert("max_fov_deg".into(), number(max_fov_deg, "max_fov_deg")?);
    for (name, v) in [("fx", fx), ("fy", fy), ("cx", cx), ("cy", cy)] {
        d.insert(name.into(), number(v, name)?);
    }
    d.extend(fields);
    let (yaw, pitch, roll) = angles;
    d.insert(
        "rotation".into(),
        json!({
            "yaw_deg": number(yaw, "yaw_deg")?,
            "pitch_deg": number(pitch, "pitch_deg")?,
            "roll_deg": number(roll, "roll_deg")?,
        }),
    );
    let text = Value::Object(d).to_string();
    let name = PathBuf::from(format!("<Camera.{model}>"));
    let desc = CameraDescription::parse(&text, &name).py()?;
    Ok(described(desc, centre_of(centre)))
}

/// A JSON number, or an error naming the argument (JSON has no NaN or infinity).
pub fn number(v: f64, name: &str) -> PyResult<Value> {
    serde_json::Number::from_f64(v)
        .map(Value::Number)
        .ok_or_else(|| usage(format!("{name} must be a finite number, not {v}")))
}

/// A JSON list of numbers.
pub fn numbers(vs: &[f64], name: &str) -> PyResult<Value> {
    vs.iter()
        .map(|&v| number(v, name))
        .collect::<PyResult<Vec<_>>>()
        .map(Value::Array)
}

/// The camera of a description: its lens with the description's axes, at `centre`.
fn described(desc: CameraDescription, centre: Vector3<f64>) -> Camera {
    let camera: Box<dyn OutputCamera> = Box::new(FisheyeCamera {
        lens: desc.camera,
        rect_from_camera: desc.output_from_camera,
    });
    Camera::new(camera, centre)
}

/// A camera file (a camera description or a native calibration file, docs/fisheye.md) as a
/// `Camera` in rect axes: its rotation from the file, its optical centre `centre` (metres, in
/// rect) or the origin.
#[pyfunction]
#[pyo3(signature = (path, centre=None))]
pub fn read_camera(
    py: Python<'_>,
    path: PathBuf,
    centre: Option<&Bound<'_, PyAny>>,
) -> PyResult<Camera> {
    let centre = crate::vectors::vector3(centre, "centre")?;
    let desc = py
        .detach(|| CameraDescription::read(Path::new(&path)))
        .py()?;
    Ok(described(desc, centre_of(centre)))
}

/// The rotation of a camera in rect (identity for the command's linear output cameras).
pub fn axes(camera: &Camera) -> Matrix3<f64> {
    match (&camera.turn, camera.camera.as_fisheye()) {
        (Some(turn), _) => *turn,
        (None, Some(f)) => f.rect_from_camera,
        (None, None) => Matrix3::identity(),
    }
}
