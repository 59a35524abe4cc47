//! One frame's conversion, in two halves around the style pass: [`Context::prepare`] (read,
//! parse, decode) and [`Context::finish`] (warp, labels, depth, encode, write), so that the
//! style pass can take several frames' images at once.

use super::{KittiJob, StyleOrder};
use crate::camera::{CameraModel, ImageSize, Intrinsics, OutputCamera, Perspective};
use crate::codec::png::{self as png, PngCompression};
use crate::error::{Error, Result};
use crate::fs;
use crate::fs::{read_file, read_file_into, split_lines};
use crate::geometry::augment::{view_id, Augment, View, MAX_ATTEMPTS};
use crate::geometry::target_camera;
use crate::image::RgbImage;
use crate::kitti::calib::SourceCamera;
use crate::kitti::Cam;
use crate::kitti::{velodyne, Layout, OutputKind};
use crate::kitti::{Calib, Dataset, LabelFile, Split};
use crate::reproject::depth::{depth_map, rect_from_velo};
use crate::reproject::labels::transform_label;
use crate::run::manifest::{FrameRecord, FrameStatus, LidarRecord, ViewRecord};
use crate::run::OnceMap;
use crate::style::StyleModel;
use crate::warp::{RemapTable, Wrap};
use nalgebra::{Matrix3, Vector3};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// The output camera and remap table of one source camera.
#[derive(Clone)]
pub(super) struct CameraMapping {
    output: Arc<dyn OutputCamera>,
    table: Arc<RemapTable>,
}

type CameraMappingKey = ([u64; 4], ImageSize);

/// One output view of a camera: its id, mapping, and augmentation (None: the whole frame).
type OutputView = (String, CameraMapping, Option<View>);

pub(super) struct Context<'a> {
    job: &'a KittiJob,
    style: Option<&'a StyleModel>,
    dataset: &'a Dataset,
    mappings: OnceMap<CameraMappingKey, std::result::Result<CameraMapping, String>>,
    /// Per split: the file written once for the whole split (raw drives' `calib.txt`), as
    /// (path relative to the output, blake3). Every frame of the split lists it, so the
    /// manifest covers it whichever frames a shard or a resumed run converts.
    split_files: std::sync::Mutex<std::collections::HashMap<String, (String, String)>>,
    thin_views: AtomicUsize,
}

pub(super) struct FrameOutput {
    pub(super) record: FrameRecord,
}

fn relative(root: &Path, path: &Path) -> String {
    path.strip_prefix(root)
        .unwrap_or(path)
        .to_string_lossy()
        .replace('\\', "/")
}

impl<'a> Context<'a> {
    pub(super) fn new(
        job: &'a KittiJob,
        style: Option<&'a StyleModel>,
        dataset: &'a Dataset,
    ) -> Self {
        Context {
            job,
            style,
            dataset,
            mappings: OnceMap::default(),
            split_files: Default::default(),
            thin_views: AtomicUsize::new(0),
        }
    }

    /// Distinct (source camera → output camera) mappings built so far.
    pub(super) fn tables_built(&self) -> usize {
        self.mappings.len()
    }

    fn mapping(&self, calib_path: &Path, k: Intrinsics, size: ImageSize) -> Result<CameraMapping> {
        self.mappings
            .get_or_build(&(k.key(), size), || {
                self.build_mapping(k, size, RemapTable::build)
            })
            .map_err(|m| Error::file(calib_path, m))
    }

    /// The output camera and table of a source camera, the table made by `build` (serial
    /// inside the cache's once-cells, parallel ahead of the frames).
    pub(super) fn build_mapping(
        &self,
        k: Intrinsics,
        size: ImageSize,
        build: fn(&dyn CameraModel, &dyn CameraModel, &Matrix3<f64>, Wrap) -> RemapTable,
    ) -> std::result::Result<CameraMapping, String> {
        let source = Perspective::new(k, size);
        let output = target_camera(&self.job.output_spec, self.job.fisheye.as_ref(), k, &source)
            .map_err(|e| e.to_string())?;
        let table = build(output.as_ref(), &source, &Matrix3::identity(), Wrap::None);
        Ok(CameraMapping {
            output: Arc::from(output),
            table: Arc::new(table),
        })
    }

    /// Stores a mapping built ahead of the frames.
    pub(super) fn insert_mapping(
        &self,
        k: Intrinsics,
        size: ImageSize,
        mapping: std::result::Result<CameraMapping, String>,
    ) {
        self.mappings.insert((k.key(), size), mapping);
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
            OutputKind::Image(Cam::C2),
            OutputKind::Image(Cam::C3),
            OutputKind::Mask(Cam::C2),
            OutputKind::Mask(Cam::C3),
            OutputKind::Depth,
            OutputKind::Label,
            OutputKind::Calib,
        ];
        ids.iter()
            .flat_map(|v| kinds.iter().filter_map(|k| split.output_path(*k, v)))
            .map(|p| dir.join(p))
            .collect()
    }

    pub(super) fn remove_outputs(&self, split: &Split, id: &str) {
        for path in self.output_paths(split, id) {
            let _ = std::fs::remove_file(path);
        }
    }

    /// The calib of a layout that has one per split (raw drives), from its first frame's size.
    pub(super) fn write_split_calib(&self, split: &Split) -> Result<()> {
        let (Some(rel), Layout::Raw { calib }, Some(first)) = (
            split.split_calib_output(),
            &split.layout,
            split.frames.first(),
        ) else {
            return Ok(());
        };
        let setup =
            |e: Error| Error::Setup(format!("{}: cannot write the drive calib: {e}", split.name));
        let size_of = |cam: Cam| -> Result<ImageSize> {
            let path = split.image_path(cam, first);
            let (w, h) = png::read_size(&read_file(&path)?, &path)?;
            Ok(ImageSize::new(w, h))
        };
        let mut cameras = Vec::new();
        for &n in &self.job.cameras {
            let cam = calib.camera(n).map_err(setup)?;
            let mapping = self
                .mapping(&calib.path, cam.k, size_of(n).map_err(setup)?)
                .map_err(setup)?;
            cameras.push((n, mapping.output.clone(), cam.centre));
        }
        let cameras: Vec<(Cam, &dyn OutputCamera, Vector3<f64>)> = cameras
            .iter()
            .map(|(n, c, v)| (*n, c.as_ref(), *v))
            .collect();
        let text = calib.render_output(&cameras);
        let path = self.job.output.join(&split.name).join(rel);
        fs::write_atomic(&path, text.as_bytes())?;
        let entry = (
            relative(&self.job.output, &path),
            fs::hash_hex(text.as_bytes()),
        );
        self.split_files
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(split.name.clone(), entry);
        Ok(())
    }

    /// Reads, parses and decodes a frame: everything before the style pass. Styling after the
    /// warp, the views are warped here too, so `images` is always what the style pass takes.
    pub(super) fn prepare(&self, split: &Split, id: &str) -> Result<Prepared> {
        let root = &self.dataset.root;
        let mut inputs = Vec::new();

        let (calib, calib_path) = match &split.layout {
            Layout::Object => {
                let path = split.calib_path(id);
                let bytes = read_file(&path)?;
                inputs.push((relative(root, &path), fs::hash_hex(&bytes)));
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
        let cam2 = calib.camera(Cam::C2)?;

        let labels = if split.has_labels {
            let path = split.label_path(id);
            let bytes = read_file(&path)?;
            inputs.push((relative(root, &path), fs::hash_hex(&bytes)));
            Some(LabelFile::parse(&path, split_lines(&bytes, &path)?)?)
        } else {
            None
        };

        let image_path = split.image_path(Cam::C2, id);
        let image = read_png(&image_path, |bytes| {
            inputs.push((relative(root, &image_path), fs::hash_hex(bytes)));
        })?;
        let size = ImageSize::new(image.width(), image.height());
        let objects = |camera: &dyn CameraModel| -> u32 {
            let source = cam2.camera(size);
            labels.as_ref().map_or(0, |l| {
                l.labels
                    .iter()
                    .filter(|label| label.kind != "DontCare")
                    .filter(|label| transform_label(label, &cam2.centre, &source, camera).is_some())
                    .count() as u32
            })
        };
        // (views of an unlabelled split have no objects to count: their first draws stand)
        let draw = match &labels {
            Some(_) => Draw::Fewest(&objects),
            None => Draw::First,
        };
        let views2 = self.views(split, id, &calib_path, cam2.k, size, draw)?;
        let attempts: Vec<u32> = views2
            .iter()
            .map(|(_, _, v)| v.map_or(0, |v| v.attempt))
            .collect();
        let mut images = vec![image];

        // The right camera, converted about its own centre C3 (labels stay with camera 2).
        let right = if self.job.cameras.contains(&Cam::C3) {
            let cam3 = calib.camera(Cam::C3)?;
            let path = split.image_path(Cam::C3, id);
            let img = read_png(&path, |bytes| {
                inputs.push((relative(root, &path), fs::hash_hex(bytes)));
            })?;
            let size3 = ImageSize::new(img.width(), img.height());
            let views3 = self.views(split, id, &calib_path, cam3.k, size3, Draw::As(&attempts))?;
            images.push(img);
            Some((cam3, views3))
        } else {
            None
        };

        let lidar = if self.job.depth.is_some() {
            let path = split.velodyne_path(id);
            let bytes = read_file(&path)?;
            inputs.push((relative(root, &path), fs::hash_hex(&bytes)));
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

        let mut frame = Prepared {
            calib,
            cam2,
            labels,
            inputs,
            size,
            views2,
            right,
            lidar,
            images,
        };
        if self.style_after_warp() {
            frame.images = frame.warp_all();
        }
        Ok(frame)
    }

    /// Whether the style pass takes the warped views (else the source images).
    pub(super) fn style_after_warp(&self) -> bool {
        self.style.is_some()
            && self
                .job
                .style
                .as_ref()
                .is_some_and(|s| s.order == StyleOrder::AfterWarp)
    }

    /// Warps (unless `prepare` did), transforms labels and depth, encodes and writes a frame
    /// whose `images` have been through the style pass, if any.
    pub(super) fn finish(&self, split: &Split, id: &str, frame: Prepared) -> Result<FrameOutput> {
        let after_warp = self.style_after_warp();
        let Prepared {
            calib,
            cam2,
            labels,
            inputs,
            size,
            views2,
            right,
            lidar,
            images,
        } = frame;
        let cameras_per_view = if right.is_some() { 2 } else { 1 };
        let compression = self.job.png_compression;
        // The PNG of view i's camera 2 (cam 0) or 3 (cam 1): the styled warped image, or the
        // source warped row by row as the encoder takes the rows.
        let encode_view = |i: usize, cam: usize, table: &RemapTable| {
            if after_warp {
                png::encode_rgb8(&images[i * cameras_per_view + cam], compression)
            } else {
                warp_encode(table, &images[cam], compression)
            }
        };
        let mut outputs: Vec<(PathBuf, Vec<u8>)> = Vec::new();
        let out_split = self.job.output.join(&split.name);
        let out = |kind: OutputKind, view_id: &str| {
            split.output_path(kind, view_id).map(|p| out_split.join(p))
        };
        let mut views = Vec::new();
        let mut lidar_record = None;
        let source = cam2.camera(size);
        for (i, (view_id, mapping, view)) in views2.into_iter().enumerate() {
            if let Some(path) = out(OutputKind::Image(Cam::C2), &view_id) {
                outputs.push((path, encode_view(i, 0, &mapping.table)));
            }
            if self.job.mask {
                outputs.push((
                    out(OutputKind::Mask(Cam::C2), &view_id).expect("every layout has masks"),
                    encode_mask(&mapping.table),
                ));
            }
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
                    png::encode_gray16(
                        map.width,
                        map.height,
                        &map.to_u16(),
                        self.job.png_compression,
                    ),
                ));
            }
            let mut cameras = vec![(Cam::C2, mapping.output.clone(), cam2.centre)];
            if let Some((cam3, views3)) = &right {
                outputs.push((
                    out(OutputKind::Image(Cam::C3), &view_id).expect("every layout has image 3"),
                    encode_view(i, 1, &views3[i].1.table),
                ));
                if self.job.mask {
                    outputs.push((
                        out(OutputKind::Mask(Cam::C3), &view_id).expect("every layout has masks"),
                        encode_mask(&views3[i].1.table),
                    ));
                }
                cameras.push((Cam::C3, views3[i].1.output.clone(), cam3.centre));
            }
            let cameras: Vec<(Cam, &dyn OutputCamera, Vector3<f64>)> = cameras
                .iter()
                .map(|(n, c, v)| (*n, c.as_ref(), *v))
                .collect();
            let calib_text = calib.render_output(&cameras);
            if let Some(path) = out(OutputKind::Calib, &view_id) {
                outputs.push((path, calib_text.into_bytes()));
            }
            if view.is_some() {
                views.push(ViewRecord { id: view_id, view });
            }
        }

        let mut record_outputs = Vec::new();
        for (path, bytes) in &outputs {
            fs::write_atomic(path, bytes)?;
            record_outputs.push((relative(&self.job.output, path), fs::hash_hex(bytes)));
        }
        if let Some(file) = self
            .split_files
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(&split.name)
        {
            record_outputs.push(file.clone());
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

    /// The output views of a frame: the frame itself, or its augmented views, drawn as `draw`
    /// says. The last element of each augmented view tells how many objects it holds when
    /// they were counted.
    fn views(
        &self,
        split: &Split,
        id: &str,
        calib_path: &Path,
        k: Intrinsics,
        size: ImageSize,
        draw: Draw,
    ) -> Result<Vec<OutputView>> {
        let Some(aug) = &self.job.augment else {
            return Ok(vec![(
                id.to_owned(),
                self.mapping(calib_path, k, size)?,
                None,
            )]);
        };
        let source = Perspective::new(k, size);
        let canvas = target_camera(&self.job.output_spec, self.job.fisheye.as_ref(), k, &source)
            .map_err(|e| Error::file(calib_path, e.to_string()))?;
        let view_camera = |view: &View| -> Result<Box<dyn OutputCamera>> {
            let (kv, sv) = Augment::view_camera(view, canvas.intrinsics(), canvas.size());
            canvas
                .with_intrinsics(kv, sv)
                .map_err(|e| Error::file(calib_path, e))
        };
        (0..aug.count)
            .map(|i| {
                let view_id = view_id(id, aug.count, i).ok_or_else(|| {
                    Error::file(
                        &split.image_path(Cam::C2, id),
                        "--augment needs numeric frame ids (e.g. 000123)",
                    )
                })?;
                let (view, output) = match draw {
                    Draw::First => {
                        let view = aug.view(&split.name, id, i, 0, canvas.size());
                        (view, view_camera(&view)?)
                    }
                    Draw::As(attempts) => {
                        let view =
                            aug.view(&split.name, id, i, attempts[i as usize], canvas.size());
                        (view, view_camera(&view)?)
                    }
                    Draw::Fewest(objects) => {
                        // The first draw holding enough objects, else the one holding most.
                        let mut best: Option<(u32, View, Box<dyn OutputCamera>)> = None;
                        for attempt in 0..MAX_ATTEMPTS.max(1) {
                            let view = aug.view(&split.name, id, i, attempt, canvas.size());
                            let output = view_camera(&view)?;
                            let n = objects(output.as_ref());
                            if best.as_ref().is_none_or(|(m, _, _)| n > *m) {
                                best = Some((n, view, output));
                            }
                            if n >= aug.min_objects {
                                break;
                            }
                        }
                        let (n, view, output) = best.expect("at least one draw");
                        if n < aug.min_objects.max(1) {
                            self.thin_views.fetch_add(1, Ordering::Relaxed);
                        }
                        (view, output)
                    }
                };
                // Every view has its own camera, so its table is not shared.
                let table =
                    RemapTable::build(output.as_ref(), &source, &Matrix3::identity(), Wrap::None);
                let mapping = CameraMapping {
                    output: Arc::from(output),
                    table: Arc::new(table),
                };
                Ok((view_id, mapping, Some(view)))
            })
            .collect()
    }

    /// Augmented views of labelled frames holding fewer objects than asked (or none, when no
    /// minimum was asked).
    pub(super) fn thin_views(&self) -> usize {
        self.thin_views.load(Ordering::Relaxed)
    }
}

/// How a camera's augmented views are drawn.
#[derive(Clone, Copy)]
enum Draw<'a> {
    /// Redrawn until they hold enough objects, counted by the function (camera 2).
    Fewest(&'a dyn Fn(&dyn CameraModel) -> u32),
    /// With the draws camera 2's views took (camera 3 follows camera 2).
    As(&'a [u32]),
    /// The first draw of each view.
    First,
}

thread_local! {
    /// Each worker's buffer for the PNG files it reads: one allocation for the whole run, not
    /// fresh (page-faulting) memory for every image.
    static PNG_BYTES: std::cell::RefCell<Vec<u8>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Reads and decodes an RGB PNG, handing its bytes to `seen` first (for the manifest's hash).
fn read_png(path: &Path, seen: impl FnOnce(&[u8])) -> Result<RgbImage> {
    PNG_BYTES.with(|cell| {
        let mut own = Vec::new();
        // (a worker is never inside another read here, but a fresh buffer is correct anyway)
        let mut borrowed = cell.try_borrow_mut();
        let buf = borrowed.as_deref_mut().unwrap_or(&mut own);
        read_file_into(path, buf)?;
        seen(buf);
        png::decode_rgb8(buf, path)
    })
}

/// A frame read and decoded, waiting for the style pass and the rest of its conversion.
pub(super) struct Prepared {
    calib: Calib,
    cam2: SourceCamera,
    labels: Option<LabelFile>,
    /// (path relative to the input, blake3) of every file read.
    inputs: Vec<(String, String)>,
    /// Camera 2's source size.
    size: ImageSize,
    views2: Vec<OutputView>,
    right: Option<(SourceCamera, Vec<OutputView>)>,
    /// LiDAR points in rect, and how many non-finite ones were dropped.
    lidar: Option<(Vec<Vector3<f64>>, usize)>,
    /// What the style pass takes, in order: camera 2's source image then camera 3's; or, when
    /// styling after the warp, each view's warped camera 2 and camera 3 images.
    pub(super) images: Vec<RgbImage>,
}

/// The mask of a table's output: white where every tap of the pixel lies inside the source.
fn encode_mask(table: &RemapTable) -> Vec<u8> {
    let size = table.size();
    png::encode_mask(size.width, size.height, |u, v| table.is_inside(u, v))
}

/// Warps `src` row by row as the PNG encoder takes the rows, so that the warped image never
/// has to exist whole.
fn warp_encode(table: &RemapTable, src: &RgbImage, compression: PngCompression) -> Vec<u8> {
    let size = table.size();
    png::encode_rgb8_rows(size.width, size.height, compression, |v, row| {
        table.apply_row(src, v, row)
    })
}

impl Prepared {
    /// Each view's warped camera 2 image, then its camera 3 image, from the source `images`.
    fn warp_all(&self) -> Vec<RgbImage> {
        let mut warped = Vec::with_capacity(self.images.len() * self.views2.len());
        for (i, (_, mapping, _)) in self.views2.iter().enumerate() {
            warped.push(mapping.table.apply(&self.images[0]));
            if let Some((_, views3)) = &self.right {
                warped.push(views3[i].1.table.apply(&self.images[1]));
            }
        }
        warped
    }
}
