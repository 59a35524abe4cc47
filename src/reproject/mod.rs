//! Moving annotations with the image: 2D/3D labels into the output camera, LiDAR into a depth
//! map, and predictions in output pixels back to KITTI's rectified camera.

pub mod depth;
pub mod labels;
pub(crate) mod source_box;
pub mod unproject;
pub mod visibility;
