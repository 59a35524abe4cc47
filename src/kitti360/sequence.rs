//! A KITTI-360 sequence in the official layout, read into neutral [`Frame`]s:
//!
//! ```text
//! ROOT/calibration/{calib_cam_to_pose.txt, perspective.txt, image_02.yaml, image_03.yaml,
//!                   calib_cam_to_velo.txt}
//! ROOT/data_2d_raw/SEQ/image_0{0,1}/data_rect/%010d.png
//! ROOT/data_2d_raw/SEQ/image_0{2,3}/data_rgb/%010d.png
//! ROOT/data_3d_raw/SEQ/velodyne_points/data/%010d.bin
//! ROOT/data_poses/SEQ/poses.txt
//! ROOT/data_3d_bboxes/{train,...}/SEQ.xml        (optional: test sequences have none)
//! ```
//!
//! Transforms as kitti360Scripts defines them: rectified image_00/01 → world =
//! `pose · cam_to_pose[k] · R_rect_k⁻¹`, fisheye → world = `pose · cam_to_pose[k]`, Velodyne →
//! world = `pose · cam_to_pose[0] · cam_to_velo⁻¹`. A frame's reference frame is its level frame
//! (`level.rs`); its `world_from_reference` is KITTI's `Tr_rect_to_world`.

use super::bboxes::{read_boxes, WorldBox};
use super::calib::{Calibration, CAMERAS, DEFAULT_FISHEYE_FOV_DEG};
use super::poses::read_poses;
use super::velodyne::{parse_scan, SweepMotion};
use crate::camera::CameraModel;
use crate::error::{Error, Result};
use crate::source::world_from_level;
use crate::source::{Frame, LidarPoint, Pose, RigCamera, VehicleBox};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What to read besides the cameras.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Field of view of image_02 and image_03, degrees.
    pub fisheye_fov_deg: [f64; 2],
    /// Read each frame's Velodyne scan.
    pub lidar: bool,
    /// Keep the objects of classes KITTI has no type for (named by their KITTI-360 class).
    pub all_classes: bool,
    /// Motion-compensate each Velodyne sweep ([`Sequence::sweep_motion`]); off, the points are
    /// read as the scanner measured them.
    pub compensate_sweep: bool,
    /// The Velodyne returns dropped as the vehicle's own (the Velodyne's frame, as measured).
    pub vehicle_box: VehicleBox,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            fisheye_fov_deg: [DEFAULT_FISHEYE_FOV_DEG; 2],
            lidar: true,
            all_classes: false,
            compensate_sweep: true,
            vehicle_box: VehicleBox::KITTI360,
        }
    }
}

/// An opened sequence: its calibration, poses and boxes, read once.
#[derive(Debug)]
pub struct Sequence {
    /// The dataset root.
    pub root: PathBuf,
    /// The sequence's folder name (`2013_05_28_drive_0000_sync`).
    pub name: String,
    /// The calibration folder.
    pub calibration: Calibration,
    /// world_from_pose by frame number.
    pub poses: BTreeMap<u32, Pose>,
    /// Every box of the sequence's XML file (empty without one).
    pub boxes: Vec<WorldBox>,
    options: Options,
    poses_path: PathBuf,
    boxes_path: Option<PathBuf>,
    models: [Arc<dyn CameraModel>; 4],
}

/// The image file of camera `k` (0 to 3) for `frame` in the official layout.
pub fn image_path(root: &Path, sequence: &str, k: usize, frame: u32) -> PathBuf {
    let sub = if k < 2 { "data_rect" } else { "data_rgb" };
    root.join("data_2d_raw")
        .join(sequence)
        .join(CAMERAS[k])
        .join(sub)
        .join(format!("{frame:010}.png"))
}

/// The Velodyne scan of `frame`.
pub fn scan_path(root: &Path, sequence: &str, frame: u32) -> PathBuf {
    root.join("data_3d_raw")
        .join(sequence)
        .join("velodyne_points/data")
        .join(format!("{frame:010}.bin"))
}

/// The poses file of a sequence.
pub fn poses_path(root: &Path, sequence: &str) -> PathBuf {
    root.join("data_poses").join(sequence).join("poses.txt")
}

/// The sequence's box file: `data_3d_bboxes/*/SEQ.xml`, None when there is none; two
/// (e.g. in `train` and `train_full`) are ambiguous and refused.
pub fn boxes_path(root: &Path, sequence: &str) -> Result<Option<PathBuf>> {
    let dir = root.join("data_3d_bboxes");
    if !dir.is_dir() {
        return Ok(None);
    }
    let mut found: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(|e| Error::io(&dir, e))?
        .filter_map(|e| e.ok())
        .map(|e| e.path().join(format!("{sequence}.xml")))
        .filter(|p| p.is_file())
        .collect();
    found.sort();
    match found.len() {
        0 => Ok(None),
        1 => Ok(found.pop()),
        _ => Err(Error::file(
            &dir,
            format!(
                "{} box files for {sequence}: {}; keep one",
                found.len(),
                found
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )),
    }
}

impl Sequence {
    /// Reads the calibration, the poses and the boxes of `sequence` under `root`.
    pub fn open(root: &Path, sequence: &str, options: Options) -> Result<Self> {
        if sequence.is_empty() || sequence.contains(['/', '\\']) || sequence == ".." {
            return Err(Error::Setup(format!(
                "sequence {sequence:?} must be a folder name such as 2013_05_28_drive_0000_sync"
            )));
        }
        let calibration = Calibration::read(&root.join("calibration"), options.fisheye_fov_deg)?;
        let poses_file = poses_path(root, sequence);
        let poses = read_poses(&poses_file)?;
        let boxes_file = boxes_path(root, sequence)?;
        let boxes = match &boxes_file {
            Some(p) => read_boxes(p)?,
            None => Vec::new(),
        };
        let models: [Arc<dyn CameraModel>; 4] = [
            Arc::new(calibration.perspective[0].model.clone()),
            Arc::new(calibration.perspective[1].model.clone()),
            Arc::new(calibration.fisheye[0].clone()),
            Arc::new(calibration.fisheye[1].clone()),
        ];
        Ok(Self {
            root: root.to_path_buf(),
            name: sequence.to_owned(),
            calibration,
            poses,
            boxes,
            options,
            poses_path: poses_file,
            boxes_path: boxes_file,
            models,
        })
    }

    /// The frames with a pose, ascending: the usable ones.
    pub fn frames(&self) -> Vec<u32> {
        self.poses.keys().copied().collect()
    }

    /// The image of camera `k` that `frame` lacks among `cameras`, if any.
    pub fn missing_image(&self, frame: u32, cameras: &[usize]) -> Option<PathBuf> {
        cameras
            .iter()
            .map(|&k| image_path(&self.root, &self.name, k, frame))
            .find(|p| !p.is_file())
    }

    /// The frames of [`Sequence::frames`] split into those whose images of `cameras` all exist
    /// (the frames) and those that lack one: a pose alone (a partial download, a sample) is
    /// not a frame.
    pub fn frames_with_images(&self, cameras: &[usize]) -> (Vec<u32>, Vec<u32>) {
        self.frames()
            .into_iter()
            .partition(|&f| self.missing_image(f, cameras).is_none())
    }

    fn pose(&self, frame: u32) -> Result<&Pose> {
        self.poses.get(&frame).ok_or_else(|| {
            Error::file(
                &self.poses_path,
                format!("frame {frame} has no pose: only frames listed here are usable"),
            )
        })
    }

    /// world_from_camera for camera `k` (0 to 3) at `frame`, in the axes of its images.
    pub fn world_from_image(&self, frame: u32, k: usize) -> Result<Pose> {
        Ok(self
            .pose(frame)?
            .compose(&self.calibration.pose_from_image(k)))
    }

    /// world_from_velo at `frame`.
    pub fn world_from_velo(&self, frame: u32) -> Result<Pose> {
        Ok(self
            .pose(frame)?
            .compose(&self.calibration.pose_from_velo()))
    }

    /// The Velodyne's motion during the sweep of `frame` ([`SweepMotion`]), from the
    /// neighbouring poses: the motion from the frame before to `frame` when the frame before
    /// has a pose, else the motion from `frame` to the frame after (the first frame of a
    /// sequence, or one after a gap), else None: a frame with neither neighbour is not
    /// compensated (its points are read as measured).
    pub fn sweep_motion(&self, frame: u32) -> Result<Option<SweepMotion>> {
        let listed = |f: Option<u32>| f.filter(|f| self.poses.contains_key(f));
        let (later, earlier) = match (listed(frame.checked_sub(1)), listed(frame.checked_add(1))) {
            (Some(previous), _) => (frame, previous),
            (None, Some(next)) => (next, frame),
            (None, None) => return Ok(None),
        };
        let velo_later = self.world_from_velo(later)?.inverse().ok_or_else(|| {
            Error::file(&self.poses_path, format!("frame {later}: singular pose"))
        })?;
        let motion = velo_later.compose(&self.world_from_velo(earlier)?);
        Ok(Some(SweepMotion::from_frame_motion(&motion)))
    }

    /// world_from_level at `frame`: KITTI's `Tr_rect_to_world` of the frame.
    pub fn world_from_level(&self, frame: u32) -> Result<Pose> {
        let rect0 = self.world_from_image(frame, 0)?;
        world_from_level(&rect0).ok_or_else(|| {
            Error::file(
                &self.poses_path,
                format!("frame {frame}: image_00 looks straight up or down; no level frame"),
            )
        })
    }

    /// The boxes of `frame` (static ones whose range holds it, dynamic entries of it).
    pub fn boxes_of(&self, frame: u32) -> impl Iterator<Item = &WorldBox> {
        self.boxes.iter().filter(move |b| b.in_frame(frame))
    }

    /// Frame `frame` in its level frame: the four cameras, the boxes (KITTI classes only
    /// unless [`Options::all_classes`]), the scan when [`Options::lidar`] (motion-compensated
    /// unless [`Options::compensate_sweep`] is off).
    pub fn frame(&self, frame: u32) -> Result<Frame> {
        let world_from_level = self.world_from_level(frame)?;
        let level_from_world = world_from_level.inverse().ok_or_else(|| {
            Error::file(&self.poses_path, format!("frame {frame}: singular pose"))
        })?;
        let mut provenance = self.calibration.files.clone();
        provenance.push(self.poses_path.clone());
        provenance.extend(self.boxes_path.clone());
        let mut rig = Vec::with_capacity(4);
        for (k, name) in CAMERAS.iter().enumerate() {
            let image = image_path(&self.root, &self.name, k, frame);
            provenance.push(image.clone());
            rig.push(RigCamera {
                name: (*name).to_owned(),
                model: Arc::clone(&self.models[k]),
                reference_from_camera: level_from_world.compose(&self.world_from_image(frame, k)?),
                image,
                // the cameras are triggered with the sweep (docs/kitti360.md)
                time: None,
            });
        }
        let objects = self
            .boxes_of(frame)
            .filter(|b| {
                self.options.all_classes || super::classes::kitti_type(b.kitti_id).is_some()
            })
            .map(|b| b.to_source(&level_from_world))
            .collect();
        let level_from_velo = level_from_world.compose(&self.world_from_velo(frame)?);
        let mut lidar = Vec::new();
        let mut input_hashes = Vec::new();
        if self.options.lidar {
            let path = scan_path(&self.root, &self.name, frame);
            let bytes = crate::fs::read_file(&path)?;
            let motion = match self.options.compensate_sweep {
                true => self.sweep_motion(frame)?,
                false => None,
            };
            lidar = parse_scan(&bytes, &path)?
                .into_iter()
                .filter(|(p, _)| !self.options.vehicle_box.holds(p))
                .map(|(p, intensity)| {
                    let p = motion.map_or(p, |m| m.compensate(&p));
                    LidarPoint {
                        position: level_from_velo.apply(&p),
                        intensity,
                    }
                })
                .collect();
            input_hashes.push((path.clone(), crate::fs::hash_hex(&bytes)));
            provenance.push(path);
        }
        Ok(Frame {
            id: format!("{frame:06}"),
            provenance,
            rig,
            objects,
            regions: Vec::new(),
            lidar,
            world_from_reference: Some(world_from_level),
            reference_from_lidar: Some(level_from_velo),
            lidar_from_imu: self.calibration.pose_from_velo().inverse(),
            input_hashes,
        })
    }
}
