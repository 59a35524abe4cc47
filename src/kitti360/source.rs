//! KITTI-360 as a [`RigSource`]: the selected sequences opened, their frames with their output
//! ids, the class table applied, and what the manifest and the objects records say of them.
//!
//! A frame's id is its KITTI-360 frame number in six digits (frame 250 → `000250`) when one
//! sequence is converted; with several, the sequence's drive number (`_drive_NNNN_` in its
//! name) in four digits comes first (drive 3, frame 250 → `0003000250`), so that ids never
//! collide. The manifest's parameters record the rule (`frame_ids`).

use super::calib::{CAMERAS, DEFAULT_FISHEYE_FOV_DEG};
use super::sequence::{scan_path, Options, Sequence};
use crate::camera::CameraModel;
use crate::error::{Error, Result};
use crate::source::{
    record_value, CameraInfo, RigItem, RigItems, RigSource, SourceBox, SourceCamera, SourceFrame,
    VehicleBox,
};
use serde::Serialize;
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};

/// Which classes' objects are written (KITTI types: docs/kitti360.md's class table).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kitti360Classes {
    /// The classes with a KITTI type only.
    Kitti,
    /// Every class; those without a KITTI type named by their KITTI-360 class.
    All,
    /// The KITTI types and these KITTI-360 classes (named by their KITTI-360 class).
    Also(Vec<String>),
}

impl Kitti360Classes {
    /// Whether a box of the KITTI-360 class `dataset_class`, written as `class`, is kept.
    pub fn keeps(&self, class: &str, dataset_class: &str) -> bool {
        let kitti_type = super::classes::CLASSES
            .iter()
            .any(|(_, name, kind)| *name == dataset_class && *kind == Some(class));
        match self {
            Kitti360Classes::Kitti => kitti_type,
            Kitti360Classes::All => true,
            Kitti360Classes::Also(names) => kitti_type || names.iter().any(|n| n == dataset_class),
        }
    }
}

/// What of a KITTI-360 root is converted, and how its cameras and scans are read.
#[derive(Debug, Clone, PartialEq)]
pub struct Kitti360Selection {
    /// The KITTI-360 root (`calibration/`, `data_2d_raw/`, ...).
    pub input: PathBuf,
    /// The sequences (folder names such as `2013_05_28_drive_0000_sync`).
    pub sequences: Vec<String>,
    /// Only these frame numbers (of every sequence); None: every frame with a pose.
    pub frames: Option<Vec<u32>>,
    /// Which classes are written.
    pub classes: Kitti360Classes,
    /// Field of view of image_02 and image_03, degrees.
    pub fisheye_fov_deg: [f64; 2],
    /// Read each frame's Velodyne scan (depth maps, the objects' LiDAR check, or a
    /// depth-guided stitch).
    pub lidar: bool,
    /// Read the boxes of every class: those of classes not asked for are scenery for a
    /// depth-guided stitch, neither labelled nor listed ([`RigSource::listed`]).
    pub scenery: bool,
    /// The Velodyne returns dropped as the vehicle's own.
    pub vehicle_box: VehicleBox,
}

impl Kitti360Selection {
    /// Every frame of `sequences` under `input`, KITTI classes, the default fisheye fields of
    /// view, with scans.
    pub fn new(input: PathBuf, sequences: Vec<String>) -> Self {
        Self {
            input,
            sequences,
            frames: None,
            classes: Kitti360Classes::Kitti,
            fisheye_fov_deg: [DEFAULT_FISHEYE_FOV_DEG; 2],
            lidar: true,
            scenery: false,
            vehicle_box: VehicleBox::KITTI360,
        }
    }
}

/// The drive number of a KITTI-360 sequence name (`2013_05_28_drive_0003_sync` → 3).
pub fn drive_number(sequence: &str) -> Option<u32> {
    let rest = sequence.split("_drive_").nth(1)?;
    let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
    if digits.is_empty() || digits.len() > 4 {
        return None;
    }
    digits.parse().ok()
}

/// A frame's output id: the frame number in six digits, after the drive number in four when
/// several sequences share the output (`drive` Some).
pub fn frame_id(drive: Option<u32>, frame: u32) -> String {
    match drive {
        Some(d) => format!("{d:04}{frame:06}"),
        None => format!("{frame:06}"),
    }
}

/// The selected sequences of a KITTI-360 root, opened.
#[derive(Debug)]
pub struct Kitti360Source {
    selection: Kitti360Selection,
    /// Each sequence with its camera set (image_00 to image_03).
    sequences: Vec<(Sequence, Vec<SourceCamera>)>,
}

/// The order of the manifest's parameters of a `kitti360` run.
const PARAMETER_ORDER: &[&str] = &[
    "input",
    "sequences",
    "frame_ids",
    "output_spec",
    "fisheye",
    "cameras",
    "frames",
    "stitch_distance",
    "blend_width_deg",
    "exposure_gains",
    "centre",
    "objects",
    "classes",
    "depth",
    "fisheye_fov_deg",
    "vehicle_box",
    "shard",
    "png_compression",
    "ego_masks",
    "style",
    "augment",
];

impl Kitti360Source {
    /// Opens the selected sequences (calibration, poses, boxes): every problem is a set-up
    /// error naming its file.
    pub fn open(selection: Kitti360Selection) -> Result<Self> {
        if selection.sequences.is_empty() {
            return Err(Error::Setup("no sequence given".into()));
        }
        if !selection.input.is_dir() {
            return Err(Error::Setup(format!(
                "input {} is not a directory",
                selection.input.display()
            )));
        }
        let options = Options {
            fisheye_fov_deg: selection.fisheye_fov_deg,
            lidar: selection.lidar,
            all_classes: selection.classes != Kitti360Classes::Kitti || selection.scenery,
            vehicle_box: selection.vehicle_box,
            // the reader's default (motion-compensated sweeps) until the command has an option
            ..Options::default()
        };
        let mut sequences = Vec::new();
        for name in &selection.sequences {
            let seq = Sequence::open(&selection.input, name, options)?;
            let cameras = camera_set(&seq);
            sequences.push((seq, cameras));
        }
        Ok(Self {
            selection,
            sequences,
        })
    }

    /// The opened sequences, in the selection's order.
    pub fn sequences(&self) -> impl Iterator<Item = &Sequence> {
        self.sequences.iter().map(|(s, _)| s)
    }

    /// The drive number of each sequence when several share the output; an error when one
    /// has none or two have the same.
    fn drives(&self) -> Result<Vec<Option<u32>>> {
        if self.sequences.len() < 2 {
            return Ok(vec![None; self.sequences.len()]);
        }
        let mut drives = Vec::new();
        for (seq, _) in &self.sequences {
            let d = drive_number(&seq.name).ok_or_else(|| {
                Error::Setup(format!(
                    "sequence {:?} has no drive number (_drive_NNNN_): several sequences are \
                     told apart by it in the frame ids",
                    seq.name
                ))
            })?;
            if drives.contains(&Some(d)) {
                return Err(Error::Setup(format!(
                    "two sequences have drive number {d}: their frame ids would collide"
                )));
            }
            drives.push(Some(d));
        }
        Ok(drives)
    }
}

/// What the rig pass needs of a sequence's four cameras.
/// Whether a box read from KITTI-360 has a KITTI type (the boxes written by default).
fn has_kitti_type(b: &SourceBox) -> bool {
    super::classes::CLASSES
        .iter()
        .any(|(_, name, kitti)| *name == b.dataset_class && kitti.is_some())
}

fn camera_set(seq: &Sequence) -> Vec<SourceCamera> {
    let c = &seq.calibration;
    let pinhole = |k: usize| SourceCamera {
        name: CAMERAS[k].to_owned(),
        info: CameraInfo {
            focal: c.perspective[k].model.k,
            max_theta: None,
        },
        size: c.perspective[k].model.size(),
    };
    let fisheye = |k: usize| SourceCamera {
        name: CAMERAS[k + 2].to_owned(),
        info: CameraInfo {
            focal: c.fisheye[k].centre_intrinsics(),
            max_theta: Some(c.fisheye[k].max_theta()),
        },
        size: c.fisheye[k].size(),
    };
    vec![pinhole(0), pinhole(1), fisheye(0), fisheye(1)]
}

impl RigSource for Kitti360Source {
    fn command(&self) -> &'static str {
        "kitti360"
    }

    fn root(&self) -> &Path {
        &self.selection.input
    }

    fn parts(&self) -> usize {
        self.sequences.len()
    }

    fn cameras(&self, part: usize) -> &[SourceCamera] {
        &self.sequences[part].1
    }

    fn items(&self, cameras: &[usize]) -> Result<RigItems> {
        let drives = self.drives()?;
        let several = self.sequences.len() > 1;
        let mut items = Vec::new();
        let mut not_frames = Vec::new();
        for (part, ((seq, _), drive)) in self.sequences.iter().zip(drives).enumerate() {
            let frames = match &self.selection.frames {
                Some(list) => {
                    for &f in list.iter().filter(|f| seq.poses.contains_key(f)) {
                        if let Some(image) = seq.missing_image(f, cameras) {
                            return Err(Error::Setup(format!(
                                "--frames {f}: {} does not exist (a frame needs the images of \
                                 every camera of --cameras)",
                                image.display()
                            )));
                        }
                    }
                    list.clone()
                }
                None => {
                    let (with, without) = seq.frames_with_images(cameras);
                    not_frames.extend(without.iter().map(|f| format!("{}/{f:010}", seq.name)));
                    with
                }
            };
            for frame in frames {
                if several && frame >= 1_000_000 {
                    return Err(Error::Setup(format!(
                        "frame {frame} of {} has more than six digits: it has no id when \
                         several sequences share an output",
                        seq.name
                    )));
                }
                items.push(RigItem {
                    id: frame_id(drive, frame),
                    part,
                    index: u64::from(frame),
                });
            }
        }
        if items.is_empty() && !not_frames.is_empty() {
            return Err(Error::Setup(format!(
                "no frame to convert: none of the {} poses has the images of --cameras (first: {})",
                not_frames.len(),
                not_frames[0]
            )));
        }
        if items.is_empty() {
            return Err(Error::Setup("the selection holds no frame".into()));
        }
        items.sort_by(|a, b| a.id.cmp(&b.id));
        if let Some(w) = items.windows(2).find(|w| w[0].id == w[1].id) {
            return Err(Error::Setup(format!(
                "frame {} is asked for twice",
                w[0].id
            )));
        }
        Ok(RigItems { items, not_frames })
    }

    fn read(&self, item: &RigItem) -> Result<SourceFrame> {
        let seq = &self.sequences[item.part].0;
        let frame = u32::try_from(item.index)
            .map_err(|_| Error::Setup(format!("frame {}: not a frame number", item.index)))?;
        let mut record = Map::new();
        record.insert("sequence".into(), Value::from(seq.name.clone()));
        record.insert("frame".into(), Value::from(item.index));
        Ok(SourceFrame {
            frame: seq.frame(frame)?,
            record,
        })
    }

    fn listed(&self) -> Option<fn(&SourceBox) -> bool> {
        (self.selection.classes == Kitti360Classes::Kitti && self.selection.scenery)
            .then_some(has_kitti_type as fn(&SourceBox) -> bool)
    }

    fn keeps(&self, b: &SourceBox) -> bool {
        self.selection.classes.keeps(&b.class, &b.dataset_class)
    }

    fn label_types(&self) -> Vec<String> {
        let untyped = super::classes::CLASSES
            .iter()
            .filter(|(_, _, k)| k.is_none());
        let named: Vec<&str> = match &self.selection.classes {
            Kitti360Classes::Kitti => return Vec::new(),
            Kitti360Classes::All => untyped.map(|(_, name, _)| *name).collect(),
            Kitti360Classes::Also(names) => untyped
                .filter(|(_, name, _)| names.iter().any(|n| n == name))
                .map(|(_, name, _)| *name)
                .collect(),
        };
        named.into_iter().map(super::classes::label_type).collect()
    }

    fn parameters(&self) -> Map<String, Value> {
        let s = &self.selection;
        let mut m = Map::new();
        m.insert("input".into(), record_value(&s.input));
        m.insert("sequences".into(), record_value(&s.sequences));
        let frame_ids = if s.sequences.len() > 1 {
            "drive_frame"
        } else {
            "frame"
        };
        m.insert("frame_ids".into(), record_value(frame_ids));
        m.insert("frames".into(), record_value(s.frames.as_deref()));
        m.insert("classes".into(), record_value(&s.classes));
        m.insert("fisheye_fov_deg".into(), record_value(s.fisheye_fov_deg));
        // recorded when not the default, so that default runs keep their manifests
        if s.vehicle_box != VehicleBox::KITTI360 {
            m.insert("vehicle_box".into(), record_value(s.vehicle_box));
        }
        m
    }

    fn parameter_order(&self) -> &'static [&'static str] {
        PARAMETER_ORDER
    }

    fn frame_folder(&self, item: &RigItem) -> PathBuf {
        let seq = &self.sequences[item.part].0;
        seq.root.join("data_2d_raw").join(&seq.name)
    }

    fn scan_file(&self, item: &RigItem) -> Option<(PathBuf, String)> {
        let seq = &self.sequences.get(item.part)?.0;
        let frame = u32::try_from(item.index).ok()?;
        let what = format!("frame {frame}'s Velodyne scan");
        self.selection
            .lidar
            .then(|| (scan_path(&seq.root, &seq.name, frame), what))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_six_digit_frames_and_drive_prefixed_for_several_sequences() {
        assert_eq!(frame_id(None, 250), "000250");
        assert_eq!(frame_id(Some(3), 250), "0003000250");
        assert_eq!(drive_number("2013_05_28_drive_0003_sync"), Some(3));
        assert_eq!(drive_number("2013_05_28_drive_0010_sync"), Some(10));
        assert_eq!(drive_number("my_sequence"), None);
        let classes = Kitti360Classes::Also(vec!["building".into()]);
        assert!(classes.keeps("Car", "car") && classes.keeps("building", "building"));
        assert!(!classes.keeps("pole", "pole"));
        assert!(!Kitti360Classes::Kitti.keeps("building", "building"));
        assert!(Kitti360Classes::All.keeps("pole", "pole"));
    }
}
