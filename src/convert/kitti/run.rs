//! Running a KITTI conversion: checks and set-up before anything is written, the frames in
//! groups over the rayon pool (resumed frames kept, failed ones reported and recorded), then
//! the image sets and the manifest.

use super::context::Context;
use super::read::prepare;
use super::write::{finish, remove_outputs, write_split_calib};
use super::{KittiJob, KittiSource, KittiSummary, Parameters};
use crate::convert::style_pass::{convert_group, StylePass};
use crate::error::{Error, Result};
use crate::fs;
use crate::kitti::{Cam, Dataset, FrameRef, OutputKind, Split};
use crate::run::journal::{Journal, Previous};
use crate::run::manifest::{FrameRecord, FrameStatus};
use crate::run::names::IMAGE_SETS;
use crate::run::{Claim, FrameRun, FrameWork, OutputFolder, Progress};
use crate::style::StyleModel;
use std::collections::HashMap;
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// Runs a conversion. Set-up problems return `Err` before anything is written; a broken frame
/// is reported through `progress`, recorded in the manifest and counted in the summary.
/// `stop` (SIGINT, SIGTERM) ends the taking of frames; those in flight finish.
pub fn run_kitti(
    job: &KittiJob,
    progress: &dyn Progress,
    stop: &AtomicBool,
) -> Result<KittiSummary> {
    let started = std::time::Instant::now();
    if matches!(job.source, KittiSource::Object { .. }) {
        check_not_converted_or_split(&job.input)?;
    }
    let dataset = job.source.open(&job.input)?;
    // Held until the run returns: one process per output (per shard).
    let folder = OutputFolder::claim(Claim {
        input: &job.input,
        output: &job.output,
        shard: job.shard,
        mode: job.mode,
        resumable: true,
        started,
    })?;
    let frames = selected_frames(job, &dataset)?;
    let style = crate::convert::run_options::load_style(job.style.as_ref())?;
    let parameters =
        serde_json::to_value(Parameters::new(job, style.as_ref())).expect("parameters serialise");
    let previous = folder.previous(&parameters)?;
    check_output_size(job, &dataset, &frames)?;
    folder.prepare()?;
    create_output_folders(job, &dataset, &folder)?;

    let ctx = Context::new(job, style.as_ref(), &dataset);
    let style_pass = style
        .as_ref()
        .map(|m| StylePass::new(m, job.style.as_ref().map_or(1, |s| s.batch)));
    if job.augment.is_none() {
        // (augmented views have tables of their own, built with the frame)
        build_tables_ahead(&ctx, &frames, &previous, progress);
    }
    for split in &dataset.splits {
        write_split_calib(&ctx, split)?;
    }
    let unusable = unusable_frames(job, &dataset);
    // what the dataset holds that is no frame: listed once, by an unsharded run or shard 0
    let listed = job.frames.is_none() && folder.writes_shared_files();
    let not_frames = if listed {
        crate::kitti::not_frames::list(&dataset)
    } else {
        Vec::new()
    };
    let mut run = folder.start(
        job.source.command(),
        parameters,
        previous,
        frames.len() + unusable.len(),
        progress,
        stop,
    )?;
    let work = KittiFrames {
        dataset: &dataset,
        ctx: &ctx,
        style_pass: style_pass.as_ref(),
    };
    let group = style_pass.as_ref().map_or(1, |p| p.group_len());
    run.run(&frames, group, &work);
    record_unusable(&run, &unusable);
    let summary = run.finish(ctx.views.tables_built(), |journal| {
        if job.augment.is_some() && job.shard.is_none() {
            // augmented ids are new: list them so KITTI loaders find the views
            write_image_sets(&job.output, &dataset, journal)?;
        }
        Ok(())
    })?;
    Ok(KittiSummary {
        run: summary,
        style_runs: style.as_ref().map(StyleModel::runs),
        thin_views: job
            .augment
            .map(|a| (ctx.views.thin_views(), a.min_objects.max(1) as usize)),
        not_frames,
    })
}

/// Builds the tables of the frames still to convert (those of a resumed run's records aside).
fn build_tables_ahead(
    ctx: &Context,
    frames: &[FrameRef],
    previous: &Previous,
    progress: &dyn Progress,
) {
    let todo: Vec<(&Split, &str)> = (frames.iter())
        .filter(|f| !previous.contains(&f.split, &f.id))
        .filter_map(|f| Some((ctx.dataset.split(&f.split)?, f.id.as_str())))
        .collect();
    super::tables::build_ahead(ctx, &todo, &ctx.job.cameras, progress);
}

/// The frames of the selection this process converts: checked on the whole selection, before
/// sharding (a shard may own no frame of a small set), then the shard's.
fn selected_frames(job: &KittiJob, dataset: &Dataset) -> Result<Vec<FrameRef>> {
    let ids = job.frames.as_ref().map(|ids| full_ids(dataset, ids));
    let (mut frames, missing) = dataset.select(ids.as_deref());
    dataset.check_selection(&frames, &missing)?;
    dataset.check_folders(&job.cameras, job.depth.is_some())?;
    if let Some(shard) = job.shard {
        frames.retain(|f| shard.owns(&f.split, &f.id));
    }
    Ok(frames)
}

/// The image files of the selection that are not frames, each recorded as a failure.
fn record_unusable(run: &FrameRun, unusable: &[(&Split, &String)]) {
    for &(split, name) in unusable {
        let e = Error::file(
            &split.image_path(Cam::C2, "x").with_file_name(name),
            "not a KITTI frame name (frames are <id>.png, lower case, with a UTF-8 name): rename it to convert it",
        );
        run.record_failed(&split.name, name, &e);
    }
}

/// Two inputs that look like a KITTI root but are not the one to give: a dataset panoconv
/// wrote (its images are no longer pinhole, so converting it again would be wrong), and a
/// split folder (`K/training`) given instead of its root.
fn check_not_converted_or_split(input: &Path) -> Result<()> {
    let manifest = input.join(crate::run::manifest::MANIFEST);
    if manifest.is_file() {
        return Err(Error::Setup(format!(
            "input {} is a converted dataset (it holds {}, written by panoconv): its images are \
             no longer pinhole; give the original KITTI dataset as --input",
            input.display(),
            manifest.display()
        )));
    }
    let name = input.file_name().and_then(|n| n.to_str()).unwrap_or("");
    if crate::kitti::dataset::SPLITS.contains(&name) && input.join("image_2").is_dir() {
        let root = input.parent().unwrap_or(Path::new("."));
        let root = if root.as_os_str().is_empty() {
            Path::new(".")
        } else {
            root
        };
        return Err(Error::Setup(format!(
            "input {} is the {name} split, not a KITTI root: use --input {} (the folder that \
             holds training/ and testing/), and --split {name} for this split only",
            input.display(),
            root.display()
        )));
    }
    Ok(())
}

/// The ids of `--frames` as the dataset names them: an id found in no split is tried in
/// KITTI's six-digit form (`7` → `000007`), as `preview --frame` does.
fn full_ids(dataset: &Dataset, ids: &[String]) -> Vec<String> {
    let present = |id: &str| {
        dataset
            .splits
            .iter()
            .any(|s| s.frames.binary_search_by(|f| f.as_str().cmp(id)).is_ok())
    };
    ids.iter()
        .map(|id| {
            let id = id.trim();
            match id.parse::<u64>() {
                Ok(n) if !present(id) && present(&format!("{n:06}")) => format!("{n:06}"),
                _ => id.to_owned(),
            }
        })
        .collect()
}

/// An output scale that makes every frame's image too large is a set-up error, not one error
/// per frame: checked on the first frame of each split (KITTI's cameras differ little).
fn check_output_size(job: &KittiJob, dataset: &Dataset, frames: &[FrameRef]) -> Result<()> {
    for split in &dataset.splits {
        let Some(first) = frames.iter().find(|f| f.split == split.name) else {
            continue;
        };
        for (k, size) in super::tables::source_cameras(split, &first.id, &job.cameras) {
            let source = crate::camera::Perspective::new(k, size);
            let Err(e) = job.target.camera(k, &source) else {
                continue;
            };
            let text = e.to_string();
            if !text.ends_with(" is too large") {
                return Err(Error::Setup(format!("frame {first}: {text}")));
            }
            let option = match job.target.scale() {
                crate::geometry::Scale::PanoWidth(w) => format!("--pano-width {w}"),
                crate::geometry::Scale::PixelsPerDegree(d) => format!("--px-per-deg {d}"),
                crate::geometry::Scale::SourceFocal => "the output size".to_owned(),
            };
            return Err(Error::Setup(format!(
                "{option} is too large: frame {first} would give an {} (the limit is 65535 pixels a side); choose a smaller scale",
                text.trim_end_matches(" is too large")
            )));
        }
    }
    Ok(())
}

/// Creates every output folder the job writes into, per split.
fn create_output_folders(job: &KittiJob, dataset: &Dataset, folder: &OutputFolder) -> Result<()> {
    let mut dirs = Vec::new();
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
                let parent = p.parent().unwrap_or(Path::new(""));
                dirs.push(job.output.join(&split.name).join(parent));
            }
        }
    }
    folder.create_dirs(dirs)
}

/// Files that look like frames but cannot be read as one: reported, not silently skipped.
/// (With a frame selection they were not asked for; each shard reports its own share.)
fn unusable_frames<'d>(job: &KittiJob, dataset: &'d Dataset) -> Vec<(&'d Split, &'d String)> {
    dataset
        .splits
        .iter()
        .flat_map(|s| s.unusable.iter().map(move |name| (s, name)))
        .filter(|(s, n)| job.frames.is_none() && job.shard.is_none_or(|sh| sh.owns(&s.name, n)))
        .collect()
}

/// A KITTI conversion's frames for the run's frame loop.
struct KittiFrames<'a> {
    dataset: &'a Dataset,
    ctx: &'a Context<'a>,
    style_pass: Option<&'a StylePass<'a>>,
}

impl FrameWork for KittiFrames<'_> {
    type Item = FrameRef;

    fn key<'k>(&self, f: &'k FrameRef) -> (&'k str, &'k str) {
        (&f.split, &f.id)
    }

    fn convert(&self, group: &[&FrameRef]) -> Vec<Result<FrameRecord>> {
        let items: Vec<(&Split, &str)> = group
            .iter()
            .map(|f| {
                let split = self
                    .dataset
                    .split(&f.split)
                    .expect("selected frames come from the dataset's splits");
                (split, f.id.as_str())
            })
            .collect();
        let ctx = self.ctx;
        let results = convert_group(
            self.style_pass,
            &items,
            |&(split, id)| split.image_path(Cam::C2, id),
            |&(split, id)| prepare(ctx, split, id),
            |&(split, id), p| finish(ctx, split, id, p),
        );
        results
            .into_iter()
            .zip(&items)
            .map(|(converted, &(split, id))| {
                converted.map(|out| out.record).inspect_err(|_| {
                    // (an output an earlier run left for this frame included)
                    remove_outputs(self.ctx, split, id);
                })
            })
            .collect()
    }
}

/// `OUT/ImageSets/<split>.txt`: the view ids written per split; none when no frame was
/// written (empty lists would make a folder of failures look like an empty dataset).
fn write_image_sets(output: &Path, dataset: &Dataset, journal: &Journal) -> Result<()> {
    let dir = output.join(IMAGE_SETS);
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
    if by_split.is_empty() {
        return Ok(());
    }
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    for split in &dataset.splits {
        let mut ids = by_split.remove(&split.name).unwrap_or_default();
        ids.sort_unstable();
        let text: String = ids.iter().map(|id| format!("{id}\n")).collect();
        fs::write_atomic(&dir.join(format!("{}.txt", split.name)), text.as_bytes())?;
    }
    Ok(())
}
