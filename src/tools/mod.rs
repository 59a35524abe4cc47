//! The commands around a conversion: preview, inspect, verify, depth evaluation, predictions
//! back to KITTI, and the synthetic samples (KITTI and KITTI-360).

pub mod depth_array;
pub mod eval_depth;
pub mod inspect;
pub mod predictions;
pub mod preview;
pub mod synth;
pub mod synth360;
pub mod unproject;
pub mod verify;
