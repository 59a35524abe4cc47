//! The KITTI conversion: frames flow through read → (style) → warp → labels/calib → write, in
//! parallel over frames (or groups of frames, when the style pass batches) on one rayon pool
//! (the only owner of threads).

mod context;
mod labels;
mod options;
mod read;
mod run;
mod tables;
mod views;
mod write;

pub use crate::convert::run_options::{DepthJob, StyleJob, StyleOrder};
pub use labels::{move_label, transform_label, MovedLabel};
pub use options::KittiOptions;
pub use run::run_kitti;

use crate::codec::png::PngCompression;
use crate::error::Result;
use crate::geometry::augment::Augment;
use crate::geometry::{FisheyeTarget, Target, TargetRecord};
use crate::kitti::{raw, Cam, Dataset};
use crate::reproject::visibility::Visibility;
use crate::run::journal::Shard;
use crate::run::{OutputMode, Summary};
use crate::style::{StyleInfo, StyleModel};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Everything a `kitti` or `kitti-raw` conversion needs (the manifest records what decides
/// the outputs as `parameters`).
#[derive(Debug, Clone)]
pub struct KittiJob {
    /// The dataset's root: an object root or a raw date folder, as `source` says.
    pub input: PathBuf,
    /// Where the converted dataset goes.
    pub output: PathBuf,
    /// Which layout `input` has and what part of it is converted.
    pub source: KittiSource,
    /// What the frames are rendered into: a projection (scale, canvas) or a fisheye camera,
    /// then the crop and resize.
    pub target: Target,
    /// Write `mask_2/` (and `mask_3/`): where each output pixel has source data.
    pub mask: bool,
    /// Restrict to these frame ids.
    pub frames: Option<Vec<String>>,
    /// New, `--overwrite` or `--resume` (skip frames whose outputs a previous run
    /// completed, with the same parameters and inputs).
    pub mode: OutputMode,
    /// PNG encoder effort.
    pub png_compression: PngCompression,
    /// The CycleGAN style pass, if any.
    pub style: Option<StyleJob>,
    /// Random scale-and-crop views instead of the whole frame.
    pub augment: Option<Augment>,
    /// Cameras to convert: 2 (left colour), and 3 (right colour) for stereo pairs.
    pub cameras: Vec<Cam>,
    /// LiDAR depth maps (`depth_2/`), if asked for.
    pub depth: Option<DepthJob>,
    /// This process converts one shard of the frames.
    pub shard: Option<Shard>,
    /// Which placed objects are written as objects (the others as DontCare regions).
    pub visibility: Visibility,
}

/// The input of a KITTI conversion.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum KittiSource {
    /// A KITTI object root (`training/`, `testing/`): all of it, or the split named.
    Object {
        /// `training` or `testing`.
        split: Option<String>,
    },
    /// A KITTI raw date folder: all its drives, or the drive named.
    Raw {
        /// A drive folder's name (`2011_09_26_drive_0001_sync`).
        drive: Option<String>,
    },
}

impl KittiSource {
    /// The dataset at `root`, restricted as asked.
    fn open(&self, root: &Path) -> Result<Dataset> {
        match self {
            KittiSource::Object { split } => Dataset::open(root, split.as_deref()),
            KittiSource::Raw { drive } => raw::open(root, drive.as_deref()),
        }
    }

    /// The subcommand the manifest names.
    fn command(&self) -> &'static str {
        match self {
            KittiSource::Object { .. } => "kitti",
            KittiSource::Raw { .. } => "kitti-raw",
        }
    }
}

/// The manifest's `parameters`: what decides the outputs (docs/formats.md), so a `--resume`
/// or a `merge` can tell a run with other options. Field order is the file's.
#[derive(Debug, Serialize)]
struct Parameters<'a> {
    input: &'a Path,
    output_spec: TargetRecord,
    #[serde(skip_serializing_if = "Option::is_none")]
    fisheye: Option<&'a FisheyeTarget>,
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    mask: bool,
    /// The object split or the raw drive.
    split: Option<&'a str>,
    frames: Option<&'a [String]>,
    png_compression: PngCompression,
    augment: Option<&'a Augment>,
    cameras: &'a [Cam],
    depth: Option<&'a DepthJob>,
    shard: Option<Shard>,
    #[serde(skip_serializing_if = "Visibility::is_implied")]
    visibility: Visibility,
    raw: bool,
    style: Option<StyleRecord<'a>>,
}

impl<'a> Parameters<'a> {
    fn new(job: &'a KittiJob, style: Option<&'a StyleModel>) -> Self {
        let (split, raw) = match &job.source {
            KittiSource::Object { split } => (split.as_deref(), false),
            KittiSource::Raw { drive } => (drive.as_deref(), true),
        };
        Parameters {
            input: &job.input,
            output_spec: job.target.record(),
            fisheye: job.target.fisheye(),
            mask: job.mask,
            split,
            frames: job.frames.as_deref(),
            png_compression: job.png_compression,
            augment: job.augment.as_ref(),
            cameras: &job.cameras,
            depth: job.depth.as_ref(),
            shard: job.shard,
            visibility: job.visibility,
            raw,
            style: style.map(|m| StyleRecord {
                model: m.info(),
                order: job
                    .style
                    .as_ref()
                    .map_or(StyleOrder::BeforeWarp, |s| s.order),
            }),
        }
    }
}

/// What the manifest records of the style pass.
#[derive(Debug, Serialize)]
struct StyleRecord<'a> {
    model: &'a StyleInfo,
    order: StyleOrder,
}

/// What a KITTI conversion did: the run's counts and what only a KITTI conversion has.
#[derive(Debug)]
pub struct KittiSummary {
    /// Frames, failures, time, tables.
    pub run: Summary,
    /// Style model runs and the images they took (batch checks included), if styled.
    pub style_runs: Option<(usize, usize)>,
    /// With --augment: the views holding fewer objects than asked (at least one), and that
    /// minimum.
    pub thin_views: Option<(usize, usize)>,
    /// Files of the input that no frame takes (`split/folder/name: why`): an image that is not
    /// a PNG, a calib or label without an image. Listed by unsharded runs of the whole dataset
    /// (and shard 0).
    pub not_frames: Vec<String>,
}
