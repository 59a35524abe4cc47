//! The KITTI conversion: frames flow through read → (style) → warp → labels/calib → write, in
//! parallel over frames on one rayon pool (the only owner of threads).

use crate::augment::{view_id, Augment, View};
use crate::camera::{ImageSize, Intrinsics, LinearCamera, Perspective};
use crate::depth::{depth_map, rect_from_velo, OcclusionFilter};
use crate::error::{read_file, split_lines, Error, Result};
use crate::geometry::{output_camera, OutputSpec};
use crate::journal::{self, Journal, Shard};
use crate::kitti::png_io::{self, PngCompression};
use crate::kitti::{raw, velodyne, Layout, OutputKind};
use crate::kitti::{Calib, Dataset, FrameRef, LabelFile, Split};
use crate::labels::transform_label;
use crate::output::LidarRecord;
use crate::output::{self, FrameRecord, FrameStatus, ViewRecord};
use crate::style::{StyleInfo, StyleModel, StyleOptions};
use crate::warp::{OnceMap, RemapTable, Wrap};
use nalgebra::Matrix3;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Everything a `kitti` conversion needs; also recorded in the manifest.
#[derive(Debug, Clone, Serialize)]
pub struct KittiJob {
    pub input: PathBuf,
    #[serde(skip)]
    pub output: PathBuf,
    pub output_spec: OutputSpec,
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

/// Reports progress; the CLI passes an indicatif bar, tests a no-op.
pub trait Progress: Sync {
    fn start(&self, total: usize);
    fn frame_done(&self);
    /// A frame failed: report it (once) without disturbing the bar.
    fn frame_failed(&self, frame: &FrameRef, error: &Error);
    fn finish(&self);
}

/// A progress reporter that says nothing.
pub struct Silent;

impl Progress for Silent {
    fn start(&self, _: usize) {}
    fn frame_done(&self) {}
    fn frame_failed(&self, _: &FrameRef, _: &Error) {}
    fn finish(&self) {}
}

#[derive(Debug)]
pub struct Summary {
    pub frames: usize,
    pub converted: usize,
    pub failed: usize,
    /// Frames a previous run had completed (--resume).
    pub resumed: usize,
    /// Stopped by SIGINT/SIGTERM before every frame was taken.
    pub interrupted: bool,
    pub seconds: f64,
    /// Distinct (source camera → output camera) mappings built.
    pub tables_built: usize,
}

/// The output camera and remap table of one source camera.
#[derive(Clone)]
struct Mapping {
    output: Arc<dyn LinearCamera>,
    table: Arc<RemapTable>,
}

type MappingKey = ([u64; 4], ImageSize);

struct Context<'a> {
    job: &'a KittiJob,
    style: Option<&'a StyleModel>,
    dataset: &'a Dataset,
    mappings: OnceMap<MappingKey, std::result::Result<Mapping, String>>,
}

struct FrameOutput {
    record: FrameRecord,
}

fn relative(root: &Path, path: &Path) -> String {
    path.strip_prefix(root)
        .unwrap_or(path)
        .to_string_lossy()
        .replace('\\', "/")
}

impl Context<'_> {
    fn mapping(&self, calib_path: &Path, k: Intrinsics, size: ImageSize) -> Result<Mapping> {
        let source = Perspective::new(k, size);
        self.mappings
            .get_or_build(&(k.key(), size), || {
                let output =
                    output_camera(&self.job.output_spec, k, &source).map_err(|e| e.to_string())?;
                let table =
                    RemapTable::build(output.as_ref(), &source, &Matrix3::identity(), Wrap::None);
                Ok(Mapping {
                    output: Arc::from(output),
                    table: Arc::new(table),
                })
            })
            .map_err(|m| Error::file(calib_path, m))
    }

    /// Every file `convert` may write for a frame.
    fn output_paths(&self, split: &Split, id: &str) -> Vec<PathBuf> {
        let dir = self.job.output.join(&split.name);
        let ids: Vec<String> = match &self.job.augment {
            Some(a) => (0..a.count)
                .filter_map(|i| view_id(id, a.count, i))
                .collect(),
            None => vec![id.to_owned()],
        };
        let kinds = [
            OutputKind::Image(2),
            OutputKind::Image(3),
            OutputKind::Depth,
            OutputKind::Label,
            OutputKind::Calib,
        ];
        ids.iter()
            .flat_map(|v| kinds.iter().filter_map(|k| split.output_path(*k, v)))
            .map(|p| dir.join(p))
            .collect()
    }

    fn remove_outputs(&self, split: &Split, id: &str) {
        for path in self.output_paths(split, id) {
            let _ = std::fs::remove_file(path);
        }
    }

    /// The calib of a layout that has one per split (raw drives), from its first frame's size.
    fn write_split_calib(&self, split: &Split) -> Result<()> {
        let (Some(rel), Layout::Raw { calib }, Some(first)) = (
            split.split_calib_output(),
            &split.layout,
            split.frames.first(),
        ) else {
            return Ok(());
        };
        let setup =
            |e: Error| Error::Setup(format!("{}: cannot write the drive calib: {e}", split.name));
        let size_of = |cam: usize| -> Result<ImageSize> {
            let path = split.image_path(cam, first);
            let (w, h) = png_io::read_size(&read_file(&path)?, &path)?;
            Ok(ImageSize::new(w, h))
        };
        let mut cameras = Vec::new();
        for &n in &self.job.cameras {
            let cam = calib.camera(n).map_err(setup)?;
            let mapping = self
                .mapping(&calib.path, cam.k, size_of(n).map_err(setup)?)
                .map_err(setup)?;
            cameras.push((n, mapping.output.intrinsics(), cam.centre));
        }
        let text = calib.render_output(self.job.output_spec.projection.name(), &cameras);
        output::write_atomic(
            &self.job.output.join(&split.name).join(rel),
            text.as_bytes(),
        )
    }

    fn convert(&self, split: &Split, id: &str) -> Result<FrameOutput> {
        let root = &self.dataset.root;
        let mut inputs = Vec::new();
        let mut outputs: Vec<(PathBuf, Vec<u8>)> = Vec::new();

        let (calib, calib_path) = match &split.layout {
            Layout::Object => {
                let path = split.calib_path(id);
                let bytes = read_file(&path)?;
                inputs.push((relative(root, &path), output::hash_hex(&bytes)));
                (Calib::parse(&path, split_lines(&bytes, &path)?)?, path)
            }
            Layout::Raw { calib } => ((**calib).clone(), calib.path.clone()),
        };
        if calib.projection.is_some() {
            return Err(Error::file(
                &calib_path,
                "this calib was written by panoconv (it has a projection: line): convert the original dataset",
            ));
        }
        let cam2 = calib.camera(2)?;

        let labels = if split.has_labels {
            let path = split.label_path(id);
            let bytes = read_file(&path)?;
            inputs.push((relative(root, &path), output::hash_hex(&bytes)));
            Some(LabelFile::parse(&path, split_lines(&bytes, &path)?)?)
        } else {
            None
        };

        let image_path = split.image_path(2, id);
        let image_bytes = read_file(&image_path)?;
        inputs.push((relative(root, &image_path), output::hash_hex(&image_bytes)));
        let mut image = png_io::decode_rgb8(&image_bytes, &image_path)?;
        let after_warp = self.job.style.as_ref().is_some_and(|s| s.after_warp);
        if let (Some(model), false) = (self.style, after_warp) {
            image = model.stylize(&image)?;
        }
        let size = ImageSize::new(image.width(), image.height());

        // The right camera, converted about its own centre C3 (labels stay with camera 2).
        let right = if self.job.cameras.contains(&3) {
            let cam3 = calib.camera(3)?;
            let path = split.image_path(3, id);
            let bytes = read_file(&path)?;
            inputs.push((relative(root, &path), output::hash_hex(&bytes)));
            let mut img = png_io::decode_rgb8(&bytes, &path)?;
            if let (Some(model), false) = (self.style, after_warp) {
                img = model.stylize(&img)?;
            }
            let size3 = ImageSize::new(img.width(), img.height());
            let views3 = self.views(split, id, &calib_path, cam3.k, size3)?;
            Some((cam3, img, views3))
        } else {
            None
        };

        let lidar = if self.job.depth.is_some() {
            let path = split.velodyne_path(id);
            let bytes = read_file(&path)?;
            inputs.push((relative(root, &path), output::hash_hex(&bytes)));
            let scan = velodyne::parse(&bytes, &path)?;
            let r0 = calib
                .r0_rect
                .ok_or_else(|| Error::file(&calib_path, "no R0_rect line (needed for --depth)"))?;
            let tr = calib.tr_velo_to_cam.ok_or_else(|| {
                Error::file(&calib_path, "no Tr_velo_to_cam line (needed for --depth)")
            })?;
            Some((
                rect_from_velo(&scan.points, &r0, &tr),
                scan.dropped_non_finite,
            ))
        } else {
            None
        };

        let out_split = self.job.output.join(&split.name);
        let out = |kind: OutputKind, view_id: &str| {
            split.output_path(kind, view_id).map(|p| out_split.join(p))
        };
        let mut views = Vec::new();
        let mut lidar_record = None;
        let views2 = self.views(split, id, &calib_path, cam2.k, size)?;
        for (i, (view_id, mapping, view)) in views2.into_iter().enumerate() {
            let mut warped = mapping.table.apply(&image);
            if let (Some(model), true) = (self.style, after_warp) {
                warped = model.stylize(&warped)?;
            }
            if let Some(path) = out(OutputKind::Image(2), &view_id) {
                outputs.push((path, png_io::encode_rgb8(&warped, self.job.png_compression)));
            }
            let source = cam2.camera(size);
            if let Some(labels) = &labels {
                let mut text = String::new();
                for label in &labels.labels {
                    if let Some(line) =
                        transform_label(label, &cam2.centre, &source, mapping.output.as_ref())
                    {
                        text.push_str(&line);
                        text.push('\n');
                    }
                }
                if let Some(path) = out(OutputKind::Label, &view_id) {
                    outputs.push((path, text.into_bytes()));
                }
            }
            if let (Some((points, non_finite)), Some(depth)) = (&lidar, &self.job.depth) {
                let filter = depth.occlusion_filter.as_ref();
                // Projected straight into the final camera: crops and resizes never resample it.
                let (map, occluded) = depth_map(
                    points,
                    &cam2.centre,
                    mapping.output.as_ref(),
                    &source,
                    filter,
                );
                lidar_record = Some(LidarRecord {
                    points: points.len() + non_finite,
                    dropped_non_finite: *non_finite,
                    dropped_occluded: occluded,
                    depth_pixels: map.valid(),
                });
                outputs.push((
                    out(OutputKind::Depth, &view_id).expect("every layout has depth maps"),
                    png_io::encode_gray16(
                        map.width,
                        map.height,
                        &map.to_u16(),
                        self.job.png_compression,
                    ),
                ));
            }
            let mut cameras = vec![(2, mapping.output.intrinsics(), cam2.centre)];
            if let Some((cam3, img3, views3)) = &right {
                let mapping3 = &views3[i].1;
                let mut warped3 = mapping3.table.apply(img3);
                if let (Some(model), true) = (self.style, after_warp) {
                    warped3 = model.stylize(&warped3)?;
                }
                outputs.push((
                    out(OutputKind::Image(3), &view_id).expect("every layout has image 3"),
                    png_io::encode_rgb8(&warped3, self.job.png_compression),
                ));
                cameras.push((3, mapping3.output.intrinsics(), cam3.centre));
            }
            let projection = mapping.output.projection().name();
            let calib_text = calib.render_output(projection, &cameras);
            if let Some(path) = out(OutputKind::Calib, &view_id) {
                outputs.push((path, calib_text.into_bytes()));
            }
            if view.is_some() {
                views.push(ViewRecord { id: view_id, view });
            }
        }

        let mut record_outputs = Vec::new();
        for (path, bytes) in &outputs {
            output::write_atomic(path, bytes)?;
            record_outputs.push((relative(&self.job.output, path), output::hash_hex(bytes)));
        }
        Ok(FrameOutput {
            record: FrameRecord {
                split: split.name.clone(),
                id: id.to_owned(),
                status: FrameStatus::Ok,
                error: None,
                inputs,
                outputs: record_outputs,
                views,
                lidar: lidar_record,
            },
        })
    }

    /// The output views of a frame: the frame itself, or its augmented views.
    fn views(
        &self,
        split: &Split,
        id: &str,
        calib_path: &Path,
        k: Intrinsics,
        size: ImageSize,
    ) -> Result<Vec<(String, Mapping, Option<View>)>> {
        let Some(aug) = &self.job.augment else {
            return Ok(vec![(
                id.to_owned(),
                self.mapping(calib_path, k, size)?,
                None,
            )]);
        };
        let source = Perspective::new(k, size);
        let canvas = output_camera(&self.job.output_spec, k, &source)
            .map_err(|e| Error::file(calib_path, e.to_string()))?;
        (0..aug.count)
            .map(|i| {
                let view_id = view_id(id, aug.count, i).ok_or_else(|| {
                    Error::file(
                        &split.image_path(2, id),
                        "--augment needs numeric frame ids (e.g. 000123)",
                    )
                })?;
                let view = aug.view(&split.name, id, i, canvas.size());
                let (kv, sv) = Augment::view_camera(&view, canvas.intrinsics(), canvas.size());
                let output = self.job.output_spec.projection.camera(kv, sv);
                // Every view has its own camera, so its table is not shared.
                let table =
                    RemapTable::build(output.as_ref(), &source, &Matrix3::identity(), Wrap::None);
                let mapping = Mapping {
                    output: Arc::from(output),
                    table: Arc::new(table),
                };
                Ok((view_id, mapping, Some(view)))
            })
            .collect()
    }
}

/// Runs a conversion. Set-up problems return `Err` before anything is written; a broken frame
/// is reported through `progress`, recorded in the manifest and counted in the summary.
pub fn run_kitti(job: &KittiJob, progress: &dyn Progress, stop: &AtomicBool) -> Result<Summary> {
    let started = std::time::Instant::now();
    let dataset = if job.raw {
        raw::open(&job.input, job.split.as_deref())?
    } else {
        Dataset::open(&job.input, job.split.as_deref())?
    };
    // Resumed runs and shards write into a folder that already holds outputs.
    output::check_output_dir(
        &job.input,
        &job.output,
        job.overwrite || job.resume || job.shard.is_some(),
    )?;
    let (mut frames, mut missing) = dataset.select(job.frames.as_deref());
    if let Some(shard) = job.shard {
        frames.retain(|f| shard.owns(&f.split, &f.id));
        missing.retain(|id| shard.owns("", id));
    }
    // Loaded before anything is written: a missing library or a bad model is a set-up error.
    // One session per worker with one thread each, so --jobs alone sets the core count.
    let style = match &job.style {
        Some(s) => {
            let options = StyleOptions {
                intra_threads: 1,
                ..s.options.clone()
            };
            Some(StyleModel::load_pool(
                &options,
                rayon::current_num_threads(),
            )?)
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

    let ctx = Context {
        job,
        style: style.as_ref(),
        dataset: &dataset,
        mappings: OnceMap::default(),
    };
    for split in &dataset.splits {
        ctx.write_split_calib(split)?;
    }
    let command = if is_raw { "kitti-raw" } else { "kitti" };
    let journal = Journal::new(&job.output, job.shard, command, parameters, Vec::new());
    progress.start(frames.len() + missing.len());
    let (mut resumed, mut done) = (0usize, 0usize);
    let outcomes: Vec<Option<bool>> = frames
        .par_iter()
        .map(|f| {
            // SIGINT/SIGTERM: take no new frame; those in flight finish.
            if stop.load(Ordering::Relaxed) {
                return None;
            }
            let split = dataset
                .split(&f.split)
                .expect("selected frames come from the dataset's splits");
            if let Some(r) = previous.get(&(f.split.clone(), f.id.clone())) {
                if journal::still_valid(r, &job.input, &job.output) {
                    journal.record(r.clone());
                    progress.frame_done();
                    return Some(true);
                }
            }
            // A panic in one frame (a bug) fails that frame, not the whole run.
            let converted = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                ctx.convert(split, &f.id)
            }))
            .unwrap_or_else(|panic| {
                let what = panic
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                Err(Error::file(
                    &split.image_path(2, &f.id),
                    format!("internal error (please report): {what}"),
                ))
            });
            let record = match converted {
                Ok(out) => {
                    progress.frame_done();
                    out.record
                }
                Err(e) => {
                    progress.frame_failed(f, &e);
                    // A failed frame leaves no output behind, not even one from an earlier
                    // run into the same folder (--overwrite), which loaders would pick up.
                    ctx.remove_outputs(split, &f.id);
                    FrameRecord::failed(&f.split, &f.id, &e)
                }
            };
            journal.record(record);
            Some(false)
        })
        .collect();
    for o in outcomes.iter().flatten() {
        done += 1;
        resumed += usize::from(*o);
    }
    for id in missing {
        let f = FrameRef {
            split: String::new(),
            id: id.clone(),
        };
        let e = Error::Setup(format!(
            "frame {id} was asked for but is in no selected split"
        ));
        progress.frame_failed(&f, &e);
        journal.record(FrameRecord::failed(&f.split, &f.id, &e));
    }
    progress.finish();
    let interrupted = done < frames.len();
    let records = journal.finish(!interrupted)?;

    if job.augment.is_some() && job.shard.is_none() {
        // augmented ids are new: list them so KITTI loaders find the views
        write_image_sets(&job.output, &dataset, &records)?;
    }
    let failed = records
        .iter()
        .filter(|r| r.status == FrameStatus::Failed)
        .count();
    Ok(Summary {
        frames: records.len(),
        converted: records.len() - failed,
        failed,
        resumed,
        interrupted,
        seconds: started.elapsed().as_secs_f64(),
        tables_built: ctx.mappings.len(),
    })
}

/// `OUT/ImageSets/<split>.txt`: the view ids written per split.
fn write_image_sets(output: &Path, dataset: &Dataset, records: &[FrameRecord]) -> Result<()> {
    let dir = output.join("ImageSets");
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    for split in &dataset.splits {
        let mut ids: Vec<&str> = records
            .iter()
            .filter(|r| r.split == split.name && r.status == FrameStatus::Ok)
            .flat_map(|r| {
                if r.views.iter().any(|v| v.view.is_some()) {
                    r.views.iter().map(|v| v.id.as_str()).collect()
                } else {
                    vec![r.id.as_str()]
                }
            })
            .collect();
        ids.sort_unstable();
        let text: String = ids.iter().map(|id| format!("{id}\n")).collect();
        output::write_atomic(&dir.join(format!("{}.txt", split.name)), text.as_bytes())?;
    }
    Ok(())
}
