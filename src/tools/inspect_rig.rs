//! `panoconv inspect` on a rig dataset's root (nuScenes, KITTI-360): its versions or sequences,
//! their scenes, samples or frames, cameras, LiDAR and annotations, and what a conversion of
//! each would write, read with the conversion's own readers.

use crate::error::Result;
use crate::kitti360::{Options, Sequence};
use crate::nuscenes::{versions, NuScenes, Selection};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// What a rig dataset's root holds.
#[derive(Debug, Clone, Serialize)]
pub struct RigReport {
    /// The dataset root, as given.
    pub dataset: String,
    /// `nuscenes` or `kitti360`: the command that converts it.
    pub format: String,
    /// Its versions (nuScenes) or sequences (KITTI-360), by name.
    pub parts: Vec<RigPart>,
}

/// One version of a nuScenes root, or one sequence of a KITTI-360 root.
#[derive(Debug, Clone, Serialize)]
pub struct RigPart {
    /// The version folder (`v1.0-mini`) or the sequence (`2013_05_28_drive_0000_sync`).
    pub name: String,
    /// Scenes (nuScenes; a KITTI-360 sequence is one).
    pub scenes: usize,
    /// Samples (nuScenes) or frames with a pose (KITTI-360).
    pub samples: usize,
    /// The camera channels a conversion stitches by default, in its order.
    pub cameras: Vec<String>,
    /// The LiDAR the depth maps and the stitch read, None when the part has none.
    pub lidar: Option<String>,
    /// Annotated 3D boxes (nuScenes' sample annotations; KITTI-360's boxes).
    pub annotations: usize,
    /// Annotation categories (nuScenes' category.json; KITTI-360's classes present).
    pub categories: usize,
    /// The frames a conversion writes: one per sample, or per posed frame with every
    /// camera's image.
    pub frames: usize,
    /// The command that converts it.
    pub command: String,
}

/// The KITTI-layout files a rig conversion writes, for the report's last line.
const WRITES: &str = "OUT/training/{image_2,label_2,calib,source_2,objects}/ID.* \
     (depth_2 with --depth) and OUT/panoconv.json";

/// The report of `root` when it is a nuScenes or KITTI-360 root, else None.
pub fn inspect_rig(root: &Path) -> Result<Option<RigReport>> {
    let (format, parts) = if !versions(root).is_empty() {
        ("nuscenes", nuscenes_parts(root)?)
    } else if root.join("data_poses").is_dir() && root.join("calibration").is_dir() {
        ("kitti360", kitti360_parts(root)?)
    } else {
        return Ok(None);
    };
    Ok(Some(RigReport {
        dataset: root.display().to_string(),
        format: format.to_owned(),
        parts,
    }))
}

fn nuscenes_parts(root: &Path) -> Result<Vec<RigPart>> {
    let mut parts = Vec::new();
    for version in versions(root) {
        let tables = NuScenes::open(root, &version, &Selection::default())?;
        let samples = tables.scenes.iter().map(|s| s.samples.len()).sum();
        parts.push(RigPart {
            scenes: tables.scenes.len(),
            samples,
            cameras: tables.cameras.clone(),
            lidar: Some(tables.lidar.clone()),
            annotations: tables.annotation_count(),
            categories: tables.category_names().len(),
            frames: samples,
            command: format!(
                "panoconv nuscenes --input {} --version {version} --to equirect --output OUT",
                root.display()
            ),
            name: version,
        });
    }
    Ok(parts)
}

fn kitti360_parts(root: &Path) -> Result<Vec<RigPart>> {
    let names = crate::fs::folders_holding(&root.join("data_poses"), "poses.txt");
    let mut parts = Vec::new();
    for name in names {
        let options = Options {
            lidar: false,
            ..Options::default()
        };
        let sequence = Sequence::open(root, &name, options)?;
        let posed = sequence.frames();
        let cameras: Vec<usize> = (0..4)
            .filter(|&k| {
                posed
                    .iter()
                    .any(|&f| sequence.missing_image(f, &[k]).is_none())
            })
            .collect();
        let lidar = root.join("data_3d_raw").join(&name).join("velodyne_points");
        let mut classes: Vec<i64> = sequence.boxes.iter().map(|b| b.kitti_id).collect();
        classes.sort_unstable();
        classes.dedup();
        parts.push(RigPart {
            scenes: 1,
            samples: posed.len(),
            cameras: cameras.iter().map(|k| format!("image_{k:02}")).collect(),
            lidar: lidar.is_dir().then(|| "velodyne_points".to_owned()),
            annotations: sequence.boxes.len(),
            categories: classes.len(),
            frames: sequence.frames_with_images(&[0, 1, 2, 3]).0.len(),
            command: format!(
                "panoconv kitti360 --input {} --sequence {name} --to equirect --output OUT",
                root.display()
            ),
            name,
        });
    }
    Ok(parts)
}

impl RigReport {
    /// Pretty JSON with a final newline.
    pub fn to_json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).expect("report serialises");
        s.push('\n');
        s
    }

    /// The human-readable report.
    pub fn to_text(&self) -> String {
        let nuscenes = self.format == "nuscenes";
        let what = match nuscenes {
            true => "a nuScenes-format dataset",
            false => "a KITTI-360 dataset",
        };
        let mut s = String::new();
        let _ = writeln!(s, "dataset: {} ({what}, not a KITTI layout)", self.dataset);
        for p in &self.parts {
            let _ = match nuscenes {
                true => writeln!(
                    s,
                    "version {}: {}, {}, {} in {}",
                    p.name,
                    count(p.scenes, "scene", "scenes"),
                    count(p.samples, "sample", "samples"),
                    count(p.annotations, "annotation", "annotations"),
                    count(p.categories, "category", "categories"),
                ),
                false => writeln!(
                    s,
                    "sequence {}: {}, {} of {}",
                    p.name,
                    count(p.samples, "frame with a pose", "frames with a pose"),
                    count(p.annotations, "3D box", "3D boxes"),
                    count(p.categories, "class", "classes"),
                ),
            };
            let _ = writeln!(
                s,
                "  cameras: {} ({})",
                p.cameras.join(", "),
                p.cameras.len()
            );
            let _ = writeln!(s, "  LiDAR: {}", p.lidar.as_deref().unwrap_or("none"));
            let _ = writeln!(
                s,
                "  converts to {}: {}",
                count(p.frames, "frame", "frames"),
                p.command
            );
        }
        let _ = writeln!(s, "a conversion writes {WRITES}");
        s
    }
}

/// `n` and the word: `one` for 1, else `many`.
fn count(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}
