//! The manifest's records: what each frame read and wrote, with hashes.

use serde::Serialize;

pub use crate::run::names::MANIFEST;

/// One item's entry in the manifest's `frames` list (and one line of the journal).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct FrameRecord {
    /// The KITTI split (`training`, `testing` or a raw drive); empty for a folder image.
    pub split: String,
    /// The frame id (image file stem), or a folder image's file name.
    pub id: String,
    /// Whether the item was converted or failed.
    pub status: FrameStatus,
    /// Why the item failed (the error as the run reported it); absent when it succeeded.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Input file (relative to the input root) → blake3.
    pub inputs: Vec<(String, String)>,
    /// Output file (relative to the output root) → blake3.
    pub outputs: Vec<(String, String)>,
    /// With --augment: each view's output id and how it was drawn.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub views: Vec<ViewRecord>,
    /// With --depth: what happened to the LiDAR points (of the last view).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lidar: Option<LidarRecord>,
}

/// What the `--depth` map of a frame made of its LiDAR scan (the manifest's `lidar` key).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct LidarRecord {
    /// Points in the velodyne scan, non-finite ones included.
    pub points: usize,
    /// Points dropped for a NaN or infinite coordinate.
    pub dropped_non_finite: usize,
    /// Points the occlusion filter removed (0 without the filter).
    pub dropped_occluded: usize,
    /// Pixels of the written depth map that hold a depth.
    pub depth_pixels: usize,
}

impl FrameRecord {
    /// The record of a frame that failed: its error, no outputs.
    pub fn failed(split: &str, id: &str, error: &crate::error::Error) -> Self {
        Self {
            split: split.to_owned(),
            id: id.to_owned(),
            status: FrameStatus::Failed,
            error: Some(error.to_string()),
            inputs: Vec::new(),
            outputs: Vec::new(),
            views: Vec::new(),
            lidar: None,
        }
    }
}

/// One `--augment` view of a frame, in the record's `views` list.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct ViewRecord {
    /// The view's output frame id (see [`crate::geometry::augment::view_id`]).
    pub id: String,
    /// How the view was drawn (scale, scaled size, crop, attempt), flattened into this object.
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub view: Option<crate::geometry::augment::View>,
}

/// A frame record's `status` (`"ok"` or `"failed"` in the JSON).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FrameStatus {
    /// Every output of the item was written and is listed.
    Ok,
    /// The item failed: its `error` says why, and it lists no outputs.
    Failed,
}
