//! panoconv: adapt rectilinear driving datasets (KITTI) to panoramic, cylindrical and fisheye
//! cameras. Images, 2D/3D labels and calibration are reprojected exactly; see `docs/` and the
//! README for the conventions.

pub mod image;
pub mod style;
