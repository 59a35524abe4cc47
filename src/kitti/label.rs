//! KITTI label files (`label_2/NNNNNN.txt`): 15 fields per object, 16 with a score.
//!
//! The original tokens are kept so that the fields panoconv does not change (everything but the
//! 2D box and the truncation) are written back byte for byte.

use crate::error::{Error, Result};
use crate::fs::read_lines;
use crate::source::{SourceBox, SourceRegion};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

const FIELD_NAMES: [&str; 16] = [
    "type",
    "truncated",
    "occluded",
    "alpha",
    "bbox.left",
    "bbox.top",
    "bbox.right",
    "bbox.bottom",
    "dimensions.height",
    "dimensions.width",
    "dimensions.length",
    "location.x",
    "location.y",
    "location.z",
    "rotation_y",
    "score",
];

/// The class KITTI gives its ignore regions: an area whose objects are not labelled, never an
/// object itself.
pub const DONT_CARE: &str = "DontCare";

/// What a label's class means to panoconv: an object of a named class, or an ignore region.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LabelClass<'a> {
    /// An object (`Car`, `Pedestrian`, ...): it has a 3D box.
    Object(&'a str),
    /// A `DontCare` region: a 2D box only.
    DontCare,
}

/// One object of a KITTI label file (`label_2/NNNNNN.txt`), in camera 2's rect frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Label {
    /// The line's tokens as read (15 or 16).
    pub tokens: Vec<String>,
    /// The class: `Car`, `Pedestrian`, ..., or `DontCare` for an ignored region.
    pub kind: String,
    /// How much of the object leaves the image, 0 (inside) to 1.
    pub truncated: f64,
    /// 0 visible, 1 partly occluded, 2 largely occluded, 3 unknown.
    pub occluded: i32,
    /// Observation angle, radians in [−π, π].
    pub alpha: f64,
    /// left, top, right, bottom in pixels.
    pub bbox: [f64; 4],
    /// height, width, length in metres.
    pub dimensions: [f64; 3],
    /// Bottom centre of the 3D box in rect, metres.
    pub location: Vector3<f64>,
    /// Heading about rect's y axis, radians in [−π, π] (0: facing the camera's x axis).
    pub rotation_y: f64,
    /// The 16th column of detections, absent from ground truth.
    pub score: Option<f64>,
}

/// A label file: its objects in line order (blank lines skipped).
#[derive(Debug, Clone)]
pub struct LabelFile {
    /// The file it was read from (errors name it).
    pub path: PathBuf,
    /// One per non-blank line.
    pub labels: Vec<Label>,
}

impl LabelFile {
    /// Reads and parses a label file; errors name the file, line and field.
    pub fn read(path: &Path) -> Result<LabelFile> {
        Self::parse(path, read_lines(path)?)
    }

    /// Parses the lines of `path` (already read).
    pub fn parse(path: &Path, lines: Vec<String>) -> Result<LabelFile> {
        let mut labels = Vec::new();
        for (i, line) in lines.iter().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            labels.push(Label::parse(path, i + 1, line)?);
        }
        Ok(LabelFile {
            path: path.to_path_buf(),
            labels,
        })
    }
}

impl Label {
    /// Parses line `line_no` of `path` (15 tokens, or 16 with a score).
    pub fn parse(path: &Path, line_no: usize, line: &str) -> Result<Label> {
        let tokens: Vec<String> = line.split_whitespace().map(str::to_owned).collect();
        if tokens.len() != 15 && tokens.len() != 16 {
            return Err(Error::parse(
                path,
                line_no,
                "fields",
                format!("expected 15 fields (16 with score), found {}", tokens.len()),
            ));
        }
        let num = |i: usize| -> Result<f64> {
            let t = &tokens[i];
            match t.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                Ok(_) => Err(Error::parse(
                    path,
                    line_no,
                    FIELD_NAMES[i],
                    format!("{t:?} is not finite"),
                )),
                Err(_) => Err(Error::parse(
                    path,
                    line_no,
                    FIELD_NAMES[i],
                    format!("{t:?} is not a number"),
                )),
            }
        };
        let occluded = num(2)?;
        if occluded.fract() != 0.0 {
            return Err(Error::parse(
                path,
                line_no,
                FIELD_NAMES[2],
                format!("{:?} is not an integer", tokens[2]),
            ));
        }
        let dimensions = [num(8)?, num(9)?, num(10)?];
        // Only DontCare rows carry KITTI's -1 placeholders; an object with a flipped or empty
        // box would get a 2D box computed from nonsense.
        if tokens[0] != DONT_CARE {
            if let Some(i) = dimensions.iter().position(|&d| !(d > 0.0)) {
                return Err(Error::parse(
                    path,
                    line_no,
                    FIELD_NAMES[8 + i],
                    format!(
                        "{:?} must be positive for a {} (only DontCare rows carry -1 placeholders)",
                        tokens[8 + i],
                        tokens[0]
                    ),
                ));
            }
        }
        Ok(Label {
            kind: tokens[0].clone(),
            truncated: num(1)?,
            occluded: occluded as i32,
            alpha: num(3)?,
            bbox: [num(4)?, num(5)?, num(6)?, num(7)?],
            dimensions,
            location: Vector3::new(num(11)?, num(12)?, num(13)?),
            rotation_y: num(14)?,
            score: if tokens.len() == 16 {
                Some(num(15)?)
            } else {
                None
            },
            tokens,
        })
    }

    /// The label's class: an object's, or an ignore region.
    pub fn class(&self) -> LabelClass<'_> {
        if self.kind == DONT_CARE {
            LabelClass::DontCare
        } else {
            LabelClass::Object(&self.kind)
        }
    }

    /// Whether the label is an ignore region (`DontCare`), not an object.
    pub fn is_dont_care(&self) -> bool {
        self.class() == LabelClass::DontCare
    }

    /// Whether the object carries a 3D box (DontCare and placeholder rows do not).
    pub fn has_box_3d(&self) -> bool {
        !self.is_dont_care() && self.dimensions.iter().all(|&d| d > 0.0) && self.location.z > -999.0
    }

    /// The 8 corners of the 3D box in rect: bottom face first (y = location.y), then top.
    pub fn corners(&self) -> [Vector3<f64>; 8] {
        let [h, w, l] = self.dimensions;
        let (s, c) = self.rotation_y.sin_cos();
        let mut out = [Vector3::zeros(); 8];
        let xs = [l / 2.0, l / 2.0, -l / 2.0, -l / 2.0];
        let zs = [w / 2.0, -w / 2.0, -w / 2.0, w / 2.0];
        for i in 0..8 {
            let (x, z) = (xs[i % 4], zs[i % 4]);
            let y = if i < 4 { 0.0 } else { -h };
            // rotation about y: x' = c x + s z, z' = -s x + c z (KITTI's convention)
            out[i] = self.location + Vector3::new(c * x + s * z, y, -s * x + c * z);
        }
        out
    }

    /// The neutral box of an object with a 3D box (None for DontCare and placeholder rows):
    /// its truncation where the row gives one (not KITTI's −1), its occlusion.
    pub fn to_source_box(&self) -> Option<SourceBox> {
        if !self.has_box_3d() {
            return None;
        }
        Some(SourceBox {
            truncation: (self.truncated >= 0.0).then_some(self.truncated),
            occlusion: u8::try_from(self.occluded).ok(),
            ..SourceBox::from_kitti(&self.kind, self.dimensions, self.location, self.rotation_y)
        })
    }

    /// The label's 2D box as a region of rig camera `camera`'s image: an ignore region for
    /// DontCare, else an object without a 3D box.
    pub fn to_region(&self, camera: usize) -> SourceRegion {
        SourceRegion {
            camera,
            bounds: self.bbox,
            class: match self.class() {
                LabelClass::Object(kind) => Some(kind.to_owned()),
                LabelClass::DontCare => None,
            },
        }
    }

    /// The label's line in an output camera: its 2D box there (`bbox`, clipped), and its
    /// truncation raised to the fraction of the box that clipping removed (`clipped`); a row
    /// without a truncation (DontCare's −1, "not applicable") keeps it. Other tokens verbatim.
    pub fn moved_line(&self, bbox: [f64; 4], clipped: f64) -> String {
        let truncated = (self.truncated >= 0.0).then(|| self.truncated.max(clipped));
        self.to_line_with(bbox, truncated)
    }

    /// The label line with a new 2D box and truncation (None keeps it); other tokens verbatim.
    pub fn to_line_with(&self, bbox: [f64; 4], truncated: Option<f64>) -> String {
        let mut tokens = self.tokens.clone();
        if let Some(t) = truncated {
            tokens[1] = format!("{:.2}", t);
        }
        for (i, v) in bbox.iter().enumerate() {
            tokens[4 + i] = format!("{:.2}", v);
        }
        tokens.join(" ")
    }
}
