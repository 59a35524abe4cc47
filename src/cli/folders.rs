//! `fisheye` and `pano`: folders of fisheye images or panoramas.

use super::shared::run::{with_pool, Bar, RunArgs};
use super::shared::target::{scale_of, FolderTo};
use anyhow::{bail, Result};
use clap::Args;
use panoconv::error::Error;
use std::path::PathBuf;
use std::process::ExitCode;

// ---------------------------------------------------------------------------------------------
// Folder conversions: fisheye and pano

pub(super) const FISHEYE_EXAMPLES: &str = "Examples:
  panoconv fisheye --camera front.json --to cylindrical --input frames/ --output cyl/
  panoconv fisheye --camera front.json --to cylindrical --vfov 90 --px-per-deg 4 --input F --output O
  panoconv fisheye --camera rear.json --to perspective --fov 100 --input F --output O

The camera file is a camera description (JSON, \"version\": 1) or a KITTI-360 (image_0x.yaml),
WoodScape (calibration JSON) or OpenCV FileStorage (K/D, K/D/xi) file, recognised by its
content; all are documented in docs/fisheye.md. The output is
levelled (the camera's pitch and roll undone) and turned to the camera's heading. Each image
NAME.png gives NAME.png and NAME.txt (projection:, K:, R:) in OUTPUT, plus OUTPUT/panoconv.json.
Inputs are PNG, JPEG, TIFF or WebP (8 or 16 bits).";

pub(super) const PANO_EXAMPLES: &str = "Examples:
  panoconv pano --to cylindrical --vfov 60 --input panos/ --output cyl/
  panoconv pano --to perspective --yaw 0,90,180,270 --fov 90 --input panos/ --output views/
  panoconv pano --to equirect --vfov 60 --yaw 180 --input panos/ --output strips/

Input: every 2:1 equirect PNG, JPEG, TIFF or WebP in INPUT. Each image NAME.png gives NAME.png and
NAME.txt (projection:, K:, R:), or NAME_yawDEG.png/.txt per yaw when several are given.";

#[derive(Args)]
pub(super) struct FolderArgs {
    /// Target projection.
    #[arg(long, value_enum)]
    to: FolderTo,
    /// Folder of input images (PNG, JPEG, TIFF or WebP).
    #[arg(long, short = 'i')]
    input: PathBuf,
    /// Output folder (created; must be empty unless --overwrite).
    #[arg(long, short = 'o')]
    output: PathBuf,
    /// Horizontal field of view of the output, degrees.
    #[arg(long, value_name = "DEG")]
    fov: Option<f64>,
    /// Vertical field of view of the output, degrees (latitude range at the centre).
    #[arg(long, value_name = "DEG")]
    vfov: Option<f64>,
    /// Scale given as the width in pixels of a full 360° at the output's scale.
    /// Default: the source's pixels per radian at its centre.
    #[arg(long, value_name = "PIXELS", conflicts_with = "px_per_deg")]
    pano_width: Option<u32>,
    /// Scale in pixels per degree at the output's centre.
    #[arg(long, value_name = "PX")]
    px_per_deg: Option<f64>,
    #[command(flatten)]
    run: RunArgs,
}

#[derive(Args)]
pub(super) struct FisheyeArgs {
    /// Camera description (JSON) or a KITTI-360, WoodScape or OpenCV calibration file
    /// (docs/fisheye.md).
    #[arg(long, value_name = "FILE")]
    camera: PathBuf,
    #[command(flatten)]
    common: FolderArgs,
}

#[derive(Args)]
pub(super) struct PanoArgs {
    /// View centres in degrees, right positive; one output per yaw.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "DEG,...",
        allow_hyphen_values = true
    )]
    yaw: Option<Vec<f64>>,
    /// View tilt in degrees, up positive.
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 0.0,
        allow_hyphen_values = true
    )]
    pitch: f64,
    #[command(flatten)]
    common: FolderArgs,
}

pub(super) fn degrees(v: Option<f64>, flag: &str) -> Result<Option<f64>> {
    match v {
        Some(d) if !(d > 0.0 && d <= 360.0) => {
            bail!(Error::Setup(format!("{flag} must be in (0, 360] degrees")))
        }
        v => Ok(v.map(f64::to_radians)),
    }
}

pub(super) fn run_folder_job(
    common: &FolderArgs,
    plan: &dyn panoconv::convert::folder::FolderPlan,
) -> Result<ExitCode> {
    let job = panoconv::convert::folder::FolderJob {
        input: common.input.clone(),
        output: common.output.clone(),
        overwrite: common.run.overwrite,
        png_compression: common.run.png_compression(),
    };

    let bar = Bar::counting(common.run.quiet, "image");
    let summary = with_pool(common.run.jobs, || {
        panoconv::convert::folder::run_folder(&job, plan, &bar)
    })??;
    if !common.run.quiet {
        super::shared::outcome::report(&summary, "image", &job.output);
    }
    Ok(super::shared::outcome::exit_code(&summary).unwrap_or(ExitCode::SUCCESS))
}

pub(super) fn fisheye(args: FisheyeArgs) -> Result<ExitCode> {
    use panoconv::camera::description::CameraDescription;
    use panoconv::convert::pano::FisheyeView;
    let a = &args.common;
    let desc = CameraDescription::read(&args.camera)?;
    let spec = FisheyeView {
        projection: a.to.0,
        hfov: degrees(a.fov, "--fov")?,
        vfov: degrees(a.vfov, "--vfov")?,
        scale: scale_of(a.pano_width, a.px_per_deg)?,
    };
    // Built before anything is written (one camera, one table): errors are set-up errors.
    let plan = spec.plan_folder(&args.camera, &desc)?;
    run_folder_job(a, &plan)
}

pub(super) fn pano(args: PanoArgs) -> Result<ExitCode> {
    use panoconv::convert::pano::PanoViews;
    let a = &args.common;
    let projection = a.to.0;
    let yaws: Vec<f64> = args
        .yaw
        .clone()
        .unwrap_or_else(|| vec![0.0])
        .iter()
        .map(|d| d.to_radians())
        .collect();
    if !yaws.iter().all(|y| y.is_finite()) || args.pitch.is_nan() || args.pitch.abs() > 90.0 {
        bail!(Error::Setup(
            "--yaw must be finite and --pitch within [-90, 90] degrees".into()
        ));
    }
    let hfov = degrees(a.fov, "--fov")?.unwrap_or(projection.default_pano_hfov());
    let vfov = degrees(a.vfov, "--vfov")?.unwrap_or(projection.default_pano_vfov(hfov));
    let views = PanoViews {
        projection,
        yaws,
        pitch: args.pitch.to_radians(),
        hfov,
        vfov,
        scale: scale_of(a.pano_width, a.px_per_deg)?,
    };
    views.validate()?;
    run_folder_job(a, &views)
}
