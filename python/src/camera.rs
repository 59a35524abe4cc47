//! `panoconv.Camera`: an output camera (any projection, fisheye included) and its optical
//! centre in rect, projecting numpy arrays of rect points and unprojecting pixels; and
//! `crop_resize`, the camera of a cropped and resized image (half-pixel rule).

use crate::errors::usage;
use nalgebra::{Point2, Vector3};
use ndarray::{Array1, Array2, ArrayView2};
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike2};
use panoconv::camera::{ImageSize, OutputCamera};
use panoconv::geometry::{crop_intrinsics, resize_intrinsics, Crop};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;

/// Rows per rayon task: small arrays stay on the calling thread's task.
const ROWS_PER_TASK: usize = 4096;

/// The camera an image was written in: pixel = K · Γ(X − C) for a rect point X.
#[pyclass(module = "panoconv", frozen)]
pub struct Camera {
    pub camera: Box<dyn OutputCamera>,
    pub centre: Vector3<f64>,
}

impl Camera {
    pub fn new(camera: Box<dyn OutputCamera>, centre: Vector3<f64>) -> Self {
        Self { camera, centre }
    }
}

/// `project`'s pixels (N, 2) and their validity (N,).
type Projected<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<bool>>);

/// Rows of an (N, `cols`) array, or a ValueError naming the argument.
fn check_rows(a: &ArrayView2<f64>, cols: usize, name: &str) -> PyResult<usize> {
    if a.ncols() != cols {
        return Err(PyValueError::new_err(format!(
            "{name}: expected an (N, {cols}) array, got shape {:?}",
            a.shape()
        )));
    }
    Ok(a.nrows())
}

/// Applies `f` to every row of `a` in parallel (rayon), writing `out_cols` values per row.
fn map_rows(
    a: &ArrayView2<f64>,
    out_cols: usize,
    f: impl Fn(&[f64], &mut [f64]) + Sync,
) -> Vec<f64> {
    let n = a.nrows();
    let mut out = vec![0.0; n * out_cols];
    out.par_chunks_mut(ROWS_PER_TASK * out_cols)
        .enumerate()
        .for_each(|(chunk, rows)| {
            let mut row = vec![0.0; a.ncols()];
            for (i, o) in rows.chunks_mut(out_cols).enumerate() {
                for (dst, src) in row.iter_mut().zip(a.row(chunk * ROWS_PER_TASK + i)) {
                    *dst = *src;
                }
                f(&row, o);
            }
        });
    out
}

fn matrix<'py>(
    py: Python<'py>,
    rows: usize,
    cols: usize,
    v: Vec<f64>,
) -> Bound<'py, PyArray2<f64>> {
    // from_owned_array hands the buffer to numpy without a copy.
    PyArray2::from_owned_array(py, Array2::from_shape_vec((rows, cols), v).expect("shape"))
}

#[pymethods]
impl Camera {
    /// Pixels of rect points: `(uv (N, 2), valid (N,))`. A point the projection cannot map
    /// (behind a perspective camera, beyond a fisheye's field of view, on a panorama's axis)
    /// has `valid` False and `uv` NaN. A valid pixel may still lie outside the image: see
    /// `contains`.
    fn project<'py>(
        &self,
        py: Python<'py>,
        points_rect: PyArrayLike2<'py, f64, AllowTypeChange>,
    ) -> PyResult<Projected<'py>> {
        let points = points_rect.as_array();
        let n = check_rows(&points, 3, "points_rect")?;
        let uv = py.detach(|| {
            map_rows(&points, 2, |p, o| {
                let rel = Vector3::new(p[0], p[1], p[2]) - self.centre;
                match self.camera.project_point(&rel) {
                    Ok(px) => o.copy_from_slice(&[px.x, px.y]),
                    Err(_) => o.copy_from_slice(&[f64::NAN, f64::NAN]),
                }
            })
        });
        let valid: Array1<bool> = uv.chunks(2).map(|p| !p[0].is_nan()).collect();
        Ok((matrix(py, n, 2, uv), PyArray1::from_owned_array(py, valid)))
    }

    /// Unit bearings in rect axes of pixels `uv (N, 2)`: `(N, 3)`, NaN where a pixel has no
    /// ray (outside the projection's domain, beyond a fisheye's field of view). The ray of a
    /// pixel is `C + t · bearing`, t > 0.
    fn unproject<'py>(
        &self,
        py: Python<'py>,
        uv: PyArrayLike2<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let uv = uv.as_array();
        let n = check_rows(&uv, 2, "uv")?;
        let bearings = py.detach(|| {
            map_rows(&uv, 3, |p, o| {
                match self.camera.unproject(&Point2::new(p[0], p[1])) {
                    Ok(d) => o.copy_from_slice(&[d.x, d.y, d.z]),
                    Err(_) => o.copy_from_slice(&[f64::NAN; 3]),
                }
            })
        });
        Ok(matrix(py, n, 3, bearings))
    }

    /// The distance the projection pairs with, of rect points `(N, 3)`: z (perspective),
    /// the range (equirect, fisheye) or rho = sqrt(x² + z²) (cylindrical), from C.
    fn distance<'py>(
        &self,
        py: Python<'py>,
        points_rect: PyArrayLike2<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let points = points_rect.as_array();
        check_rows(&points, 3, "points_rect")?;
        let d = py.detach(|| {
            map_rows(&points, 1, |p, o| {
                o[0] = self
                    .camera
                    .distance(&(Vector3::new(p[0], p[1], p[2]) - self.centre))
            })
        });
        Ok(PyArray1::from_vec(py, d))
    }

    /// Whether pixels `uv (N, 2)` lie on the image: [-0.5, width - 0.5) × [-0.5, height - 0.5).
    fn contains<'py>(
        &self,
        py: Python<'py>,
        uv: PyArrayLike2<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let uv = uv.as_array();
        check_rows(&uv, 2, "uv")?;
        let inside: Array1<bool> = uv
            .rows()
            .into_iter()
            .map(|p| self.camera.contains(&Point2::new(p[0], p[1])))
            .collect();
        Ok(PyArray1::from_owned_array(py, inside))
    }

    /// The 3×3 intrinsics: pixel = K · (a, b, 1) of the projection's coordinates.
    #[getter(K)]
    fn k<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, 3, 3, self.camera.intrinsics().matrix().to_vec())
    }

    /// The optical centre in rect, metres (3,).
    #[getter(C)]
    fn c<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.centre.as_slice().to_vec())
    }

    /// The camera's axes in rect (3×3, a rotation): identity for the linear projections, the
    /// calib's `R2:` for a fisheye.
    #[getter(R)]
    fn r<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let m = self
            .camera
            .as_fisheye()
            .map_or_else(nalgebra::Matrix3::identity, |f| f.rect_from_camera);
        matrix(py, 3, 3, m.transpose().as_slice().to_vec())
    }

    /// `perspective`, `equirect`, `cylindrical` or `fisheye`.
    #[getter]
    fn projection(&self) -> &'static str {
        self.camera.projection().name()
    }

    /// A fisheye's lens model (`kannala_brandt`, `mei`, ...); None for the linear projections.
    #[getter]
    fn model(&self) -> Option<&'static str> {
        self.camera.as_fisheye().map(|f| f.lens.name())
    }

    /// Image width, pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.camera.size().width
    }

    /// Image height, pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.camera.size().height
    }

    /// `(width, height)`.
    #[getter]
    fn size(&self) -> (u32, u32) {
        let s = self.camera.size();
        (s.width, s.height)
    }

    fn __repr__(&self) -> String {
        let k = self.camera.intrinsics();
        format!(
            "Camera(projection={:?}, size={}, fu={}, fv={}, cu={}, cv={}, C=[{}, {}, {}])",
            self.projection(),
            self.camera.size(),
            k.fu,
            k.fv,
            k.cu,
            k.cv,
            self.centre.x,
            self.centre.y,
            self.centre.z
        )
    }
}

/// The camera of an image cropped to `crop = (x, y, width, height)` (x, y: the window's
/// top-left pixel; may reach beyond the image), then resized to `size = (width, height)`:
/// the same rule as `panoconv kitti --crop --resize` (pixel centres at integers, so
/// cu' = s·(cu + 0.5) − 0.5).
#[pyfunction]
#[pyo3(signature = (camera, crop=None, size=None))]
pub fn crop_resize(
    camera: &Camera,
    crop: Option<(i64, i64, u32, u32)>,
    size: Option<(u32, u32)>,
) -> PyResult<Camera> {
    let mut k = camera.camera.intrinsics();
    let mut image = camera.camera.size();
    if let Some((x, y, width, height)) = crop {
        if width == 0 || height == 0 {
            return Err(usage("crop width and height must be positive"));
        }
        (k, image) = crop_intrinsics(
            k,
            &Crop {
                x,
                y,
                width,
                height,
            },
        );
    }
    if let Some((width, height)) = size {
        if width == 0 || height == 0 {
            return Err(usage("resize width and height must be positive"));
        }
        let to = ImageSize::new(width, height);
        k = resize_intrinsics(k, image, to);
        image = to;
    }
    let moved = camera.camera.with_intrinsics(k, image).map_err(usage)?;
    Ok(Camera::new(moved, camera.centre))
}
