//! The KITTI conversion: frames flow through read → (style) → warp → labels/calib → write, in
//! parallel over frames (or groups of frames, when the style pass batches) on one rayon pool
//! (the only owner of threads).

mod batch;
mod frame;
mod read;
mod tables;
mod views;
mod write;

use crate::codec::png::PngCompression;
use crate::error::{Error, Result};
use crate::fs;
use crate::geometry::augment::Augment;
use crate::geometry::{FisheyeTarget, OutputSpec};
use crate::kitti::Cam;
use crate::kitti::{raw, OutputKind};
use crate::kitti::{Dataset, FrameRef, Split};
use crate::reproject::depth::OcclusionFilter;
use crate::run::journal::{self, Journal, Shard};
use crate::run::manifest::{FrameRecord, FrameStatus};
use crate::run::{Progress, Summary};
use crate::style::{Device, StyleInfo, StyleModel, StyleOptions};
use batch::StylePass;
use frame::Context;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Everything a `kitti` or `kitti-raw` conversion needs (the manifest records what decides
/// the outputs as `parameters`).
#[derive(Debug, Clone)]
pub struct KittiJob {
    /// The dataset's root: an object root or a raw date folder, as `source` says.
    pub input: PathBuf,
    /// Where the converted dataset goes.
    pub output: PathBuf,
    /// Which layout `input` has and what part of it is converted.
    pub source: KittiSource,
    /// The target projection, scale, canvas, crop and resize.
    pub output_spec: OutputSpec,
    /// The fisheye camera of `--to fisheye`.
    pub fisheye: Option<FisheyeTarget>,
    /// Write `mask_2/` (and `mask_3/`): where each output pixel has source data.
    pub mask: bool,
    /// Restrict to these frame ids.
    pub frames: Option<Vec<String>>,
    /// Write into a non-empty output folder.
    pub overwrite: bool,
    /// PNG encoder effort.
    pub png_compression: PngCompression,
    /// The CycleGAN style pass, if any.
    pub style: Option<StyleJob>,
    /// Random scale-and-crop views instead of the whole frame.
    pub augment: Option<Augment>,
    /// Cameras to convert: 2 (left colour), and 3 (right colour) for stereo pairs.
    pub cameras: Vec<Cam>,
    /// LiDAR depth maps (`depth_2/`), if asked for.
    pub depth: Option<DepthJob>,
    /// This process converts one shard of the frames.
    pub shard: Option<Shard>,
    /// Skip frames whose outputs a previous run completed (same parameters, same inputs).
    pub resume: bool,
}

/// The input of a KITTI conversion.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum KittiSource {
    /// A KITTI object root (`training/`, `testing/`): all of it, or the split named.
    Object {
        /// `training` or `testing`.
        split: Option<String>,
    },
    /// A KITTI raw date folder: all its drives, or the drive named.
    Raw {
        /// A drive folder's name (`2011_09_26_drive_0001_sync`).
        drive: Option<String>,
    },
}

impl KittiSource {
    /// The dataset at `root`, restricted as asked.
    fn open(&self, root: &Path) -> Result<Dataset> {
        match self {
            KittiSource::Object { split } => Dataset::open(root, split.as_deref()),
            KittiSource::Raw { drive } => raw::open(root, drive.as_deref()),
        }
    }

    /// The subcommand the manifest names.
    fn command(&self) -> &'static str {
        match self {
            KittiSource::Object { .. } => "kitti",
            KittiSource::Raw { .. } => "kitti-raw",
        }
    }
}

/// The manifest's `parameters`: what decides the outputs (docs/formats.md), so a `--resume`
/// or a `merge` can tell a run with other options. Field order is the file's.
#[derive(Debug, Serialize)]
struct Parameters<'a> {
    input: &'a Path,
    output_spec: &'a OutputSpec,
    #[serde(skip_serializing_if = "Option::is_none")]
    fisheye: Option<&'a FisheyeTarget>,
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    mask: bool,
    /// The object split or the raw drive.
    split: Option<&'a str>,
    frames: Option<&'a [String]>,
    png_compression: PngCompression,
    augment: Option<&'a Augment>,
    cameras: &'a [Cam],
    depth: Option<&'a DepthJob>,
    shard: Option<Shard>,
    raw: bool,
    style: Option<StyleRecord<'a>>,
}

impl<'a> Parameters<'a> {
    fn new(job: &'a KittiJob, style: Option<&'a StyleModel>) -> Self {
        let (split, raw) = match &job.source {
            KittiSource::Object { split } => (split.as_deref(), false),
            KittiSource::Raw { drive } => (drive.as_deref(), true),
        };
        Parameters {
            input: &job.input,
            output_spec: &job.output_spec,
            fisheye: job.fisheye.as_ref(),
            mask: job.mask,
            split,
            frames: job.frames.as_deref(),
            png_compression: job.png_compression,
            augment: job.augment.as_ref(),
            cameras: &job.cameras,
            depth: job.depth.as_ref(),
            shard: job.shard,
            raw,
            style: style.map(|m| StyleRecord {
                model: m.info(),
                order: job
                    .style
                    .as_ref()
                    .map_or(StyleOrder::BeforeWarp, |s| s.order),
            }),
        }
    }
}

/// The depth output of a conversion.
#[derive(Debug, Clone, Serialize)]
pub struct DepthJob {
    /// None turns the occlusion correction off.
    pub occlusion_filter: Option<OcclusionFilter>,
}

/// The style pass of a conversion.
#[derive(Debug, Clone)]
pub struct StyleJob {
    /// The model, the ONNX Runtime library and the device.
    pub options: StyleOptions,
    /// Before or after the warp.
    pub order: StyleOrder,
    /// Equal-size images of up to this many consecutive frames go through the model in one
    /// run (1: frame by frame). Outputs do not depend on it (see `batch`).
    pub batch: usize,
}

/// What the manifest records of the style pass.
#[derive(Debug, Serialize)]
struct StyleRecord<'a> {
    model: &'a StyleInfo,
    order: StyleOrder,
}

/// Whether the style pass takes the source images or the warped ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StyleOrder {
    /// Style the source image, then warp it (as the paper does).
    BeforeWarp,
    /// Warp, then style the output image.
    AfterWarp,
}

/// What a KITTI conversion did: the run's counts and what only a KITTI conversion has.
#[derive(Debug)]
pub struct KittiSummary {
    /// Frames, failures, time, tables.
    pub run: Summary,
    /// Style model runs and the images they took (batch checks included), if styled.
    pub style_runs: Option<(usize, usize)>,
    /// With --augment: the views holding fewer objects than asked (at least one), and that
    /// minimum.
    pub thin_views: Option<(usize, usize)>,
}

/// Runs a conversion. Set-up problems return `Err` before anything is written; a broken frame
/// is reported through `progress`, recorded in the manifest and counted in the summary.
/// `stop` (SIGINT, SIGTERM) ends the taking of frames; those in flight finish.
pub fn run_kitti(
    job: &KittiJob,
    progress: &dyn Progress,
    stop: &AtomicBool,
) -> Result<KittiSummary> {
    let started = std::time::Instant::now();
    let dataset = job.source.open(&job.input)?;
    // Resumed runs and shards write into a folder that already holds outputs.
    // Held until the run returns: one process per output (per shard).
    let _lock = journal::claim_output(
        &job.input,
        &job.output,
        job.shard,
        job.overwrite || job.resume || job.shard.is_some(),
    )?;
    let (mut frames, missing) = dataset.select(job.frames.as_deref());
    // Checked on the whole selection, before sharding: a shard may own no frame of a small set.
    dataset.check_selection(&frames, &missing)?;
    dataset.check_folders(&job.cameras, job.depth.is_some())?;
    if let Some(shard) = job.shard {
        frames.retain(|f| shard.owns(&f.split, &f.id));
    }
    // Loaded before anything is written: a missing library or a bad model is a set-up error.
    // On the CPU, one session per worker with one thread each, so --jobs alone sets the core
    // count. On a GPU each session holds its own weights and activation arena in device
    // memory, and one device runs one model at a time anyway: two sessions (one computing
    // while the other's inputs are prepared) serve any number of workers.
    let style = match &job.style {
        Some(s) => {
            let options = StyleOptions {
                intra_threads: 1,
                ..s.options.clone()
            };
            let workers = rayon::current_num_threads();
            let sessions = match options.device {
                Device::Cpu => workers,
                Device::Cuda => workers.min(2),
            };
            Some(StyleModel::load_pool(&options, sessions)?)
        }
        None => None,
    };
    let parameters =
        serde_json::to_value(Parameters::new(job, style.as_ref())).expect("parameters serialise");
    let previous = if job.resume {
        journal::load_previous(&job.output, job.shard, &parameters)?
    } else {
        HashMap::new()
    };

    if matches!(job.source, KittiSource::Raw { .. }) && job.augment.is_some() {
        return Err(Error::Setup(
            "--augment is not available for KITTI raw drives (one calib per drive)".into(),
        ));
    }
    for split in &dataset.splits {
        let mut kinds = vec![OutputKind::Image(Cam::C2), OutputKind::Calib];
        if split.has_labels {
            kinds.push(OutputKind::Label);
        }
        if job.cameras.contains(&Cam::C3) {
            kinds.push(OutputKind::Image(Cam::C3));
        }
        if job.mask {
            kinds.extend(job.cameras.iter().map(|&c| OutputKind::Mask(c)));
        }
        if job.depth.is_some() {
            kinds.push(OutputKind::Depth);
        }
        for k in kinds {
            if let Some(p) = split.output_path(k, "x") {
                let dir = job
                    .output
                    .join(&split.name)
                    .join(p.parent().unwrap_or(Path::new("")));
                std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
            }
        }
    }
    if job.resume {
        journal::remove_stale_temporaries(&job.output);
    }

    let ctx = Context::new(job, style.as_ref(), &dataset);
    let style_pass = style
        .as_ref()
        .map(|m| StylePass::new(m, job.style.as_ref().map_or(1, |s| s.batch)));
    let group_len = style_pass.as_ref().map_or(1, |p| p.group_len());
    if job.augment.is_none() {
        // (augmented views have tables of their own, built with the frame)
        let todo: Vec<(&Split, &str)> = frames
            .iter()
            .filter(|f| !previous.contains_key(&(f.split.clone(), f.id.clone())))
            .filter_map(|f| Some((dataset.split(&f.split)?, f.id.as_str())))
            .collect();
        tables::build_ahead(&ctx, &todo, &job.cameras);
    }
    for split in &dataset.splits {
        ctx.write_split_calib(split)?;
    }
    let journal = Journal::new(
        &job.output,
        job.shard,
        job.source.command(),
        parameters,
        job.resume,
    )?;
    // Files that look like frames but cannot be read as one: reported, not silently skipped.
    // (With a frame selection they were not asked for; each shard reports its own share.)
    let unusable: Vec<(&Split, &String)> = dataset
        .splits
        .iter()
        .flat_map(|s| s.unusable.iter().map(move |name| (s, name)))
        .filter(|(s, n)| job.frames.is_none() && job.shard.is_none_or(|sh| sh.owns(&s.name, n)))
        .collect();
    progress.start(frames.len() + unusable.len());
    let (mut resumed, mut done) = (0usize, 0usize);
    // The first write the output device refused for want of space (or being read-only): no
    // new frame is taken after it, since every one would fail the same way.
    let device_full: std::sync::OnceLock<Error> = std::sync::OnceLock::new();
    let written = AtomicUsize::new(0);
    // Groups of consecutive frames (one frame each unless the style pass batches): the
    // grouping depends on the selection and the options only, never on the thread count.
    let outcomes: Vec<Option<bool>> = frames
        .par_chunks(group_len)
        .flat_map_iter(|group| {
            // SIGINT/SIGTERM or a full device: take no new group; those in flight finish.
            if stop.load(Ordering::Relaxed) || device_full.get().is_some() {
                return vec![None; group.len()];
            }
            let mut outcomes = vec![Some(true); group.len()];
            let mut todo = Vec::new();
            for (i, f) in group.iter().enumerate() {
                let split = dataset
                    .split(&f.split)
                    .expect("selected frames come from the dataset's splits");
                if let Some(r) = previous.get(&(f.split.clone(), f.id.clone())) {
                    if journal::still_valid(r, &job.input, &job.output) {
                        journal.record(r.clone());
                        written.fetch_add(1, Ordering::Relaxed);
                        progress.frame_done();
                        continue;
                    }
                }
                outcomes[i] = Some(false);
                todo.push((i, split, f));
            }
            let items: Vec<(&Split, &str)> =
                todo.iter().map(|(_, s, f)| (*s, f.id.as_str())).collect();
            let results = batch::convert_group(&ctx, style_pass.as_ref(), &items);
            for ((i, split, f), converted) in todo.into_iter().zip(results) {
                let record = match converted {
                    Ok(out) => {
                        written.fetch_add(1, Ordering::Relaxed);
                        progress.frame_done();
                        out.record
                    }
                    Err(e) => {
                        // A failed frame leaves no output behind, not even one from an earlier
                        // run into the same folder (--overwrite), which loaders would pick up.
                        ctx.remove_outputs(split, &f.id);
                        if e.is_device_full() {
                            // Not this frame's fault: it is left for --resume, reported once.
                            let _ = device_full.set(e);
                            outcomes[i] = None;
                            continue;
                        }
                        progress.frame_failed(&f.to_string(), &e);
                        FrameRecord::failed(&f.split, &f.id, &e)
                    }
                };
                journal.record(record);
            }
            outcomes
        })
        .collect();
    for o in outcomes.iter().flatten() {
        done += 1;
        resumed += usize::from(*o);
    }
    for &(split, name) in &unusable {
        let f = FrameRef {
            split: split.name.clone(),
            id: name.clone(),
        };
        let e = Error::file(
            &split.image_path(Cam::C2, "x").with_file_name(name),
            "not a KITTI frame name (frames are <id>.png, lower case, with a UTF-8 name): rename it to convert it",
        );
        progress.frame_failed(&f.to_string(), &e);
        journal.record(FrameRecord::failed(&f.split, &f.id, &e));
    }
    progress.finish();
    let interrupted = done < frames.len();
    let device_full = device_full.into_inner().map(|e| {
        format!(
            "output device full after {} of {} frames ({e}): free space and run again with --resume",
            written.load(Ordering::Relaxed),
            frames.len()
        )
    });
    // On a full device the manifest may not fit either: then say so with the rest.
    let when_full = |e: Error| match &device_full {
        Some(full) => Error::DeviceFull(format!(
            "{full}; the manifest could not be written either ({e})"
        )),
        None => e,
    };
    if job.augment.is_some() && job.shard.is_none() {
        // augmented ids are new: list them so KITTI loaders find the views
        write_image_sets(&job.output, &dataset, &journal).map_err(when_full)?;
    }
    let finished = journal.finish(!interrupted).map_err(when_full)?;
    Ok(KittiSummary {
        run: Summary {
            frames: finished.frames,
            converted: finished.frames - finished.failed,
            failed: finished.failed,
            resumed,
            interrupted: interrupted && device_full.is_none(),
            device_full,
            seconds: started.elapsed().as_secs_f64(),
            tables_built: ctx.tables_built(),
        },
        style_runs: style.as_ref().map(StyleModel::runs),
        thin_views: job
            .augment
            .map(|a| (ctx.thin_views(), a.min_objects.max(1) as usize)),
    })
}

/// `OUT/ImageSets/<split>.txt`: the view ids written per split.
fn write_image_sets(output: &Path, dataset: &Dataset, journal: &Journal) -> Result<()> {
    let dir = output.join("ImageSets");
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let mut by_split: HashMap<String, Vec<String>> = HashMap::new();
    journal.for_each_record(|r| {
        if r.status != FrameStatus::Ok {
            return;
        }
        let ids = by_split.entry(r.split).or_default();
        if r.views.iter().any(|v| v.view.is_some()) {
            ids.extend(r.views.into_iter().map(|v| v.id));
        } else {
            ids.push(r.id);
        }
    })?;
    for split in &dataset.splits {
        let mut ids = by_split.remove(&split.name).unwrap_or_default();
        ids.sort_unstable();
        let text: String = ids.iter().map(|id| format!("{id}\n")).collect();
        fs::write_atomic(&dir.join(format!("{}.txt", split.name)), text.as_bytes())?;
    }
    Ok(())
}
