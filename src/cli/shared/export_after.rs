//! The export files of a converted dataset, as the `export` command and every conversion's
//! `--export` write and report them.

use super::derived::record_derived;
use super::outcome::{count, EXIT_FRAMES_FAILED};
use anyhow::Result;
use clap::ValueEnum;
use panoconv::export::{ClassMap, ExportOptions, ExportReport, ExportSplit, Format, SplitRule};
use panoconv::reproject::visibility::Visibility;
use std::path::Path;
use std::process::ExitCode;

#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum FormatArg {
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

/// Runs one export and reports it; the exit code says whether frames failed.
pub(crate) fn run_export(
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
pub(crate) fn export_after_kitti(
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
