//! The tools around a conversion: preview, inspect, verify, predictions, depth metrics,
//! completions, man pages and the synthetic sample.

use super::shared::derived::record_derived;
use super::shared::outcome::{count, EXIT_FRAMES_FAILED};
use super::shared::parse::parse_size;
use super::shared::run::Bar;
use anyhow::{bail, Context as _, Result};
use clap::{Args, ValueEnum};
use panoconv::camera::ImageSize;
use panoconv::codec::png::PngCompression;
use panoconv::error::Error;
use std::path::PathBuf;
use std::process::ExitCode;

pub(super) const PREVIEW_EXAMPLES: &str = "Examples:
  panoconv preview /data/kitti_equi --frame 000123 --output preview.png
  panoconv preview /data/kitti_cyl --split testing --frame 000007 --output p.png
  panoconv preview /data/kitti_equi --grid 4x3 --output sheet.png
  panoconv preview O --grid 2x1 --frames 000001,000042 --tile-width 800 --output s.png
  panoconv preview /data/kitti --frame 000123 --output p.png        # plain KITTI: drawn with P2

Each 3D box is drawn from the written calib alone (projection:, K2:, C2:; else P2) in the class
colour, the 2D box in white, with the class and the distance the projection pairs with (z,
range or cylindrical rho) in metres. OUT/<split>/depth_2/NNNNNN.png is overlaid in colour when it
exists (red 0 m, yellow 5 m, green 20 m, cyan 45 m, blue 80 m and beyond; a scale is drawn).
A preview written inside a converted dataset is recorded in its manifest (see `verify`).";

pub(super) const INSPECT_EXAMPLES: &str = "Examples:
  panoconv inspect /data/kitti
  panoconv inspect /data/kitti_equi --split training
  panoconv inspect /data/kitti --json > report.json
  panoconv inspect fixtures/nuscenes             # a nuScenes or KITTI-360 root: described

Exit codes: 0 the dataset is clean; 1 missing or malformed files were found (the report is still
printed; each as file:line: field: message); 2 set-up error (no KITTI, nuScenes or KITTI-360
dataset there).";

pub(super) const COMPLETIONS_EXAMPLES: &str = "Examples:
  mkdir -p ~/.local/share/bash-completion/completions
  panoconv completions bash > ~/.local/share/bash-completion/completions/panoconv
  panoconv completions zsh > ~/.zfunc/_panoconv      # with fpath+=~/.zfunc before compinit
  panoconv completions fish > ~/.config/fish/completions/panoconv.fish
  panoconv completions powershell >> $PROFILE";

pub(super) const MAN_EXAMPLES: &str = "Examples:
  panoconv man > panoconv.1 && man ./panoconv.1
  panoconv man --output /usr/local/share/man/man1     # panoconv.1, panoconv-kitti.1, ...";

#[derive(Args)]
pub(super) struct PreviewArgs {
    /// A dataset written by `panoconv kitti` (or any KITTI root, drawn as perspective).
    dataset: PathBuf,
    /// Frame id (`000007`, or `7`); found in whichever split holds it unless --split is given.
    #[arg(long, required_unless_present = "grid", conflicts_with = "grid")]
    frame: Option<String>,
    /// The split to look in [default: for --frame, the one holding it; for --grid, training].
    #[arg(long)]
    split: Option<String>,
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
pub(super) struct InspectArgs {
    /// KITTI object root (training/ and/or testing/), original or written by panoconv; or a
    /// nuScenes or KITTI-360 root, described (versions or sequences, scenes, samples, cameras,
    /// LiDAR, annotations, the frames a conversion writes).
    dataset: PathBuf,
    /// Inspect only this split (training or testing).
    #[arg(long)]
    split: Option<String>,
    /// Print the report as JSON (stable key order) instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
pub(super) struct CompletionsArgs {
    /// The shell to write a completion script for.
    #[arg(value_enum)]
    shell: clap_complete::Shell,
}

#[derive(Args)]
pub(super) struct ManArgs {
    /// Write panoconv.1 and one page per subcommand (panoconv-kitti.1, ...) into DIR.
    #[arg(long, short = 'o', value_name = "DIR")]
    output: Option<PathBuf>,
}

#[derive(Args)]
pub(super) struct LabelsToPixelsArgs {
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
pub(super) struct UnprojectArgs {
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
    /// Which image each result's 2D box belongs to: `source` (KITTI's benchmark scores the
    /// box against the original label_2: the 3D box through the calib's P2, clipped to the
    /// source image) or `converted` (the image the detector ran on; always so for a rig
    /// output, whose P2 is no source camera, and a perspective one).
    #[arg(long = "box", value_enum, default_value_t = BoxArg::Source)]
    box_image: BoxArg,
    /// The source images' size for `--box source` [default: read from the source dataset the
    /// converted dataset's manifest names].
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    source_size: Option<ImageSize>,
}

#[derive(Clone, Copy, ValueEnum)]
pub(super) enum BoxArg {
    Source,
    Converted,
}

#[derive(Args)]
pub(super) struct EvalDepthArgs {
    /// Predicted depth maps: 16-bit PNGs (metres x 256) named as the ground truth, or float
    /// metres in .npy / .npz files of the same stem.
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
pub(super) struct VerifyArgs {
    /// Output folder written by `panoconv kitti` (holding panoconv.json).
    output: PathBuf,
    /// Print only the problems, no summary line.
    #[arg(long, short = 'q')]
    quiet: bool,
    /// Accept a run that recorded failed frames (without it, failed frames fail `verify`).
    #[arg(long)]
    allow_failed: bool,
}

#[derive(Args)]
pub(super) struct SynthArgs {
    /// Output root (created; must be empty unless --overwrite).
    #[arg(long, short = 'o')]
    output: PathBuf,
    /// Write into a non-empty output, replacing the sample's files there (other files stay).
    #[arg(long)]
    overwrite: bool,
    /// Write a synthetic KITTI-360 sequence in the official layout instead (docs/kitti360.md).
    #[arg(long, group = "rig")]
    kitti360: bool,
    /// Write a synthetic nuScenes scene in the official layout instead (docs/nuscenes.md).
    #[arg(long, group = "rig")]
    nuscenes: bool,
    /// With --kitti360 or --nuscenes: image scale (1 = the official sizes).
    #[arg(long, requires = "rig", default_value_t = 1.0)]
    scale: f64,
    /// With --kitti360 or --nuscenes: all camera centres at the first camera's (nuScenes: and
    /// every camera firing at the LiDAR's time).
    #[arg(long, requires = "rig")]
    zero_baseline: bool,
    /// With --kitti360: the number of frames; with --nuscenes: the number of samples.
    #[arg(long, requires = "rig", default_value_t = 3)]
    frames: u32,
}

pub(super) fn synth(args: SynthArgs) -> Result<ExitCode> {
    if args.nuscenes {
        use panoconv::tools::synth_nuscenes::{write_scene, SynthNuScenesOptions};
        let options = SynthNuScenesOptions {
            samples: args.frames,
            scale: args.scale,
            zero_baseline: args.zero_baseline,
        };
        write_scene(&args.output, &options, args.overwrite, &Bar::new(false))?;
        eprintln!(
            "panoconv: synthetic nuScenes scene written to {}",
            args.output.display()
        );
        return Ok(ExitCode::SUCCESS);
    }
    if args.kitti360 {
        use panoconv::tools::synth360::{write_sequence, Synth360Options};
        let options = Synth360Options {
            frames: args.frames,
            scale: args.scale,
            zero_baseline: args.zero_baseline,
        };
        write_sequence(&args.output, &options, args.overwrite, &Bar::new(false))?;
        eprintln!(
            "panoconv: synthetic KITTI-360 sequence written to {}",
            args.output.display()
        );
        return Ok(ExitCode::SUCCESS);
    }
    panoconv::tools::synth::write_dataset(&args.output, args.overwrite, &Bar::new(false))?;
    eprintln!(
        "panoconv: synthetic KITTI dataset written to {}",
        args.output.display()
    );
    Ok(ExitCode::SUCCESS)
}

pub(super) fn preview(args: PreviewArgs) -> Result<ExitCode> {
    use panoconv::codec::png;
    use panoconv::tools::preview::{contact_sheet, render_frame, PreviewOptions};
    // The preview is a PNG: a file named otherwise would hold something else than it says.
    if !args
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        bail!(Error::Setup(format!(
            "--output {}: a preview is written as PNG; give a .png file name",
            args.output.display()
        )));
    }
    let options = PreviewOptions {
        depth: !args.no_depth,
        text_scale: args.no_text.then_some(0),
    };
    let image = match (args.grid, &args.frame) {
        (Some(grid), _) => {
            let split = args.split.as_deref().unwrap_or("training");
            if args.tile_width == 0 {
                bail!(Error::Setup("--tile-width must be positive".into()));
            }
            let n = (grid.width * grid.height) as usize;
            let ids = match &args.frames {
                Some(ids) => ids.clone(),
                None => {
                    let dir = args.dataset.join(split).join("image_2");
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
                    args.dataset.join(split).display()
                )));
            }
            // Text sized so that it stays legible once the tile is scaled down.
            let mut tiles = Vec::with_capacity(ids.len());
            for id in &ids {
                let mut opts = options;
                if opts.text_scale.is_none() {
                    let dir = args.dataset.join(split).join("image_2");
                    let path = dir.join(format!("{id}.png"));
                    let bytes = panoconv::fs::read_file(&path)?;
                    let (w, _) = png::read_size(&bytes, &path)?;
                    opts.text_scale = Some(w.div_ceil(args.tile_width).max(1));
                }
                let tile = render_frame(&args.dataset, split, id, &opts)?;
                tiles.push((format!("{split}/{id}"), tile));
            }
            contact_sheet(&tiles, grid.width, args.tile_width)
        }
        (None, Some(frame)) => {
            let (split, id) =
                panoconv::tools::preview::find_frame(&args.dataset, args.split.as_deref(), frame)?;
            render_frame(&args.dataset, &split, &id, &options)?
        }
        (None, None) => unreachable!("clap requires --frame or --grid"),
    };
    panoconv::fs::write_atomic(
        &args.output,
        &png::encode_rgb8(&image, PngCompression::Default),
    )?;
    record_derived("preview", &args.output, std::slice::from_ref(&args.output))?;
    Ok(ExitCode::SUCCESS)
}

pub(super) fn folder_exit(
    summary: panoconv::tools::predictions::FolderSummary,
    output: &std::path::Path,
) -> ExitCode {
    for (id, e) in &summary.failed {
        eprintln!("panoconv: frame {id} failed: {e}");
    }
    eprintln!(
        "panoconv: {} written, {} failed -> {}",
        count(summary.done, "frame"),
        summary.failed.len(),
        output.display()
    );
    if summary.failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FRAMES_FAILED)
    }
}

pub(super) fn labels_to_pixels(a: LabelsToPixelsArgs) -> Result<ExitCode> {
    let summary =
        panoconv::tools::predictions::labels_to_pixels(&a.input.join(&a.split), &a.output)?;
    record_derived("labels-to-pixels", &a.output, &summary.written)?;
    Ok(folder_exit(summary, &a.output))
}

pub(super) fn unproject(a: UnprojectArgs) -> Result<ExitCode> {
    if let Some(f) = a.trained_focal {
        if !(f > 0.0 && f.is_finite()) {
            bail!(Error::Setup("--trained-focal must be positive".into()));
        }
    }
    let images = a
        .images
        .clone()
        .unwrap_or_else(|| panoconv::tools::predictions::default_images_dir(&a.calib));
    let summary = panoconv::tools::predictions::unproject(
        &a.calib,
        &images,
        &a.input,
        &a.output,
        a.trained_focal,
        match a.box_image {
            BoxArg::Source => panoconv::tools::predictions::BoxChoice::Source {
                size: a.source_size,
            },
            BoxArg::Converted => panoconv::tools::predictions::BoxChoice::Converted,
        },
    )?;
    record_derived("unproject", &a.output, &summary.written)?;
    Ok(folder_exit(summary, &a.output))
}

pub(super) fn eval_depth(a: EvalDepthArgs) -> Result<ExitCode> {
    let e = panoconv::tools::eval_depth::evaluate(&a.pred, &a.gt, a.min_depth, a.max_depth)?;
    for (name, err) in &e.failed {
        eprintln!("panoconv: {name} not evaluated: {err}");
    }
    if e.images == 0 {
        // Means over no image would print as numbers; there are none to give.
        bail!(Error::Setup(format!(
            "no image could be evaluated: all {} failed (listed above), so there are no metrics",
            count(e.failed.len(), "ground-truth map")
        )));
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

pub(super) fn inspect(args: InspectArgs) -> Result<ExitCode> {
    let report = panoconv::tools::inspect::inspect_root(&args.dataset, args.split.as_deref())?;
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

/// `cmd`: the whole command line (the parent's `Cli`), which this file does not import.
pub(super) fn completions(args: CompletionsArgs, mut cmd: clap::Command) -> Result<ExitCode> {
    clap_complete::generate(args.shell, &mut cmd, "panoconv", &mut std::io::stdout());
    Ok(ExitCode::SUCCESS)
}

/// `cmd`: the whole command line, as for [`completions`].
pub(super) fn man(args: ManArgs, cmd: clap::Command) -> Result<ExitCode> {
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

pub(super) fn verify(a: VerifyArgs) -> Result<ExitCode> {
    let report = panoconv::tools::verify::verify(&a.output)?;
    for problem in &report.problems {
        println!("{problem}");
    }
    if let Some(incomplete) = &report.incomplete {
        println!("{incomplete}");
    }
    let ok = report.is_ok_allowing_failed(a.allow_failed);
    if let Some(failed) = report.failed_line().filter(|_| !a.allow_failed) {
        println!("{failed}");
    }
    if !a.quiet {
        let verdict = match (&report.incomplete, ok) {
            (_, true) => "OK",
            (Some(_), _) if report.problems.is_empty() => "INCOMPLETE",
            _ => "FAILED",
        };
        let failed = match report.failed.len() {
            0 => String::new(),
            n if a.allow_failed => format!(", {n} failed frames (allowed)"),
            n => format!(", {n} failed frames"),
        };
        println!(
            "panoconv verify: {verdict}: {}{failed} ({})",
            report.summary(),
            a.output.display()
        );
    }
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FRAMES_FAILED)
    })
}
