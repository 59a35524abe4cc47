//! `panoconv.Dataset`: the frames of one split of a converted (or plain KITTI) dataset, each
//! with its image path, labels, camera and depth path, for a PyTorch or JAX `Dataset` to wrap.

use crate::calib::{self, Calib};
use crate::camera::Camera;
use crate::errors::IntoPy;
use crate::labels::{read_label_file, Label};
use panoconv::kitti::{Cam, Dataset as KittiDataset, Split};
use pyo3::exceptions::{PyIndexError, PyKeyError};
use pyo3::prelude::*;
use std::path::PathBuf;

/// One split of a dataset in KITTI's layout (`ROOT/<split>/image_2/NNNNNN.png`, `calib/`,
/// `label_2/`, `depth_2/`): `len()`, indexing by position or frame id, iteration.
#[pyclass(module = "panoconv", frozen)]
pub struct Dataset {
    split: Split,
}

/// One frame: paths, labels and camera.
#[pyclass(module = "panoconv", frozen)]
pub struct Frame {
    /// The frame id (`000042`).
    #[pyo3(get)]
    id: String,
    /// The split's name.
    #[pyo3(get)]
    split: String,
    /// `image_2/<id>.png`.
    #[pyo3(get)]
    image: String,
    /// `image_3/<id>.png` when present.
    #[pyo3(get)]
    image_3: Option<String>,
    /// `depth_2/<id>.png` when present (16-bit, round(d·256), 0 = none).
    #[pyo3(get)]
    depth: Option<String>,
    /// `mask_2/<id>.png` when present (white where the image holds source data).
    #[pyo3(get)]
    mask: Option<String>,
    /// `source_2/<id>.png` when present (a rig's output: the camera of each pixel, 255 where
    /// no camera sees it).
    #[pyo3(get)]
    source_map: Option<String>,
    /// The objects of `label_2/<id>.txt` (empty for a split without labels).
    #[pyo3(get)]
    labels: Vec<Py<Label>>,
    /// The calib of the frame.
    #[pyo3(get)]
    calib: Py<Calib>,
}

#[pymethods]
impl Frame {
    /// The camera image_2 was written in (the calib's camera 2).
    #[getter]
    fn camera(&self, py: Python<'_>) -> Py<Camera> {
        self.calib.get().camera2(py)
    }

    fn __repr__(&self) -> String {
        format!(
            "Frame(split={:?}, id={:?}, labels={})",
            self.split,
            self.id,
            self.labels.len()
        )
    }
}

fn existing(p: PathBuf) -> Option<String> {
    p.is_file().then(|| p.display().to_string())
}

impl Dataset {
    fn frame(&self, py: Python<'_>, id: &str) -> PyResult<Frame> {
        let s = &self.split;
        let image = s.image_path(Cam::C2, id);
        let calib_path = s.calib_path(id);
        let label_path = s.label_path(id);
        let has_labels = s.has_labels;
        let (parts, labels) = py
            .detach(|| -> panoconv::error::Result<_> {
                let parts = calib::read(&calib_path, None, Some(&image))?;
                let labels = if has_labels {
                    Some(read_label_file(&label_path)?)
                } else {
                    None
                };
                Ok((parts, labels))
            })
            .py()?;
        let labels = match labels {
            Some(labels) => labels
                .into_iter()
                .map(|l| Py::new(py, l))
                .collect::<PyResult<_>>()?,
            None => Vec::new(),
        };
        let (calib, cameras) = parts;
        Ok(Frame {
            id: id.to_owned(),
            split: s.name.clone(),
            image: image.display().to_string(),
            image_3: existing(s.image_path(Cam::C3, id)),
            depth: existing(s.dir.join("depth_2").join(format!("{id}.png"))),
            mask: existing(s.dir.join("mask_2").join(format!("{id}.png"))),
            source_map: existing(s.dir.join("source_2").join(format!("{id}.png"))),
            labels,
            calib: Py::new(py, Calib::from_parts(py, calib, cameras)?)?,
        })
    }
}

#[pymethods]
impl Dataset {
    /// Opens `ROOT/<split>` (`training` or `testing`); its frames are the PNGs of `image_2/`.
    #[new]
    #[pyo3(signature = (path, split="training"))]
    fn new(py: Python<'_>, path: PathBuf, split: &str) -> PyResult<Self> {
        let dataset = py.detach(|| KittiDataset::open(&path, Some(split))).py()?;
        let split = dataset
            .splits
            .into_iter()
            .next()
            .expect("open with a split name returns that split or an error");
        Ok(Self { split })
    }

    /// The frame ids, sorted.
    #[getter]
    fn ids(&self) -> Vec<String> {
        self.split.frames.clone()
    }

    /// The split's folder.
    #[getter]
    fn root(&self) -> String {
        self.split.dir.display().to_string()
    }

    fn __len__(&self) -> usize {
        self.split.frames.len()
    }

    /// A frame by position (negative from the end) or by id (`"000042"`).
    fn __getitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Frame> {
        if let Ok(i) = key.extract::<isize>() {
            let n = self.split.frames.len() as isize;
            let j = if i < 0 { i + n } else { i };
            if !(0..n).contains(&j) {
                return Err(PyIndexError::new_err(format!(
                    "frame index {i} out of range ({n} frames)"
                )));
            }
            let id = self.split.frames[j as usize].clone();
            return self.frame(py, &id);
        }
        let id: String = key.extract()?;
        if self.split.frames.binary_search(&id).is_err() {
            return Err(PyKeyError::new_err(format!(
                "frame {id} not found in {}",
                self.split.dir.display()
            )));
        }
        self.frame(py, &id)
    }

    fn __iter__(slf: Bound<'_, Self>) -> FrameIter {
        FrameIter {
            dataset: slf.unbind(),
            next: std::sync::atomic::AtomicUsize::new(0),
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "Dataset(root={:?}, split={:?}, frames={})",
            self.split.dir.display().to_string(),
            self.split.name,
            self.split.frames.len()
        )
    }
}

/// Iterates a `Dataset`'s frames in id order.
#[pyclass(module = "panoconv", frozen)]
pub struct FrameIter {
    dataset: Py<Dataset>,
    next: std::sync::atomic::AtomicUsize,
}

#[pymethods]
impl FrameIter {
    fn __iter__(slf: Bound<'_, Self>) -> Bound<'_, Self> {
        slf
    }

    fn __next__(&self, py: Python<'_>) -> PyResult<Option<Frame>> {
        let d = self.dataset.get();
        let i = self.next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        match d.split.frames.get(i) {
            Some(id) => d.frame(py, &id.clone()).map(Some),
            None => Ok(None),
        }
    }
}
