//! The converters: a KITTI dataset (object or raw) to a projection or a fisheye camera, a
//! camera rig's frames (KITTI-360) into one output camera, and folders of panoramas or fisheye
//! images to views.

mod augment_draw;
pub mod canvas_flags;
pub mod folder;
pub mod kitti;
pub mod pano;
pub mod rig;
pub mod run_options;
mod style_pass;
mod view_depth;
mod view_pass;

pub use augment_draw::best_draw;
