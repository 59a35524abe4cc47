//! `panoconv._native`: the Python module's compiled part (PyO3). The Python package
//! (`python/panoconv/`) re-exports it; docs/python.md describes the API.

use panoconv::run::alloc::KeepLarge;
use pyo3::prelude::*;

/// The module's own allocations keep their large freed blocks for the next sample (a loader
/// allocates the same buffers every sample); Python's and other libraries' malloc is left as
/// it is.
#[global_allocator]
static ALLOCATOR: KeepLarge = KeepLarge::new();

mod calib;
mod camera;
mod camera_core;
mod dataset;
mod errors;
mod io;
mod labels;
mod manifest;
mod models;
mod redraw;
mod rig;
mod turned;
mod vectors;
mod warp;
mod warp_depth;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("PanoconvError", py.get_type::<errors::PanoconvError>())?;
    m.add("ParseError", py.get_type::<errors::ParseError>())?;
    m.add_class::<camera::Camera>()?;
    m.add_class::<calib::Calib>()?;
    m.add_class::<labels::Label>()?;
    m.add_class::<dataset::Dataset>()?;
    m.add_class::<dataset::Frame>()?;
    m.add_class::<dataset::FrameIter>()?;
    m.add_class::<manifest::VerifyReport>()?;
    m.add_class::<warp::Warp>()?;
    m.add_function(wrap_pyfunction!(calib::read_calib, m)?)?;
    m.add_function(wrap_pyfunction!(camera::crop_resize, m)?)?;
    m.add_function(wrap_pyfunction!(labels::read_labels, m)?)?;
    m.add_function(wrap_pyfunction!(labels::box_2d, m)?)?;
    m.add_function(wrap_pyfunction!(labels::box_corners, m)?)?;
    m.add_function(wrap_pyfunction!(manifest::read_manifest, m)?)?;
    m.add_function(wrap_pyfunction!(manifest::verify, m)?)?;
    m.add_function(wrap_pyfunction!(models::read_camera, m)?)?;
    m.add_function(wrap_pyfunction!(redraw::best_draw, m)?)?;
    m.add_function(wrap_pyfunction!(io::read_image, m)?)?;
    m.add_function(wrap_pyfunction!(io::read_depth, m)?)?;
    m.add_function(wrap_pyfunction!(io::read_velodyne, m)?)?;
    m.add_function(wrap_pyfunction!(rig::_camera_wire, m)?)?;
    Ok(())
}
