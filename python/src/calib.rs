//! `panoconv.read_calib`: a calib file (plain KITTI or written by panoconv) with its KITTI
//! matrices and the cameras its images were taken or written in.

use crate::camera::Camera;
use crate::errors::IntoPy;
use nalgebra::{Matrix3, Matrix3x4, Vector3};
use numpy::PyArray2;
use panoconv::camera::{ImageSize, OutputCamera};
use panoconv::codec::png::read_file_size;
use panoconv::error::Error;
use panoconv::kitti::{Calib as KittiCalib, Cam};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

/// A calibration file: the KITTI matrices and the cameras of its images.
#[pyclass(module = "panoconv", frozen)]
pub struct Calib {
    pub calib: KittiCalib,
    /// The cameras of image_2 and image_3 (when present), by number.
    cameras: Vec<(usize, Py<Camera>)>,
}

fn array34<'py>(py: Python<'py>, m: &Option<Matrix3x4<f64>>) -> Option<Bound<'py, PyArray2<f64>>> {
    m.map(|m| {
        let rows: Vec<Vec<f64>> = (0..3).map(|r| m.row(r).iter().copied().collect()).collect();
        PyArray2::from_vec2(py, &rows).expect("3x4")
    })
}

fn array33<'py>(py: Python<'py>, m: &Option<Matrix3<f64>>) -> Option<Bound<'py, PyArray2<f64>>> {
    m.map(|m| {
        let rows: Vec<Vec<f64>> = (0..3).map(|r| m.row(r).iter().copied().collect()).collect();
        PyArray2::from_vec2(py, &rows).expect("3x3")
    })
}

/// The image whose size a calib's camera takes: `<split>/image_N/<id>.png` beside
/// `<split>/calib/<id>.txt`.
fn sibling_image(calib: &Path, n: Cam) -> Option<PathBuf> {
    let stem = calib.file_stem()?;
    let split = calib.parent()?.parent()?;
    let mut name = stem.to_os_string();
    name.push(".png");
    Some(split.join(format!("image_{n}")).join(name))
}

/// A camera of a calib: its number, model and optical centre in rect.
pub type CameraParts = (usize, Box<dyn OutputCamera>, Vector3<f64>);

/// Reads `path` and builds the cameras of its images (their size from `size`, else `image`'s
/// PNG header, else the sibling `image_2/<id>.png`).
pub fn read(
    path: &Path,
    size: Option<ImageSize>,
    image: Option<&Path>,
) -> panoconv::error::Result<(KittiCalib, Vec<CameraParts>)> {
    let calib = KittiCalib::read(path)?;
    let size_of = |n: Cam| -> panoconv::error::Result<ImageSize> {
        if let Some(s) = size {
            return Ok(s);
        }
        let image = match (image, n) {
            (Some(i), Cam::C2) => i.to_path_buf(),
            _ => sibling_image(path, n).ok_or_else(|| {
                Error::file(
                    path,
                    "no image to take the size from: pass size=(width, height)",
                )
            })?,
        };
        if !image.is_file() {
            return Err(Error::file(
                path,
                format!(
                    "no image to take the size from ({} is not there): pass size=(width, height) or image=PATH",
                    image.display()
                ),
            ));
        }
        let (w, h) = read_file_size(&image)?;
        Ok(ImageSize::new(w, h))
    };
    let mut cameras = Vec::new();
    for n in [Cam::C2, Cam::C3] {
        let described = match calib.projection {
            Some(_) => calib.k_out[n.number()].is_some(),
            None => calib.p[n.number()].is_some(),
        };
        // Camera 2 is required (an error names what is missing); camera 3 when described and
        // its image size is known.
        if n == Cam::C3 && !described {
            continue;
        }
        let s = match (n, size_of(n)) {
            (_, Ok(s)) => s,
            (Cam::C3, Err(_)) => match size_of(Cam::C2) {
                Ok(s) => s,
                Err(_) => continue,
            },
            (_, Err(e)) => return Err(e),
        };
        let (camera, centre) = calib.image_camera(n, s)?;
        cameras.push((n.number(), camera, centre));
    }
    Ok((calib, cameras))
}

impl Calib {
    pub fn load(
        py: Python<'_>,
        path: &Path,
        size: Option<ImageSize>,
        image: Option<&Path>,
    ) -> PyResult<Calib> {
        let (calib, cameras) = py.detach(|| read(path, size, image)).py()?;
        Self::from_parts(py, calib, cameras)
    }

    pub fn from_parts(
        py: Python<'_>,
        calib: KittiCalib,
        cameras: Vec<CameraParts>,
    ) -> PyResult<Calib> {
        let cameras = cameras
            .into_iter()
            .map(|(n, cam, c)| Ok((n, Py::new(py, Camera::new(cam, c))?)))
            .collect::<PyResult<_>>()?;
        Ok(Calib { calib, cameras })
    }

    pub fn camera2(&self, py: Python<'_>) -> Py<Camera> {
        self.cameras
            .iter()
            .find(|(n, _)| *n == 2)
            .map(|(_, c)| c.clone_ref(py))
            .expect("camera 2 is always built")
    }
}

#[pymethods]
impl Calib {
    /// The camera image_2 was taken (plain KITTI: the perspective camera of P2) or written in
    /// (a converted dataset: `projection:`, `K2:`, `C2:` and a fisheye's lens lines).
    #[getter]
    fn camera(&self, py: Python<'_>) -> Py<Camera> {
        self.camera2(py)
    }

    /// The cameras by number: 2, and 3 when the calib describes it.
    #[getter]
    fn cameras(&self, py: Python<'_>) -> std::collections::BTreeMap<usize, Py<Camera>> {
        self.cameras
            .iter()
            .map(|(n, c)| (*n, c.clone_ref(py)))
            .collect()
    }

    /// The `projection:` line (`equirect`, ...); None for a plain KITTI calib.
    #[getter]
    fn projection(&self) -> Option<&'static str> {
        self.calib.projection.map(|p| p.name())
    }

    /// The file read.
    #[getter]
    fn path(&self) -> String {
        self.calib.path.display().to_string()
    }

    /// The file's lines, verbatim.
    #[getter]
    fn lines(&self) -> Vec<String> {
        self.calib.lines.clone()
    }

    /// P0 (3×4), None when the file has no such line.
    #[getter(P0)]
    fn p0<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        array34(py, &self.calib.p[0])
    }
    /// P1 (3×4).
    #[getter(P1)]
    fn p1<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        array34(py, &self.calib.p[1])
    }
    /// P2 (3×4): the source camera (rewritten only for a perspective output).
    #[getter(P2)]
    fn p2<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        array34(py, &self.calib.p[2])
    }
    /// P3 (3×4).
    #[getter(P3)]
    fn p3<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        array34(py, &self.calib.p[3])
    }
    /// R0_rect (3×3): rect from camera 0's unrectified axes.
    #[getter(R0_rect)]
    fn r0_rect<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        array33(py, &self.calib.r0_rect)
    }
    /// Tr_velo_to_cam (3×4): camera 0 from Velodyne.
    #[getter(Tr_velo_to_cam)]
    fn tr_velo_to_cam<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        array34(py, &self.calib.tr_velo_to_cam)
    }
    /// Tr_imu_to_velo (3×4): Velodyne from the IMU.
    #[getter(Tr_imu_to_velo)]
    fn tr_imu_to_velo<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        array34(py, &self.calib.tr_imu_to_velo)
    }
    /// rect from Velodyne (3×4): R0_rect · Tr_velo_to_cam, so X_rect = M[:, :3] @ p + M[:, 3].
    #[getter]
    fn rect_from_velo<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        let (r, t) = (self.calib.r0_rect?, self.calib.tr_velo_to_cam?);
        array34(py, &Some(r * t))
    }

    fn __repr__(&self) -> String {
        format!(
            "Calib(path={:?}, projection={:?}, cameras={:?})",
            self.path(),
            self.projection(),
            self.cameras.iter().map(|(n, _)| *n).collect::<Vec<_>>()
        )
    }
}

/// Reads a calib file (`calib/NNNNNN.txt`), plain KITTI or written by panoconv. The cameras
/// need their image's size: `size=(width, height)`, else the PNG `image`, else the sibling
/// `image_2/NNNNNN.png` of a KITTI layout.
#[pyfunction]
#[pyo3(signature = (path, size=None, image=None))]
pub fn read_calib(
    py: Python<'_>,
    path: PathBuf,
    size: Option<&Bound<'_, PyAny>>,
    image: Option<PathBuf>,
) -> PyResult<Calib> {
    let size = size
        .filter(|s| !s.is_none())
        .map(|s| crate::vectors::size_array::<2>(s, "size"))
        .transpose()?;
    Calib::load(
        py,
        &path,
        size.map(|[w, h]| ImageSize::new(w, h)),
        image.as_deref(),
    )
}
