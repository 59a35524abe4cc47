//! What every rig command (`kitti360`, `nuscenes`) shares: the output camera, the stitch, the
//! objects, the depth maps and the run options ([`RigArgs`]), turned into one
//! [`RigJob`] and run on any [`RigSource`] through one path ([`run_rig_command`]).

use super::shared::augment::AugmentArgs;
use super::shared::export_after::{export_after_kitti, FormatArg};
use super::shared::outcome::{count, exit_code};
use super::shared::parse::{parse_crop, parse_shard, parse_size};
use super::shared::run::{install_stop_handler, with_pool, Bar, RunArgs, STOP};
use super::shared::style::StyleArgs;
use super::shared::target::{projection_of, To};
use anyhow::{bail, Result};
use clap::Args;
use nalgebra::Vector3;
use panoconv::camera::{ImageSize, OutputProjection};
use panoconv::convert::rig::{
    rig_output_spec, run_rig, CanvasFlags, ObjectRule, RigJob, RigSpec, RigSummary, StitchMode,
};
use panoconv::convert::run_options::{DepthJob, RunOptions};
use panoconv::error::Error;
use panoconv::geometry::{Crop, FisheyeTarget, Target};
use panoconv::reproject::depth::OcclusionFilter;
use panoconv::run::journal::Shard;
use panoconv::run::OutputMode;
use panoconv::source::RigSource;
use panoconv::warp::StitchOptions;
use std::path::PathBuf;
use std::process::ExitCode;

mod coverage;

/// `--stitch-mode`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum StitchModeArg {
    /// Each pixel at its own distance (the frame's scan and 3D boxes).
    Depth,
    /// Every pixel at --stitch-distance.
    Fixed,
}

/// The options of a rig conversion that do not depend on the dataset.
#[derive(Args)]
pub(super) struct RigArgs {
    /// Target projection (fisheye: the camera of --camera, its rotation relative to the level
    /// frame).
    #[arg(long, value_enum)]
    to: To,
    /// The fisheye camera of --to fisheye (a camera description or calibration file).
    #[arg(long, value_name = "FILE")]
    camera: Option<PathBuf>,
    /// Output root (created; must be empty unless --overwrite).
    #[arg(long, short = 'o')]
    pub(super) output: PathBuf,
    /// Also write LiDAR depth maps (depth_2/: range from C2 for equirect and fisheye, z for
    /// perspective, rho for cylindrical; 16-bit, round(d·256)).
    #[arg(long)]
    depth: bool,
    /// Keep LiDAR points the output centre cannot see (the occlusion correction is on).
    #[arg(long, requires = "depth")]
    no_occlusion_filter: bool,
    /// Azimuth step of the LiDAR sweep, degrees, for the occlusion filter [default: the
    /// dataset's LiDAR: 0.09 for KITTI-360's HDL-64E, 0.33 for nuScenes' HDL-32E; synthetic
    /// data: 0.2 / scale].
    #[arg(long, value_name = "DEG", requires = "depth")]
    lidar_azimuth_step: Option<f64>,
    /// Proxy distance of the stitch, metres: with `--stitch-mode fixed`, or for a frame
    /// without a scan, every pixel is stitched at this distance.
    #[arg(long, value_name = "M", default_value_t = 10.0)]
    stitch_distance: f64,
    /// `depth`: each pixel stitched at its own distance, from the frame's scan and 3D boxes;
    /// `fixed`: every pixel at --stitch-distance.
    #[arg(long, value_enum, value_name = "MODE", default_value = "depth")]
    stitch_mode: StitchModeArg,
    /// Also write the distance each pixel was stitched at (stitch_depth_2/: metres from C2
    /// along the ray, 16-bit round(d·256), 0 for the sky).
    #[arg(long)]
    stitch_depth: bool,
    /// Blend width, degrees: a camera's weight rises from 0 at its field of view's edge to 1
    /// this far inside.
    #[arg(long, value_name = "DEG", default_value_t = 5.0)]
    blend_width: f64,
    /// Keep each camera's exposure (no per-frame gains).
    #[arg(long)]
    no_exposure_gains: bool,
    /// Leave out objects whose centre is farther from C2, metres.
    #[arg(long, value_name = "M", default_value_t = 80.0)]
    max_distance: f64,
    /// Leave out objects with fewer LiDAR points inside their box (its lowest 0.1 m aside);
    /// 0 reads no scan for this [default: 3 for KITTI-360; 0 for nuScenes, whose annotations
    /// count their points (see --keep-unseen)].
    #[arg(long, value_name = "N")]
    min_points: Option<usize>,
    /// The panorama centre C2 in the level frame, metres (default: the mean of the cameras'
    /// centres).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_centre, allow_hyphen_values = true)]
    centre: Option<Vector3<f64>>,
    /// Scale given as the width of a full 360° panorama (2048 → 325.95 px/rad). Default: 2048
    /// for a panorama of several cameras, else the first camera's focal length. Given alone,
    /// a panorama of several cameras is the whole sphere (--crop cuts the band).
    #[arg(long, value_name = "PIXELS", conflicts_with = "px_per_deg")]
    pano_width: Option<u32>,
    /// Scale in pixels per degree at the image centre.
    #[arg(long, value_name = "PX")]
    px_per_deg: Option<f64>,
    /// Cover the whole 360° (equirect: and 180° of latitude). Default for a panorama of
    /// several cameras: the band of elevations the cameras cover, unless a scale is given
    /// (then the whole sphere).
    #[arg(long, conflicts_with = "size")]
    full_360: bool,
    /// Explicit output size, centred on the first camera's field of view.
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    size: Option<ImageSize>,
    /// Crop the output canvas to this window (canvas pixels).
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_crop)]
    crop: Option<Crop>,
    /// Resize the (cropped) output to this size.
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    resize: Option<ImageSize>,
    /// Continue a killed or interrupted run.
    #[arg(long)]
    resume: bool,
    /// Convert only shard K of N, writing panoconv.shard-K-of-N.json (join with `merge`).
    #[arg(long, value_name = "K/N", value_parser = parse_shard)]
    shard: Option<Shard>,
    /// After a conversion with no failed frame, also export (coco, omni3d into OUT/annotations,
    /// yolo into OUT_yolo).
    #[arg(long, value_enum, value_delimiter = ',', value_name = "FORMAT,...")]
    export: Vec<FormatArg>,
    #[command(flatten)]
    pub(super) run: RunArgs,
    #[command(flatten)]
    augment: AugmentArgs,
    #[command(flatten)]
    styling: StyleArgs,
    /// Not supported by rig commands (named here to say so).
    #[arg(long, hide = true)]
    style_after_warp: bool,
    /// Also write mask_2/: 1-bit PNGs, white where the pixel's colour is trustworthy (a
    /// camera passed the depth-guided stitch's occlusion test; with `--stitch-mode fixed`, some
    /// camera covers it): source_2 below 64.
    #[arg(long)]
    mask: bool,
}

/// What a dataset's command decides of a [`RigJob`]: the cameras, their masks and the
/// defaults of its LiDAR.
pub(super) struct RigChoice {
    /// The command's name, for errors (`kitti360`).
    pub(super) command: &'static str,
    /// The rig cameras used, by index into the source's camera set.
    pub(super) cameras: Vec<usize>,
    /// Ego masks by rig index.
    pub(super) ego_masks: Vec<(usize, PathBuf)>,
    /// `--lidar-azimuth-step`'s default, degrees.
    pub(super) lidar_azimuth_step_deg: f64,
    /// `--min-points`'s default.
    pub(super) min_points: usize,
}

pub(super) fn setup(message: String) -> anyhow::Error {
    Error::Setup(message).into()
}

fn parse_centre(s: &str) -> std::result::Result<Vector3<f64>, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| "expected X,Y,Z in metres, e.g. 0,0,0.5".to_owned())?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vector3::new(x, y, z)),
        _ => Err("expected X,Y,Z in metres, e.g. 0,0,0.5".into()),
    }
}

/// Ego masks of `--ego-mask K=PATH,...`, the camera named as `camera` resolves it to a rig
/// index (None: not a camera of the rig; `expected` says which are).
pub(super) fn ego_masks(
    given: &[String],
    camera: impl Fn(&str) -> Option<usize>,
    expected: &str,
) -> Result<Vec<(usize, PathBuf)>> {
    let mut masks = Vec::new();
    for g in given {
        let (k, path) = g.split_once('=').ok_or_else(|| {
            setup(format!(
                "--ego-mask {g:?}: expected CAMERA=PATH, e.g. {expected}=masks/camera.png"
            ))
        })?;
        let Some(k) = camera(k.trim()) else {
            bail!(setup(format!(
                "--ego-mask {:?}={path}: not a chosen camera (expected {expected})",
                k.trim()
            )))
        };
        masks.push((k, PathBuf::from(path)));
    }
    Ok(masks)
}

impl RigArgs {
    /// The flag rig commands name only to refuse it, with the reason.
    fn refuse_unsupported(&self, command: &str) -> Result<()> {
        if self.style_after_warp {
            bail!(setup(format!(
                "--style-after-warp is not supported by {command}: each camera's image is styled \
                 before the stitch, so that the blend and the exposure gains work on styled images"
            )));
        }
        Ok(())
    }

    /// The scale and canvas flags as given.
    fn canvas_flags(&self) -> CanvasFlags {
        CanvasFlags {
            pano_width: self.pano_width,
            px_per_deg: self.px_per_deg,
            full_360: self.full_360,
            size: self.size,
            crop: self.crop,
            resize: self.resize,
        }
    }

    /// The output camera. A panorama of several cameras covers 360°; one camera, or a
    /// perspective view, the first camera's field of view.
    fn target(&self, cameras: usize) -> Result<Target> {
        let flags = self.canvas_flags();
        Ok(match (projection_of(self.to), &self.camera) {
            (OutputProjection::Fisheye, Some(file)) => {
                if flags.sized_flag().is_some() {
                    bail!(setup(
                        "--pano-width/--px-per-deg/--full-360/--size: a fisheye target has the \
                         size and scale of its camera file"
                            .into()
                    ));
                }
                Target::Fisheye {
                    camera: Box::new(FisheyeTarget::read(file)?),
                    crop: flags.crop,
                    resize: flags.resize,
                }
            }
            (OutputProjection::Fisheye, None) => bail!(setup(
                "--to fisheye needs --camera FILE: a camera description or calibration file".into()
            )),
            (OutputProjection::Linear(_), Some(_)) => bail!(setup(
                "--camera describes the camera of --to fisheye".into()
            )),
            (OutputProjection::Linear(projection), None) => {
                Target::Linear(rig_output_spec(projection, cameras, &flags)?)
            }
        })
    }

    /// The rig job of these options and the dataset's choice: flags mapped to a
    /// [`RigSpec`], whose rules [`RigJob::new`] checks (the CLI adds none of its own).
    pub(super) fn job(&self, choice: RigChoice) -> Result<RigJob> {
        self.refuse_unsupported(choice.command)?;
        let target = self.target(choice.cameras.len())?;
        let azimuth_step = self
            .lidar_azimuth_step
            .unwrap_or(choice.lidar_azimuth_step_deg);
        let spec = RigSpec {
            run: RunOptions {
                output: self.output.clone(),
                mode: OutputMode::from_flags(self.run.overwrite, self.resume),
                shard: self.shard,
                png_compression: self.run.png_compression(),
                style: self.styling.job(),
                augment: self.augment.views(),
                depth: self.depth.then(|| DepthJob {
                    occlusion_filter: (!self.no_occlusion_filter).then(|| OcclusionFilter {
                        azimuth_spacing: azimuth_step.to_radians(),
                        ..OcclusionFilter::default()
                    }),
                }),
                export: !self.export.is_empty(),
            },
            target,
            cameras: choice.cameras,
            stitch: StitchOptions {
                distance: self.stitch_distance,
                blend_width: self.blend_width.to_radians(),
                even_exposure: !self.no_exposure_gains,
            },
            stitch_mode: match self.stitch_mode {
                StitchModeArg::Depth => StitchMode::Depth,
                StitchModeArg::Fixed => StitchMode::Fixed,
            },
            stitch_depth: self.stitch_depth,
            mask: self.mask,
            centre: self.centre,
            objects: ObjectRule {
                max_distance: self.max_distance,
                min_points: self.min_points.unwrap_or(choice.min_points),
                visibility: self.augment.visibility(),
            },
            ego_masks: choice.ego_masks,
        };
        Ok(RigJob::new(spec)?)
    }
}

/// Runs the rig job and source that `prepare` gives (inside the worker pool, so that a
/// reader's own parallel work keeps to `--jobs`), reports it, and exports when asked: the one
/// run path of every rig command.
pub(super) fn run_rig_command<S: RigSource>(
    args: &RigArgs,
    prepare: impl FnOnce() -> Result<(RigJob, S)> + Send,
) -> Result<ExitCode> {
    install_stop_handler();
    let bar = Bar::new(args.run.quiet);
    let (job, summary, label_types) = with_pool(args.run.jobs, || -> Result<_> {
        let (job, source) = prepare()?;
        let summary = run_rig(&job, &source, &bar, &STOP)?;
        Ok((job, summary, source.label_types()))
    })??;
    let job = &job;
    if !args.run.quiet {
        report(&summary, job);
        coverage::report_coverage(job, &args.canvas_flags());
    }
    if let Some(code) = exit_code(&summary.run) {
        return Ok(code);
    }
    if !args.export.is_empty() {
        let overwrite = job.run.mode != OutputMode::New;
        return export_after_kitti(
            &job.run.output,
            &job.run.output,
            &args.export,
            &label_types,
            job.run.augment.is_some(),
            overwrite,
            args.run.quiet,
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// The run's summary: frames, objects written and dropped, thin views, the style pass.
fn report(summary: &RigSummary, job: &RigJob) {
    super::shared::outcome::report(&summary.run, "frame", &job.run.output);
    let o = &summary.objects;
    let unseen = match job.objects.min_points {
        0 => format!("{} seen by no sensor", o.unseen),
        n => format!("{} with fewer than {n} LiDAR points", o.unseen),
    };
    eprintln!(
        "panoconv: {} written ({} tilted); dropped: {} by class, {} beyond {} m, {unseen}, {} \
         outside the image",
        count(o.written, "object"),
        o.tilted,
        o.class,
        o.distance,
        job.objects.max_distance,
        o.outside
    );
    if o.uncovered > 0 {
        eprintln!(
            "panoconv: {} dropped: on no pixel the chosen cameras give (--cameras)",
            count(o.uncovered, "object")
        );
    }
    if o.barely_visible > 0 {
        eprintln!(
            "panoconv: {} written as DontCare regions: less of them visible than \
             --min-visible {},{}",
            count(o.barely_visible, "object"),
            job.objects.visibility.min_side_px,
            job.objects.visibility.min_share
        );
    }
    if !summary.not_frames.is_empty() {
        let first: Vec<&str> = summary
            .not_frames
            .iter()
            .take(5)
            .map(String::as_str)
            .collect();
        eprintln!(
            "panoconv: {} without an image of every chosen camera (--cameras, default all) not \
             converted (not frames): {}{}",
            count(summary.not_frames.len(), "pose"),
            first.join(", "),
            if summary.not_frames.len() > 5 {
                ", ..."
            } else {
                ""
            }
        );
    }
    if let Some(thin) = summary.thin_views.filter(|n| *n > 0) {
        eprintln!(
            "panoconv: {} with fewer than {} objects after {} draws",
            count(thin, "augmented view"),
            job.run.augment.map_or(0, |a| a.min_objects),
            panoconv::geometry::augment::MAX_ATTEMPTS
        );
    }
    super::shared::outcome::report_style(summary.style_runs);
}
