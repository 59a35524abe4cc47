//! The commands around a conversion: preview, inspect, verify, depth evaluation, predictions
//! back to KITTI, and the synthetic sample.

pub mod eval_depth;
pub mod inspect;
pub mod predictions;
pub mod preview;
pub mod synth;
pub mod verify;
