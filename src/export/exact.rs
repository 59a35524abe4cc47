//! The exact 3D boxes a rig conversion writes beside its labels (`objects/ID.json`,
//! docs/formats.md). KITTI's label line holds one angle, so a box that leans (KITTI-360 has a
//! few) loses its pitch and roll there; the Omni3D export takes the box from this file instead.
//! Only the written objects (`"dropped": null`) are kept, in file order: the order of the
//! frame's `label_2` lines other than DontCare (an object the visibility rule leaves out is
//! a DontCare line there and dropped here).

use crate::error::{Error, Result};
use nalgebra::{Matrix3, Vector3};
use serde::Deserialize;
use std::path::Path;

/// A box as the conversion knew it, in the output's reference frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ExactBox {
    /// Geometric centre, metres.
    pub centre: Vector3<f64>,
    /// Length, height, width (along local x, y, z), metres.
    pub size: Vector3<f64>,
    /// reference_from_box (local x length, y down, z width).
    pub rotation: Matrix3<f64>,
}

#[derive(Deserialize)]
struct ObjectsFile {
    objects: Vec<Entry>,
}

#[derive(Deserialize)]
struct Entry {
    centre: [f64; 3],
    size: [f64; 3],
    rotation: [f64; 9],
    dropped: Option<serde_json::Value>,
}

/// The written objects' exact boxes of `path`, in label order; None when there is no such file
/// (a KITTI conversion writes none).
pub(crate) fn read_exact_boxes(path: &Path) -> Result<Option<Vec<ExactBox>>> {
    if !path.is_file() {
        return Ok(None);
    }
    let bytes = crate::fs::read_file(path)?;
    let file: ObjectsFile = serde_json::from_slice(&bytes)
        .map_err(|e| Error::parse(path, e.line(), "objects", e.to_string()))?;
    let mut boxes = Vec::new();
    for (i, e) in file.objects.into_iter().enumerate() {
        if e.dropped.as_ref().is_some_and(|d| !d.is_null()) {
            continue;
        }
        let rotation = Matrix3::from_row_slice(&e.rotation);
        let orthonormal = (rotation.transpose() * rotation - Matrix3::identity())
            .abs()
            .max()
            < 1e-6;
        let finite = e.centre.iter().chain(&e.size).all(|v| v.is_finite());
        if !orthonormal || !finite || e.size.iter().any(|s| *s <= 0.0) {
            return Err(Error::file(
                path,
                format!("objects[{i}]: not a box (a finite centre, positive size and a rotation)"),
            ));
        }
        boxes.push(ExactBox {
            centre: Vector3::from(e.centre),
            size: Vector3::from(e.size),
            rotation,
        });
    }
    Ok(Some(boxes))
}
