//! The manifest's records: what each frame read and wrote, with hashes.

use serde::Serialize;

/// The manifest's file name, at the output's root.
pub const MANIFEST: &str = "panoconv.json";

#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct FrameRecord {
    pub split: String,
    pub id: String,
    pub status: FrameStatus,
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

#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct LidarRecord {
    pub points: usize,
    pub dropped_non_finite: usize,
    pub dropped_occluded: usize,
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

#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct ViewRecord {
    pub id: String,
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub view: Option<crate::geometry::augment::View>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FrameStatus {
    Ok,
    Failed,
}
