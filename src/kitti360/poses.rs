//! `data_poses/SEQ/poses.txt`: one line per frame, `frame r11 r12 r13 t1 ... r33 t3`, the
//! vehicle's pose frame to the world (world_from_pose). Only frames listed here are usable.

use super::text::{matrix_3x4, numbers};
use crate::error::{Error, Result};
use crate::fs::read_lines;
use crate::source::Pose;
use std::collections::BTreeMap;
use std::path::Path;

/// Reads the poses by frame number. A frame listed twice, a line of the wrong length or a
/// value that is not a number is an error naming the line.
pub fn read_poses(path: &Path) -> Result<BTreeMap<u32, Pose>> {
    let mut out = BTreeMap::new();
    for (i, text) in read_lines(path)?.iter().enumerate() {
        let line = i + 1;
        let tokens: Vec<String> = text.split_whitespace().map(str::to_owned).collect();
        if tokens.is_empty() {
            continue;
        }
        let frame = tokens[0]
            .parse::<u32>()
            .ok()
            .or_else(|| {
                // numpy.savetxt writes frame numbers as floats (`250.0`, `2.5e+02`)
                tokens[0]
                    .parse::<f64>()
                    .ok()
                    .filter(|f| *f >= 0.0 && f.fract() == 0.0 && *f <= u32::MAX as f64)
                    .map(|f| f as u32)
            })
            .ok_or_else(|| {
                Error::parse(
                    path,
                    line,
                    "frame",
                    format!("not a frame number: {:?}", tokens[0]),
                )
            })?;
        let v = numbers(&tokens[1..], 12, path, line, "pose")?;
        let pose = Pose::from_matrix4(&matrix_3x4(&v));
        if !((pose.rotation.determinant() - 1.0).abs() < 1e-3) {
            return Err(Error::parse(
                path,
                line,
                "pose",
                format!(
                    "the 3x3 part is not a rotation (determinant {:.6})",
                    pose.rotation.determinant()
                ),
            ));
        }
        if out.insert(frame, pose).is_some() {
            return Err(Error::parse(
                path,
                line,
                "frame",
                format!("frame {frame} is listed twice"),
            ));
        }
    }
    if out.is_empty() {
        return Err(Error::file(path, "no poses: the file lists no frame"));
    }
    Ok(out)
}
