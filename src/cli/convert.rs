//! `kitti`, `kitti-raw` and `merge`: the KITTI conversions and their options.

use super::shared::augment::AugmentArgs;
use super::shared::export_after::{export_after_kitti, FormatArg};
use super::shared::outcome::{count, exit_code};
use super::shared::parse::{parse_crop, parse_shard, parse_size};
use super::shared::run::{install_stop_handler, with_pool, Bar, RunArgs, STOP};
use super::shared::style::StyleArgs;
use super::shared::target::{projection_of, To};
use anyhow::{bail, Result};
use clap::Args;
use panoconv::camera::ImageSize;
use panoconv::convert::canvas_flags::CanvasFlags;
use panoconv::convert::kitti::{run_kitti, KittiOptions, KittiSource, KittiSummary};
use panoconv::convert::run_options::{DepthJob, RunOptions, StyleJob, StyleOrder};
use panoconv::error::Error;
use panoconv::geometry::augment::Augment;
use panoconv::geometry::Crop;
use panoconv::kitti::dataset::read_id_list;
use panoconv::kitti::Cam;
use panoconv::reproject::depth::OcclusionFilter;
use panoconv::reproject::visibility::Visibility;
use panoconv::run::{OutputMode, Shard};
use std::path::PathBuf;
use std::process::ExitCode;

pub(super) const RAW_EXAMPLES: &str = "Examples:
  panoconv kitti-raw --to equirect --cameras 2,3 --depth --input /data/raw/2011_09_26 --output /data/raw_equi
  panoconv kitti-raw --to cylindrical --drive 2011_09_26_drive_0001_sync --input /data/raw/2011_09_26 --output O

Output mirrors the input: OUT/<drive>/image_02/data/*.png (image_03 with --cameras 2,3),
OUT/<drive>/depth_02/data/*.png with --depth, and one OUT/<drive>/calib.txt in KITTI object form
(P0..P3, R0_rect, Tr_velo_to_cam from the date folder) with projection:, K2:, C2: added.
Frames are selected with --frames or --frames-from (ids are the image file stems).";

pub(super) const KITTI_EXAMPLES: &str = "Examples:
  panoconv kitti --to equirect --input /data/kitti --output /data/kitti_equi
  panoconv kitti --to cylindrical --input /data/kitti --output /data/kitti_cyl --jobs 8
  panoconv kitti --to cylindrical --depth --input /data/kitti --output /data/kitti_cyl
  panoconv kitti --to equirect --cameras 2,3 --input /data/kitti --output /data/kitti_equi
  panoconv kitti --to equirect --pano-width 2048 --input /data/kitti --output /data/kitti_2048
  panoconv kitti --to equirect --split training --image-set val --input K --output O
  panoconv kitti --to perspective --frames 000001,000042 --input K --output O
  panoconv kitti --to equirect --style miami_BtoA.onnx --input K --output O_miami
  panoconv kitti --to equirect --pano-width 2048 --crop 0,20,469,128 --input K --output O
  panoconv kitti --to cylindrical --resize 620x200 --input K --output O
  panoconv kitti --to equirect --augment 4 --seed 7 --scale-range 0.8,1.25 --crop-size 448x128 --input K --output O
  panoconv kitti --to fisheye --camera front.json --mask --depth --input K --output O_fish
  panoconv kitti --to fisheye --camera kitti360_image_02.yaml --input K --output O_kitti360
  panoconv kitti --to equirect --export coco,yolo --input K --output O

Output: OUT/<split>/{image_2,label_2,calib}/NNNNNN.* in KITTI's format, and OUT/panoconv.json.
The calib keeps every input line and adds `projection:`, `K2:` and `C2:` (see the README); a
fisheye output adds the lens: `model2:`, `D2:` (its parameters), `fov2:` and `R2:` (its axes in
rect), documented in docs/formats.md.";

/// `panoconv kitti`: a KITTI object root.
#[derive(Args)]
pub(super) struct KittiArgs {
    /// KITTI object root holding training/ and/or testing/ (each with image_2/, calib/, ...).
    #[arg(long, short = 'i')]
    input: PathBuf,
    /// Convert only this split (training or testing).
    #[arg(long)]
    split: Option<String>,
    /// Convert only the frames listed in INPUT/ImageSets/NAME.txt.
    #[arg(long, value_name = "NAME", conflicts_with_all = ["frames", "frames_from"])]
    image_set: Option<String>,
    #[command(flatten)]
    common: ConvertArgs,
    #[command(flatten)]
    augment: AugmentArgs,
}

/// `panoconv kitti-raw`: a KITTI raw date folder.
#[derive(Args)]
pub(super) struct RawArgs {
    /// KITTI raw date folder holding calib_cam_to_cam.txt, calib_velo_to_cam.txt and
    /// *_drive_*_sync/ drives (e.g. /data/raw/2011_09_26).
    #[arg(long, short = 'i')]
    input: PathBuf,
    /// Convert only this drive (e.g. 2011_09_26_drive_0001_sync).
    #[arg(long, value_name = "NAME")]
    drive: Option<String>,
    #[command(flatten)]
    common: ConvertArgs,
}

/// What `kitti` and `kitti-raw` share: the target, the frames, the outputs and the run.
#[derive(Args)]
pub(super) struct ConvertArgs {
    /// Target projection (fisheye: the camera of --camera).
    #[arg(long, value_enum)]
    to: To,
    /// The fisheye camera of --to fisheye: a camera description (JSON) or a KITTI-360, WoodScape
    /// or OpenCV calibration file (docs/fisheye.md); its rotation turns it relative to KITTI's
    /// rectified camera axes.
    #[arg(long, value_name = "FILE")]
    camera: Option<PathBuf>,
    /// Output root (created; must be empty unless --overwrite).
    #[arg(long, short = 'o')]
    output: PathBuf,
    /// Also write mask_2/ (mask_3/ with --cameras 2,3): 1-bit PNGs, white where the output
    /// pixel has source data, for trainers to ignore the rest.
    #[arg(long)]
    mask: bool,
    /// Convert only these frame ids (comma-separated; `7` stands for `000007`).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "ID,...",
        conflicts_with = "frames_from"
    )]
    frames: Option<Vec<String>>,
    /// Convert only the frame ids listed in FILE (one per line).
    #[arg(long, value_name = "FILE")]
    frames_from: Option<PathBuf>,
    /// Scale given as the width in pixels of a full 360° panorama (2048 → 325.95 px/rad).
    /// Default: the source focal length in pixels per radian.
    #[arg(long, value_name = "PIXELS", conflicts_with = "px_per_deg")]
    pano_width: Option<u32>,
    /// Scale in pixels per degree at the image centre.
    #[arg(long, value_name = "PX")]
    px_per_deg: Option<f64>,
    /// Cover the full 360° of azimuth (and 180° of latitude for equirect).
    #[arg(long, conflicts_with = "size")]
    full_360: bool,
    /// Explicit output size, centred on the source field of view.
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    size: Option<ImageSize>,
    /// Crop the output canvas to this window (in canvas pixels; may reach beyond it). K, boxes
    /// and truncation follow; the image is still resampled once.
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_crop)]
    crop: Option<Crop>,
    /// Resize the (cropped) output to this size: fu' = s·fu, cu' = s(cu + 0.5) − 0.5.
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    resize: Option<ImageSize>,
    /// Cameras to convert: 2 (left colour), 3 (right colour, about its own centre C3).
    #[arg(long, value_delimiter = ',', default_value = "2", value_parser = parse_camera)]
    cameras: Vec<Cam>,
    /// Also write LiDAR depth maps (depth_2/, 16-bit, round(d·256)) from velodyne/ (kitti-raw:
    /// each drive's velodyne_points/data/).
    #[arg(long)]
    depth: bool,
    /// Keep LiDAR points the camera cannot see (the occlusion correction is on by default).
    #[arg(long, requires = "depth")]
    no_occlusion_filter: bool,
    /// Continue a killed or interrupted run: frames whose outputs match the manifest are kept.
    #[arg(long)]
    resume: bool,
    /// Convert only shard K of N (K from 0), writing panoconv.shard-K-of-N.json; join the
    /// shards with `panoconv merge OUT`.
    #[arg(long, value_name = "K/N", value_parser = parse_shard)]
    shard: Option<Shard>,
    #[command(flatten)]
    run: RunArgs,
    #[command(flatten)]
    styling: StyleArgs,
    /// Apply the style model to the warped image instead of the source.
    #[arg(long, requires = "style")]
    style_after_warp: bool,
    /// After a conversion with no failed frame, also export: coco and omni3d into
    /// OUT/annotations, yolo into OUT_yolo beside OUT (see `panoconv export --help`).
    #[arg(long, value_enum, value_delimiter = ',', value_name = "FORMAT,...")]
    export: Vec<FormatArg>,
}

#[derive(Args)]
pub(super) struct MergeArgs {
    /// The shared output folder of the shards.
    output: PathBuf,
}

pub(super) fn parse_camera(s: &str) -> std::result::Result<Cam, String> {
    match s.trim() {
        "2" => Ok(Cam::C2),
        "3" => Ok(Cam::C3),
        other => Err(format!(
            "camera {other:?}: expected 2 or 3 (KITTI's colour cameras)"
        )),
    }
}

pub(super) fn kitti(args: KittiArgs) -> Result<ExitCode> {
    let image_set = match &args.image_set {
        Some(set) => {
            let file = args.input.join("ImageSets").join(format!("{set}.txt"));
            if !file.is_file() {
                bail!(Error::Setup(format!(
                    "image set {set:?}: {} does not exist",
                    file.display()
                )));
            }
            Some(read_id_list_nonempty(&file)?)
        }
        None => None,
    };
    let visibility = args.augment.visibility();
    let augment = args.augment.views();
    convert(
        args.common,
        args.input,
        KittiSource::Object { split: args.split },
        image_set,
        (augment, visibility),
    )
}

pub(super) fn kitti_raw(args: RawArgs) -> Result<ExitCode> {
    convert(
        args.common,
        args.input,
        KittiSource::Raw { drive: args.drive },
        None,
        (None, Visibility::default()),
    )
}

/// An id list that names at least one frame (an empty list selects nothing: a set-up error).
fn read_id_list_nonempty(file: &std::path::Path) -> Result<Vec<String>> {
    let ids = read_id_list(file)?;
    if ids.is_empty() {
        bail!(Error::Setup(format!(
            "{}: lists no frame id, so nothing would be converted",
            file.display()
        )));
    }
    Ok(ids)
}

/// Builds and runs a conversion job from the shared options.
fn convert(
    args: ConvertArgs,
    input: PathBuf,
    source: KittiSource,
    image_set: Option<Vec<String>>,
    (augment, visibility): (Option<Augment>, Visibility),
) -> Result<ExitCode> {
    let frames = match (args.frames, &args.frames_from) {
        // `--frames "1, 4"`: the spaces are not part of the ids.
        (Some(list), _) => Some(list.iter().map(|id| id.trim().to_owned()).collect()),
        (None, Some(file)) => Some(read_id_list_nonempty(file)?),
        (None, None) => image_set,
    };
    let job = KittiOptions {
        input,
        run: RunOptions {
            output: args.output,
            mode: OutputMode::from_flags(args.run.overwrite, args.resume),
            png_compression: args.run.png_compression(),
            depth: args.depth.then(|| DepthJob {
                occlusion_filter: (!args.no_occlusion_filter).then(OcclusionFilter::default),
            }),
            augment,
            shard: args.shard,
            style: args.styling.job().map(|s| StyleJob {
                order: if args.style_after_warp {
                    StyleOrder::AfterWarp
                } else {
                    StyleOrder::BeforeWarp
                },
                ..s
            }),
            export: !args.export.is_empty(),
        },
        source,
        to: projection_of(args.to),
        camera: args.camera,
        canvas: CanvasFlags {
            pano_width: args.pano_width,
            px_per_deg: args.px_per_deg,
            full_360: args.full_360,
            size: args.size,
            crop: args.crop,
            resize: args.resize,
        },
        mask: args.mask,
        frames,
        cameras: args.cameras.clone(),
        visibility,
    }
    .validate()?;
    install_stop_handler();
    let bar = Bar::new(args.run.quiet);
    let summary = with_pool(args.run.jobs, || run_kitti(&job, &bar, &STOP))??;
    if !args.run.quiet {
        report(&summary, &job.output);
    }
    if let Some(code) = exit_code(&summary.run) {
        return Ok(code);
    }
    if !args.export.is_empty() {
        let augmented = job.augment.is_some();
        // A resumed run replaces the export of the run it continues.
        let (overwrite, quiet) = (job.mode != OutputMode::New, args.run.quiet);
        return export_after_kitti(
            &job.input,
            &job.output,
            &args.export,
            &[],
            augmented,
            overwrite,
            quiet,
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// A KITTI run's summary: frames, the files that are not frames, thin views, the style pass.
fn report(summary: &KittiSummary, output: &std::path::Path) {
    super::shared::outcome::report(&summary.run, "frame", output);
    if !summary.not_frames.is_empty() {
        // The run succeeds without them, but a dataset smaller than its folder is named.
        const SHOWN: usize = 20;
        eprintln!(
            "panoconv: {} of the input not converted (not frames):",
            count(summary.not_frames.len(), "file")
        );
        for line in summary.not_frames.iter().take(SHOWN) {
            eprintln!("  {line}");
        }
        if summary.not_frames.len() > SHOWN {
            eprintln!("  and {} more", summary.not_frames.len() - SHOWN);
        }
    }
    if let Some((views, min)) = summary.thin_views {
        eprintln!(
            "panoconv: {} held fewer than {} (DontCare regions aside)",
            count(views, "augmented view"),
            count(min, "object")
        );
    }
    super::shared::outcome::report_style(summary.style_runs);
}

pub(super) fn merge(a: MergeArgs) -> Result<ExitCode> {
    let n = panoconv::run::journal::merge(&a.output)?;
    eprintln!(
        "panoconv: merged {} into {}",
        count(n, "frame"),
        a.output.join(panoconv::run::manifest::MANIFEST).display()
    );
    Ok(ExitCode::SUCCESS)
}
