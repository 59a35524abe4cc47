//! `camera convert`: fit another lens model to a camera file.

use anyhow::{bail, Result};
use clap::{Args, Subcommand, ValueEnum};
use panoconv::camera::description::CameraDescription;
use panoconv::camera::fit::{fit, TargetModel};
use panoconv::error::Error;
use std::path::PathBuf;
use std::process::ExitCode;

pub(super) const CAMERA_EXAMPLES: &str = "Examples:
  panoconv camera convert kitti360/calibration/image_02.yaml --to kannala_brandt --output kb.json
  panoconv camera convert front.json --to double_sphere --output ds.json

FILE is a camera description JSON (docs/fisheye.md) or a native calibration file (KITTI-360
image_0[23].yaml, WoodScape JSON, OpenCV FileStorage with K, D [, xi]). The target model is
fitted over the source's field of view on a dense grid of its pixels (Levenberg-Marquardt);
the RMS and max reprojection errors, in pixels, are measured on a second grid and printed.
The description written keeps the source's size, field of view and rotation.";

#[derive(Args)]
pub(super) struct CameraArgs {
    #[command(subcommand)]
    command: CameraCommand,
}

#[derive(Subcommand)]
enum CameraCommand {
    /// Fit another lens model to a camera and write it as a camera description JSON.
    #[command(after_help = CAMERA_EXAMPLES)]
    Convert(ConvertCameraArgs),
}

#[derive(Clone, Copy, ValueEnum)]
enum TargetArg {
    #[value(name = "kannala_brandt", alias = "kannala-brandt")]
    KannalaBrandt,
    Mei,
    Eucm,
    #[value(name = "double_sphere", alias = "double-sphere")]
    DoubleSphere,
}

#[derive(Args)]
struct ConvertCameraArgs {
    /// Camera description JSON or native calibration file.
    #[arg(value_name = "FILE")]
    file: PathBuf,
    /// Model to fit.
    #[arg(long, value_enum)]
    to: TargetArg,
    /// Camera description JSON to write.
    #[arg(long, short = 'o', value_name = "OUT.json")]
    output: PathBuf,
    /// Fit only over rays within this full field of view (degrees); default: the source's.
    #[arg(long, value_name = "DEG")]
    max_fov: Option<f64>,
    /// Replace OUTPUT if it exists.
    #[arg(long)]
    overwrite: bool,
}

pub(super) fn camera(args: CameraArgs) -> Result<ExitCode> {
    match args.command {
        CameraCommand::Convert(a) => convert_camera(a),
    }
}

fn convert_camera(a: ConvertCameraArgs) -> Result<ExitCode> {
    let source = CameraDescription::read(&a.file)?;
    if a.output.exists() && !a.overwrite {
        bail!(Error::Setup(format!(
            "{} exists (use --overwrite to replace it)",
            a.output.display()
        )));
    }
    if same_file(&a.file, &a.output) {
        bail!(Error::Setup("--output must not be the input file".into()));
    }
    let target = match a.to {
        TargetArg::KannalaBrandt => TargetModel::KannalaBrandt,
        TargetArg::Mei => TargetModel::Mei,
        TargetArg::Eucm => TargetModel::Eucm,
        TargetArg::DoubleSphere => TargetModel::DoubleSphere,
    };
    let max_theta = match a.max_fov {
        Some(d) if !(d > 0.0 && d < 360.0) => {
            bail!(Error::Setup("--max-fov must be in (0, 360) degrees".into()))
        }
        d => d.map(|d| d.to_radians() / 2.0),
    };
    let report = fit(&source.camera, target, max_theta).map_err(|e| {
        Error::Setup(format!(
            "{}: cannot fit {} to this {} camera: {e}",
            a.file.display(),
            target.name(),
            source.camera.name()
        ))
    })?;
    let summary = format!(
        "{} fitted to {} ({}) over a {:.1}° field of view: RMS {:.4} px, max {:.4} px \
         ({} rays fitted, {} other rays measured, {} iterations)",
        target.name(),
        source.camera.name(),
        a.file.display(),
        2.0 * report.lens.max_theta().to_degrees(),
        report.rms_px,
        report.max_px,
        report.fit_rays,
        report.eval_rays,
        report.iterations
    );
    let written = CameraDescription {
        camera: report.lens.clone(),
        output_from_camera: source.output_from_camera,
    };
    panoconv::fs::write_atomic(
        &a.output,
        written
            .to_json(Some(&format!("panoconv camera convert: {summary}")))
            .as_bytes(),
    )?;
    // One write; a closed pipe (`| head`) is not an error of the conversion, already written.
    let _ = std::io::Write::write_all(
        &mut std::io::stdout().lock(),
        format!(
            "{summary}\nrms_px {}\nmax_px {}\n",
            report.rms_px, report.max_px
        )
        .as_bytes(),
    );
    Ok(ExitCode::SUCCESS)
}

/// Whether two paths name the same existing file.
fn same_file(a: &std::path::Path, b: &std::path::Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}
