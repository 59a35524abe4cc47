//! The KITTI conversion: frames flow through read → (style) → warp → labels/calib → write, in
//! parallel over frames (or groups of frames, when the style pass batches) on one rayon pool
//! (the only owner of threads).

mod batch;
mod frame;
mod tables;

use crate::codec::png::PngCompression;
use crate::error::{Error, Result};
use crate::fs;
use crate::geometry::augment::Augment;
use crate::geometry::{FisheyeTarget, OutputSpec};
use crate::kitti::{raw, Layout, OutputKind};
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

/// Everything a `kitti` conversion needs; also recorded in the manifest.
#[derive(Debug, Clone, Serialize)]
pub struct KittiJob {
    pub input: PathBuf,
    #[serde(skip)]
    pub output: PathBuf,
    pub output_spec: OutputSpec,
    /// The fisheye camera of `--to fisheye`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fisheye: Option<FisheyeTarget>,
    /// Write `mask_2/` (and `mask_3/`): where each output pixel has source data.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub mask: bool,
    pub split: Option<String>,
    /// Restrict to these frame ids.
    pub frames: Option<Vec<String>>,
    #[serde(skip)]
    pub overwrite: bool,
    pub png_compression: PngCompression,
    /// The CycleGAN style pass, if any.
    #[serde(skip)]
    pub style: Option<StyleJob>,
    /// Random scale-and-crop views instead of the whole frame.
    pub augment: Option<Augment>,
    /// Cameras to convert: 2 (left colour), and 3 (right colour) for stereo pairs.
    pub cameras: Vec<usize>,
    /// LiDAR depth maps (`depth_2/`), if asked for.
    pub depth: Option<DepthJob>,
    /// This process converts one shard of the frames.
    pub shard: Option<Shard>,
    /// Skip frames whose outputs a previous run completed (same parameters, same inputs).
    #[serde(skip)]
    pub resume: bool,
    /// The input is a KITTI raw date folder (splits are its drives).
    pub raw: bool,
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
    pub options: StyleOptions,
    /// Style the warped image instead of the source (the paper styles before the warp).
    pub after_warp: bool,
    /// Equal-size images of up to this many consecutive frames go through the model in one
    /// run (1: frame by frame). Outputs do not depend on it (see `batch`).
    pub batch: usize,
}

/// What the manifest records of the style pass.
#[derive(Debug, Serialize)]
struct StyleRecord<'a> {
    model: &'a StyleInfo,
    order: &'static str,
}

/// The manifest's parameters: the job and the style model that was actually loaded.
#[derive(Debug, Serialize)]
struct Parameters<'a> {
    #[serde(flatten)]
    job: &'a KittiJob,
    style: Option<StyleRecord<'a>>,
}

/// Runs a conversion. Set-up problems return `Err` before anything is written; a broken frame
/// is reported through `progress`, recorded in the manifest and counted in the summary.
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

pub fn run_kitti(
    job: &KittiJob,
    progress: &dyn Progress,
    stop: &AtomicBool,
) -> Result<KittiSummary> {
    let started = std::time::Instant::now();
    let dataset = if job.raw {
        raw::open(&job.input, job.split.as_deref())?
    } else {
        Dataset::open(&job.input, job.split.as_deref())?
    };
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
    let parameters = serde_json::to_value(Parameters {
        job,
        style: style.as_ref().map(|m| StyleRecord {
            model: m.info(),
            order: if job.style.as_ref().is_some_and(|s| s.after_warp) {
                "after_warp"
            } else {
                "before_warp"
            },
        }),
    })
    .expect("parameters serialise");
    let previous = if job.resume {
        journal::load_previous(&job.output, job.shard, &parameters)?
    } else {
        HashMap::new()
    };

    let is_raw = dataset
        .splits
        .iter()
        .any(|s| matches!(s.layout, Layout::Raw { .. }));
    if is_raw && job.augment.is_some() {
        return Err(Error::Setup(
            "--augment is not available for KITTI raw drives (one calib per drive)".into(),
        ));
    }
    for split in &dataset.splits {
        let mut kinds = vec![OutputKind::Image(2), OutputKind::Calib];
        if split.has_labels {
            kinds.push(OutputKind::Label);
        }
        if job.cameras.contains(&3) {
            kinds.push(OutputKind::Image(3));
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
    let command = if is_raw { "kitti-raw" } else { "kitti" };
    let journal = Journal::new(&job.output, job.shard, command, parameters, job.resume)?;
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
            &split.image_path(2, "x").with_file_name(name),
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
