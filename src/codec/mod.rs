//! Image file formats: PNG (read and write, with a direct fast path for KITTI's 8-bit RGB) and
//! JPEG (read).

pub mod jpeg;
pub mod png;
