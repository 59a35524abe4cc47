//! Moving annotations with the image: neutral 2D/3D boxes into the output camera, LiDAR into a
//! depth map. Below the dataset readers: it knows none of their formats.

pub mod depth;
pub mod labels;
pub(crate) mod source_box;
