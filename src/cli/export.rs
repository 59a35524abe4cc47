//! `export`: COCO, YOLO and Omni3D files from a converted (or plain KITTI) dataset (the files
//! and their report are `shared/export_after.rs`'s, which every conversion's `--export` uses).

use super::shared::export_after::{run_export, FormatArg};
use anyhow::Result;
use clap::Args;
use panoconv::export::{ClassMap, ExportOptions, SplitRule};
use panoconv::reproject::visibility::Visibility;
use std::path::PathBuf;
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
