//! The commands around a conversion: preview, inspect, verify, depth evaluation, predictions
//! back to KITTI, and the synthetic samples (KITTI, KITTI-360 and nuScenes).

pub mod depth_array;
pub mod eval_depth;
pub mod inspect;
mod inspect_files;
mod inspect_p2;
mod inspect_pandaset;
pub mod inspect_rig;
pub mod predictions;
pub mod preview;
pub mod synth;
pub mod synth360;
pub mod synth_nuscenes;
pub mod unproject;
pub mod verify;
