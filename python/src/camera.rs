//! `panoconv.Camera`: an output camera (any projection, fisheye included) and its optical
//! centre in rect, projecting numpy arrays of rect points and unprojecting pixels; and
//! `crop_resize`, the camera of a cropped and resized image (half-pixel rule).

pub use crate::camera_core::Camera;
use crate::errors::usage;
use crate::models;
use crate::vectors::{floats, int_array, size_array, vector3};
use nalgebra::{Point2, Vector3};
use ndarray::{Array1, Array2, ArrayView2};
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLike2};
use panoconv::camera::ImageSize;
use panoconv::camera::Projection;
use panoconv::geometry::{crop_intrinsics, resize_intrinsics, Crop};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;
use serde_json::{json, Map};

/// Rows per rayon task: small arrays stay on the calling thread's task.
const ROWS_PER_TASK: usize = 4096;

/// Yaw, pitch and roll of a constructor's arguments.
fn ypr(yaw_deg: f64, pitch_deg: f64, roll_deg: f64) -> models::Angles {
    (yaw_deg, pitch_deg, roll_deg)
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
    let task = |(chunk, rows): (usize, &mut [f64])| {
        let mut row = vec![0.0; a.ncols()];
        for (i, o) in rows.chunks_mut(out_cols).enumerate() {
            for (dst, src) in row.iter_mut().zip(a.row(chunk * ROWS_PER_TASK + i)) {
                *dst = *src;
            }
            f(&row, o);
        }
    };
    if pool_is_ours() {
        out.par_chunks_mut(ROWS_PER_TASK * out_cols)
            .enumerate()
            .for_each(task);
    } else {
        out.chunks_mut(ROWS_PER_TASK * out_cols)
            .enumerate()
            .for_each(task);
    }
    out
}

/// Whether rayon's pool belongs to this process: a process forked after its parent started the
/// pool (a data loader's worker) has none of the pool's threads, and a parallel call there
/// would wait for ever; it works serially instead.
fn pool_is_ours() -> bool {
    static STARTED_BY: std::sync::OnceLock<u32> = std::sync::OnceLock::new();
    let pid = std::process::id();
    *STARTED_BY.get_or_init(|| pid) == pid
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

    /// The camera's axes in rect (3×3, a rotation: a camera bearing d is R·d in rect):
    /// identity for the command's linear projections, the calib's `R2:` for a fisheye, the
    /// turn of a camera built with yaw/pitch/roll.
    #[getter(R)]
    fn r<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let m = models::axes(self);
        matrix(py, 3, 3, m.transpose().as_slice().to_vec())
    }

    /// A perspective camera: pixel = (fx·x/z + cx, fy·y/z + cy) in its axes, which are rect's
    /// turned by yaw, pitch and roll (degrees, docs/fisheye.md's convention); its optical
    /// centre `centre` in rect (metres) or the origin.
    #[staticmethod]
    #[pyo3(signature = (width, height, fx, fy, cx, cy, yaw_deg=0.0, pitch_deg=0.0, roll_deg=0.0, centre=None))]
    #[allow(clippy::too_many_arguments)]
    fn perspective(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        yaw_deg: f64,
        pitch_deg: f64,
        roll_deg: f64,
        centre: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Camera> {
        let angles = ypr(yaw_deg, pitch_deg, roll_deg);
        models::linear(
            Projection::Perspective,
            (width, height),
            (fx, fy, cx, cy),
            angles,
            vector3(centre, "centre")?,
        )
    }

    /// An equirectangular camera: u = fx·longitude + cx, v = fy·latitude + cy (radians), turned
    /// as `perspective`.
    #[staticmethod]
    #[pyo3(signature = (width, height, fx, fy, cx, cy, yaw_deg=0.0, pitch_deg=0.0, roll_deg=0.0, centre=None))]
    #[allow(clippy::too_many_arguments)]
    fn equirect(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        yaw_deg: f64,
        pitch_deg: f64,
        roll_deg: f64,
        centre: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Camera> {
        let angles = ypr(yaw_deg, pitch_deg, roll_deg);
        models::linear(
            Projection::Equirect,
            (width, height),
            (fx, fy, cx, cy),
            angles,
            vector3(centre, "centre")?,
        )
    }

    /// A cylindrical camera: u = fx·longitude + cx, v = fy·y/ρ + cy, turned as `perspective`.
    #[staticmethod]
    #[pyo3(signature = (width, height, fx, fy, cx, cy, yaw_deg=0.0, pitch_deg=0.0, roll_deg=0.0, centre=None))]
    #[allow(clippy::too_many_arguments)]
    fn cylindrical(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        yaw_deg: f64,
        pitch_deg: f64,
        roll_deg: f64,
        centre: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Camera> {
        let angles = ypr(yaw_deg, pitch_deg, roll_deg);
        models::linear(
            Projection::Cylindrical,
            (width, height),
            (fx, fy, cx, cy),
            angles,
            vector3(centre, "centre")?,
        )
    }

    /// A Kannala-Brandt (OpenCV fisheye) lens with coefficients `k` (up to 4), seeing
    /// `max_fov_deg` (full angle): the camera a description file with these values gives.
    #[staticmethod]
    #[pyo3(signature = (width, height, fx, fy, cx, cy, k, yaw_deg=0.0, pitch_deg=0.0, roll_deg=0.0, centre=None, max_fov_deg=180.0))]
    #[allow(clippy::too_many_arguments)]
    fn kannala_brandt(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        k: &Bound<'_, PyAny>,
        yaw_deg: f64,
        pitch_deg: f64,
        roll_deg: f64,
        centre: Option<&Bound<'_, PyAny>>,
        max_fov_deg: f64,
    ) -> PyResult<Camera> {
        let mut fields = Map::new();
        fields.insert("k".into(), models::numbers(&floats(k, "k")?, "k")?);
        let angles = ypr(yaw_deg, pitch_deg, roll_deg);
        models::lens(
            "kannala_brandt",
            (width, height),
            (fx, fy, cx, cy),
            fields,
            max_fov_deg,
            angles,
            vector3(centre, "centre")?,
        )
    }

    /// An ideal radial lens: `model` is `equidistant` (r = f·θ), `equisolid`
    /// (r = 2f·sin(θ/2)), `stereographic` (r = 2f·tan(θ/2)) or `orthographic` (r = f·sin θ).
    #[staticmethod]
    #[pyo3(signature = (model, width, height, fx, fy, cx, cy, yaw_deg=0.0, pitch_deg=0.0, roll_deg=0.0, centre=None, max_fov_deg=180.0))]
    #[allow(clippy::too_many_arguments)]
    fn radial(
        model: &str,
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        yaw_deg: f64,
        pitch_deg: f64,
        roll_deg: f64,
        centre: Option<&Bound<'_, PyAny>>,
        max_fov_deg: f64,
    ) -> PyResult<Camera> {
        if !["equidistant", "equisolid", "stereographic", "orthographic"].contains(&model) {
            return Err(usage(format!(
                "unknown radial model {model:?} (equidistant, equisolid, stereographic, orthographic)"
            )));
        }
        let angles = ypr(yaw_deg, pitch_deg, roll_deg);
        models::lens(
            model,
            (width, height),
            (fx, fy, cx, cy),
            Map::new(),
            max_fov_deg,
            angles,
            vector3(centre, "centre")?,
        )
    }

    /// A MEI (unified) lens: mirror parameter `xi`, radial `k = (k1, k2)`, tangential
    /// `p = (p1, p2)`.
    #[staticmethod]
    #[pyo3(signature = (width, height, fx, fy, cx, cy, xi, k=None, p=None, yaw_deg=0.0, pitch_deg=0.0, roll_deg=0.0, centre=None, max_fov_deg=180.0))]
    #[allow(clippy::too_many_arguments)]
    fn mei(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        xi: f64,
        k: Option<&Bound<'_, PyAny>>,
        p: Option<&Bound<'_, PyAny>>,
        yaw_deg: f64,
        pitch_deg: f64,
        roll_deg: f64,
        centre: Option<&Bound<'_, PyAny>>,
        max_fov_deg: f64,
    ) -> PyResult<Camera> {
        let mut fields = Map::new();
        fields.insert("xi".into(), models::number(xi, "xi")?);
        for (name, value) in [("k", k), ("p", p)] {
            let v = value.map_or(Ok(Vec::new()), |v| floats(v, name))?;
            fields.insert(name.into(), models::numbers(&v, name)?);
        }
        let angles = ypr(yaw_deg, pitch_deg, roll_deg);
        models::lens(
            "mei",
            (width, height),
            (fx, fy, cx, cy),
            fields,
            max_fov_deg,
            angles,
            vector3(centre, "centre")?,
        )
    }

    /// An enhanced unified camera model (EUCM) lens with `alpha` and `beta`.
    #[staticmethod]
    #[pyo3(signature = (width, height, fx, fy, cx, cy, alpha, beta, yaw_deg=0.0, pitch_deg=0.0, roll_deg=0.0, centre=None, max_fov_deg=180.0))]
    #[allow(clippy::too_many_arguments)]
    fn eucm(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        alpha: f64,
        beta: f64,
        yaw_deg: f64,
        pitch_deg: f64,
        roll_deg: f64,
        centre: Option<&Bound<'_, PyAny>>,
        max_fov_deg: f64,
    ) -> PyResult<Camera> {
        let fields = json!({"alpha": models::number(alpha, "alpha")?, "beta": models::number(beta, "beta")?});
        let fields = fields.as_object().cloned().unwrap_or_default();
        let angles = ypr(yaw_deg, pitch_deg, roll_deg);
        models::lens(
            "eucm",
            (width, height),
            (fx, fy, cx, cy),
            fields,
            max_fov_deg,
            angles,
            vector3(centre, "centre")?,
        )
    }

    /// A double sphere lens with `xi` and `alpha`.
    #[staticmethod]
    #[pyo3(signature = (width, height, fx, fy, cx, cy, xi, alpha, yaw_deg=0.0, pitch_deg=0.0, roll_deg=0.0, centre=None, max_fov_deg=180.0))]
    #[allow(clippy::too_many_arguments)]
    fn double_sphere(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        xi: f64,
        alpha: f64,
        yaw_deg: f64,
        pitch_deg: f64,
        roll_deg: f64,
        centre: Option<&Bound<'_, PyAny>>,
        max_fov_deg: f64,
    ) -> PyResult<Camera> {
        let fields =
            json!({"xi": models::number(xi, "xi")?, "alpha": models::number(alpha, "alpha")?});
        let fields = fields.as_object().cloned().unwrap_or_default();
        let angles = ypr(yaw_deg, pitch_deg, roll_deg);
        models::lens(
            "double_sphere",
            (width, height),
            (fx, fy, cx, cy),
            fields,
            max_fov_deg,
            angles,
            vector3(centre, "centre")?,
        )
    }

    /// The lens parameters besides fx, fy, cx, cy (`k1`..`k4`, `xi`, `alpha`, ...), as the
    /// calib's `D2:` line names them; empty for the linear projections.
    #[getter]
    fn parameters(&self) -> Vec<(&'static str, f64)> {
        self.camera
            .as_fisheye()
            .map(|f| f.lens.parameters())
            .unwrap_or_default()
    }

    /// A fisheye's full field of view, degrees; None for the linear projections.
    #[getter]
    fn max_fov_deg(&self) -> Option<f64> {
        self.camera
            .as_fisheye()
            .map(|f| (2.0 * f.lens.max_theta()).to_degrees())
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
    crop: Option<&Bound<'_, PyAny>>,
    size: Option<&Bound<'_, PyAny>>,
) -> PyResult<Camera> {
    let mut k = camera.camera.intrinsics();
    let mut image = camera.camera.size();
    if let Some(crop) = crop.filter(|c| !c.is_none()) {
        let [x, y, width, height] = int_array::<4>(crop, "crop")?;
        let (width, height) = match (u32::try_from(width), u32::try_from(height)) {
            (Ok(w), Ok(h)) if w > 0 && h > 0 => (w, h),
            _ => return Err(usage("crop width and height must be positive")),
        };
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
    if let Some(size) = size.filter(|s| !s.is_none()) {
        let [width, height] = size_array::<2>(size, "size")?;
        if width == 0 || height == 0 {
            return Err(usage("resize width and height must be positive"));
        }
        let to = ImageSize::new(width, height);
        k = resize_intrinsics(k, image, to);
        image = to;
    }
    let moved = camera.camera.with_intrinsics(k, image).map_err(usage)?;
    Ok(Camera {
        camera: moved,
        centre: camera.centre,
        turn: camera.turn,
    })
}
