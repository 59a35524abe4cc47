//! Command-line interface: argument parsing, progress display and exit codes.
//!
//! Exit codes: 0 all frames converted; 1 some frames failed (each reported); 2 usage or set-up
//! error, nothing written.

use anyhow::{bail, Context as _, Result};
use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use panoconv::augment::Augment;
use panoconv::camera::{ImageSize, Projection};
use panoconv::error::Error;
use panoconv::geometry::{Canvas, Crop, OutputSpec, Scale};
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
    Kitti(Box<KittiArgs>),
    /// Draw a converted frame's labels (3D boxes as curves, 2D boxes) using only its written calib.
    #[command(
        after_help = "Examples:\n  panoconv preview /data/kitti_equi --frame 000123 --output preview.png\n  panoconv preview /data/kitti_cyl --split testing --frame 000007 --output p.png"
    )]
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
    /// Write a small synthetic KITTI dataset with exact labels (for tests and demos).
    #[command(after_help = "Example:\n  panoconv synth --output /tmp/synthetic_kitti")]
    Synth(SynthArgs),
    /// Check a converted dataset against its manifest: re-hash every listed output (blake3),
    /// report missing, changed and unlisted files.
    #[command(
        after_help = "Examples:\n  panoconv verify /data/kitti_equi\n\nOne line per problem on stdout (missing:, changed:, extra:, ...), then a summary.\nExit codes: 0 everything matches; 1 problems found; 2 the manifest is missing or unreadable."
    )]
    Verify(VerifyArgs),
}

const KITTI_EXAMPLES: &str = "Examples:
  panoconv kitti --to equirect --input /data/kitti --output /data/kitti_equi
  panoconv kitti --to cylindrical --input /data/kitti --output /data/kitti_cyl --jobs 8
  panoconv kitti --to equirect --pano-width 2048 --input /data/kitti --output /data/kitti_2048
  panoconv kitti --to equirect --split training --image-set val --input K --output O
  panoconv kitti --to perspective --frames 000001,000042 --input K --output O
  panoconv kitti --to equirect --style miami_BtoA.onnx --input K --output O_miami
  panoconv kitti --to equirect --pano-width 2048 --crop 0,20,469,128 --input K --output O
  panoconv kitti --to cylindrical --resize 620x200 --input K --output O
  panoconv kitti --to equirect --augment 4 --seed 7 --scale-range 0.8,1.25 --crop-size 448x128 --input K --output O

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
    /// Crop the output canvas to this window (in canvas pixels; may reach beyond it). K, boxes
    /// and truncation follow; the image is still resampled once.
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_crop)]
    crop: Option<Crop>,
    /// Resize the (cropped) output to this size: fu' = s·fu, cu' = s(cu + 0.5) − 0.5.
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    resize: Option<ImageSize>,
    /// Write N random scale-and-crop views of each frame (ids frame×N+k) instead of the frame.
    #[arg(long, value_name = "N", conflicts_with_all = ["crop", "resize"], requires = "crop_size")]
    augment: Option<u32>,
    /// Seed of --augment (same seed, same views, whatever --jobs).
    #[arg(long, default_value_t = 0, requires = "augment")]
    seed: u64,
    /// Range of the --augment scale factor, drawn uniformly.
    #[arg(long, value_name = "MIN,MAX", default_value = "1,1", value_parser = parse_range, requires = "augment")]
    scale_range: (f64, f64),
    /// Size of every --augment view.
    #[arg(long, value_name = "WxH", value_parser = parse_size, requires = "augment")]
    crop_size: Option<ImageSize>,
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
struct LabelsToPixelsArgs {
    /// A dataset written by `panoconv kitti`.
    #[arg(long, short = 'i')]
    input: PathBuf,
    /// Folder for the pixel-object files (one per frame).
    #[arg(long, short = 'o')]
    output: PathBuf,
    #[arg(long, default_value = "training")]
    split: String,
}

#[derive(Args)]
struct UnprojectArgs {
    /// The converted dataset's calib folder (e.g. O/training/calib).
    #[arg(long)]
    calib: PathBuf,
    /// Its images, for their sizes (default: CALIB/../image_2).
    #[arg(long)]
    images: Option<PathBuf>,
    /// Folder of pixel-object predictions, one NNNNNN.txt per frame.
    #[arg(long, short = 'i')]
    input: PathBuf,
    /// Folder for the KITTI result files.
    #[arg(long, short = 'o')]
    output: PathBuf,
    /// The detector was trained on perspective images of this vertical focal length (px):
    /// distances are rescaled to the output camera (Z at f becomes rho at f_y).
    #[arg(long, value_name = "PX")]
    trained_focal: Option<f64>,
}

#[derive(Args)]
struct SynthArgs {
    /// Output root (created; must be empty unless --overwrite).
    #[arg(long, short = 'o')]
    output: PathBuf,
    #[arg(long)]
    overwrite: bool,
}

#[derive(Args)]
struct VerifyArgs {
    /// Output folder written by `panoconv kitti` (holding panoconv.json).
    output: PathBuf,
    /// Print only the problems, no summary line.
    #[arg(long, short = 'q')]
    quiet: bool,
}

fn parse_crop(s: &str) -> std::result::Result<Crop, String> {
    let v: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y, w, h] = v[..] else {
        return Err("expected X,Y,WIDTH,HEIGHT, e.g. 0,20,469,128".into());
    };
    let int = |t: &str| {
        t.parse::<i64>()
            .map_err(|_| format!("{t:?} is not an integer"))
    };
    let (width, height) = (int(w)?, int(h)?);
    if width <= 0 || height <= 0 || width > 65535 || height > 65535 {
        return Err("crop width and height must be between 1 and 65535".into());
    }
    Ok(Crop {
        x: int(x)?,
        y: int(y)?,
        width: width as u32,
        height: height as u32,
    })
}

fn parse_range(s: &str) -> std::result::Result<(f64, f64), String> {
    let (a, b) = s.split_once(',').ok_or("expected MIN,MAX, e.g. 0.8,1.25")?;
    let num = |t: &str| {
        t.trim()
            .parse::<f64>()
            .map_err(|_| format!("{t:?} is not a number"))
    };
    let (a, b) = (num(a)?, num(b)?);
    if !(a > 0.0 && b >= a && b.is_finite()) {
        return Err("expected 0 < MIN <= MAX".into());
    }
    Ok((a, b))
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
            crop: args.crop,
            resize: args.resize,
        },
        split: args.split,
        frames,
        overwrite: args.overwrite,
        png_compression: args.png_compression,
        augment: args.augment.map(|count| Augment {
            count,
            seed: args.seed,
            scale_range: args.scale_range,
            crop_size: args
                .crop_size
                .expect("clap requires --crop-size with --augment"),
        }),
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

fn folder_exit(
    summary: panoconv::predictions::FolderSummary,
    output: &std::path::Path,
) -> ExitCode {
    for (id, e) in &summary.failed {
        eprintln!("panoconv: frame {id} failed: {e}");
    }
    eprintln!(
        "panoconv: {} frames written, {} failed -> {}",
        summary.done,
        summary.failed.len(),
        output.display()
    );
    if summary.failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FRAMES_FAILED)
    }
}

fn labels_to_pixels(a: LabelsToPixelsArgs) -> Result<ExitCode> {
    let summary = panoconv::predictions::labels_to_pixels(&a.input.join(&a.split), &a.output)?;
    Ok(folder_exit(summary, &a.output))
}

fn unproject(a: UnprojectArgs) -> Result<ExitCode> {
    if let Some(f) = a.trained_focal {
        if !(f > 0.0 && f.is_finite()) {
            bail!(Error::Setup("--trained-focal must be positive".into()));
        }
    }
    let images = a
        .images
        .clone()
        .unwrap_or_else(|| panoconv::predictions::default_images_dir(&a.calib));
    let summary =
        panoconv::predictions::unproject(&a.calib, &images, &a.input, &a.output, a.trained_focal)?;
    Ok(folder_exit(summary, &a.output))
}

fn verify(a: VerifyArgs) -> Result<ExitCode> {
    let report = panoconv::verify::verify(&a.output)?;
    for problem in &report.problems {
        println!("{problem}");
    }
    if !a.quiet {
        let verdict = if report.is_ok() { "OK" } else { "FAILED" };
        println!(
            "panoconv verify: {verdict}: {} ({})",
            report.summary(),
            a.output.display()
        );
    }
    Ok(if report.is_ok() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FRAMES_FAILED)
    })
}

fn run() -> Result<ExitCode> {
    let cli = Cli::parse();
    match cli.command {
        Command::Kitti(a) => kitti(*a),
        Command::Preview(a) => preview(a),
        Command::LabelsToPixels(a) => labels_to_pixels(a),
        Command::Unproject(a) => unproject(a),
        Command::Synth(a) => synth(a),
        Command::Verify(a) => verify(a),
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
