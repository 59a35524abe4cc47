//! The converters: a KITTI dataset (object or raw) to a projection or a fisheye camera, and
//! folders of panoramas or fisheye images to views.

pub mod folder;
pub mod kitti;
pub mod pano;
