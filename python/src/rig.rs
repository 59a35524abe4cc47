//! What `panoconv.convert_rig` sends the command of a `panoconv.Camera` (docs/python.md): a
//! pinhole as `{"model": "pinhole", width, height, fx, fy, cx, cy}`, a fisheye as its camera
//! description (docs/fisheye.md), each with its rotation when it is turned, for the command
//! to refuse (a rig camera is in its own axes).

use crate::camera::Camera;
use crate::models;
use nalgebra::Matrix3;
use panoconv::camera::description::CameraDescription;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use serde_json::json;

/// The camera's wire JSON (a string).
#[pyfunction]
pub fn _camera_wire(camera: PyRef<'_, Camera>) -> PyResult<String> {
    if let Some(f) = camera.camera.as_fisheye() {
        let desc = CameraDescription {
            camera: f.lens.clone(),
            output_from_camera: f.rect_from_camera,
        };
        return Ok(desc.to_json(None));
    }
    let projection = camera.camera.projection().name();
    if projection != "perspective" {
        return Err(PyValueError::new_err(format!(
            "a rig camera is a pinhole (perspective) or a fisheye, not {projection}"
        )));
    }
    let k = camera.camera.intrinsics();
    let size = camera.camera.size();
    let mut wire = json!({
        "model": "pinhole",
        "width": size.width,
        "height": size.height,
        "fx": k.fu,
        "fy": k.fv,
        "cx": k.cu,
        "cy": k.cv,
    });
    let axes = models::axes(&camera);
    if axes != Matrix3::identity() {
        let rows: Vec<[f64; 3]> = (0..3)
            .map(|i| [axes[(i, 0)], axes[(i, 1)], axes[(i, 2)]])
            .collect();
        wire["rotation"] = json!({ "matrix": rows });
    }
    Ok(wire.to_string())
}
