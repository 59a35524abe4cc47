//! `panoconv kitti360`'s job: which sequences, frames, cameras and output, what the manifest
//! records of it, and how its frames are named.
//!
//! The output is a KITTI object dataset: `OUT/training/{image_2, label_2, calib, source_2,
//! objects, depth_2}/ID.*` (docs/kitti360.md). A frame's id is its KITTI-360 frame number in
//! six digits (frame 250 → `000250`) when one sequence is converted; with several, the
//! sequence's drive number (`_drive_NNNN_` in its name) in four digits comes first
//! (drive 3, frame 250 → `0003000250`), so that ids never collide. The manifest's parameters
//! record the rule (`frame_ids`).

use super::objects::{DropReason, ObjectOutcome, ObjectRule};
use crate::codec::png::PngCompression;
use crate::geometry::augment::Augment;
use crate::geometry::Target;
use crate::reproject::depth::OcclusionFilter;
use crate::run::Shard;
use crate::run::Summary;
use crate::style::{StyleInfo, StyleOptions};
use crate::warp::StitchOptions;
use nalgebra::Vector3;
use serde::Serialize;
use std::path::PathBuf;

/// The split every frame is written to (KITTI's loaders and panoconv's tools find it there).
pub const SPLIT: &str = "training";

pub use crate::kitti360::{drive_number, frame_id, Kitti360Classes};

/// A `panoconv kitti360` conversion.
#[derive(Debug, Clone)]
pub struct Kitti360Job {
    /// The KITTI-360 root (`calibration/`, `data_2d_raw/`, ...).
    pub input: PathBuf,
    /// The sequences (folder names such as `2013_05_28_drive_0000_sync`).
    pub sequences: Vec<String>,
    /// The output folder.
    pub output: PathBuf,
    /// The output camera.
    pub target: Target,
    /// The rig cameras used (0 to 3: image_00 to image_03), in order.
    pub cameras: Vec<usize>,
    /// Only these frame numbers (of every sequence); None: every frame with a pose.
    pub frames: Option<Vec<u32>>,
    /// Proxy distance, blend width, exposure gains.
    pub stitch: StitchOptions,
    /// The output centre C2 in the level frame (default: the mean of the cameras' centres).
    pub centre: Option<Vector3<f64>>,
    /// Which objects are written.
    pub objects: ObjectRule,
    /// Which classes are written.
    pub classes: Kitti360Classes,
    /// `depth_2/`: with the occlusion filter (Some(Some)), without it (Some(None)), or none.
    pub depth: Option<Option<OcclusionFilter>>,
    /// Field of view of image_02 and image_03, degrees.
    pub fisheye_fov_deg: [f64; 2],
    /// Replace a previous run's output.
    pub overwrite: bool,
    /// Keep the frames a previous run with the same parameters completed.
    pub resume: bool,
    /// Convert one shard of the frames.
    pub shard: Option<Shard>,
    /// PNG encoder effort.
    pub png_compression: PngCompression,
    /// Ego masks: (rig camera 0 to 3, mask image) pairs (non-zero pixels are the vehicle's
    /// body; `warp::EgoMask`).
    pub ego_masks: Vec<(usize, PathBuf)>,
    /// The CycleGAN style pass: each used camera's image styled before the stitch (so the
    /// blend and the exposure gains work on styled images).
    pub style: Option<StyleOptions>,
    /// Equal-size images of up to this many consecutive frames go through the style model in
    /// one run (1: frame by frame). Outputs do not depend on it (`convert::style_pass`).
    pub style_batch: usize,
    /// Random scale-and-crop views of each frame's output (ids frame × N + k) instead of the
    /// whole output.
    pub augment: Option<Augment>,
}

impl Kitti360Job {
    /// Whether LiDAR scans are read (depth maps, or the objects' LiDAR check).
    pub fn needs_lidar(&self) -> bool {
        self.depth.is_some() || self.objects.min_points > 0
    }
}

/// Objects written and dropped over a run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct ObjectCounts {
    /// Written to label_2.
    pub written: usize,
    /// Of those, boxes leaning more than 1 mrad from upright (written with their heading).
    pub tilted: usize,
    /// Dropped: a class not asked for.
    pub class: usize,
    /// Dropped: farther than `--max-distance`.
    pub distance: usize,
    /// Dropped: fewer LiDAR points inside than `--min-points`.
    pub unseen: usize,
    /// Dropped: outside the output image.
    pub outside: usize,
}

impl ObjectCounts {
    /// The counts of one frame's outcomes.
    pub fn of(outcomes: &[ObjectOutcome]) -> Self {
        let mut c = Self::default();
        for o in outcomes {
            match o.dropped {
                None => {
                    c.written += 1;
                    c.tilted += usize::from(o.is_tilted());
                }
                Some(DropReason::Class) => c.class += 1,
                Some(DropReason::Distance) => c.distance += 1,
                Some(DropReason::Unseen) => c.unseen += 1,
                Some(DropReason::Outside) => c.outside += 1,
            }
        }
        c
    }

    /// The sum of two counts.
    pub fn add(&mut self, o: &ObjectCounts) {
        self.written += o.written;
        self.tilted += o.tilted;
        self.class += o.class;
        self.distance += o.distance;
        self.unseen += o.unseen;
        self.outside += o.outside;
    }
}

/// What a `kitti360` run did.
#[derive(Debug)]
pub struct Kitti360Summary {
    /// Frames, failures, time.
    pub run: Summary,
    /// Objects written and dropped, by reason, over the frames converted by this run (each
    /// augmented view counted as a frame).
    pub objects: ObjectCounts,
    /// Style model runs and the images they took, if styled.
    pub style_runs: Option<(usize, usize)>,
    /// With `--augment`: the views holding fewer objects than asked (at least one).
    pub thin_views: Option<usize>,
}

/// The manifest's `parameters`: what decides the outputs.
#[derive(Debug, Serialize)]
pub(super) struct Parameters<'a> {
    pub(super) input: &'a std::path::Path,
    pub(super) sequences: &'a [String],
    /// `frame` (one sequence) or `drive_frame` (several): see [`frame_id`].
    pub(super) frame_ids: &'static str,
    pub(super) output_spec: crate::geometry::TargetRecord,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) fisheye: Option<&'a crate::geometry::FisheyeTarget>,
    pub(super) cameras: Vec<&'static str>,
    pub(super) frames: Option<&'a [u32]>,
    pub(super) stitch_distance: f64,
    pub(super) blend_width_deg: f64,
    pub(super) exposure_gains: bool,
    pub(super) centre: Option<[f64; 3]>,
    pub(super) objects: &'a ObjectRule,
    pub(super) classes: &'a Kitti360Classes,
    pub(super) depth: Option<&'a Option<OcclusionFilter>>,
    pub(super) fisheye_fov_deg: [f64; 2],
    pub(super) shard: Option<Shard>,
    pub(super) png_compression: PngCompression,
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    pub(super) ego_masks: &'a [EgoMaskRecord],
    /// The style model (name, blake3, convention), applied to each camera's image.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) style: Option<&'a StyleInfo>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) augment: Option<&'a Augment>,
}

/// An ego mask as the manifest records it.
#[derive(Debug, Clone, Serialize)]
pub(super) struct EgoMaskRecord {
    /// The camera (`image_02`).
    pub(super) camera: &'static str,
    /// The mask image as given.
    pub(super) path: PathBuf,
    /// blake3 of its bytes.
    pub(super) hash: String,
}

impl<'a> Parameters<'a> {
    pub(super) fn new(
        job: &'a Kitti360Job,
        ego_masks: &'a [EgoMaskRecord],
        style: Option<&'a StyleInfo>,
    ) -> Self {
        Parameters {
            input: &job.input,
            sequences: &job.sequences,
            frame_ids: if job.sequences.len() > 1 {
                "drive_frame"
            } else {
                "frame"
            },
            output_spec: job.target.record(),
            fisheye: job.target.fisheye(),
            cameras: job
                .cameras
                .iter()
                .map(|&k| crate::kitti360::CAMERAS[k])
                .collect(),
            frames: job.frames.as_deref(),
            stitch_distance: job.stitch.distance,
            blend_width_deg: job.stitch.blend_width.to_degrees(),
            exposure_gains: job.stitch.even_exposure,
            centre: job.centre.map(|c| [c.x, c.y, c.z]),
            objects: &job.objects,
            classes: &job.classes,
            depth: job.depth.as_ref(),
            fisheye_fov_deg: job.fisheye_fov_deg,
            shard: job.shard,
            png_compression: job.png_compression,
            ego_masks,
            style,
            augment: job.augment.as_ref(),
        }
    }
}
