//! `panoconv.read_labels`, `box_2d` and `box_corners`: KITTI label files and the exact 2D box
//! of a 3D box in any output camera (curved edges, the ±180° seam), as the conversion writes it.

use crate::camera::Camera;
use crate::errors::IntoPy;
use nalgebra::Vector3;
use ndarray::Array2;
use numpy::PyArray2;
use panoconv::fs::read_lines;
use panoconv::kitti::Label as KittiLabel;
use panoconv::reproject::labels::{box_bounds, clip};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

/// One object of a KITTI label file, every field: `type`, `truncated`, `occluded`, `alpha`,
/// `bbox`, `dimensions`, `location`, `rotation_y`, `score`.
#[pyclass(module = "panoconv", frozen)]
pub struct Label {
    pub label: KittiLabel,
    /// 1-based line in the file.
    #[pyo3(get)]
    pub line: usize,
}

impl Label {
    pub fn new(label: KittiLabel, line: usize) -> Self {
        Self { label, line }
    }
}

#[pymethods]
impl Label {
    /// The class: `Car`, `Pedestrian`, ..., or `DontCare` for an ignored region.
    #[getter(r#type)]
    fn kind(&self) -> &str {
        &self.label.kind
    }
    /// How much of the object leaves the image, 0 to 1 (-1 for DontCare).
    #[getter]
    fn truncated(&self) -> f64 {
        self.label.truncated
    }
    /// 0 visible, 1 partly occluded, 2 largely occluded, 3 unknown.
    #[getter]
    fn occluded(&self) -> i32 {
        self.label.occluded
    }
    /// Observation angle, radians.
    #[getter]
    fn alpha(&self) -> f64 {
        self.label.alpha
    }
    /// The 2D box `(left, top, right, bottom)`, pixels, as written in the file.
    #[getter]
    fn bbox(&self) -> (f64, f64, f64, f64) {
        let [l, t, r, b] = self.label.bbox;
        (l, t, r, b)
    }
    /// `(height, width, length)`, metres.
    #[getter]
    fn dimensions(&self) -> (f64, f64, f64) {
        let [h, w, l] = self.label.dimensions;
        (h, w, l)
    }
    /// Bottom centre of the 3D box in rect `(x, y, z)`, metres.
    #[getter]
    fn location(&self) -> (f64, f64, f64) {
        let p = self.label.location;
        (p.x, p.y, p.z)
    }
    /// Heading about rect's y axis, radians.
    #[getter]
    fn rotation_y(&self) -> f64 {
        self.label.rotation_y
    }
    /// The 16th column of detections; None in ground truth.
    #[getter]
    fn score(&self) -> Option<f64> {
        self.label.score
    }
    /// Whether the object has a 3D box (DontCare regions and placeholder rows do not).
    #[getter]
    fn has_box_3d(&self) -> bool {
        self.label.has_box_3d()
    }
    /// The line's tokens as read.
    #[getter]
    fn tokens(&self) -> Vec<String> {
        self.label.tokens.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "Label(type={:?}, bbox={:?}, location={:?}, line={})",
            self.label.kind,
            self.bbox(),
            self.location(),
            self.line
        )
    }
}

/// Reads a KITTI label file: one `Label` per non-blank line. A malformed value raises
/// `ParseError` naming the file, line and field.
#[pyfunction]
pub fn read_labels(py: Python<'_>, path: PathBuf) -> PyResult<Vec<Label>> {
    py.detach(|| read_label_file(&path)).py()
}

/// The labels of a file with their 1-based line numbers (blank lines skipped), as
/// `LabelFile::read` parses them.
pub fn read_label_file(path: &Path) -> panoconv::error::Result<Vec<Label>> {
    let mut labels = Vec::new();
    for (i, line) in read_lines(path)?.iter().enumerate() {
        if !line.trim().is_empty() {
            labels.push(Label::new(KittiLabel::parse(path, i + 1, line)?, i + 1));
        }
    }
    Ok(labels)
}

/// The 8 corners of the object's 3D box in rect, (8, 3): bottom face first, then the top
/// (KITTI's convention).
#[pyfunction]
pub fn box_corners<'py>(py: Python<'py>, obj: &Label) -> Bound<'py, PyArray2<f64>> {
    let corners = obj.label.corners();
    let flat: Vec<f64> = corners.iter().flat_map(|c| [c.x, c.y, c.z]).collect();
    PyArray2::from_owned_array(py, Array2::from_shape_vec((8, 3), flat).expect("8x3"))
}

/// The 2D box `(left, top, right, bottom)` of the object's 3D box in `camera`: the tight
/// bounds of its exact projection (straight edges project to curves; a box across a
/// panorama's ±180° seam is kept whole on the side of its centre), clipped to the image as
/// `label_2` writes it (`clip=False`: before clipping, possibly beyond the image). None when
/// nothing of it is in the image. Objects without a 3D box (DontCare) raise ValueError.
#[pyfunction]
#[pyo3(signature = (obj, camera, clip=true))]
pub fn box_2d(
    py: Python<'_>,
    obj: &Label,
    camera: &Camera,
    clip: bool,
) -> PyResult<Option<(f64, f64, f64, f64)>> {
    if !obj.label.has_box_3d() {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "{} at line {} has no 3D box: its 2D box is the warped rectangle the conversion wrote",
            obj.label.kind, obj.line
        )));
    }
    let corners: [Vector3<f64>; 8] = obj.label.corners().map(|c| c - camera.centre);
    let bounds = py.detach(|| {
        let b = box_bounds(&corners, camera.camera.as_ref())?;
        if clip {
            let s = camera.camera.size();
            self::clip(b, s.width, s.height)
        } else {
            Some(b)
        }
    });
    Ok(bounds.map(|[l, t, r, b]| (l, t, r, b)))
}
