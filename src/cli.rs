//! Command-line interface: argument parsing, progress display and exit codes.
//!
//! Exit codes: 0 all frames converted; 1 some frames failed (each reported); 2 usage or set-up
//! error, nothing written.

use anyhow::{bail, Context as _, Result};
use clap::{Args, CommandFactory, Parser, Subcommand, ValueEnum};
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
    #[command(after_help = PREVIEW_EXAMPLES)]
    Preview(PreviewArgs),
    /// Write a small synthetic KITTI dataset with exact labels (for tests and demos).
    #[command(
        after_help = "Examples:\n  panoconv synth --output /tmp/synthetic_kitti\n  panoconv synth --output data/synthetic_kitti --overwrite"
    )]
    Synth(SynthArgs),
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

fn run() -> Result<ExitCode> {
    let cli = Cli::parse();
    match cli.command {
        Command::Kitti(a) => kitti(a),
        Command::Preview(a) => preview(a),
        Command::Synth(a) => synth(a),
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
