//! `panoconv kitti360`: a KITTI-360 sequence's rig into panoramas (or one camera converted),
//! with labels, calib, depth and the source map, as a KITTI dataset.

use super::convert::{
    install_stop_handler, parse_crop, parse_shard, style_job, AugmentArgs, DeviceArg, STOP,
};
use super::export::{export_after_kitti, FormatArg};
use super::outcome::exit_code;
use super::{count, projection_of, scale_of, with_pool, Bar, RunArgs, To};
use anyhow::{bail, Result};
use clap::Args;
use nalgebra::Vector3;
use panoconv::camera::{ImageSize, OutputProjection, Projection};
use panoconv::convert::rig::{run_rig, ObjectRule, RigJob, RigSummary, StitchMode};
use panoconv::convert::run_options::{DepthJob, RunOptions};
use panoconv::error::Error;
use panoconv::geometry::{Canvas, Crop, FisheyeTarget, OutputSpec, Target};
use panoconv::kitti360::{
    Kitti360Classes, Kitti360Selection, Kitti360Source, DEFAULT_FISHEYE_FOV_DEG,
};
use panoconv::reproject::depth::OcclusionFilter;
use panoconv::run::journal::Shard;
use panoconv::run::OutputMode;
use panoconv::warp::StitchOptions;
use std::path::PathBuf;
use std::process::ExitCode;

/// `--stitch-mode`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum StitchModeArg {
    /// Each pixel at its own distance (the frame's scan and 3D boxes).
    Depth,
    /// Every pixel at --stitch-distance.
    Fixed,
}

pub(super) const KITTI360_EXAMPLES: &str = "Examples:
  panoconv kitti360 --to equirect --input fixtures/kitti360 --sequence 2013_05_28_drive_0000_sync --output /tmp/k360_equi --pano-width 1024
  panoconv kitti360 --to equirect --depth --input /data/KITTI-360 --sequence 2013_05_28_drive_0000_sync --output O --frames 250,251
  panoconv kitti360 --to cylindrical --cameras 02 --input /data/KITTI-360 --sequence 2013_05_28_drive_0000_sync --output O_left
  panoconv kitti360 --to equirect --input R --sequence 2013_05_28_drive_0000_sync,2013_05_28_drive_0003_sync --output O --export coco
  panoconv kitti360 --to equirect --style miami_BtoA.onnx --input R --sequence 2013_05_28_drive_0000_sync --output O_miami
  panoconv kitti360 --to equirect --augment 4 --seed 7 --crop-size 1024x512 --min-objects 2 --input R --sequence 2013_05_28_drive_0000_sync --output O_aug

Output: OUT/training/{image_2,label_2,calib,source_2,objects}/ID.* (depth_2 with --depth) and
OUT/panoconv.json. ID is the frame number in 6 digits (000250); with several sequences the
drive number comes first (0003000250). The rect of every file is the frame's level frame
(y down along gravity, z the heading of image_00, origin at image_00's centre): calib has
R0_rect = I, Tr_velo_to_cam into it, projection:/K2:/C2: and Tr_rect_to_world: (to the
KITTI-360 world). source_2 names the camera of each pixel (0-3, 255 none). docs/kitti360.md
has the stitch model, the class table and the rule for the objects written.";

/// `panoconv kitti360`.
#[derive(Args)]
pub(super) struct Kitti360Args {
    /// Target projection (fisheye: the camera of --camera, its rotation relative to the level
    /// frame).
    #[arg(long, value_enum)]
    to: To,
    /// The fisheye camera of --to fisheye (a camera description or calibration file).
    #[arg(long, value_name = "FILE")]
    camera: Option<PathBuf>,
    /// KITTI-360 root (calibration/, data_2d_raw/, data_3d_raw/, data_poses/, data_3d_bboxes/).
    #[arg(long, short = 'i')]
    input: PathBuf,
    /// Sequence folder name(s), comma-separated (e.g. 2013_05_28_drive_0000_sync).
    #[arg(long, value_delimiter = ',', required = true, value_name = "NAME,...")]
    sequence: Vec<String>,
    /// Output root (created; must be empty unless --overwrite).
    #[arg(long, short = 'o')]
    output: PathBuf,
    /// Convert only these KITTI-360 frame numbers (comma-separated, e.g. 250,251), of every
    /// sequence.
    #[arg(long, value_delimiter = ',', value_name = "N,...")]
    frames: Option<Vec<String>>,
    /// Rig cameras to use: 00 and 01 (forward pinholes), 02 (left fisheye), 03 (right).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "00,01,02,03",
        value_name = "K,..."
    )]
    cameras: Vec<String>,
    /// Also write LiDAR depth maps (depth_2/: range from C2 for equirect and fisheye, z for
    /// perspective, rho for cylindrical; 16-bit, round(d·256)).
    #[arg(long)]
    depth: bool,
    /// Keep LiDAR points the output centre cannot see (the occlusion correction is on).
    #[arg(long, requires = "depth")]
    no_occlusion_filter: bool,
    /// Azimuth step of the LiDAR sweep, degrees, for the occlusion filter (HDL-64E: 0.09;
    /// synthetic sequences: 0.2 / scale).
    #[arg(long, value_name = "DEG", default_value_t = 0.09, requires = "depth")]
    lidar_azimuth_step: f64,
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
    /// 0 reads no scan for this.
    #[arg(long, value_name = "N", default_value_t = 3)]
    min_points: usize,
    /// Also write these KITTI-360 classes (named by their KITTI-360 class), or `all`.
    #[arg(long, value_delimiter = ',', value_name = "CLASS,...")]
    classes: Option<Vec<String>>,
    /// The panorama centre C2 in the level frame, metres (default: the mean of the cameras'
    /// centres).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_centre, allow_hyphen_values = true)]
    centre: Option<Vector3<f64>>,
    /// Field of view of the fisheyes image_02 and image_03, degrees (one value, or two).
    #[arg(long, value_delimiter = ',', value_name = "DEG[,DEG]")]
    fisheye_fov: Option<Vec<f64>>,
    /// Scale given as the width of a full 360° panorama (2048 → 325.95 px/rad). Default: the
    /// first camera's focal length (3472 for image_00 at full size).
    #[arg(long, value_name = "PIXELS", conflicts_with = "px_per_deg")]
    pano_width: Option<u32>,
    /// Scale in pixels per degree at the image centre.
    #[arg(long, value_name = "PX")]
    px_per_deg: Option<f64>,
    /// Crop the output canvas to this window (canvas pixels).
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_crop)]
    crop: Option<Crop>,
    /// Resize the (cropped) output to this size.
    #[arg(long, value_name = "WxH", value_parser = super::parse_size)]
    resize: Option<ImageSize>,
    /// Ego masks, one per camera (PNG, the camera's image size; non-zero = the vehicle's
    /// body): the camera gives no output pixel whose sample would touch its mask.
    #[arg(long, value_delimiter = ',', value_name = "K=PATH,...")]
    ego_mask: Vec<String>,
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
    run: RunArgs,
    #[command(flatten)]
    augment: AugmentArgs,
    /// CycleGAN generator (ONNX) giving each camera's image the target domain's look, before
    /// the stitch.
    #[arg(long, value_name = "MODEL.onnx")]
    style: Option<PathBuf>,
    /// ONNX Runtime library (libonnxruntime.so); else $ORT_DYLIB_PATH, else beside the binary.
    #[arg(long, value_name = "PATH", requires = "style")]
    ort_lib: Option<PathBuf>,
    /// Where the style model runs.
    #[arg(long, value_enum, default_value_t = DeviceArg::Cpu, requires = "style")]
    device: DeviceArg,
    /// Equal-size images of up to N consecutive frames go through the model in one run, when
    /// its batch axis is dynamic [default: 4 with --device cuda, 1 on the CPU, where a batch
    /// is no faster]. Outputs are the same for every N.
    #[arg(long, value_name = "N", requires = "style",
          value_parser = clap::value_parser!(u16).range(1..=panoconv::style::MAX_BATCH as i64))]
    style_batch: Option<u16>,
    /// Not supported by kitti360 (named here to say so).
    #[arg(long, hide = true)]
    style_after_warp: bool,
    /// Not supported by kitti360 (named here to say so).
    #[arg(long, hide = true)]
    mask: bool,
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

/// The rig index of a camera named `00` to `03` (or `0` to `3`): image_00 to image_03.
fn rig_camera(name: &str) -> Option<usize> {
    match name.trim() {
        "00" | "0" => Some(0),
        "01" | "1" => Some(1),
        "02" | "2" => Some(2),
        "03" | "3" => Some(3),
        _ => None,
    }
}

fn setup(message: String) -> anyhow::Error {
    Error::Setup(message).into()
}

pub(super) fn kitti360(args: Kitti360Args) -> Result<ExitCode> {
    refuse_unsupported(&args)?;
    let (job, selection) = jobs(&args)?;
    install_stop_handler();
    let bar = Bar::new(args.run.quiet);
    let summary = with_pool(args.run.jobs, || -> panoconv::error::Result<_> {
        let source = Kitti360Source::open(selection)?;
        run_rig(&job, &source, &bar, &STOP)
    })??;
    if !args.run.quiet {
        report(&summary, &job);
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
            job.run.augment.is_some(),
            overwrite,
            args.run.quiet,
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// The flags kitti360 names only to refuse them, with the reason.
fn refuse_unsupported(args: &Kitti360Args) -> Result<()> {
    for (given, flag, why) in [
        (
            args.style_after_warp,
            "--style-after-warp",
            "each camera's image is styled before the stitch, so that the blend and the \
             exposure gains work on styled images",
        ),
        (
            args.mask,
            "--mask",
            "source_2/ marks the pixels without a camera (255)",
        ),
    ] {
        if given {
            bail!(setup(format!("{flag} is not supported by kitti360: {why}")));
        }
    }
    Ok(())
}

/// Ego mask files by rig index.
type EgoMasks = Vec<(usize, PathBuf)>;

/// The rig cameras of `--cameras` and the ego masks of `--ego-mask`, by rig index.
fn cameras_and_masks(args: &Kitti360Args) -> Result<(Vec<usize>, EgoMasks)> {
    let mut cameras = Vec::new();
    for c in &args.cameras {
        let Some(k) = rig_camera(c) else {
            bail!(setup(format!(
                "--cameras {:?}: expected 00, 01, 02 or 03 (image_00 to image_03)",
                c.trim()
            )))
        };
        if cameras.contains(&k) {
            bail!(setup(format!("--cameras names {c} twice")));
        }
        cameras.push(k);
    }
    let mut ego_masks = Vec::new();
    for given in &args.ego_mask {
        let (k, path) = given.split_once('=').ok_or_else(|| {
            setup(format!(
                "--ego-mask {given:?}: expected CAMERA=PATH, e.g. 02=masks/image_02.png"
            ))
        })?;
        let Some(k) = rig_camera(k) else {
            bail!(setup(format!(
                "--ego-mask {:?}={path}: the camera is 00, 01, 02 or 03",
                k.trim()
            )))
        };
        ego_masks.push((k, PathBuf::from(path)));
    }
    Ok((cameras, ego_masks))
}

/// The output camera. A panorama of several cameras covers 360°; one camera, or a perspective
/// view, the first camera's field of view.
fn target(args: &Kitti360Args, cameras: usize) -> Result<Target> {
    Ok(match (projection_of(args.to), &args.camera) {
        (OutputProjection::Fisheye, Some(file)) => {
            if args.pano_width.is_some() || args.px_per_deg.is_some() {
                bail!(setup(
                    "--pano-width/--px-per-deg: a fisheye target has the scale of its camera file"
                        .into()
                ));
            }
            Target::Fisheye {
                camera: Box::new(FisheyeTarget::read(file)?),
                crop: args.crop,
                resize: args.resize,
            }
        }
        (OutputProjection::Fisheye, None) => bail!(setup(
            "--to fisheye needs --camera FILE: a camera description or calibration file".into()
        )),
        (OutputProjection::Linear(_), Some(_)) => bail!(setup(
            "--camera describes the camera of --to fisheye".into()
        )),
        (OutputProjection::Linear(projection), None) => Target::Linear(OutputSpec {
            projection,
            scale: scale_of(args.pano_width, args.px_per_deg)?,
            canvas: if cameras > 1 && projection != Projection::Perspective {
                Canvas::Full360
            } else {
                Canvas::Tight
            },
            crop: args.crop,
            resize: args.resize,
        }),
    })
}

/// What of the KITTI-360 root is read: `--sequence`, `--frames`, `--classes`,
/// `--fisheye-fov`.
fn selection(args: &Kitti360Args, lidar: bool, scenery: bool) -> Result<Kitti360Selection> {
    let frames = match &args.frames {
        Some(list) => {
            let mut out = Vec::new();
            for t in list {
                out.push(
                    t.trim()
                        .parse::<u32>()
                        .map_err(|_| setup(format!("--frames {t:?}: not a frame number")))?,
                );
            }
            Some(out)
        }
        None => None,
    };
    let classes = match &args.classes {
        None => Kitti360Classes::Kitti,
        Some(list) if list.iter().any(|c| c == "all") => Kitti360Classes::All,
        Some(list) => {
            for c in list {
                if !panoconv::kitti360::classes::CLASSES
                    .iter()
                    .any(|(_, name, _)| name == c)
                {
                    bail!(setup(format!(
                        "--classes {c:?}: not a KITTI-360 class (car, building, pole, ...)"
                    )));
                }
            }
            Kitti360Classes::Also(list.clone())
        }
    };
    let fisheye_fov_deg = match args.fisheye_fov.as_deref() {
        None => [DEFAULT_FISHEYE_FOV_DEG; 2],
        Some([a]) => [*a, *a],
        Some([a, b]) => [*a, *b],
        Some(_) => bail!(setup("--fisheye-fov takes one or two angles".into())),
    };
    Ok(Kitti360Selection {
        input: args.input.clone(),
        sequences: args.sequence.iter().map(|s| s.trim().to_owned()).collect(),
        frames,
        classes,
        fisheye_fov_deg,
        lidar,
        scenery,
    })
}

/// The rig job and the selection of the arguments, their rules checked.
fn jobs(args: &Kitti360Args) -> Result<(RigJob, Kitti360Selection)> {
    let (cameras, ego_masks) = cameras_and_masks(args)?;
    let target = target(args, cameras.len())?;
    if !(args.lidar_azimuth_step > 0.0 && args.lidar_azimuth_step.is_finite()) {
        bail!(setup("--lidar-azimuth-step must be positive".into()));
    }
    for (v, flag) in [
        (args.stitch_distance, "--stitch-distance"),
        (args.blend_width, "--blend-width"),
        (args.max_distance, "--max-distance"),
    ] {
        if !(v > 0.0 && v.is_finite()) {
            bail!(setup(format!("{flag} must be positive")));
        }
    }
    let job = RigJob {
        run: RunOptions {
            output: args.output.clone(),
            mode: OutputMode::from_flags(args.run.overwrite, args.resume),
            shard: args.shard,
            png_compression: args.run.png_compression(),
            style: style_job(&args.style, &args.ort_lib, args.device, args.style_batch),
            augment: args.augment.views(),
            depth: args.depth.then(|| DepthJob {
                occlusion_filter: (!args.no_occlusion_filter).then(|| OcclusionFilter {
                    azimuth_spacing: args.lidar_azimuth_step.to_radians(),
                    ..OcclusionFilter::default()
                }),
            }),
            export: !args.export.is_empty(),
        },
        target,
        cameras,
        stitch: StitchOptions {
            distance: args.stitch_distance,
            blend_width: args.blend_width.to_radians(),
            even_exposure: !args.no_exposure_gains,
        },
        stitch_mode: match args.stitch_mode {
            StitchModeArg::Depth => StitchMode::Depth,
            StitchModeArg::Fixed => StitchMode::Fixed,
        },
        stitch_depth: args.stitch_depth,
        centre: args.centre,
        objects: ObjectRule {
            max_distance: args.max_distance,
            min_points: args.min_points,
            visibility: args.augment.visibility(),
        },
        ego_masks,
    };
    job.validate()?;
    let selection = selection(args, job.needs_lidar(), job.depth_guided())?;
    Ok((job, selection))
}

/// The run's summary: frames, objects written and dropped, thin views, the style pass.
fn report(summary: &RigSummary, job: &RigJob) {
    super::outcome::report(&summary.run, "frame", &job.run.output);
    let o = &summary.objects;
    eprintln!(
        "panoconv: {} written ({} tilted); dropped: {} by class, {} beyond {} m, {} with \
         fewer than {} LiDAR points, {} outside the image",
        count(o.written, "object"),
        o.tilted,
        o.class,
        o.distance,
        job.objects.max_distance,
        o.unseen,
        job.objects.min_points,
        o.outside
    );
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
            "panoconv: {} without the images of --cameras not converted (not frames): {}{}",
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
    if let Some((runs, images)) = summary.style_runs {
        eprintln!(
            "panoconv: style pass: {} in {}",
            count(images, "image"),
            count(runs, "model run")
        );
    }
}
