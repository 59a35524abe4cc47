//! `Warp`'s LiDAR depth maps: of rect points, of a velodyne scan file as it is read, and of
//! the source's own depth map.

use crate::warp::Warp;
use nalgebra::{Point2, Vector3};
use ndarray::Array2;
use numpy::{AllowTypeChange, PyArray2, PyArrayLike2};
use panoconv::kitti::velodyne;
use panoconv::reproject::depth::{depth_map, DepthMap, DepthPoints, OcclusionFilter};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::Path;

use crate::errors::IntoPy;

/// `Warp.depth`: rect points `(N, 3)`, non-finite rows dropped.
pub(crate) fn of_points<'py>(
    py: Python<'py>,
    warp: &Warp,
    points_rect: PyArrayLike2<'py, f64, AllowTypeChange>,
    occlusion: bool,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let points = points_rect.as_array();
    if points.ncols() != 3 {
        return Err(PyValueError::new_err(format!(
            "points_rect: expected an (N, 3) array, got shape {:?}",
            points.shape()
        )));
    }
    let (src, dst, centre) = warp.depth_cameras();
    let map = py.detach(|| {
        let finite = points
            .rows()
            .into_iter()
            .map(|r| Vector3::new(r[0], r[1], r[2]))
            .filter(|p| p.iter().all(|v| v.is_finite()));
        let filter = occlusion.then(OcclusionFilter::default);
        depth_map(finite, &centre, dst, src, filter.as_ref()).0
    });
    Ok(to_array(py, map))
}

/// `Warp.depth_velodyne`: `of_points` of the scan's rect points (a scan drops its non-finite
/// points as `read_velodyne` does), each projected as it is read.
pub(crate) fn of_velodyne<'py>(
    py: Python<'py>,
    warp: &Warp,
    path: &Path,
    calib: &crate::calib::Calib,
    occlusion: bool,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let (r0, tr) = crate::io::velo_to_rect(calib)?;
    let (src, dst, centre) = warp.depth_cameras();
    let map = py
        .detach(|| {
            let mut points = DepthPoints::new(&centre, dst, src);
            // (a chunk of the file at a time, in lanes: `rect_from_velo_map`'s bits)
            velodyne::for_each_chunk(path, &mut Default::default(), |columns| {
                velodyne::rect_from_velo_columns(&r0, &tr, columns);
                let [x, y, z] = &*columns;
                points.push_columns([x, y, z]);
            })?;
            let filter = occlusion.then(OcclusionFilter::default);
            Ok::<_, panoconv::error::Error>(points.finish(filter.as_ref()).0)
        })
        .py()?;
    Ok(to_array(py, map))
}

/// `Warp.depth_map`: the source's own depth map (`HxW` metres over its pixels), each pixel
/// that holds a distance taken as its ray's point at that distance.
pub(crate) fn of_source_map<'py>(
    py: Python<'py>,
    warp: &Warp,
    depth: PyArrayLike2<'py, f64, AllowTypeChange>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let depth = depth.as_array();
    warp.check_source_pixels(depth.shape(), "depth")?;
    let (src, dst, centre) = warp.depth_cameras();
    let map = py.detach(|| {
        let points: Vec<Vector3<f64>> = depth
            .indexed_iter()
            .filter(|(_, d)| **d > 0.0 && d.is_finite())
            .filter_map(|((v, u), &d)| {
                let ray = src.unproject(&Point2::new(u as f64, v as f64)).ok()?;
                let t = d / src.distance(&ray);
                (t > 0.0 && t.is_finite()).then(|| centre + ray * t)
            })
            .collect();
        depth_map(points, &centre, dst, src, None).0
    });
    Ok(to_array(py, map))
}

fn to_array(py: Python<'_>, map: DepthMap) -> Bound<'_, PyArray2<f64>> {
    let values = Array2::from_shape_vec((map.height as usize, map.width as usize), map.values)
        .expect("shape");
    PyArray2::from_owned_array(py, values)
}
