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

mod level;
mod object;
mod pose;
mod region;
mod rig;
mod rig_source;

pub use level::world_from_level;
pub use object::SourceBox;
pub use pose::Pose;
pub use region::SourceRegion;
pub use rig::RigCamera;
pub use rig_source::{
    record_value, CameraInfo, RigItem, RigItems, RigSource, SourceCamera, SourceFrame,
};

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
    /// The LiDAR's axes in the reference frame, where the dataset has a LiDAR.
    pub reference_from_lidar: Option<Pose>,
    /// The IMU (the vehicle's pose sensor) in the LiDAR's axes, where the dataset has one.
    pub lidar_from_imu: Option<Pose>,
    /// blake3 (hex) of the per-frame input files this read took, by path: a run records
    /// these instead of reading the files a second time.
    pub input_hashes: Vec<(PathBuf, String)>,
}

impl Frame {
    /// The rig camera called `name`.
    pub fn camera(&self, name: &str) -> Option<&RigCamera> {
        self.rig.iter().find(|c| c.name == name)
    }
}
