//! Command-line interface: argument parsing, progress display and exit codes.
//!
//! Exit codes: 0 all frames converted; 1 some frames failed (each reported); 2 usage or set-up
//! error, nothing written.

use anyhow::{bail, Context as _, Result};
use clap::{Args, CommandFactory, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use panoconv::augment::Augment;
use panoconv::camera::{ImageSize, Projection};
use panoconv::depth::OcclusionFilter;
use panoconv::error::Error;
use panoconv::geometry::{Canvas, Crop, OutputSpec, Scale};
use panoconv::journal::Shard;
use panoconv::kitti::dataset::read_id_list;
use panoconv::kitti::png_io::PngCompression;
use panoconv::kitti::FrameRef;
use panoconv::pipeline::{run_kitti, DepthJob, KittiJob, Progress, StyleJob};
use panoconv::style::{Device, StyleOptions};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

const EXIT_FRAMES_FAILED: u8 = 1;
const EXIT_SETUP: u8 = 2;
const EXIT_INTERRUPTED: u8 = 130;

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
    KittiRaw(Box<KittiArgs>),
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
        after_help = "Examples:\n  panoconv verify /data/kitti_equi\n\nOne line per problem on stdout (missing:, changed:, extra:, ...), then a summary.\nExit codes: 0 everything matches; 1 problems found; 2 the manifest is missing or unreadable."
    )]
    Verify(VerifyArgs),
    /// Write a small synthetic KITTI dataset with exact labels (for tests and demos).
    #[command(
        after_help = "Examples:\n  panoconv synth --output /tmp/synthetic_kitti\n  panoconv synth --output data/synthetic_kitti --overwrite"
    )]
    Synth(SynthArgs),
    /// Warp a folder of fisheye images (camera description JSON) to cylindrical, equirect or perspective.
    #[command(after_help = FISHEYE_EXAMPLES)]
    Fisheye(FisheyeArgs),
    /// Warp a folder of 2:1 equirect panoramas (PNG) to cylindrical, perspective views or an equirect strip.
    #[command(after_help = PANO_EXAMPLES)]
    Pano(PanoArgs),
    /// Report what a KITTI-layout dataset holds and what is missing or malformed in it.
    #[command(after_help = INSPECT_EXAMPLES)]
    Inspect(InspectArgs),
    /// Print a shell completion script for panoconv.
    #[command(after_help = COMPLETIONS_EXAMPLES)]
    Completions(CompletionsArgs),
    /// Print the man page (roff), or write one page per subcommand with --output.
    #[command(after_help = MAN_EXAMPLES)]
    Man(ManArgs),
}

const PREVIEW_EXAMPLES: &str = "Examples:
  panoconv preview /data/kitti_equi --frame 000123 --output preview.png
  panoconv preview /data/kitti_cyl --split testing --frame 000007 --output p.png
  panoconv preview /data/kitti_equi --grid 4x3 --output sheet.png
  panoconv preview O --grid 2x1 --frames 000001,000042 --tile-width 800 --output s.png
  panoconv preview /data/kitti --frame 000123 --output p.png        # plain KITTI: drawn with P2

Each 3D box is drawn from the written calib alone (projection:, K2:, C2:; else P2) in the class
colour, the 2D box in white, with the class and the distance the projection pairs with (z,
range or cylindrical rho) in metres. OUT/<split>/depth_2/NNNNNN.png is overlaid in colour
(red near, blue at 80 m and beyond) when it exists.";

const INSPECT_EXAMPLES: &str = "Examples:
  panoconv inspect /data/kitti
  panoconv inspect /data/kitti_equi --split training
  panoconv inspect /data/kitti --json > report.json

Exit codes: 0 the dataset is clean; 1 missing or malformed files were found (the report is still
printed; each as file:line: field: message); 2 set-up error (no KITTI dataset there).";

const COMPLETIONS_EXAMPLES: &str = "Examples:
  panoconv completions bash > ~/.local/share/bash-completion/completions/panoconv
  panoconv completions zsh > ~/.zfunc/_panoconv      # with fpath+=~/.zfunc before compinit
  panoconv completions fish > ~/.config/fish/completions/panoconv.fish
  panoconv completions powershell >> $PROFILE";

const MAN_EXAMPLES: &str = "Examples:
  panoconv man > panoconv.1 && man ./panoconv.1
  panoconv man --output /usr/local/share/man/man1     # panoconv.1, panoconv-kitti.1, ...";

const RAW_EXAMPLES: &str = "Examples:
  panoconv kitti-raw --to equirect --cameras 2,3 --depth --input /data/raw/2011_09_26 --output /data/raw_equi
  panoconv kitti-raw --to cylindrical --drive 2011_09_26_drive_0001_sync --input /data/raw/2011_09_26 --output O

Output mirrors the input: OUT/<drive>/image_02/data/*.png (image_03 with --cameras 2,3),
OUT/<drive>/depth_02/data/*.png with --depth, and one OUT/<drive>/calib.txt in KITTI object form
(P0..P3, R0_rect, Tr_velo_to_cam from the date folder) with projection:, K2:, C2: added.
All `kitti` options apply except --split, --image-set and --augment.";

const KITTI_EXAMPLES: &str = "Examples:
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
    /// kitti-raw: convert only this drive (e.g. 2011_09_26_drive_0001_sync).
    #[arg(long, value_name = "NAME")]
    drive: Option<String>,
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
    /// Cameras to convert: 2 (left colour), 3 (right colour, about its own centre C3).
    #[arg(long, value_delimiter = ',', default_value = "2", value_parser = parse_camera)]
    cameras: Vec<usize>,
    /// Also write LiDAR depth maps (depth_2/, 16-bit, round(d·256)) from velodyne/.
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
    #[arg(long, required_unless_present = "grid", conflicts_with = "grid")]
    frame: Option<String>,
    #[arg(long, default_value = "training")]
    split: String,
    /// PNG to write.
    #[arg(long, short = 'o')]
    output: PathBuf,
    /// Contact sheet of C columns and R rows: the first C*R frames of the split (or of --frames).
    #[arg(long, value_name = "CxR", value_parser = parse_size)]
    grid: Option<ImageSize>,
    /// Frames of the contact sheet (comma-separated).
    #[arg(long, value_delimiter = ',', value_name = "ID,...", requires = "grid")]
    frames: Option<Vec<String>>,
    /// Width of each contact-sheet tile in pixels.
    #[arg(long, value_name = "PX", default_value_t = 480, requires = "grid")]
    tile_width: u32,
    /// Do not overlay depth_2/ maps.
    #[arg(long)]
    no_depth: bool,
    /// Draw the boxes without the class and distance text.
    #[arg(long)]
    no_text: bool,
}

#[derive(Args)]
struct InspectArgs {
    /// KITTI object root (training/ and/or testing/), original or written by panoconv.
    dataset: PathBuf,
    /// Inspect only this split (training or testing).
    #[arg(long)]
    split: Option<String>,
    /// Print the report as JSON (stable key order) instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct CompletionsArgs {
    /// The shell to write a completion script for.
    #[arg(value_enum)]
    shell: clap_complete::Shell,
}

#[derive(Args)]
struct ManArgs {
    /// Write panoconv.1 and one page per subcommand (panoconv-kitti.1, ...) into DIR.
    #[arg(long, short = 'o', value_name = "DIR")]
    output: Option<PathBuf>,
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
struct EvalDepthArgs {
    /// Predicted depth maps.
    #[arg(long)]
    pred: PathBuf,
    /// Ground-truth depth maps (e.g. OUT/training/depth_2).
    #[arg(long)]
    gt: PathBuf,
    /// Metres.
    #[arg(long, default_value_t = 1e-3)]
    min_depth: f64,
    /// Metres.
    #[arg(long, default_value_t = 50.0)]
    max_depth: f64,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct MergeArgs {
    /// The shared output folder of the shards.
    output: PathBuf,
}

#[derive(Args)]
struct VerifyArgs {
    /// Output folder written by `panoconv kitti` (holding panoconv.json).
    output: PathBuf,
    /// Print only the problems, no summary line.
    #[arg(long, short = 'q')]
    quiet: bool,
}

#[derive(Args)]
struct SynthArgs {
    /// Output root (created; must be empty unless --overwrite).
    #[arg(long, short = 'o')]
    output: PathBuf,
    #[arg(long)]
    overwrite: bool,
}

fn parse_shard(s: &str) -> std::result::Result<Shard, String> {
    let (k, n) = s
        .split_once('/')
        .ok_or("expected K/N, e.g. 3/16 (K from 0)")?;
    let k: u32 = k
        .trim()
        .parse()
        .map_err(|_| format!("bad shard index {k:?}"))?;
    let n: u32 = n
        .trim()
        .parse()
        .map_err(|_| format!("bad shard count {n:?}"))?;
    if n == 0 || k >= n {
        return Err(format!("shard {k}/{n}: need 0 <= K < N"));
    }
    Ok(Shard { index: k, count: n })
}

fn parse_camera(s: &str) -> std::result::Result<usize, String> {
    match s.trim() {
        "2" => Ok(2),
        "3" => Ok(3),
        other => Err(format!(
            "camera {other:?}: expected 2 or 3 (KITTI's colour cameras)"
        )),
    }
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

fn kitti(args: KittiArgs, raw: bool) -> Result<ExitCode> {
    if raw && (args.split.is_some() || args.image_set.is_some()) {
        bail!(Error::Setup(
            "kitti-raw selects drives with --drive, not --split/--image-set".into()
        ));
    }
    if !raw && args.drive.is_some() {
        bail!(Error::Setup("--drive is for kitti-raw".into()));
    }
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
        split: if raw { args.drive } else { args.split },
        raw,
        frames,
        overwrite: args.overwrite,
        png_compression: args.png_compression,
        cameras: {
            let mut c = args.cameras.clone();
            c.sort_unstable();
            c.dedup();
            if !c.contains(&2) {
                bail!(Error::Setup(
                    "--cameras must include 2 (labels and depth belong to camera 2)".into()
                ));
            }
            c
        },
        shard: args.shard,
        resume: args.resume,
        depth: args.depth.then(|| DepthJob {
            occlusion_filter: (!args.no_occlusion_filter).then(OcclusionFilter::default),
        }),
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
    install_stop_handler();
    let bar = Bar::new(args.quiet);
    let summary = with_pool(args.jobs, || run_kitti(&job, &bar, &STOP))??;
    if !args.quiet {
        let resumed = if summary.resumed > 0 {
            format!(" ({} kept from the previous run)", summary.resumed)
        } else {
            String::new()
        };
        eprintln!(
            "panoconv: {} frames converted{resumed}, {} failed in {:.2} s ({:.1} frames/s) -> {}",
            summary.converted,
            summary.failed,
            summary.seconds,
            (summary.converted - summary.resumed) as f64 / summary.seconds.max(1e-9),
            job.output.display()
        );
    }
    if summary.interrupted {
        eprintln!("panoconv: interrupted; the manifest lists the finished frames: run again with --resume");
        return Ok(ExitCode::from(EXIT_INTERRUPTED));
    }
    Ok(if summary.failed > 0 {
        ExitCode::from(EXIT_FRAMES_FAILED)
    } else {
        ExitCode::SUCCESS
    })
}

/// Set by SIGINT/SIGTERM: the conversion takes no new frame, finishes those in flight and
/// writes its manifest.
static STOP: AtomicBool = AtomicBool::new(false);

fn install_stop_handler() {
    // ctrlc replaces the default handlers, so a second signal while stopping exits at once.
    let _ = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) {
            std::process::exit(EXIT_INTERRUPTED as i32);
        }
    });
}

fn merge(a: MergeArgs) -> Result<ExitCode> {
    let n = panoconv::journal::merge(&a.output)?;
    eprintln!(
        "panoconv: merged {n} frames into {}",
        a.output.join(panoconv::journal::MANIFEST).display()
    );
    Ok(ExitCode::SUCCESS)
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
    use panoconv::kitti::png_io;
    use panoconv::preview::{contact_sheet, render_frame, PreviewOptions};
    let options = PreviewOptions {
        depth: !args.no_depth,
        text_scale: args.no_text.then_some(0),
    };
    let image = match (args.grid, &args.frame) {
        (Some(grid), _) => {
            if args.tile_width == 0 {
                bail!(Error::Setup("--tile-width must be positive".into()));
            }
            let n = (grid.width * grid.height) as usize;
            let ids = match &args.frames {
                Some(ids) => ids.clone(),
                None => {
                    let dir = args.dataset.join(&args.split).join("image_2");
                    let entries = std::fs::read_dir(&dir)
                        .map_err(|e| Error::Setup(format!("{}: {e}", dir.display())))?;
                    let mut ids: Vec<String> = entries
                        .flatten()
                        .filter_map(|e| {
                            let name = e.file_name().to_str()?.to_owned();
                            let id = name.strip_suffix(".png")?;
                            (!id.starts_with('.')).then(|| id.to_owned())
                        })
                        .collect();
                    ids.sort();
                    ids
                }
            };
            let ids: Vec<String> = ids.into_iter().take(n).collect();
            if ids.is_empty() {
                bail!(Error::Setup(format!(
                    "no frames to show in {}",
                    args.dataset.join(&args.split).display()
                )));
            }
            // Text sized so that it stays legible once the tile is scaled down.
            let mut tiles = Vec::with_capacity(ids.len());
            for id in &ids {
                let mut opts = options;
                if opts.text_scale.is_none() {
                    let dir = args.dataset.join(&args.split).join("image_2");
                    let path = dir.join(format!("{id}.png"));
                    let bytes = panoconv::error::read_file(&path)?;
                    let (w, _) = png_io::read_size(&bytes, &path)?;
                    opts.text_scale = Some(w.div_ceil(args.tile_width).max(1));
                }
                let tile = render_frame(&args.dataset, &args.split, id, &opts)?;
                tiles.push((format!("{}/{id}", args.split), tile));
            }
            contact_sheet(&tiles, grid.width, args.tile_width)
        }
        (None, Some(frame)) => render_frame(&args.dataset, &args.split, frame, &options)?,
        (None, None) => unreachable!("clap requires --frame or --grid"),
    };
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

fn eval_depth(a: EvalDepthArgs) -> Result<ExitCode> {
    let e = panoconv::eval::evaluate(&a.pred, &a.gt, a.min_depth, a.max_depth)?;
    for (name, err) in &e.failed {
        eprintln!("panoconv: {name} not evaluated: {err}");
    }
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&e).context("serialising the metrics")?
        );
    } else {
        let m = &e.mean;
        println!(
            "{} images, {} pixels, depth range {}..{} m",
            e.images, m.pixels, e.min_depth, e.max_depth
        );
        println!(
            "{:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}",
            "abs_rel", "sq_rel", "rmse", "rmse_log", "d<1.25", "d<1.25^2", "d<1.25^3"
        );
        println!(
            "{:>10.4} {:>10.4} {:>10.4} {:>10.4} {:>10.4} {:>10.4} {:>10.4}",
            m.abs_rel, m.sq_rel, m.rmse, m.rmse_log, m.delta_1, m.delta_2, m.delta_3
        );
    }
    Ok(if e.failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FRAMES_FAILED)
    })
}

fn inspect(args: InspectArgs) -> Result<ExitCode> {
    let report = panoconv::inspect::inspect(&args.dataset, args.split.as_deref())?;
    if args.json {
        print!("{}", report.to_json());
    } else {
        print!("{}", report.to_text());
    }
    Ok(if report.is_clean() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FRAMES_FAILED)
    })
}

fn completions(args: CompletionsArgs) -> Result<ExitCode> {
    let mut cmd = Cli::command();
    clap_complete::generate(args.shell, &mut cmd, "panoconv", &mut std::io::stdout());
    Ok(ExitCode::SUCCESS)
}

fn man(args: ManArgs) -> Result<ExitCode> {
    let cmd = Cli::command();
    match args.output {
        Some(dir) => {
            std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
            clap_mangen::generate_to(cmd, &dir).map_err(|e| Error::io(&dir, e))?;
        }
        None => {
            let mut out = Vec::new();
            clap_mangen::Man::new(cmd)
                .render(&mut out)
                .context("cannot render the man page")?;
            use std::io::Write as _;
            std::io::stdout()
                .write_all(&out)
                .context("cannot write to stdout")?;
        }
    }
    Ok(ExitCode::SUCCESS)
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
        Command::Kitti(a) => kitti(*a, false),
        Command::KittiRaw(a) => kitti(*a, true),
        Command::Preview(a) => preview(a),
        Command::LabelsToPixels(a) => labels_to_pixels(a),
        Command::Unproject(a) => unproject(a),
        Command::EvalDepth(a) => eval_depth(a),
        Command::Merge(a) => merge(a),
        Command::Verify(a) => verify(a),
        Command::Synth(a) => synth(a),
        Command::Fisheye(a) => fisheye(a),
        Command::Pano(a) => pano(a),
        Command::Inspect(a) => inspect(a),
        Command::Completions(a) => completions(a),
        Command::Man(a) => man(a),
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

// ---------------------------------------------------------------------------------------------
// Folder conversions: fisheye and pano

const FISHEYE_EXAMPLES: &str = "Examples:
  panoconv fisheye --camera front.json --to cylindrical --input frames/ --output cyl/
  panoconv fisheye --camera front.json --to cylindrical --vfov 90 --px-per-deg 4 --input F --output O
  panoconv fisheye --camera rear.json --to perspective --fov 100 --input F --output O

The camera description (JSON, \"version\": 1) is documented in docs/fisheye.md. The output is
levelled (the camera's pitch and roll undone) and turned to the camera's heading. Each image
NAME.png gives NAME.png and NAME.txt (projection:, K:, R:) in OUTPUT, plus OUTPUT/panoconv.json.
PNG input only.";

const PANO_EXAMPLES: &str = "Examples:
  panoconv pano --to cylindrical --vfov 60 --input panos/ --output cyl/
  panoconv pano --to perspective --yaw 0,90,180,270 --fov 90 --input panos/ --output views/
  panoconv pano --to equirect --vfov 60 --yaw 180 --input panos/ --output strips/

Input: every 2:1 equirect PNG in INPUT (JPEG is not read). Each image NAME.png gives NAME.png and
NAME.txt (projection:, K:, R:), or NAME_yawDEG.png/.txt per yaw when several are given.";

#[derive(Args)]
struct FolderArgs {
    /// Target projection.
    #[arg(long, value_enum)]
    to: To,
    /// Folder of input images (PNG).
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
}

#[derive(Args)]
struct FisheyeArgs {
    /// Camera description (JSON, see docs/fisheye.md).
    #[arg(long, value_name = "CAMERA.json")]
    camera: PathBuf,
    #[command(flatten)]
    common: FolderArgs,
}

#[derive(Args)]
struct PanoArgs {
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

fn projection_of(to: To) -> Projection {
    match to {
        To::Equirect => Projection::Equirect,
        To::Cylindrical => Projection::Cylindrical,
        To::Perspective => Projection::Perspective,
    }
}

fn view_scale(a: &FolderArgs) -> Result<panoconv::pano::ViewScale> {
    use panoconv::pano::ViewScale;
    Ok(match (a.pano_width, a.px_per_deg) {
        (Some(0), _) => bail!(Error::Setup("--pano-width must be positive".into())),
        (Some(w), _) => ViewScale::PanoWidth(w),
        (None, Some(d)) if !(d > 0.0 && d.is_finite()) => {
            bail!(Error::Setup("--px-per-deg must be positive".into()))
        }
        (None, Some(d)) => ViewScale::PixelsPerDegree(d),
        (None, None) => ViewScale::Source,
    })
}

fn degrees(v: Option<f64>, flag: &str) -> Result<Option<f64>> {
    match v {
        Some(d) if !(d > 0.0 && d <= 360.0) => {
            bail!(Error::Setup(format!("{flag} must be in (0, 360] degrees")))
        }
        v => Ok(v.map(f64::to_radians)),
    }
}

fn run_folder_job(
    common: &FolderArgs,
    job: &panoconv::folder::FolderJob,
    planner: &panoconv::folder::Planner,
) -> Result<ExitCode> {
    let bar = Bar::new(common.quiet);
    let summary = with_pool(common.jobs, || {
        panoconv::folder::run_folder(job, planner, &bar)
    })??;
    if !common.quiet {
        eprintln!(
            "panoconv: {} images converted, {} failed in {:.2} s -> {}",
            summary.converted,
            summary.failed,
            summary.seconds,
            job.output.display()
        );
    }
    Ok(if summary.failed > 0 {
        ExitCode::from(EXIT_FRAMES_FAILED)
    } else {
        ExitCode::SUCCESS
    })
}

fn fisheye(args: FisheyeArgs) -> Result<ExitCode> {
    use panoconv::camera::description::CameraDescription;
    use panoconv::pano::FisheyeView;
    let a = &args.common;
    let desc = CameraDescription::read(&args.camera)?;
    let spec = FisheyeView {
        projection: projection_of(a.to),
        hfov: degrees(a.fov, "--fov")?,
        vfov: degrees(a.vfov, "--vfov")?,
        scale: view_scale(a)?,
    };
    let size = desc.camera.size;
    // Built before anything is written (one camera, one table): errors are set-up errors.
    let view = spec.plan(&desc)?;
    let (hfov, vfov) = spec.fov(&desc);
    let job = panoconv::folder::FolderJob {
        command: "fisheye",
        input: a.input.clone(),
        output: a.output.clone(),
        overwrite: a.overwrite,
        png_compression: a.png_compression,
        parameters: serde_json::json!({
            "input": a.input,
            "camera": args.camera,
            "camera_model": desc.camera.model.name(),
            "projection": spec.projection,
            "hfov_deg": hfov.to_degrees(),
            "vfov_deg": vfov.to_degrees(),
            "scale": spec.scale,
            "png_compression": a.png_compression,
        }),
    };
    let planner = move |s: panoconv::camera::ImageSize| {
        if s != size {
            return Err(Error::Setup(format!(
                "image is {s}, the camera description says {size}"
            )));
        }
        Ok(vec![view.clone()])
    };
    run_folder_job(a, &job, &planner)
}

fn pano(args: PanoArgs) -> Result<ExitCode> {
    use panoconv::pano::PanoViews;
    let a = &args.common;
    let projection = projection_of(a.to);
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
    let hfov = degrees(a.fov, "--fov")?.unwrap_or(match projection {
        Projection::Perspective => 90f64.to_radians(),
        _ => 2.0 * std::f64::consts::PI,
    });
    let vfov = degrees(a.vfov, "--vfov")?.unwrap_or(match projection {
        Projection::Perspective => hfov,
        Projection::Cylindrical => 90f64.to_radians(),
        Projection::Equirect => std::f64::consts::PI,
    });
    let views = PanoViews {
        projection,
        yaws,
        pitch: args.pitch.to_radians(),
        hfov,
        vfov,
        scale: view_scale(a)?,
    };
    views.validate()?;
    let job = panoconv::folder::FolderJob {
        command: "pano",
        input: a.input.clone(),
        output: a.output.clone(),
        overwrite: a.overwrite,
        png_compression: a.png_compression,
        parameters: serde_json::json!({
            "input": a.input,
            "views": &views,
            "png_compression": a.png_compression,
        }),
    };
    let planner = |s: panoconv::camera::ImageSize| views.plan(s);
    run_folder_job(a, &job, &planner)
}
