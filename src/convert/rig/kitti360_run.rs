//! Running `panoconv kitti360`: the sequences opened and the selection checked before anything
//! is written (`kitti360_setup.rs`), then the output folder's run (`run::OutputFolder`: claim,
//! previous records, journal, the frame loop, the manifest) over this command's
//! [`FrameWork`]: frames in groups through `convert::style_pass` (each read with its views
//! drawn, the group's camera images styled together, then each converted through the rig pass
//! and written, atomically and hashed for the manifest); a failed frame leaves no file.

use super::gray::encode_gray8;
use super::kitti360::{
    Kitti360Classes, Kitti360Job, Kitti360Summary, ObjectCounts, Parameters, SPLIT,
};
use super::kitti360_setup::{
    check_output_camera, load_style, open_sequences, read_ego_masks, select, Item,
};
use super::pass::{
    convert_into, count_objects, output_camera, read_images, CameraInfo, ClassFilter, RigOptions,
};
use crate::camera::OutputCamera;
use crate::convert::augment_draw::{draw_view, CountObjects};
use crate::convert::style_pass::{convert_group, StyleImages, StylePass};
use crate::convert::view_pass::{relative, write_views, PassView, ViewFiles, ViewImage, ViewSink};
use crate::error::{Error, Result};
use crate::fs;
use crate::geometry::augment::{view_id, Augment, View};
use crate::image::RgbImage;
use crate::kitti360::Sequence;
use crate::run::manifest::{FrameRecord, FrameStatus};
use crate::run::{Claim, FrameWork, OnceMap, OutputFolder, OutputMode, Progress};
use crate::style::{StyleError, StyleModel};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

/// The per-frame output folders under `OUT/training/`.
const FOLDERS: [&str; 7] = [
    "image_2",
    "calib",
    "label_2",
    "source_2",
    "objects",
    "depth_2",
    "stitch_depth_2",
];

/// One output of a frame: its id, how an augmented view was drawn (None: the whole frame) and
/// its camera.
type OutputView = (String, Option<View>, Box<dyn OutputCamera>);

/// A frame read, its views drawn, waiting for the style pass and the stitch.
struct Prepared {
    frame: crate::source::Frame,
    views: Vec<OutputView>,
    /// The chosen cameras' images, in `--cameras` order (styled in place by the style pass).
    images: Vec<RgbImage>,
    /// The chosen cameras' image files, in `images`' order: a failed style pass names the
    /// image that failed.
    image_paths: Vec<PathBuf>,
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
    job: &'a Kitti360Job,
    sequences: Vec<(Sequence, Vec<CameraInfo>)>,
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
}

impl Ctx<'_> {
    fn output_path(&self, folder: &str, id: &str, ext: &str) -> PathBuf {
        self.job
            .output
            .join(SPLIT)
            .join(folder)
            .join(format!("{id}.{ext}"))
    }

    /// Every file a frame may write.
    fn output_paths(&self, id: &str) -> Vec<PathBuf> {
        FOLDERS
            .iter()
            .map(|f| {
                let ext = if matches!(*f, "calib" | "label_2") {
                    "txt"
                } else if *f == "objects" {
                    "json"
                } else {
                    "png"
                };
                self.output_path(f, id, ext)
            })
            .collect()
    }

    fn input_hash(&self, path: &Path, per_frame: bool) -> Result<String> {
        if per_frame {
            return Ok(fs::hash_hex(&fs::read_file(path)?));
        }
        self.hashes
            .get_or_build(&path.to_path_buf(), || {
                fs::read_file(path)
                    .map(|b| fs::hash_hex(&b))
                    .map_err(|e| e.to_string())
            })
            .map_err(|m| Error::file(path, m))
    }

    /// The output ids of a frame: its own, or its augmented views'.
    fn output_ids(&self, item: &Item) -> Vec<String> {
        match &self.job.augment {
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
        item: &Item,
        frame: &crate::source::Frame,
        info: &[CameraInfo],
        options: &RigOptions,
        keep: ClassFilter,
    ) -> Result<Vec<OutputView>> {
        let job = self.job;
        let canvas = output_camera(frame, info, &job.target, job.cameras[0])?;
        let Some(aug) = &job.augment else {
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
            let count = |camera: &dyn OutputCamera| count_objects(frame, camera, options, keep);
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

    /// Reads a frame and its chosen cameras' images, and draws its output views: everything
    /// before the style pass.
    fn prepare(&self, item: &Item) -> Result<Prepared> {
        let (sequence, info) = &self.sequences[item.sequence];
        let frame = sequence.frame(item.frame)?;
        let options = &self.options;
        let views = self.output_views(item, &frame, info, options, &|b| self.keeps(b))?;
        let images = read_images(&frame, options)?;
        let image_paths = options
            .cameras
            .iter()
            .filter_map(|&k| frame.rig.get(k).map(|c| c.image.clone()))
            .collect();
        Ok(Prepared {
            frame,
            views,
            images,
            image_paths,
        })
    }

    /// Whether a box's class is written.
    fn keeps(&self, b: &crate::source::SourceBox) -> bool {
        self.job.classes.keeps(&b.class, &b.dataset_class)
    }

    /// The rest of a prepared frame's conversion: each output view stitched from its (styled)
    /// images, with its labels, depth and calib, written and recorded.
    fn finish(&self, item: &Item, prepared: Prepared) -> Result<FrameRecord> {
        let (sequence, info) = &self.sequences[item.sequence];
        let job = self.job;
        let Prepared {
            frame,
            views,
            images,
            ..
        } = prepared;
        let world_from_level = sequence.world_from_level(item.frame)?;
        let level_from_world = world_from_level.inverse().ok_or_else(|| {
            Error::file(
                &frame.provenance[0],
                format!("frame {}: singular pose", item.frame),
            )
        })?;
        let mut files = RigViewFiles {
            ctx: self,
            sequence,
            frame_number: item.frame,
            frame: &frame,
            info,
            images: &images,
            options: &self.options,
            level_from_velo: level_from_world.compose(&sequence.world_from_velo(item.frame)?),
            velo_from_imu: sequence.calibration.pose_from_velo().inverse(),
            counts: ObjectCounts::default(),
        };
        let views = views.into_iter().map(|(id, view, camera)| PassView {
            id: id.clone(),
            view,
            files: (id, camera),
        });
        let written = write_views(&job.output, job.png_compression, views, &mut files)?;
        let counts = files.counts;
        // the images of the cameras used, and every other input the frame read
        let unused: Vec<&PathBuf> = frame
            .rig
            .iter()
            .enumerate()
            .filter(|(k, _)| !job.cameras.contains(k))
            .map(|(_, c)| &c.image)
            .collect();
        let per_frame: Vec<&PathBuf> = frame.rig.iter().map(|c| &c.image).collect();
        let mut inputs = Vec::new();
        for path in frame.provenance.iter().filter(|p| !unused.contains(p)) {
            let own = per_frame.contains(&path) || path.extension().is_some_and(|e| e == "bin");
            inputs.push((relative(&job.input, path), self.input_hash(path, own)?));
        }
        self.objects
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .add(&counts);
        Ok(FrameRecord {
            split: SPLIT.to_owned(),
            id: item.id.clone(),
            status: FrameStatus::Ok,
            error: None,
            inputs,
            outputs: written.outputs,
            views: written.views,
            lidar: written.lidar,
        })
    }
}

/// A KITTI-360 frame's files for each output view: the stitch's image, calib, labels, source
/// map, objects record and depth.
struct RigViewFiles<'a> {
    ctx: &'a Ctx<'a>,
    sequence: &'a Sequence,
    frame_number: u32,
    frame: &'a crate::source::Frame,
    info: &'a [CameraInfo],
    /// The chosen cameras' (styled) images.
    images: &'a [RgbImage],
    options: &'a RigOptions,
    level_from_velo: crate::source::Pose,
    velo_from_imu: Option<crate::source::Pose>,
    /// The frame's object counts, over its views.
    counts: ObjectCounts,
}

impl ViewFiles for RigViewFiles<'_> {
    /// The view's output frame id and camera.
    type View = (String, Box<dyn OutputCamera>);

    fn view_files(&mut self, (id, camera): Self::View, sink: &mut ViewSink) -> Result<()> {
        let ctx = self.ctx;
        let keep = |b: &crate::source::SourceBox| ctx.keeps(b);
        let frame = self.frame;
        let out = convert_into(frame, self.info, camera, self.images, self.options, &keep)?;
        let calib = crate::kitti::rig_output::rig_calib_text(
            out.camera.as_ref(),
            &out.centre,
            &self.level_from_velo,
            self.velo_from_imu.as_ref(),
            frame.world_from_reference.as_ref(),
        );
        let mut labels = out.labels.join("\n");
        if !labels.is_empty() {
            labels.push('\n');
        }
        #[derive(serde::Serialize)]
        struct ObjectsFile<'a> {
            sequence: &'a str,
            frame: u32,
            stitch: super::scene_depth::StitchMode,
            gains: &'a [f64],
            counts: ObjectCounts,
            objects: &'a [super::objects::ObjectOutcome],
        }
        let view_counts = ObjectCounts::of(&out.objects);
        self.counts.add(&view_counts);
        let objects = serde_json::to_vec_pretty(&ObjectsFile {
            sequence: &self.sequence.name,
            frame: self.frame_number,
            stitch: out.stitch_mode,
            gains: &out.gains,
            counts: view_counts,
            objects: &out.objects,
        })
        .expect("the objects record serialises");
        let size = out.camera.size();
        sink.image(
            ctx.output_path("image_2", &id, "png"),
            ViewImage::Warped(&out.image),
        )?;
        sink.file(ctx.output_path("calib", &id, "txt"), calib.into_bytes());
        sink.file(ctx.output_path("label_2", &id, "txt"), labels.into_bytes());
        sink.file(
            ctx.output_path("source_2", &id, "png"),
            encode_gray8(size.width, size.height, &out.source),
        );
        sink.file(ctx.output_path("objects", &id, "json"), objects);
        if let Some(depth) = out.depth {
            sink.depth(ctx.output_path("depth_2", &id, "png"), depth);
        }
        if let Some(map) = out.distances {
            let png = crate::codec::png::encode_gray16(
                map.width,
                map.height,
                &map.to_u16(),
                ctx.job.png_compression,
            );
            sink.file(ctx.output_path("stitch_depth_2", &id, "png"), png);
        }
        Ok(())
    }
}

impl FrameWork for Ctx<'_> {
    type Item = Item;

    fn key<'k>(&self, item: &'k Item) -> (&'k str, &'k str) {
        (SPLIT, &item.id)
    }

    fn convert(&self, group: &[&Item]) -> Vec<Result<FrameRecord>> {
        let results = convert_group(
            self.style_pass.as_ref(),
            group,
            |item| {
                let sequence = &self.sequences[item.sequence].0;
                sequence.root.join("data_2d_raw").join(&sequence.name)
            },
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

/// Runs a conversion. Set-up problems return `Err` before anything is written; a broken frame
/// is reported through `progress`, recorded in the manifest and counted in the summary.
/// `stop` (SIGINT, SIGTERM) ends the taking of frames. Must run inside the caller's rayon pool.
pub fn run_kitti360(
    job: &Kitti360Job,
    progress: &dyn Progress,
    stop: &AtomicBool,
) -> Result<Kitti360Summary> {
    let started = std::time::Instant::now();
    let sequences = open_sequences(job)?;
    let mut items = select(job, &sequences)?;
    check_output_camera(job, &sequences, &items)?;
    let style = load_style(job)?;
    let folder = OutputFolder::claim(Claim {
        input: &job.input,
        output: &job.output,
        shard: job.shard,
        mode: OutputMode::from_flags(job.overwrite, job.resume),
        resumable: true,
        started,
    })?;
    if let Some(shard) = job.shard {
        items.retain(|i| shard.owns(SPLIT, &i.id));
    }
    let (masks, mask_records) = read_ego_masks(job, &sequences)?;
    let parameters = serde_json::to_value(Parameters::new(
        job,
        &mask_records,
        style.as_ref().map(StyleModel::info),
    ))
    .expect("parameters serialise");
    let previous = folder.previous(&parameters)?;
    folder.prepare()?;
    for name in FOLDERS {
        if (name == "depth_2" && job.depth.is_none())
            || (name == "stitch_depth_2" && !(job.stitch_depth && job.depth_guided()))
        {
            continue;
        }
        let dir = folder.root().join(SPLIT).join(name);
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    }
    let ctx = Ctx {
        job,
        sequences,
        hashes: OnceMap::default(),
        objects: Mutex::new(ObjectCounts::default()),
        options: RigOptions {
            cameras: job.cameras.clone(),
            stitch: job.stitch,
            stitch_mode: job.stitch_mode,
            stitch_depth: job.stitch_depth,
            // the other classes' boxes were read as scenery for the depth-guided stitch
            listed: (job.classes == Kitti360Classes::Kitti && job.depth_guided()).then_some(
                super::kitti360::has_kitti_type as fn(&crate::source::SourceBox) -> bool,
            ),
            centre: job.centre,
            objects: job.objects,
            depth: job.depth,
            ego_masks: masks,
            // the style pass styles the images between `prepare` and `finish`
            style: None,
        },
        style_pass: style.as_ref().map(|m| StylePass::new(m, job.style_batch)),
        thin_views: AtomicUsize::new(0),
    };
    let mut run = folder.start(
        "kitti360",
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
    Ok(Kitti360Summary {
        run: summary,
        objects,
        style_runs: style.as_ref().map(StyleModel::runs),
        thin_views: job.augment.map(|_| ctx.thin_views.load(Ordering::Relaxed)),
    })
}
