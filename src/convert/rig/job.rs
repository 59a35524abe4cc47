//! A rig conversion's job: what it is asked ([`RigSpec`]: the output camera, the cameras, the
//! stitch, the objects, the options every run shares), and [`RigJob`], made from it by the one
//! check of its rules ([`RigJob::new`]), which a rig run takes: the CLI maps flags to a spec, a
//! library caller (a plug-in adapter, the Python package) writes one, and both get the same
//! errors from the same place. Then its summary, and what the manifest records of it.
//!
//! The output is a KITTI object dataset: `OUT/training/{image_2, label_2, calib, source_2,
//! objects, depth_2, mask_2}/ID.*` (docs/kitti360.md), ID the source's item id.

use super::objects::{DropReason, ObjectOutcome, ObjectRule};
use super::scene_depth::StitchMode;
use crate::codec::png::PngCompression;
use crate::convert::run_options::{RunOptions, StyleOrder};
use crate::error::{Error, Result};
use crate::geometry::augment::Augment;
use crate::geometry::Target;
use crate::reproject::depth::OcclusionFilter;
use crate::run::Shard;
use crate::run::Summary;
use crate::source::RigSource;
use crate::style::StyleInfo;
use crate::warp::StitchOptions;
use nalgebra::Vector3;
use serde::Serialize;
use std::path::PathBuf;

/// The split every frame is written to (KITTI's loaders and panoconv's tools find it there).
pub const SPLIT: &str = "training";

/// What a rig conversion is asked: what any [`crate::source::RigSource`] is converted into,
/// and how. Plain values: [`RigJob::new`] checks them.
#[derive(Debug, Clone)]
pub struct RigSpec {
    /// The options every conversion shares: output, mode, shard, PNG effort, style (before
    /// the stitch only: the blend and the exposure gains work on styled images), augmented
    /// views, depth maps, export.
    pub run: RunOptions,
    /// The output camera.
    pub target: Target,
    /// The rig cameras used (indices into the source's camera set), in order.
    pub cameras: Vec<usize>,
    /// Proxy distance, blend width, exposure gains.
    pub stitch: StitchOptions,
    /// Depth-guided stitching (the default: each pixel at its distance from the frame's scan
    /// and boxes) or every pixel at the proxy distance.
    pub stitch_mode: StitchMode,
    /// Write the distance each pixel was stitched at (`stitch_depth_2/`).
    pub stitch_depth: bool,
    /// Write `mask_2/`: white where the pixel's colour is trustworthy (`source_2` below 64:
    /// a camera passed the occlusion test, or covers the pixel in a fixed stitch).
    pub mask: bool,
    /// The output centre C2 in the reference frame (default: the mean of the cameras'
    /// centres).
    pub centre: Option<Vector3<f64>>,
    /// Which objects are written.
    pub objects: ObjectRule,
    /// Ego masks: (rig camera index, mask image) pairs (non-zero pixels are the vehicle's
    /// body; `warp::EgoMask`).
    pub ego_masks: Vec<(usize, PathBuf)>,
}

/// A rig conversion whose rules hold ([`RigJob::new`]); it reads as its [`RigSpec`].
#[derive(Debug, Clone)]
pub struct RigJob {
    spec: RigSpec,
}

impl RigJob {
    /// The job of `spec`, its rules checked once, before any file is read, the output folder
    /// locked or a model loaded: the shared ones ([`RunOptions::validate`]), the cameras named
    /// once each, the style before the stitch, the positive distances and LiDAR azimuth step.
    /// Every refusal is a set-up error.
    pub fn new(spec: RigSpec) -> Result<Self> {
        spec.run.validate()?;
        if spec.cameras.is_empty() {
            return Err(Error::Setup("no camera chosen".into()));
        }
        if let Some(k) = (spec.cameras.iter().enumerate())
            .find_map(|(i, k)| spec.cameras[..i].contains(k).then_some(k))
        {
            return Err(Error::Setup(format!("camera {k} is chosen twice")));
        }
        // source_2's bits 64 and 128 mark the far fill and the fallback
        if let Some(k) = spec.cameras.iter().find(|&&k| k >= 64) {
            return Err(Error::Setup(format!(
                "camera {k}: source_2 holds the rig's camera indices 0 to 63 only"
            )));
        }
        if (spec.run.style.as_ref()).is_some_and(|s| s.order == StyleOrder::AfterWarp) {
            return Err(Error::Setup(
                "--style-after-warp: each camera's image is styled before the stitch, so that \
                 the blend and the exposure gains work on styled images"
                    .into(),
            ));
        }
        let azimuth_step = spec.depth().flatten().map(|f| f.azimuth_spacing);
        for (v, flag) in [
            (Some(spec.stitch.distance), "--stitch-distance"),
            (Some(spec.stitch.blend_width), "--blend-width"),
            (Some(spec.objects.max_distance), "--max-distance"),
            (azimuth_step, "--lidar-azimuth-step"),
        ] {
            if v.is_some_and(|v| !(v > 0.0 && v.is_finite())) {
                return Err(Error::Setup(format!("{flag} must be positive")));
            }
        }
        Ok(Self { spec })
    }

    /// What the job was made of.
    pub fn spec(&self) -> &RigSpec {
        &self.spec
    }
}

impl std::ops::Deref for RigJob {
    type Target = RigSpec;

    fn deref(&self) -> &RigSpec {
        &self.spec
    }
}

impl RigSpec {
    /// Whether LiDAR scans are read (depth maps, or the objects' LiDAR check): what a
    /// source is opened with.
    pub fn needs_lidar(&self) -> bool {
        self.run.depth.is_some() || self.objects.min_points > 0 || self.depth_guided()
    }

    /// Whether the frames are stitched by depth (two cameras or more, depth mode).
    pub fn depth_guided(&self) -> bool {
        self.stitch_mode == StitchMode::Depth && self.cameras.len() > 1
    }

    /// The depth maps asked for: with the occlusion filter (Some(Some)), without it
    /// (Some(None)), or none.
    pub(super) fn depth(&self) -> Option<Option<OcclusionFilter>> {
        self.run.depth.as_ref().map(|d| d.occlusion_filter)
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
    /// Dropped: on no pixel a chosen camera gives (`--cameras` leaving part of the image
    /// empty).
    #[serde(skip_serializing_if = "is_zero")]
    pub uncovered: usize,
    /// Written as DontCare regions: too little of them visible (`--min-visible`).
    #[serde(skip_serializing_if = "is_zero")]
    pub barely_visible: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
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
                Some(DropReason::Uncovered) => c.uncovered += 1,
                Some(DropReason::BarelyVisible) => c.barely_visible += 1,
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
        self.uncovered += o.uncovered;
        self.barely_visible += o.barely_visible;
    }
}

/// What a rig run did.
#[derive(Debug)]
pub struct RigSummary {
    /// Frames, failures, time.
    pub run: Summary,
    /// Objects written and dropped, by reason, over the frames converted by this run (each
    /// augmented view counted as a frame).
    pub objects: ObjectCounts,
    /// Style model runs and the images they took, if styled.
    pub style_runs: Option<(usize, usize)>,
    /// With `--augment`: the views holding fewer objects than asked (at least one).
    pub thin_views: Option<usize>,
    /// What the dataset lists that is not a frame ([`crate::source::RigItems::not_frames`]).
    pub not_frames: Vec<String>,
}

/// The run's part of the manifest's `parameters` (the source gives its own): what decides
/// the outputs.
#[derive(Debug, Serialize)]
pub(super) struct Parameters<'a> {
    pub(super) output_spec: crate::geometry::TargetRecord,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) fisheye: Option<&'a crate::geometry::FisheyeTarget>,
    pub(super) cameras: Vec<&'a str>,
    pub(super) stitch_distance: f64,
    /// `depth` (each pixel at its distance; frames without a scan at the proxy distance) or
    /// `fixed`.
    pub(super) stitch_mode: StitchMode,
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub(super) stitch_depth: bool,
    /// `--mask`: `mask_2/` written.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub(super) mask: bool,
    pub(super) blend_width_deg: f64,
    pub(super) exposure_gains: bool,
    pub(super) centre: Option<[f64; 3]>,
    pub(super) objects: &'a ObjectRule,
    pub(super) depth: Option<Option<OcclusionFilter>>,
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
    pub(super) camera: String,
    /// The mask image as given.
    pub(super) path: PathBuf,
    /// blake3 of its bytes.
    pub(super) hash: String,
}

/// The manifest's `parameters` of a run of `job` over `source`: the source's fields and the
/// run's, in the source's order.
pub(super) fn parameters(
    job: &RigJob,
    source: &dyn RigSource,
    ego_masks: &[EgoMaskRecord],
    style: Option<&StyleInfo>,
) -> serde_json::Value {
    let cameras = source.cameras(0);
    let run = Parameters {
        output_spec: job.target.record(),
        fisheye: job.target.fisheye(),
        cameras: job
            .cameras
            .iter()
            .filter_map(|&k| cameras.get(k).map(|c| c.name.as_str()))
            .collect(),
        stitch_distance: job.stitch.distance,
        stitch_mode: if job.depth_guided() {
            StitchMode::Depth
        } else {
            StitchMode::Fixed
        },
        stitch_depth: job.stitch_depth,
        mask: job.mask,
        blend_width_deg: job.stitch.blend_width.to_degrees(),
        exposure_gains: job.stitch.even_exposure,
        centre: job.centre.map(|c| [c.x, c.y, c.z]),
        objects: &job.objects,
        depth: job.depth(),
        shard: job.run.shard,
        png_compression: job.run.png_compression,
        ego_masks,
        style,
        augment: job.run.augment.as_ref(),
    };
    let serde_json::Value::Object(run) = serde_json::to_value(run).expect("parameters serialise")
    else {
        unreachable!("a struct serialises to an object")
    };
    let mut all = source.parameters();
    all.extend(run);
    let order = source.parameter_order();
    let rank = |k: &str| order.iter().position(|o| *o == k).unwrap_or(order.len());
    let mut entries: Vec<(String, serde_json::Value)> = all.into_iter().collect();
    // stable: keys the order does not name keep their relative place, after the named ones
    entries.sort_by_key(|(k, _)| rank(k));
    serde_json::Value::Object(entries.into_iter().collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Projection;
    use crate::geometry::{Canvas, OutputSpec, Scale};
    use crate::run::OutputMode;

    fn job() -> RigSpec {
        RigSpec {
            run: RunOptions {
                output: "out".into(),
                mode: OutputMode::New,
                shard: None,
                png_compression: PngCompression::Fast,
                style: None,
                augment: None,
                depth: None,
                export: false,
            },
            target: Target::Linear(OutputSpec {
                projection: Projection::Equirect,
                scale: Scale::PanoWidth(512),
                canvas: Canvas::Full360,
                crop: None,
                resize: None,
            }),
            cameras: vec![0, 2],
            stitch: StitchOptions {
                distance: 10.0,
                blend_width: 0.1,
                even_exposure: true,
            },
            stitch_mode: StitchMode::Fixed,
            stitch_depth: false,
            mask: false,
            centre: None,
            objects: ObjectRule {
                max_distance: 80.0,
                min_points: 0,
                visibility: crate::reproject::visibility::Visibility::default(),
            },
            ego_masks: Vec::new(),
        }
    }

    fn refusal(spec: RigSpec) -> String {
        match RigJob::new(spec) {
            Err(Error::Setup(m)) => m,
            other => panic!("expected a set-up error, got {other:?}"),
        }
    }

    #[test]
    fn each_rule_of_a_rig_job_refuses_before_anything_is_read() {
        assert!(RigJob::new(job()).is_ok());
        assert!(!job().needs_lidar());
        // a depth-guided stitch of two cameras reads the scans; of one camera it is a warp
        let depth = RigSpec {
            stitch_mode: StitchMode::Depth,
            ..job()
        };
        assert!(depth.depth_guided() && depth.needs_lidar());
        assert!(!RigSpec {
            cameras: vec![0],
            ..depth
        }
        .depth_guided());
        let m = refusal(RigSpec {
            cameras: vec![],
            ..job()
        });
        assert_eq!(m, "no camera chosen");
        let m = refusal(RigSpec {
            cameras: vec![2, 0, 2],
            ..job()
        });
        assert_eq!(m, "camera 2 is chosen twice");
        let mut j = job();
        j.stitch.distance = 0.0;
        assert_eq!(refusal(j), "--stitch-distance must be positive");
        let mut j = job();
        j.objects.max_distance = f64::NAN;
        assert_eq!(refusal(j), "--max-distance must be positive");
        let mut j = job();
        j.run.shard = Some(Shard { index: 1, count: 2 });
        j.run.export = true;
        assert!(refusal(j).starts_with("--export needs the whole output"));
        let mut j = job();
        j.run.depth = Some(crate::convert::run_options::DepthJob {
            occlusion_filter: None,
        });
        assert!(j.needs_lidar() && matches!(j.depth(), Some(None)));
        assert!(RigJob::new(j.clone()).is_ok());
        j.run.depth = Some(crate::convert::run_options::DepthJob {
            occlusion_filter: Some(OcclusionFilter {
                azimuth_spacing: -0.1,
                ..OcclusionFilter::default()
            }),
        });
        assert_eq!(refusal(j), "--lidar-azimuth-step must be positive");
    }
}
