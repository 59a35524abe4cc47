//! `panoconv.Warp`: one source camera's image, labels and LiDAR in a target camera, in memory,
//! by the command's own machinery: the remap table (built once, kept by the object), the label
//! placement of `panoconv kitti` and the depth map with its occlusion filter. The image, the
//! mask, the label lines and the depth values are those the command writes for the same
//! cameras.

use crate::camera::Camera;
use crate::labels::Label;
use nalgebra::{Matrix3, Vector3};
use ndarray::{Array2, ArrayD, ArrayViewD, IxDyn};
use numpy::{
    AllowTypeChange, Element, PyArray2, PyArrayDyn, PyArrayLike2, PyReadonlyArrayDyn,
    PyUntypedArrayMethods,
};
use panoconv::camera::{CameraModel, OutputProjection, Perspective, Projection};
use panoconv::convert::kitti::{move_label, MovedLabel};
use panoconv::kitti::Label as KittiLabel;
use panoconv::reproject::visibility::Visibility;
use panoconv::warp::{
    narrow_u8, pyramid, Footprint, RemapTable, Wrap, LENS_TAPS_BELOW, MAX_SUPERSAMPLE, TAPS_BELOW,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use std::borrow::Cow;
use std::path::Path;
use std::sync::OnceLock;

/// A source camera's pixels, labels and LiDAR in a target camera placed at the source's
/// optical centre (a pure reprojection). Everything runs on the calling thread with the GIL
/// released: a data loader spreads samples over its worker processes.
#[pyclass(module = "panoconv", frozen)]
pub struct Warp {
    source: Camera,
    target: Camera,
    supersample: u32,
    /// How coarse pixels average the source.
    antialias: Antialias,
    table: OnceLock<RemapTable>,
}

/// A `Warp`'s antialiasing: how a target pixel several source pixels wide averages them.
#[derive(Clone, Copy, PartialEq)]
enum Antialias {
    /// The source's pyramid from 1.5 source pixels (one to a few taps of a level).
    Pyramid,
    /// A tap per source pixel (up to `supersample`²).
    Taps,
    /// The command's rule: the taps below [`TAPS_BELOW`] source pixels ([`LENS_TAPS_BELOW`]
    /// for a fisheye target), the pyramid above.
    Command,
}

impl Antialias {
    const NAMES: [(&'static str, Antialias); 3] = [
        ("pyramid", Antialias::Pyramid),
        ("taps", Antialias::Taps),
        ("command", Antialias::Command),
    ];
}

impl Warp {
    /// The table, built on first use.
    fn table(&self, py: Python<'_>) -> &RemapTable {
        if let Some(t) = self.table.get() {
            return t;
        }
        let built = py.detach(|| self.build_table());
        // (two threads may build it at once: the same table, the first one kept)
        let _ = self.table.set(built);
        self.table.get().expect("set above")
    }

    /// The source and target cameras of a depth map, and the centre they share.
    pub(crate) fn depth_cameras(&self) -> (&dyn CameraModel, &dyn CameraModel, Vector3<f64>) {
        let (src, dst) = (self.source.camera.as_ref(), self.target.camera.as_ref());
        (src, dst, self.source.centre)
    }

    /// A ValueError unless `shape` is the source camera's HxW.
    pub(crate) fn check_source_pixels(&self, shape: &[usize], name: &str) -> PyResult<()> {
        let s = self.source.camera.size();
        if shape != [s.height as usize, s.width as usize] {
            return Err(PyValueError::new_err(format!(
                "{name}: expected the source camera's {}x{} pixels as HxW, got shape {shape:?}",
                s.width, s.height
            )));
        }
        Ok(())
    }

    /// `labels` moved into the target with their line numbers, under the visibility rule
    /// `min_visible` (`(px, share)`; None: off).
    fn moved(
        &self,
        py: Python<'_>,
        labels: &[PyRef<'_, Label>],
        min_visible: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Vec<(MovedLabel, usize)>> {
        let visibility = match min_visible.filter(|v| !v.is_none()) {
            None => Visibility::OFF,
            Some(v) => {
                let [px, share] = crate::vectors::float_array::<2>(v, "min_visible")?;
                Visibility::parse(&format!("{px},{share}"))
                    .map_err(|e| PyValueError::new_err(format!("min_visible: {e}")))?
            }
        };
        let items: Vec<(KittiLabel, usize)> =
            labels.iter().map(|l| (l.label.clone(), l.line)).collect();
        let (src, dst) = (self.source.camera.as_ref(), self.target.camera.as_ref());
        let centre = self.source.centre;
        Ok(py.detach(|| {
            items
                .iter()
                .filter_map(|(label, line)| {
                    move_label(label, &centre, src, dst, &visibility).map(|m| (m, *line))
                })
                .collect()
        }))
    }

    /// The command's table for these cameras (`convert::kitti`'s `table`): a fisheye target
    /// maps only the part of its image a perspective source can reach.
    fn build_table(&self) -> RemapTable {
        let identity = Matrix3::identity();
        let (src, dst) = (self.source.camera.as_ref(), self.target.camera.as_ref());
        let size = src.size();
        // a full 360° panorama as the source: its columns wrap
        let wrap = match src.horizontal_period() {
            Some(p) if (p - size.width as f64).abs() < 1e-6 => Wrap::Horizontal,
            _ => Wrap::None,
        };
        let pinhole = (self.source.turn.is_none()
            && src.projection() == OutputProjection::Linear(Projection::Perspective))
        .then(|| Perspective::new(src.intrinsics(), size));
        // Only the part of the target a pinhole source can reach is mapped (the table is the
        // same: the others take nothing). The command does so for a lens; a drawn camera
        // gains as much (most of a wide view lies beyond a KITTI camera's field of view). The
        // rays a target cannot project lie around its backward axis (none for a panorama).
        let seen = pinhole.as_ref().and_then(|pinhole| {
            let blind = crate::models::axes(&self.target) * -Vector3::z();
            Footprint::new(dst, pinhole, &identity, &blind)
        });
        let src: &dyn CameraModel = match &pinhole {
            Some(p) => p,
            None => src,
        };
        // A turned linear target is built as its unturned camera with the turn as the
        // rotation: the same bearings, bit for bit (`Turned` applies the same product), but
        // unprojected by columns and rows (a `Turned` camera is not separable).
        let unturned = match (self.target.turn, dst.projection()) {
            (Some(turn), OutputProjection::Linear(projection)) => Some((
                projection
                    .camera(dst.intrinsics(), dst.size())
                    .boxed_output(),
                turn,
            )),
            _ => None,
        };
        let (dst, src_from_dst): (&dyn CameraModel, Matrix3<f64>) = match &unturned {
            Some((camera, turn)) => (camera.as_ref(), *turn),
            None => (dst, identity),
        };
        let build = match self.antialias {
            Antialias::Command => {
                let below = match self.target.camera.projection() {
                    OutputProjection::Fisheye => LENS_TAPS_BELOW,
                    OutputProjection::Linear(_) => TAPS_BELOW,
                };
                let (seen, m) = (seen.as_ref(), &src_from_dst);
                // a 360° source's levels wrap as its columns do (`panoconv pano`'s tables)
                return match wrap {
                    Wrap::None => {
                        RemapTable::build_pyramid_above_within(dst, src, m, below, seen, false)
                    }
                    _ => RemapTable::build_pyramid_above_wrap(dst, src, m, wrap, below, false),
                };
            }
            Antialias::Pyramid => RemapTable::build_pyramid_within,
            Antialias::Taps => RemapTable::build_within,
        };
        build(
            dst,
            src,
            &src_from_dst,
            wrap,
            self.supersample,
            seen.as_ref(),
            false,
        )
    }
}

/// The pixel formats `image` takes.
trait Pixel: Element + Copy + Default + Send + Sync + 'static {
    /// The weighted sum of a pixel's taps, in this format's arithmetic.
    type Sum: Copy + Default + Send;
    fn add(sum: &mut Self::Sum, value: Self, weight: i16);
    fn finish(sum: Self::Sum) -> Self;
    /// The pyramid's wider sums of this format, and a level-k value of the sum of 4^k values
    /// (see `panoconv::warp::pyramid`).
    type Wide: Copy + Default + std::ops::Add<Output = Self::Wide>;
    fn widen(value: Self) -> Self::Wide;
    fn narrow(sum: Self::Wide, level: u32) -> Self;
    /// The image through the 8-bit RGB kernels, where they take this format.
    fn kernel(_table: &RemapTable, _src: &[Self], _channels: usize) -> Option<Vec<Self>> {
        None
    }
}

impl Pixel for u8 {
    type Sum = i64;
    fn add(sum: &mut i64, value: u8, weight: i16) {
        *sum += value as i64 * weight as i64;
    }
    // the kernels' rounding (weights sum to at most WEIGHT_ONE: no overflow of 255)
    fn finish(sum: i64) -> u8 {
        ((sum + (RemapTable::WEIGHT_ONE as i64 >> 1)) >> RemapTable::WEIGHT_BITS) as u8
    }
    type Wide = u32;
    fn widen(value: u8) -> u32 {
        value.into()
    }
    // the kernels' pyramid (`RemapTable::input`)
    fn narrow(sum: u32, level: u32) -> u8 {
        narrow_u8(sum, level)
    }
    fn kernel(table: &RemapTable, src: &[u8], channels: usize) -> Option<Vec<u8>> {
        if channels != 3 {
            return None;
        }
        let input = table.input(src);
        let w3 = table.size().width as usize * 3;
        let mut out = vec![0u8; w3 * table.size().height as usize];
        for (v, row) in out.chunks_mut(w3.max(1)).enumerate() {
            table.apply_row_data(&input, v, row);
        }
        Some(out)
    }
}

impl Pixel for u16 {
    type Sum = i64;
    fn add(sum: &mut i64, value: u16, weight: i16) {
        *sum += value as i64 * weight as i64;
    }
    fn finish(sum: i64) -> u16 {
        ((sum + (RemapTable::WEIGHT_ONE as i64 >> 1)) >> RemapTable::WEIGHT_BITS) as u16
    }
    type Wide = u64;
    fn widen(value: u16) -> u64 {
        value.into()
    }
    fn narrow(sum: u64, level: u32) -> u16 {
        ((sum + (1 << (2 * level - 1))) >> (2 * level)) as u16
    }
}

impl Pixel for f32 {
    type Sum = f64;
    fn add(sum: &mut f64, value: f32, weight: i16) {
        *sum += value as f64 * weight as f64;
    }
    fn finish(sum: f64) -> f32 {
        (sum / RemapTable::WEIGHT_ONE as f64) as f32
    }
    type Wide = f64;
    fn widen(value: f32) -> f64 {
        value.into()
    }
    fn narrow(sum: f64, level: u32) -> f32 {
        (sum / (1u64 << (2 * level)) as f64) as f32
    }
}

/// `src` (H×W×C, standard layout, the table's source size) or its pyramid: what the table's
/// blocks address.
fn input<'a, T: Pixel>(table: &RemapTable, src: &'a [T], channels: usize) -> Cow<'a, [T]> {
    match table.levels() {
        1 => src.into(),
        levels => {
            let size = table.source_size();
            pyramid(src, size, channels, levels, T::widen, T::narrow).into()
        }
    }
}

/// Resamples `src` (H×W×C, standard layout) through the table's blocks.
fn resample<T: Pixel>(table: &RemapTable, src: &[T], channels: usize) -> Vec<T> {
    let (sw, sh) = (
        table.source_size().width as usize,
        table.input_rows() as usize,
    );
    let src = input(table, src, channels);
    let (w, h) = (table.size().width as usize, table.size().height as usize);
    let mut out = Vec::with_capacity(w * h * channels);
    let mut sums = vec![T::Sum::default(); w * channels];
    for v in 0..h {
        sums.iter_mut().for_each(|s| *s = T::Sum::default());
        table.row_blocks(v, |u, pixel, weights| {
            // top-left, bottom-left, top-right, bottom-right; a zero weight may lie outside
            let taps = [pixel, pixel + sw, pixel + 1, pixel + sw + 1];
            for (&p, &wt) in taps.iter().zip(&weights) {
                if wt != 0 && p < sw * sh {
                    for c in 0..channels {
                        T::add(&mut sums[u * channels + c], src[p * channels + c], wt);
                    }
                }
            }
        });
        out.extend(sums.iter().map(|&s| T::finish(s)));
    }
    out
}

/// The table's inside pixels whose every tap of non-zero weight falls on a `covered` source
/// pixel (row-major over the source; a pyramid level's pixel is covered where its four finer
/// ones are).
fn within(table: &RemapTable, covered: &[bool]) -> Vec<bool> {
    let covered = match table.levels() {
        1 => Cow::from(covered),
        // (covered where all 4^k are: a count of them)
        levels => pyramid(
            covered,
            table.source_size(),
            1,
            levels,
            u32::from,
            |n, k| n == 1 << (2 * k),
        )
        .into(),
    };
    let sw = table.source_size().width as usize;
    let w = table.size().width as usize;
    let mut mask = table.inside();
    for (v, row) in mask.chunks_mut(w.max(1)).enumerate() {
        table.row_blocks(v, |u, pixel, weights| {
            // top-left, bottom-left, top-right, bottom-right, as `resample` takes them
            let taps = [pixel, pixel + sw, pixel + 1, pixel + sw + 1];
            for (&p, &wt) in taps.iter().zip(&weights) {
                if wt != 0 && !covered.get(p).copied().unwrap_or(false) {
                    row[u] = false;
                }
            }
        });
    }
    mask
}

/// The image through the table: the 8-bit RGB kernels for `HxWx3` uint8 (the command's bytes),
/// the same blocks in each format's arithmetic otherwise.
fn warp_array<T: Pixel>(table: &RemapTable, src: ArrayViewD<'_, T>) -> ArrayD<T> {
    let channels = if src.ndim() == 3 { src.shape()[2] } else { 1 };
    let data = src.as_standard_layout();
    let data = data.as_slice().expect("standard layout");
    let (w, h) = (table.size().width as usize, table.size().height as usize);
    let out = T::kernel(table, data, channels).unwrap_or_else(|| resample(table, data, channels));
    let shape: Vec<usize> = match src.ndim() {
        3 => vec![h, w, channels],
        _ => vec![h, w],
    };
    ArrayD::from_shape_vec(IxDyn(&shape), out).expect("shape")
}

/// `image` for one pixel format.
fn image_of<'py, T: Pixel>(
    py: Python<'py>,
    table: &RemapTable,
    array: PyReadonlyArrayDyn<'py, T>,
) -> Bound<'py, PyArrayDyn<T>> {
    let view = array.as_array();
    let out = py.detach(|| warp_array(table, view));
    PyArrayDyn::from_owned_array(py, out)
}

#[pymethods]
impl Warp {
    /// The warp from camera `src` to camera `dst`, with `dst` placed at `src`'s optical
    /// centre. `supersample`: the largest source-pixel footprint of a target pixel that is
    /// averaged (1: plain bilinear; 8, the default: antialiased up to 8 source pixels a
    /// pixel). `antialias`: how a target pixel two or more source pixels wide averages them:
    /// `"pyramid"` (the default: one to a few bilinear taps in the source's 2×2-box pyramid,
    /// about the cost of bilinear), `"taps"` (a tap per source pixel) or `"command"` (the
    /// command's rule and bytes: the taps below 2 source pixels, 3 for a fisheye target, the
    /// pyramid above; with `supersample` 8). The table is built on first use (`image`,
    /// `mask`, `build`) and kept.
    #[new]
    #[pyo3(signature = (src, dst, supersample=8, antialias="pyramid"))]
    fn new(src: &Camera, dst: &Camera, supersample: u32, antialias: &str) -> PyResult<Self> {
        if !(1..=MAX_SUPERSAMPLE).contains(&supersample) {
            return Err(PyValueError::new_err(format!(
                "supersample must be 1 to {MAX_SUPERSAMPLE}, not {supersample}"
            )));
        }
        let Some(&(_, antialias)) = Antialias::NAMES.iter().find(|(n, _)| *n == antialias) else {
            return Err(PyValueError::new_err(format!(
                "antialias must be \"pyramid\", \"taps\" or \"command\", not {antialias:?}"
            )));
        };
        if antialias == Antialias::Command && supersample != MAX_SUPERSAMPLE {
            return Err(PyValueError::new_err(format!(
                "antialias=\"command\" is the command's supersample {MAX_SUPERSAMPLE}, not {supersample}"
            )));
        }
        Ok(Warp {
            source: src.at(src.centre),
            target: dst.at(src.centre),
            supersample,
            antialias,
            table: OnceLock::new(),
        })
    }

    /// How a target pixel two or more source pixels wide is antialiased: `"pyramid"`,
    /// `"taps"` or `"command"`.
    #[getter]
    fn antialias(&self) -> &'static str {
        let named = Antialias::NAMES.iter().find(|(_, a)| *a == self.antialias);
        named.map_or("pyramid", |(n, _)| n)
    }

    /// Builds the table now (else on first use). Returns self.
    fn build(slf: Bound<'_, Self>) -> Bound<'_, Self> {
        slf.get().table(slf.py());
        slf
    }

    /// The source camera.
    #[getter]
    fn src(&self) -> Camera {
        self.source.at(self.source.centre)
    }

    /// The target camera, at the source's optical centre.
    #[getter]
    fn dst(&self) -> Camera {
        self.target.at(self.target.centre)
    }

    /// The largest source-pixel footprint of a target pixel that is averaged.
    #[getter]
    fn supersample(&self) -> u32 {
        self.supersample
    }

    /// Whether the table has been built.
    #[getter]
    fn built(&self) -> bool {
        self.table.get().is_some()
    }

    /// The source image (`HxW`, `HxWx3` or `HxWx4`; uint8, uint16 or float32, any layout) in
    /// the target camera: same dtype and channels, the target's size, black where the source
    /// does not reach. `HxWx3` uint8 gives the bytes the command writes.
    fn image<'py>(
        &self,
        py: Python<'py>,
        array: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let s = self.source.camera.size();
        let untyped = array.cast::<numpy::PyUntypedArray>().map_err(|_| {
            PyTypeError::new_err("image: expected a numpy array (HxW, HxWx3 or HxWx4)")
        })?;
        let shape = untyped.shape().to_vec();
        let ok = match shape[..] {
            [h, w] | [h, w, 1 | 3 | 4] => (w, h) == (s.width as usize, s.height as usize),
            _ => false,
        };
        if !ok {
            return Err(PyValueError::new_err(format!(
                "image: expected the source camera's {}x{} pixels as HxW, HxWx3 or HxWx4, got shape {shape:?}",
                s.width, s.height
            )));
        }
        let table = self.table(py);
        if let Ok(a) = array.extract::<PyReadonlyArrayDyn<'py, u8>>() {
            return Ok(image_of(py, table, a).into_any());
        }
        if let Ok(a) = array.extract::<PyReadonlyArrayDyn<'py, u16>>() {
            return Ok(image_of(py, table, a).into_any());
        }
        if let Ok(a) = array.extract::<PyReadonlyArrayDyn<'py, f32>>() {
            return Ok(image_of(py, table, a).into_any());
        }
        Err(PyTypeError::new_err(format!(
            "image: expected uint8, uint16 or float32 pixels, got {}",
            untyped.dtype()
        )))
    }

    /// Where the source gives the target's pixels (every tap of the pixel inside the source
    /// image): `HxW` bool, the command's `--mask`.
    #[getter]
    fn mask<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<bool>> {
        let table = self.table(py);
        let s = table.size();
        let m = Array2::from_shape_vec((s.height as usize, s.width as usize), table.inside())
            .expect("one value a pixel");
        PyArray2::from_owned_array(py, m)
    }

    /// Fraction of the target's pixels with at least one tap inside the source.
    #[getter]
    fn coverage(&self, py: Python<'_>) -> f64 {
        self.table(py).coverage()
    }

    /// The labels (`read_labels`) in the target camera, as `panoconv kitti` writes them: each
    /// object's exact 2D box (curved edges, the ±180° seam rule) and truncation, each DontCare
    /// region's box through the source camera; the labels with no image in the target are
    /// left out. 3D boxes keep their rect values (the target's axes are `dst.R`).
    /// `min_visible=(px, share)` is the command's `--min-visible`: an object whose box is
    /// narrower than `px` or has less than `share` of its full box in the image is written as
    /// a DontCare region (None: every object, `0,0`).
    #[pyo3(signature = (labels, min_visible=None))]
    fn labels(
        &self,
        py: Python<'_>,
        labels: Vec<PyRef<'_, Label>>,
        min_visible: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Vec<Label>> {
        let moved = self.moved(py, &labels, min_visible)?;
        moved
            .into_iter()
            .map(|(m, line)| {
                let parsed = KittiLabel::parse(Path::new("<Warp.labels>"), line, &m.line)
                    .map_err(crate::errors::to_py)?;
                Ok(Label::new(parsed, line))
            })
            .collect()
    }

    /// How many of `labels` are objects in the target, as `--min-objects` counts them: the
    /// objects `labels(labels, min_visible)` writes as objects (DontCare regions aside).
    #[pyo3(signature = (labels, min_visible=None))]
    fn count_objects(
        &self,
        py: Python<'_>,
        labels: Vec<PyRef<'_, Label>>,
        min_visible: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<usize> {
        let moved = self.moved(py, &labels, min_visible)?;
        Ok(moved.iter().filter(|(m, _)| m.object).count())
    }

    /// The LiDAR depth map of rect points `(N, 3)` in the target camera, `HxW` float64
    /// metres (0: no point): each pixel's nearest point by the target's own distance (z,
    /// range or ρ), only points inside the source image, with the occlusion filter unless
    /// `occlusion=False` (the command's `--depth` and `--no-occlusion-filter`). Non-finite
    /// rows are dropped. `round(d·256)` is the command's 16-bit `depth_2` value.
    #[pyo3(signature = (points_rect, occlusion=true))]
    fn depth<'py>(
        &self,
        py: Python<'py>,
        points_rect: PyArrayLike2<'py, f64, AllowTypeChange>,
        occlusion: bool,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        crate::warp_depth::of_points(py, self, points_rect, occlusion)
    }

    /// `depth(read_velodyne(path, calib), occlusion)`, the scan's points taken as the file is
    /// read (no array of them in between): what `RandomCameraDataset` takes for a frame with
    /// a `velodyne/` scan.
    #[pyo3(signature = (path, calib, occlusion=true))]
    fn depth_velodyne<'py>(
        &self,
        py: Python<'py>,
        path: std::path::PathBuf,
        calib: &crate::calib::Calib,
        occlusion: bool,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        crate::warp_depth::of_velodyne(py, self, &path, calib, occlusion)
    }

    /// The source's own depth map in the target: `depth` (`HxW` metres over the source's
    /// pixels, 0 where none: `read_depth` of a `depth_2`) taken as the 3D point of each pixel
    /// that holds one (the pixel's ray at that distance, the one the source's projection pairs
    /// with: z, range or ρ), each target pixel the nearest of the points landing on it by the
    /// target's own distance (`depth`'s rule, without its occlusion filter: the cameras share
    /// their optical centre, so no point hides another that the source kept). `HxW` float64
    /// metres, 0 where no point lands.
    fn depth_map<'py>(
        &self,
        py: Python<'py>,
        depth: PyArrayLike2<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        crate::warp_depth::of_source_map(py, self, depth)
    }

    /// `mask` within the source's coverage: where every tap of the target's pixel lies inside
    /// the source image on a pixel that `coverage` (`HxW` bool over the source's pixels: where
    /// its image holds data, e.g. `source_2` != 255 of a rig's panorama, or `mask_2`) marks.
    fn mask_within<'py>(
        &self,
        py: Python<'py>,
        coverage: PyArrayLike2<'py, bool, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray2<bool>>> {
        let coverage = coverage.as_array();
        self.check_source_pixels(coverage.shape(), "coverage")?;
        let table = self.table(py);
        let covered = coverage.as_standard_layout();
        let covered = covered.as_slice().expect("standard layout");
        let mask = py.detach(|| within(table, covered));
        let size = table.size();
        let m = Array2::from_shape_vec((size.height as usize, size.width as usize), mask)
            .expect("one value a pixel");
        Ok(PyArray2::from_owned_array(py, m))
    }

    fn __repr__(&self) -> String {
        let (s, d) = (self.source.camera.size(), self.target.camera.size());
        format!(
            "Warp({} {s} -> {} {d}, built={})",
            self.source.camera.projection().name(),
            self.target.camera.projection().name(),
            self.built()
        )
    }
}
