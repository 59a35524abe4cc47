//! The `Camera` value every module of the package builds and reads: an output camera, its
//! optical centre in rect and the turn of a turned linear camera. Its constructors by model
//! are `models.rs`, its Python methods `camera.rs`; both read this, neither the other's parts.

use nalgebra::{Matrix3, Vector3};
use panoconv::camera::OutputCamera;
use pyo3::prelude::*;

/// The camera an image was written in: pixel = K · Γ(X − C) for a rect point X.
#[pyclass(module = "panoconv", frozen)]
pub struct Camera {
    pub camera: Box<dyn OutputCamera>,
    pub centre: Vector3<f64>,
    /// The axes of a turned linear camera in rect (`models::linear`); None: rect's own, or a
    /// fisheye's (which its lens carries).
    pub turn: Option<Matrix3<f64>>,
}

impl Camera {
    pub fn new(camera: Box<dyn OutputCamera>, centre: Vector3<f64>) -> Self {
        Self {
            camera,
            centre,
            turn: None,
        }
    }

    /// A turned linear camera (a `Turned`) whose axes in rect are `turn`.
    pub fn turned(camera: Box<dyn OutputCamera>, centre: Vector3<f64>, turn: Matrix3<f64>) -> Self {
        Self {
            camera,
            centre,
            turn: Some(turn),
        }
    }

    /// A copy of this camera at another optical centre.
    pub fn at(&self, centre: Vector3<f64>) -> Self {
        Self {
            camera: self.camera.boxed_output(),
            centre,
            turn: self.turn,
        }
    }
}
