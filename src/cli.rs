//! Command-line interface: argument parsing, progress display and exit codes.
//!
//! Exit codes: 0 all frames converted; 1 some frames failed (each reported); 2 usage or set-up
//! error, nothing written.

use anyhow::{bail, Context as _, Result};
use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use panoconv::camera::{ImageSize, Projection};
use panoconv::error::Error;
use panoconv::geometry::{Canvas, OutputSpec, Scale};
use panoconv::kitti::dataset::read_id_list;
use panoconv::kitti::png_io::PngCompression;
use panoconv::kitti::FrameRef;
use panoconv::pipeline::{run_kitti, KittiJob, Progress, StyleJob};
use panoconv::style::{Device, StyleOptions};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

const EXIT_FRAMES_FAILED: u8 = 1;
const EXIT_SETUP: u8 = 2;

#[derive(Parser)]
#[command(
    name = "panoconv",
    version,
    about = "Adapt KITTI datasets to panoramic, cylindrical and fisheye cameras: images, labels and calibration reprojected exactly."
)]
#[command(
    after_help = "Exit codes: 0 success; 1 some frames failed (each is reported); 2 usage or set-up error (nothing written).\n\nRun `panoconv kitti --help` for examples."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Convert a KITTI object dataset (images, labels, calib) to another projection.
    #[command(after_help = KITTI_EXAMPLES)]
    Kitti(KittiArgs),
    /// Draw a converted frame's labels (3D boxes as curves, 2D boxes) using only its written calib.
    #[command(
        after_help = "Examples:\n  panoconv preview /data/kitti_equi --frame 000123 --output preview.png\n  panoconv preview /data/kitti_cyl --split testing --frame 000007 --output p.png"
    )]
    Preview(PreviewArgs),
    /// Write a small synthetic KITTI dataset with exact labels (for tests and demos).
    #[command(after_help = "Example:\n  panoconv synth --output /tmp/synthetic_kitti")]
    Synth(SynthArgs),
}

const KITTI_EXAMPLES: &str = "Examples:
  panoconv kitti --to equirect --input /data/kitti --output /data/kitti_equi
  panoconv kitti --to cylindrical --input /data/kitti --output /data/kitti_cyl --jobs 8
  panoconv kitti --to equirect --pano-width 2048 --input /data/kitti --output /data/kitti_2048
  panoconv kitti --to equirect --split training --image-set val --input K --output O
  panoconv kitti --to perspective --frames 000001,000042 --input K --output O
  panoconv kitti --to equirect --style miami_BtoA.onnx --input K --output O_miami

Output: OUT/<split>/{image_2,label_2,calib}/NNNNNN.* in KITTI's format, and OUT/panoconv.json.
The calib keeps every input line and adds `projection:`, `K2:` and `C2:` (see the README).";

#[derive(Clone, Copy, ValueEnum)]
enum To {
    Equirect,
    Cylindrical,
    Perspective,
}

#[derive(Args)]
struct KittiArgs {
    /// Target projection.
    #[arg(long, value_enum)]
    to: To,
    /// KITTI object root holding training/ and/or testing/.
    #[arg(long, short = 'i')]
    input: PathBuf,
    /// Output root (created; must be empty unless --overwrite).
    #[arg(long, short = 'o')]
    output: PathBuf,
    /// Convert only this split (training or testing).
    #[arg(long)]
    split: Option<String>,
    /// Convert only the frames listed in INPUT/ImageSets/NAME.txt.
    #[arg(long, value_name = "NAME", conflicts_with_all = ["frames", "frames_from"])]
    image_set: Option<String>,
    /// Convert only these frame ids (comma-separated).
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
    /// Worker threads (default: all cores).
    #[arg(long, short = 'j', value_name = "N")]
    jobs: Option<usize>,
    /// Write into a non-empty output folder, replacing files of the same name.
    #[arg(long)]
    overwrite: bool,
    /// PNG compression effort.
    #[arg(long, value_enum, default_value_t = PngCompression::Default)]
    png_compression: PngCompression,
    /// No progress bar and no summary line.
    #[arg(long, short = 'q')]
    quiet: bool,
    /// CycleGAN generator (ONNX) giving each image the target domain's look, before the warp.
    #[arg(long, value_name = "MODEL.onnx")]
    style: Option<PathBuf>,
    /// Apply the style model to the warped image instead of the source.
    #[arg(long, requires = "style")]
    style_after_warp: bool,
    /// ONNX Runtime library (libonnxruntime.so); else $ORT_DYLIB_PATH, else beside the binary.
    #[arg(long, value_name = "PATH", requires = "style")]
    ort_lib: Option<PathBuf>,
    /// Where the style model runs.
    #[arg(long, value_enum, default_value_t = DeviceArg::Cpu, requires = "style")]
    device: DeviceArg,
}

#[derive(Clone, Copy, ValueEnum)]
enum DeviceArg {
    Cpu,
    Cuda,
}

#[derive(Args)]
struct PreviewArgs {
    /// A dataset written by `panoconv kitti` (or any KITTI root, drawn as perspective).
    dataset: PathBuf,
    /// Frame id.
    #[arg(long)]
    frame: String,
    #[arg(long, default_value = "training")]
    split: String,
    /// PNG to write.
    #[arg(long, short = 'o')]
    output: PathBuf,
}

#[derive(Args)]
struct SynthArgs {
    /// Output root (created; must be empty unless --overwrite).
    #[arg(long, short = 'o')]
    output: PathBuf,
    #[arg(long)]
    overwrite: bool,
}

fn parse_size(s: &str) -> std::result::Result<ImageSize, String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or("expected WIDTHxHEIGHT, e.g. 2048x512")?;
    let w: u32 = w.trim().parse().map_err(|_| format!("bad width {w:?}"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("bad height {h:?}"))?;
    if w == 0 || h == 0 {
        return Err("width and height must be positive".into());
    }
    Ok(ImageSize::new(w, h))
}

/// An indicatif bar on a terminal; nothing at all otherwise (logs stay clean).
struct Bar {
    bar: ProgressBar,
}

impl Bar {
    fn new(quiet: bool) -> Self {
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
        if quiet || !std::io::stderr().is_terminal() {
            bar.set_draw_target(ProgressDrawTarget::hidden());
        }
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} frames ({per_sec}, eta {eta})",
            )
            .expect("valid template"),
        );
        Self { bar }
    }
}

impl Progress for Bar {
    fn start(&self, total: usize) {
        self.bar.set_length(total as u64);
    }
    fn frame_done(&self) {
        self.bar.inc(1);
    }
    fn frame_failed(&self, frame: &FrameRef, error: &Error) {
        let what = if frame.split.is_empty() {
            format!("frame {}", frame.id)
        } else {
            format!("frame {}/{}", frame.split, frame.id)
        };
        self.bar
            .suspend(|| eprintln!("panoconv: {what} failed: {error}"));
        self.bar.inc(1);
    }
    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// Runs `body` on a pool of `jobs` threads: the one place threads are made.
fn with_pool<T: Send>(jobs: Option<usize>, body: impl FnOnce() -> T + Send) -> Result<T> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = jobs {
        if n == 0 {
            bail!(Error::Setup("--jobs must be at least 1".into()));
        }
        builder = builder.num_threads(n);
    }
    let pool = builder.build().context("cannot start worker threads")?;
    Ok(pool.install(body))
}

fn kitti(args: KittiArgs) -> Result<ExitCode> {
    let projection = match args.to {
        To::Equirect => Projection::Equirect,
        To::Cylindrical => Projection::Cylindrical,
        To::Perspective => Projection::Perspective,
    };
    let scale = match (args.pano_width, args.px_per_deg) {
        (Some(0), _) => bail!(Error::Setup("--pano-width must be positive".into())),
        (Some(w), _) => Scale::PanoWidth(w),
        (None, Some(d)) if !(d > 0.0 && d.is_finite()) => {
            bail!(Error::Setup("--px-per-deg must be positive".into()))
        }
        (None, Some(d)) => Scale::PixelsPerDegree(d),
        (None, None) => Scale::SourceFocal,
    };
    let canvas = match (args.full_360, args.size) {
        (true, _) => Canvas::Full360,
        (false, Some(s)) => Canvas::Size(s),
        (false, None) => Canvas::Tight,
    };
    let frames = if let Some(list) = args.frames {
        Some(list)
    } else if let Some(file) = &args.frames_from {
        Some(read_id_list(file)?)
    } else if let Some(set) = &args.image_set {
        let file = args.input.join("ImageSets").join(format!("{set}.txt"));
        if !file.is_file() {
            bail!(Error::Setup(format!(
                "image set {set:?}: {} does not exist",
                file.display()
            )));
        }
        Some(read_id_list(&file)?)
    } else {
        None
    };
    let job = KittiJob {
        input: args.input,
        output: args.output,
        output_spec: OutputSpec {
            projection,
            scale,
            canvas,
        },
        split: args.split,
        frames,
        overwrite: args.overwrite,
        png_compression: args.png_compression,
        style: args.style.map(|model| StyleJob {
            options: StyleOptions {
                model,
                ort_lib: args.ort_lib,
                device: match args.device {
                    DeviceArg::Cpu => Device::Cpu,
                    DeviceArg::Cuda => Device::Cuda,
                },
                intra_threads: 1,
            },
            after_warp: args.style_after_warp,
        }),
    };
    let bar = Bar::new(args.quiet);
    let summary = with_pool(args.jobs, || run_kitti(&job, &bar))??;
    if !args.quiet {
        eprintln!(
            "panoconv: {} frames converted, {} failed in {:.2} s ({:.1} frames/s) -> {}",
            summary.converted,
            summary.failed,
            summary.seconds,
            summary.converted as f64 / summary.seconds.max(1e-9),
            job.output.display()
        );
    }
    Ok(if summary.failed > 0 {
        ExitCode::from(EXIT_FRAMES_FAILED)
    } else {
        ExitCode::SUCCESS
    })
}

fn synth(args: SynthArgs) -> Result<ExitCode> {
    panoconv::synth::write_dataset(&args.output, args.overwrite)?;
    eprintln!(
        "panoconv: synthetic KITTI dataset written to {}",
        args.output.display()
    );
    Ok(ExitCode::SUCCESS)
}

fn preview(args: PreviewArgs) -> Result<ExitCode> {
    use panoconv::camera::{ImageSize, LinearCamera};
    use panoconv::kitti::{png_io, Calib, LabelFile};
    let split = args.dataset.join(&args.split);
    let image_path = split.join("image_2").join(format!("{}.png", args.frame));
    let calib_path = split.join("calib").join(format!("{}.txt", args.frame));
    let label_path = split.join("label_2").join(format!("{}.txt", args.frame));
    let mut image = png_io::decode_rgb8(&panoconv::error::read_file(&image_path)?, &image_path)?;
    let calib = Calib::read(&calib_path)?;
    let size = ImageSize::new(image.width(), image.height());
    let (camera, centre): (Box<dyn LinearCamera>, _) = if calib.projection.is_some() {
        calib.output_camera(2, size)?
    } else {
        let c = calib.camera(2)?;
        (Box::new(c.camera(size)), c.centre)
    };
    if label_path.exists() {
        for label in LabelFile::read(&label_path)?.labels {
            panoconv::preview::draw_label(&mut image, &label, camera.as_ref(), &centre);
        }
    }
    panoconv::output::write_atomic(
        &args.output,
        &png_io::encode_rgb8(&image, PngCompression::Default),
    )?;
    Ok(ExitCode::SUCCESS)
}

fn run() -> Result<ExitCode> {
    let cli = Cli::parse();
    match cli.command {
        Command::Kitti(a) => kitti(a),
        Command::Preview(a) => preview(a),
        Command::Synth(a) => synth(a),
    }
}

pub fn main() -> ExitCode {
    match run() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("panoconv: error: {e:#}");
            ExitCode::from(EXIT_SETUP)
        }
    }
}
