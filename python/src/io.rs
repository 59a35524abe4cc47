//! Reading the images and depth maps of a dataset into numpy arrays (the package depends on
//! numpy alone: no image library needed to feed `Warp`).

use crate::errors::IntoPy;
use ndarray::{Array2, Array3};
use numpy::{PyArray2, PyArray3};
use panoconv::codec::{self, png};
use panoconv::fs::read_file;
use panoconv::kitti::velodyne;
use pyo3::prelude::*;
use std::path::PathBuf;

/// An image file (PNG, JPEG, TIFF, WebP) as `HxWx3` uint8 RGB.
#[pyfunction]
pub fn read_image(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyArray3<u8>>> {
    let image = py
        .detach(|| read_file(&path).and_then(|bytes| codec::decode_rgb8(&bytes, &path)))
        .py()?;
    let (w, h) = (image.width() as usize, image.height() as usize);
    let array = Array3::from_shape_vec((h, w, 3), image.into_raw()).expect("HxWx3");
    Ok(PyArray3::from_owned_array(py, array))
}

/// A 16-bit depth map PNG (`depth_2/`, KITTI's encoding round(d·256)) as `HxW` float64
/// metres, 0 where there is no depth.
#[pyfunction]
pub fn read_depth(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyArray2<f64>>> {
    let (w, h, values) = py
        .detach(|| read_file(&path).and_then(|bytes| png::decode_gray16(&bytes, &path)))
        .py()?;
    let metres: Vec<f64> = values.iter().map(|&d| d as f64 / 256.0).collect();
    let array = Array2::from_shape_vec((h as usize, w as usize), metres).expect("HxW");
    Ok(PyArray2::from_owned_array(py, array))
}

/// The points of a Velodyne scan (`velodyne/<id>.bin`) in rect, `(N, 3)` metres, as the
/// command's `--depth` takes them: R0_rect · Tr_velo_to_cam · p in its order of operations,
/// points with a non-finite coordinate dropped.
#[pyfunction]
pub fn read_velodyne<'py>(
    py: Python<'py>,
    path: PathBuf,
    calib: &crate::calib::Calib,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let (r0, tr) = velo_to_rect(calib)?;
    // (the rows made as the file is read, mapped to rect in lanes: `rect_from_velo_map`'s
    // bits; no vector of points between the scan and the array)
    let rows = py
        .detach(|| {
            let points = std::fs::metadata(&path).map_or(0, |m| m.len() as usize / 16);
            let mut rows: Vec<[f64; 3]> = Vec::with_capacity(points);
            velodyne::for_each_chunk(&path, &mut Default::default(), |columns| {
                velodyne::rect_from_velo_columns(&r0, &tr, columns);
                let [x, y, z] = &*columns;
                rows.extend((0..x.len()).map(|i| [x[i], y[i], z[i]]));
            })
            .map(|_| rows)
        })
        .py()?;
    Ok(PyArray2::from_owned_array(py, Array2::from(rows)))
}

/// A calib's R0_rect and Tr_velo_to_cam, or the error naming its file where a line is missing.
pub(crate) fn velo_to_rect(
    calib: &crate::calib::Calib,
) -> PyResult<(nalgebra::Matrix3<f64>, nalgebra::Matrix3x4<f64>)> {
    let c = &calib.calib;
    match (c.r0_rect, c.tr_velo_to_cam) {
        (Some(r0), Some(tr)) => Ok((r0, tr)),
        _ => Err(crate::errors::to_py(panoconv::error::Error::file(
            &c.path,
            "no R0_rect or Tr_velo_to_cam line (needed for LiDAR points)",
        ))),
    }
}
