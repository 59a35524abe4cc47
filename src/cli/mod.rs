//! Command-line interface: argument parsing, progress display and exit codes.
//!
//! Exit codes: 0 all frames converted; 1 some frames failed (each reported); 2 usage or set-up
//! error, nothing written.

use anyhow::Result;
use clap::{CommandFactory, Parser, Subcommand};
use panoconv::error::Error;
use shared::outcome::{EXIT_FRAMES_FAILED, EXIT_SETUP};
use std::process::ExitCode;

mod camera;
mod convert;
mod export;
mod folders;
mod kitti360;
mod nuscenes;
mod rig;
mod rig_stream;
mod shared;
mod tools;

use camera::{CameraArgs, CAMERA_EXAMPLES};
use convert::{
    kitti, kitti_raw, merge, KittiArgs, MergeArgs, RawArgs, KITTI_EXAMPLES, RAW_EXAMPLES,
};
use export::{ExportArgs, EXPORT_EXAMPLES};
use folders::{fisheye, pano, FisheyeArgs, PanoArgs, FISHEYE_EXAMPLES, PANO_EXAMPLES};
use kitti360::{kitti360, Kitti360Args, KITTI360_EXAMPLES};
use nuscenes::{nuscenes, NuScenesArgs, NUSCENES_EXAMPLES};
use rig_stream::{rig_stream, RigStreamArgs, RIG_STREAM_EXAMPLES};
use tools::{
    completions, eval_depth, inspect, labels_to_pixels, man, preview, synth, unproject, verify,
    CompletionsArgs, EvalDepthArgs, InspectArgs, LabelsToPixelsArgs, ManArgs, PreviewArgs,
    SynthArgs, UnprojectArgs, VerifyArgs, COMPLETIONS_EXAMPLES, INSPECT_EXAMPLES, MAN_EXAMPLES,
    PREVIEW_EXAMPLES,
};

#[derive(Parser)]
#[command(
    name = "panoconv",
    version,
    about = "Adapt KITTI datasets to panoramic, cylindrical and fisheye cameras: images, labels and calibration reprojected exactly."
)]
#[command(
    after_help = "Exit codes: 0 success; 1 some frames failed (each is reported); 2 usage or set-up error (nothing written); 130 interrupted (SIGINT/SIGTERM; finished frames are in the manifest, continue with --resume).\n\nRun `panoconv kitti --help` for examples."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Convert a KITTI object dataset (images, labels, calib) to another projection.
    #[command(after_help = KITTI_EXAMPLES)]
    Kitti(Box<KittiArgs>),
    /// Convert KITTI raw drives (a date folder with calib_*.txt and *_drive_*_sync/).
    #[command(after_help = RAW_EXAMPLES)]
    KittiRaw(Box<RawArgs>),
    /// Convert a KITTI-360 sequence: its four cameras stitched into a panorama (or one camera
    /// converted), with its 3D boxes, LiDAR depth and the camera of each pixel.
    #[command(after_help = KITTI360_EXAMPLES)]
    Kitti360(Box<Kitti360Args>),
    /// Convert a nuScenes-format dataset: each sample's cameras stitched into a panorama (or
    /// one camera converted), every sensor at its own time, with 3D boxes and LiDAR depth.
    #[command(after_help = NUSCENES_EXAMPLES)]
    Nuscenes(Box<NuScenesArgs>),
    /// Convert a rig whose frames another process serves on stdin/stdout (a Python adapter:
    /// `panoconv.convert_rig`), with the options of `nuscenes`.
    #[command(after_help = RIG_STREAM_EXAMPLES)]
    RigStream(Box<RigStreamArgs>),
    /// Draw a converted frame's labels (3D boxes as curves, 2D boxes) using only its written calib.
    #[command(after_help = PREVIEW_EXAMPLES)]
    Preview(PreviewArgs),
    /// Turn a converted dataset's labels into pixel objects (u, v, distance, ...) to train on.
    #[command(
        after_help = "Examples:\n  panoconv labels-to-pixels --input /data/kitti_equi --output /data/kitti_equi/training/pixels\n\nFormat (one object per line): type u v distance height width length alpha score\n(u, v) = pixel of the 3D box centre; distance = z, range or rho by projection."
    )]
    LabelsToPixels(LabelsToPixelsArgs),
    /// Turn pixel-object predictions made in converted images back into KITTI 3D results.
    #[command(
        after_help = "Examples:\n  panoconv unproject --calib O/training/calib --input preds/ --output preds_kitti/\n  panoconv unproject --calib O/training/calib --input preds/ --output out/ --trained-focal 721.5377\n\nImages are read from CALIB/../image_2 (for their size) unless --images is given."
    )]
    Unproject(UnprojectArgs),
    /// Depth metrics (abs rel, sq rel, RMSE, RMSE log, δ<1.25ᵏ) of predicted depth maps.
    #[command(
        after_help = "Examples:\n  panoconv eval-depth --pred preds/depth --gt /data/kitti_cyl/training/depth_2\n  panoconv eval-depth --pred P --gt G --max-depth 80 --json\n\nBoth folders hold 16-bit PNGs (round(d*256), 0 = none) with the same names. Ground truth outside\n(min, max) is discarded, predictions are clamped to [min, max], metrics are averaged per image."
    )]
    EvalDepth(EvalDepthArgs),
    /// Join the manifests of a sharded conversion (--shard K/N) into OUT/panoconv.json.
    #[command(
        after_help = "Examples:\n  panoconv kitti --to equirect --input K --output O --shard 0/4   # ... one per machine, 0..3\n  panoconv merge O\n\nChecks every shard is present once, with the same parameters, and no frame is doubled."
    )]
    Merge(MergeArgs),
    /// Check a converted dataset against its manifest: re-hash every listed output (blake3),
    /// report missing, changed and unlisted files.
    #[command(
        after_help = "Examples:\n  panoconv verify /data/kitti_equi\n  panoconv verify --allow-failed /data/kitti_equi\n\nOne line per problem on stdout (missing:, changed:, extra:, failed:, ...), then a summary.\nExit codes: 0 everything matches and no frame failed (or --allow-failed); 1 problems found, failed frames, or an unfinished run; 2 the manifest is missing or unreadable."
    )]
    Verify(VerifyArgs),
    /// Write a small synthetic KITTI dataset with exact labels (for tests and demos).
    #[command(
        after_help = "Examples:\n  panoconv synth --output /tmp/synthetic_kitti\n  panoconv synth --output fixtures/synthetic_kitti --overwrite\n  panoconv synth --kitti360 --scale 0.25 --output fixtures/kitti360 --overwrite"
    )]
    Synth(SynthArgs),
    /// Warp a folder of fisheye images (a camera description JSON, or a KITTI-360, WoodScape or
    /// OpenCV calibration file) to cylindrical, equirect or perspective.
    #[command(after_help = FISHEYE_EXAMPLES)]
    Fisheye(FisheyeArgs),
    /// Warp a folder of 2:1 equirect panoramas (PNG, JPEG, TIFF or WebP) to cylindrical, perspective views or an equirect strip.
    #[command(after_help = PANO_EXAMPLES)]
    Pano(PanoArgs),
    /// Camera files: fit another lens model to a camera (`camera convert`).
    #[command(after_help = CAMERA_EXAMPLES)]
    Camera(CameraArgs),
    /// Report what a KITTI-layout dataset holds and what is missing or malformed in it; describe
    /// a nuScenes or KITTI-360 root.
    #[command(after_help = INSPECT_EXAMPLES)]
    Inspect(InspectArgs),
    /// Write COCO, YOLO or Omni3D annotations of a converted (or plain KITTI) dataset.
    #[command(after_help = EXPORT_EXAMPLES)]
    Export(ExportArgs),
    /// Print a shell completion script for panoconv.
    #[command(after_help = COMPLETIONS_EXAMPLES)]
    Completions(CompletionsArgs),
    /// Print the man page (roff), or write one page per subcommand with --output.
    #[command(after_help = MAN_EXAMPLES)]
    Man(ManArgs),
}

fn run() -> Result<ExitCode> {
    let cli = Cli::parse();
    match cli.command {
        Command::Kitti(a) => kitti(*a),
        Command::KittiRaw(a) => kitti_raw(*a),
        Command::Kitti360(a) => kitti360(*a),
        Command::Nuscenes(a) => nuscenes(*a),
        Command::RigStream(a) => rig_stream(*a),
        Command::Preview(a) => preview(a),
        Command::LabelsToPixels(a) => labels_to_pixels(a),
        Command::Unproject(a) => unproject(a),
        Command::EvalDepth(a) => eval_depth(a),
        Command::Merge(a) => merge(a),
        Command::Verify(a) => verify(a),
        Command::Synth(a) => synth(a),
        Command::Fisheye(a) => fisheye(a),
        Command::Pano(a) => pano(a),
        Command::Camera(a) => camera::camera(a),
        Command::Inspect(a) => inspect(a),
        Command::Export(a) => export::export(a),
        Command::Completions(a) => completions(a, Cli::command()),
        Command::Man(a) => man(a, Cli::command()),
    }
}

pub fn main() -> ExitCode {
    match run() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("panoconv: error: {e:#}");
            // A run stopped by a full output device did convert frames: it is not a set-up error.
            match e.downcast_ref::<Error>() {
                Some(Error::DeviceFull(_)) => ExitCode::from(EXIT_FRAMES_FAILED),
                _ => ExitCode::from(EXIT_SETUP),
            }
        }
    }
}
