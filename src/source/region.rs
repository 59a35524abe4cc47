//! [`SourceRegion`]: an annotation that a dataset gives only as a 2D box in one source
//! camera's pixels: an ignore region (KITTI's `DontCare`: objects there are not labelled), or
//! an object the dataset gives no 3D box. It follows the image through that camera's bearings.

/// A 2D box in a source camera's image.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceRegion {
    /// The index in the frame's rig of the camera whose pixels `bounds` are in.
    pub camera: usize,
    /// [left, top, right, bottom], source pixels.
    pub bounds: [f64; 4],
    /// The object's class; None for an ignore region.
    pub class: Option<String>,
}

impl SourceRegion {
    /// Whether the region is an ignore region (no object), not an object.
    pub fn is_ignore(&self) -> bool {
        self.class.is_none()
    }
}
