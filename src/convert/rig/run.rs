//! The one rig run, for any dataset behind [`RigSource`]: the selection and the cameras checked
//! before anything is written (`setup.rs`), then the output folder's run (`run::OutputFolder`:
//! claim, previous records, journal, the frame loop, the manifest) over a [`FrameWork`]:
//! frames in groups through `convert::style_pass` (each read with its views drawn, the group's
//! camera images styled together, then each converted through the rig pass and written,
//! atomically and hashed for the manifest); a failed frame leaves no file. The KITTI files
//! (label lines, calib) are `kitti::rig_output`'s.

use super::frame_cache::FrameCache;
use super::gray::encode_gray8;
use super::job::{parameters, ObjectCounts, RigJob, RigSummary, SPLIT};
use super::objects::{DropReason, ObjectOutcome};
use super::pass::{
    convert_view, count_objects, output_camera, read_images_hashed, CameraInfo, ClassFilter,
    RigOptions,
};
use super::scan_error::explain_scan_error;
use super::scene_depth::StitchMode;
use super::setup::{check_cameras, check_output_camera, read_ego_masks, Masks};
use super::stitch_cache::StitchCache;
use crate::camera::OutputCamera;
use crate::convert::augment_draw::{draw_view, CountObjects};
use crate::convert::style_pass::{convert_group, StyleImages, StylePass};
use crate::convert::view_pass::{relative, write_views, PassView, ViewFiles, ViewImage, ViewSink};
use crate::error::{Error, Result};
use crate::fs;
use crate::geometry::augment::{view_id, Augment, View};
use crate::image::RgbImage;
use crate::kitti::{Cam, OutputKind};
use crate::run::manifest::FrameRecord;
use crate::run::{Claim, FrameWork, OnceMap, OutputFolder, Progress};
use crate::source::{Frame, RigItem, RigItems, RigSource, SourceBox, SourceFrame};
use crate::style::{StyleError, StyleModel};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// The per-frame outputs under `OUT/training/`.
const OUTPUTS: [OutputKind; 8] = [
    OutputKind::Image(Cam::C2),
    OutputKind::Calib,
    OutputKind::Label,
    OutputKind::Source,
    OutputKind::Objects,
    OutputKind::Depth,
    OutputKind::StitchDepth,
    OutputKind::Mask(Cam::C2),
];

/// One output of a frame: its id, how an augmented view was drawn (None: the whole frame) and
/// its camera.
type OutputView = (String, Option<View>, Box<dyn OutputCamera>);

/// A frame read, its views drawn, waiting for the style pass and the stitch.
struct Prepared {
    read: SourceFrame,
    views: Vec<OutputView>,
    /// The chosen cameras' images, in `--cameras` order (styled in place by the style pass).
    images: Vec<RgbImage>,
    /// The chosen cameras' image files, in `images`' order: a failed style pass names the
    /// image that failed.
    image_paths: Vec<PathBuf>,
    /// blake3 of each chosen camera's image file, as read, in `images`' order.
    image_hashes: Vec<String>,
}

impl StyleImages for Prepared {
    fn style_images(&mut self) -> &mut Vec<RgbImage> {
        &mut self.images
    }

    fn style_error(&self, index: usize, e: StyleError) -> Error {
        match self.image_paths.get(index) {
            Some(path) => Error::file(path, format!("style pass: {e}")),
            None => e.into(),
        }
    }
}

struct Ctx<'a> {
    job: &'a RigJob,
    source: &'a dyn RigSource,
    /// Each part's camera set, as the rig pass takes it.
    infos: Vec<Vec<CameraInfo>>,
    /// blake3 of the input files shared by frames (calibration, poses, boxes), by path.
    hashes: OnceMap<PathBuf, std::result::Result<String, String>>,
    objects: Mutex<ObjectCounts>,
    /// How the rig pass converts a frame, the same for every frame (the style pass runs
    /// beside it, on groups of frames).
    options: RigOptions,
    /// The style pass over groups of frames (it holds the model), if any.
    style_pass: Option<StylePass<'a>>,
    /// Augmented views holding fewer objects than asked.
    thin_views: AtomicUsize,
    /// The first frame the run converts, as the set-up check read it: the loop takes it
    /// instead of reading the frame again.
    first: Mutex<Option<(String, Result<SourceFrame>)>>,
    /// The fixed stitches kept across frames of one geometry (None: turned off).
    stitches: Option<Arc<StitchCache>>,
}

impl Ctx<'_> {
    /// Frame `id`'s file of `kind`.
    fn output_path(&self, kind: OutputKind, id: &str) -> PathBuf {
        self.job.run.output.join(SPLIT).join(kind.object_path(id))
    }

    /// Every file a frame may write.
    fn output_paths(&self, id: &str) -> Vec<PathBuf> {
        OUTPUTS.iter().map(|&k| self.output_path(k, id)).collect()
    }

    /// blake3 of an input file shared by frames, read once per run.
    fn shared_hash(&self, path: &Path) -> Result<String> {
        self.hashes
            .get_or_build(&path.to_path_buf(), || {
                fs::read_file(path)
                    .map(|b| fs::hash_hex(&b))
                    .map_err(|e| e.to_string())
            })
            .map_err(|m| Error::file(path, m))
    }

    /// The output ids of a frame: its own, or its augmented views'.
    fn output_ids(&self, item: &RigItem) -> Vec<String> {
        match &self.job.run.augment {
            None => vec![item.id.clone()],
            Some(aug) => (0..aug.count)
                .filter_map(|i| view_id(&item.id, aug.count, i))
                .collect(),
        }
    }

    /// The output cameras of a frame: the target's, or the augmented views drawn from it
    /// (each redrawn, up to `MAX_ATTEMPTS` times, until it holds `min_objects` objects).
    fn output_views(
        &self,
        item: &RigItem,
        frame: &Frame,
        info: &[CameraInfo],
        options: &RigOptions,
        keep: ClassFilter,
    ) -> Result<Vec<OutputView>> {
        let job = self.job;
        let canvas = output_camera(frame, info, &job.target, &job.cameras)?;
        let Some(aug) = &job.run.augment else {
            return Ok(vec![(item.id.clone(), None, canvas)]);
        };
        let view_camera = |view: &View| -> Result<Box<dyn OutputCamera>> {
            let (k, size) = Augment::view_camera(view, canvas.intrinsics(), canvas.size());
            canvas
                .with_intrinsics(k, size)
                .map_err(|e| Error::file(&frame.provenance[0], e))
        };
        let mut views = Vec::new();
        for i in 0..aug.count {
            let id = view_id(&item.id, aug.count, i)
                .ok_or_else(|| Error::Setup(format!("frame {}: view {i} has no id", item.id)))?;
            let count =
                |camera: &dyn OutputCamera| count_objects((frame, info), camera, options, keep);
            let drawn = draw_view(
                aug,
                (SPLIT, &item.id),
                i,
                canvas.size(),
                view_camera,
                (aug.min_objects > 0).then_some(&count as &CountObjects),
            )?;
            if drawn.objects.is_some_and(|n| n < aug.min_objects as usize) {
                self.thin_views.fetch_add(1, Ordering::Relaxed);
            }
            let (view, camera) = (drawn.view, drawn.camera);
            views.push((id, Some(view), camera));
        }
        Ok(views)
    }

    /// The frame of `item`, read once per run: the set-up check's read when it is that frame.
    fn read(&self, item: &RigItem) -> Result<SourceFrame> {
        let mut first = self.first.lock().unwrap_or_else(|e| e.into_inner());
        let read = match first.take() {
            Some((id, read)) if id == item.id => read,
            other => {
                *first = other;
                drop(first);
                self.source.read(item)
            }
        };
        read.map_err(|e| explain_scan_error(self.job, self.source, item, e))
    }

    /// Reads a frame and its chosen cameras' images, and draws its output views: everything
    /// before the style pass.
    fn prepare(&self, item: &RigItem) -> Result<Prepared> {
        let read = self.read(item)?;
        let frame = &read.frame;
        let info = &self.infos[item.part];
        let options = &self.options;
        let keep = |b: &SourceBox| source_verdict(self.source, b);
        let views = self.output_views(item, frame, info, options, &keep)?;
        let (images, image_hashes) = read_images_hashed(frame, options)?;
        let image_paths = options
            .cameras
            .iter()
            .filter_map(|&k| frame.rig.get(k).map(|c| c.image.clone()))
            .collect();
        Ok(Prepared {
            read,
            views,
            images,
            image_paths,
            image_hashes,
        })
    }

    /// The rest of a prepared frame's conversion: each output view stitched from its (styled)
    /// images, with its labels, depth and calib, written and recorded.
    fn finish(&self, item: &RigItem, prepared: Prepared) -> Result<FrameRecord> {
        let job = self.job;
        let Prepared {
            read,
            views,
            images,
            image_paths,
            image_hashes,
        } = prepared;
        let frame = &read.frame;
        let mut files = RigViewFiles {
            ctx: self,
            frame,
            record: &read.record,
            cache: FrameCache::with_stitches(self.stitches.clone()),
            info: &self.infos[item.part],
            images: &images,
            options: &self.options,
            counts: ObjectCounts::default(),
        };
        let views = views.into_iter().map(|(id, view, camera)| PassView {
            id: id.clone(),
            view,
            files: (id, camera),
        });
        let written = write_views(&job.run.output, job.run.png_compression, views, &mut files)?;
        let counts = files.counts;
        let inputs = self.inputs(frame, &image_paths, &image_hashes)?;
        self.objects
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .add(&counts);
        Ok(written.record(SPLIT.to_owned(), item.id.clone(), inputs))
    }

    /// The frame's inputs for its record, in the order it names them, each hashed once: the
    /// chosen cameras' images by the bytes they were decoded from, the files the read took
    /// by the read's hashes, the files frames share once per run; the other cameras' images
    /// are not inputs.
    fn inputs(
        &self,
        frame: &Frame,
        image_paths: &[PathBuf],
        image_hashes: &[String],
    ) -> Result<Vec<(String, String)>> {
        let unused: Vec<&PathBuf> = frame
            .rig
            .iter()
            .map(|c| &c.image)
            .filter(|p| !image_paths.contains(p))
            .collect();
        let mut inputs = Vec::new();
        for path in frame.provenance.iter().filter(|p| !unused.contains(p)) {
            let read = image_paths
                .iter()
                .zip(image_hashes)
                .chain(frame.input_hashes.iter().map(|(p, h)| (p, h)))
                .find(|(p, _)| *p == path);
            let hash = match read {
                Some((_, h)) => h.clone(),
                None => self.shared_hash(path)?,
            };
            inputs.push((relative(self.source.root(), path), hash));
        }
        Ok(inputs)
    }
}

/// A rig frame's files for each output view: the stitch's image, calib, labels, source map,
/// objects record and depth.
struct RigViewFiles<'a> {
    ctx: &'a Ctx<'a>,
    frame: &'a Frame,
    /// The source's fields of the frame's objects record.
    record: &'a serde_json::Map<String, serde_json::Value>,
    /// What the frame's views share.
    cache: FrameCache,
    info: &'a [CameraInfo],
    /// The chosen cameras' (styled) images.
    images: &'a [RgbImage],
    options: &'a RigOptions,
    /// The frame's object counts, over its views.
    counts: ObjectCounts,
}

/// A view's `objects/ID.json`: which frame of the dataset (the source's fields), the
/// exposure gains, the counts and every object's outcome.
#[derive(serde::Serialize)]
struct ObjectsFile<'a> {
    #[serde(flatten)]
    frame: &'a serde_json::Map<String, serde_json::Value>,
    stitch: StitchMode,
    gains: &'a [f64],
    counts: ObjectCounts,
    objects: &'a [ObjectOutcome],
}

impl ViewFiles for RigViewFiles<'_> {
    /// The view's output frame id and camera.
    type View = (String, Box<dyn OutputCamera>);

    fn view_files(&mut self, (id, camera): Self::View, sink: &mut ViewSink) -> Result<()> {
        let ctx = self.ctx;
        let keep = |b: &SourceBox| source_verdict(ctx.source, b);
        let frame = self.frame;
        let (info, images, options) = (self.info, self.images, self.options);
        let out = convert_view((frame, &self.cache), info, camera, images, options, &keep)?;
        let calib = crate::kitti::rig_output::rig_calib_text(
            out.camera.as_ref(),
            &out.centre,
            frame.reference_from_lidar.as_ref(),
            frame.lidar_from_imu.as_ref(),
            frame.world_from_reference.as_ref(),
        );
        let mut labels = String::new();
        for p in &out.labels {
            let line = if p.dont_care {
                crate::kitti::rig_output::dont_care_line(p.bounds)
            } else {
                let b = &frame.objects[p.index];
                crate::kitti::rig_output::label_line(b, p.bounds, p.truncation, p.occlusion)
            };
            labels.push_str(&line);
            labels.push('\n');
        }
        let view_counts = ObjectCounts::of(&out.objects);
        self.counts.add(&view_counts);
        let objects = serde_json::to_vec_pretty(&ObjectsFile {
            frame: self.record,
            stitch: out.stitch_mode,
            gains: &out.gains,
            counts: view_counts,
            objects: &out.objects,
        })
        .expect("the objects record serialises");
        let size = out.camera.size();
        let mask = ctx.job.mask.then(|| out.encode_mask());
        sink.image(
            ctx.output_path(OutputKind::Image(Cam::C2), &id),
            ViewImage::Warped(&out.image),
        )?;
        sink.file(ctx.output_path(OutputKind::Calib, &id), calib.into_bytes());
        sink.file(ctx.output_path(OutputKind::Label, &id), labels.into_bytes());
        sink.file(
            ctx.output_path(OutputKind::Source, &id),
            encode_gray8(size.width, size.height, &out.source),
        );
        sink.file(ctx.output_path(OutputKind::Objects, &id), objects);
        if let Some(depth) = out.depth {
            sink.depth(ctx.output_path(OutputKind::Depth, &id), depth);
        }
        if let Some(map) = out.distances {
            let png = crate::codec::png::encode_gray16(
                map.width,
                map.height,
                &map.to_u16(),
                ctx.job.run.png_compression,
            );
            sink.file(ctx.output_path(OutputKind::StitchDepth, &id), png);
        }
        if let Some(mask) = mask {
            sink.file(ctx.output_path(OutputKind::Mask(Cam::C2), &id), mask);
        }
        Ok(())
    }
}

impl FrameWork for Ctx<'_> {
    type Item = RigItem;

    fn key<'k>(&self, item: &'k RigItem) -> (&'k str, &'k str) {
        (SPLIT, &item.id)
    }

    fn convert(&self, group: &[&RigItem]) -> Vec<Result<FrameRecord>> {
        let results = convert_group(
            self.style_pass.as_ref(),
            group,
            |item| self.source.frame_folder(item),
            |item| self.prepare(item),
            |item, p| self.finish(item, p),
        );
        results
            .into_iter()
            .zip(group)
            .map(|(result, item)| {
                result.inspect_err(|_| {
                    // a failed frame leaves no output, not even one of an earlier run
                    for id in self.output_ids(item) {
                        for p in self.output_paths(&id) {
                            let _ = std::fs::remove_file(p);
                        }
                    }
                })
            })
            .collect()
    }
}

/// Runs a rig conversion of `source` (the job's own rules were checked when it was made).
/// Set-up problems return `Err` before anything is written; a broken frame is reported through `progress`, recorded in the manifest and
/// counted in the summary. `stop` (SIGINT, SIGTERM) ends the taking of frames. Must run inside
/// the caller's rayon pool.
pub fn run_rig(
    job: &RigJob,
    source: &dyn RigSource,
    progress: &dyn Progress,
    stop: &AtomicBool,
) -> Result<RigSummary> {
    let started = std::time::Instant::now();
    check_cameras(job, source)?;
    let RigItems {
        mut items,
        not_frames,
    } = source.items(&job.cameras)?;
    let style = crate::convert::run_options::load_style(job.run.style.as_ref())?;
    let folder = OutputFolder::claim(Claim {
        input: source.root(),
        output: &job.run.output,
        shard: job.run.shard,
        mode: job.run.mode,
        resumable: true,
        started,
    })?;
    if let Some(shard) = job.run.shard {
        items.retain(|i| shard.owns(SPLIT, &i.id));
    }
    let (masks, mask_records) = read_ego_masks(job, source)?;
    let parameters = parameters(
        job,
        source,
        &mask_records,
        style.as_ref().map(StyleModel::info),
    );
    let previous = folder.previous(&parameters)?;
    // the first frame the loop converts (the first not recorded by the run resumed; those
    // kept passed this check in that run), read once for the check and the loop
    let first = items
        .iter()
        .find(|i| !previous.contains(SPLIT, &i.id))
        .map(|item| (item, source.read(item)));
    if let Some((item, read)) = &first {
        check_output_camera(job, source, item, read)?;
    }
    folder.prepare()?;
    create_output_folders(job, &folder)?;
    let mut ctx = Ctx::new(job, source, masks, style.as_ref());
    ctx.first = Mutex::new(first.map(|(item, read)| (item.id.clone(), read)));
    let mut run = folder.start(
        source.command(),
        parameters,
        previous,
        items.len(),
        progress,
        stop,
    )?;
    let group = ctx.style_pass.as_ref().map_or(1, StylePass::group_len);
    run.run(&items, group, &ctx);
    let summary = run.finish(0, |_| Ok(()))?;
    let objects = *ctx.objects.lock().unwrap_or_else(|e| e.into_inner());
    Ok(RigSummary {
        run: summary,
        objects,
        style_runs: style.as_ref().map(StyleModel::runs),
        thin_views: job
            .run
            .augment
            .map(|_| ctx.thin_views.load(Ordering::Relaxed)),
        not_frames,
    })
}

/// The folders of `OUT/training/` the job writes into.
fn create_output_folders(job: &RigJob, folder: &OutputFolder) -> Result<()> {
    let kinds = OUTPUTS.into_iter().filter(|&kind| {
        !((kind == OutputKind::Depth && job.run.depth.is_none())
            || (kind == OutputKind::StitchDepth && !(job.stitch_depth && job.depth_guided()))
            || (kind == OutputKind::Mask(Cam::C2) && !job.mask))
    });
    folder.create_dirs(kinds.map(|kind| folder.root().join(SPLIT).join(kind.folder())))
}

impl<'a> Ctx<'a> {
    /// What the frames of a run share: the job's frame pass, its ego `masks`, the style pass
    /// of `style`; no frame read yet.
    fn new(
        job: &'a RigJob,
        source: &'a dyn RigSource,
        masks: Masks,
        style: Option<&'a StyleModel>,
    ) -> Self {
        let infos = (0..source.parts())
            .map(|p| source.cameras(p).iter().map(|c| c.info).collect())
            .collect();
        let batch = job.run.style.as_ref().map_or(1, |s| s.batch);
        Ctx {
            job,
            source,
            infos,
            hashes: OnceMap::default(),
            objects: Mutex::new(ObjectCounts::default()),
            options: RigOptions {
                cameras: job.cameras.clone(),
                stitch: job.stitch,
                stitch_mode: job.stitch_mode,
                stitch_depth: job.stitch_depth,
                listed: source.listed(),
                centre: job.centre,
                objects: job.objects,
                depth: job.depth(),
                ego_masks: masks,
                // the style pass styles the images between `prepare` and `finish`
                style: None,
            },
            style_pass: style.map(|m| StylePass::new(m, batch)),
            thin_views: AtomicUsize::new(0),
            first: Mutex::new(None),
            stitches: StitchCache::from_env(),
        }
    }
}

/// The dataset's own verdict on a box: its class, then its count of sensor returns.
fn source_verdict(source: &dyn RigSource, b: &SourceBox) -> Option<DropReason> {
    if !source.keeps(b) {
        Some(DropReason::Class)
    } else if source.drops_unseen(b) {
        Some(DropReason::Unseen)
    } else {
        None
    }
}
