//! Neutral frames: what any dataset reader yields, whatever its files look like.
//!
//! A [`Frame`] is one moment of a drive: its id and the input files it came from, a rig of
//! source cameras (each a camera model from `camera/` with its pose and its image), the 3D
//! objects as neutral boxes ([`SourceBox`]), the annotations that are only 2D boxes in a
//! camera's image ([`SourceRegion`]: ignore regions), the LiDAR points, and the frame's place in the
//! dataset's world. Everything geometric is in the frame's *reference frame*, whose axes are
//! the camera convention (x right, y down, z forward, metres), so that downstream code (warps,
//! labels, depth) treats a KITTI frame and a KITTI-360 frame alike. Readers fill these types;
//! nothing here reads a file.

mod object;
mod pose;
mod region;
mod rig;

pub use object::SourceBox;
pub use pose::Pose;
pub use region::SourceRegion;
pub use rig::RigCamera;

use nalgebra::Vector3;
use std::path::PathBuf;

/// A LiDAR point in the frame's reference frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LidarPoint {
    /// Position, metres, reference frame.
    pub position: Vector3<f64>,
    /// Reflectance as the scan stores it (0 to 1 for Velodyne scans).
    pub intensity: f32,
}

/// One frame of a dataset in neutral form.
#[derive(Debug, Clone)]
pub struct Frame {
    /// The frame's id (e.g. the dataset's frame number), used to name outputs.
    pub id: String,
    /// The input files the frame was read from, for the manifest.
    pub provenance: Vec<PathBuf>,
    /// The source cameras, in the dataset's order.
    pub rig: Vec<RigCamera>,
    /// The annotated 3D objects.
    pub objects: Vec<SourceBox>,
    /// The annotations given only in a camera's pixels (KITTI's DontCare regions).
    pub regions: Vec<SourceRegion>,
    /// LiDAR points (empty when the frame has no scan or it was not asked for).
    pub lidar: Vec<LidarPoint>,
    /// Reference frame to the dataset's world frame, where the dataset has one.
    pub world_from_reference: Option<Pose>,
}

impl Frame {
    /// The rig camera called `name`.
    pub fn camera(&self, name: &str) -> Option<&RigCamera> {
        self.rig.iter().find(|c| c.name == name)
    }
}
