//! `export`: COCO, YOLO and Omni3D files from a converted (or plain KITTI) dataset, and the
//! `--export` option of `kitti`.

use super::tools::record_derived;
use super::{count, EXIT_FRAMES_FAILED};
use anyhow::Result;
use clap::{Args, ValueEnum};
use panoconv::export::{ClassMap, ExportOptions, ExportReport, ExportSplit, Format, SplitRule};
use panoconv::reproject::visibility::Visibility;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

pub(super) const EXPORT_EXAMPLES: &str = "Examples:
  panoconv export O --format coco   --output O/annotations      # instances_<split>.json
  panoconv export O --format yolo   --output O_yolo             # images/ labels/ data.yaml
  panoconv export O --format omni3d --output O/annotations      # Omni3D_<split>.json
  panoconv export O --format coco --output O/annotations --val-fraction 0.1 --seed 3
  panoconv export O --format yolo --output O_yolo --classes Car=Car,Van=Car,Pedestrian=Pedestrian,Cyclist=Cyclist,*=-
  panoconv kitti --to equirect --input K --output O --export coco,yolo   # during the conversion

Splits: train/val from ImageSets/train.txt and val.txt (DATASET/ImageSets, or --image-sets DIR)
when present, else --val-fraction F --seed S, else every labelled frame in train; testing/ is
test. Boxes come from the written label_2 and calib (docs/formats.md, Exports).
Exit codes: 0 exported; 1 some frames failed (each reported, the others exported); 2 set-up
error, nothing written.";

#[derive(Clone, Copy, ValueEnum)]
pub(super) enum FormatArg {
    Coco,
    Yolo,
    Omni3d,
}

impl From<FormatArg> for Format {
    fn from(f: FormatArg) -> Self {
        match f {
            FormatArg::Coco => Format::Coco,
            FormatArg::Yolo => Format::Yolo,
            FormatArg::Omni3d => Format::Omni3d,
        }
    }
}

#[derive(Args)]
pub(super) struct ExportArgs {
    /// A dataset written by `panoconv kitti` (or a plain KITTI root: P2 is a perspective camera).
    dataset: PathBuf,
    /// What to write.
    #[arg(long, value_enum)]
    format: FormatArg,
    /// Folder of the export (COCO, Omni3D: the JSON files; YOLO: the whole layout, outside the
    /// dataset).
    #[arg(long, short = 'o')]
    output: PathBuf,
    /// Categories: FROM=TO,... (TO empty or - drops the class, * stands for every other class).
    /// Default: KITTI's eight classes, ids 1..8 in the devkit's order.
    #[arg(long, value_name = "MAP")]
    classes: Option<String>,
    /// Folder with train.txt and val.txt [default: DATASET/ImageSets when they exist].
    #[arg(long, value_name = "DIR", conflicts_with = "val_fraction")]
    image_sets: Option<PathBuf>,
    /// Put this fraction of the labelled frames in val (a seeded draw) instead of ImageSets.
    #[arg(long, value_name = "F")]
    val_fraction: Option<f64>,
    /// Seed of --val-fraction.
    #[arg(long, default_value_t = 0, requires = "val_fraction")]
    seed: u64,
    /// Put PREFIX before every image path in the COCO and Omni3D files (they are relative to
    /// the dataset root otherwise), e.g. kitti_equi/ for Cube R-CNN's datasets/ image root.
    #[arg(long, value_name = "PREFIX", default_value = "")]
    path_prefix: String,
    /// Export an object as an object only when its 2D box is at least PX pixels on each side
    /// and its truncation at most 1 - SHARE; the others become ignore regions (the rule of
    /// `kitti --min-visible`; without it every labelled object is exported).
    #[arg(long, value_name = "PX,SHARE", value_parser = Visibility::parse)]
    min_visible: Option<Visibility>,
    /// Replace export files that exist.
    #[arg(long)]
    overwrite: bool,
    /// No summary line.
    #[arg(long, short = 'q')]
    quiet: bool,
}

pub(super) fn export(args: ExportArgs) -> Result<ExitCode> {
    let classes = match &args.classes {
        Some(spec) => ClassMap::parse(spec)?,
        None => ClassMap::kitti(),
    };
    let split_rule = match (args.val_fraction, args.image_sets) {
        (Some(fraction), _) => SplitRule::ValFraction {
            fraction,
            seed: args.seed,
        },
        (None, Some(dir)) => SplitRule::ImageSets(dir),
        (None, None) => SplitRule::default_for(&args.dataset),
    };
    let options = ExportOptions {
        classes,
        split_rule,
        overwrite: args.overwrite,
        path_prefix: args.path_prefix,
        visibility: args.min_visible.unwrap_or(Visibility::OFF),
    };
    run_export(
        &args.dataset,
        args.format.into(),
        &args.output,
        &options,
        args.quiet,
    )
}

/// Runs one export and reports it; the exit code says whether frames failed.
fn run_export(
    dataset: &Path,
    format: Format,
    output: &Path,
    options: &ExportOptions,
    quiet: bool,
) -> Result<ExitCode> {
    let report = panoconv::export::export(dataset, format, output, options)?;
    // Files written inside the dataset are recorded in its manifest, so that verify checks them.
    let inside: Vec<std::path::PathBuf> = report
        .files
        .iter()
        .filter(|f| f.in_dataset.is_some())
        .map(|f| f.path.clone())
        .collect();
    if !inside.is_empty() {
        record_derived(&format!("export {}", format.name()), output, &inside)?;
    }
    for (frame, error) in &report.failed {
        eprintln!(
            "panoconv: frame {}/{} failed: {error}",
            frame.split, frame.id
        );
    }
    if !quiet {
        eprintln!("{}", summary(format, &report, output));
        let has_val = report.images.iter().any(|(s, _)| *s == ExportSplit::Val);
        if format == Format::Yolo && !has_val {
            eprintln!(
                "panoconv: no val split: data.yaml says val: images/train, so validation scores are on training images (hold frames out with --val-fraction or --image-sets)"
            );
        }
    }
    Ok(if report.failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FRAMES_FAILED)
    })
}

fn summary(format: Format, report: &ExportReport, output: &Path) -> String {
    let images: Vec<String> = report
        .images
        .iter()
        .map(|(s, n)| format!("{s} {n}"))
        .collect();
    let left_out = if report.left_out > 0 {
        format!(", {} in no image set", count(report.left_out, "frame"))
    } else {
        String::new()
    };
    // YOLO has no ignore regions: say that the DontCare regions were left out, not exported.
    let ignore = match format {
        Format::Yolo => format!(
            "{} dropped (YOLO has none)",
            count(report.ignore_regions, "ignore region")
        ),
        _ => count(report.ignore_regions, "ignore region"),
    };
    format!(
        "panoconv: {} export: images {}, {}, {ignore}, {} failed{left_out} -> {}",
        format.name(),
        images.join(", "),
        count(report.objects, "object"),
        report.failed.len(),
        output.display()
    )
}

/// `kitti --export`: COCO and Omni3D into OUT/annotations, YOLO into OUT_yolo beside OUT; the
/// split from INPUT/ImageSets when it has train.txt and val.txt (not with --augment, whose
/// frame ids are new). The categories: KITTI's classes, then `label_types` (the other types
/// the conversion wrote: those its `--classes` added).
pub(super) fn export_after_kitti(
    input: &Path,
    output: &Path,
    formats: &[FormatArg],
    label_types: &[String],
    augmented: bool,
    overwrite: bool,
    quiet: bool,
) -> Result<ExitCode> {
    let split_rule = match SplitRule::default_for(input) {
        rule @ SplitRule::ImageSets(_) if !augmented => rule,
        _ => SplitRule::default_for(output),
    };
    let options = ExportOptions {
        classes: ClassMap::kitti_and(label_types),
        split_rule,
        overwrite,
        path_prefix: String::new(),
        // The conversion has just applied its --min-visible to the labels it wrote.
        visibility: Visibility::OFF,
    };
    let mut code = ExitCode::SUCCESS;
    for &f in formats {
        let format = Format::from(f);
        let target = match format {
            Format::Yolo => {
                let mut name = output.file_name().unwrap_or_default().to_os_string();
                name.push("_yolo");
                output.with_file_name(name)
            }
            Format::Coco | Format::Omni3d => output.join("annotations"),
        };
        if run_export(output, format, &target, &options, quiet)? != ExitCode::SUCCESS {
            code = ExitCode::from(EXIT_FRAMES_FAILED);
        }
    }
    Ok(code)
}
