//! Writing a frame: its views warped (row by row into the PNG encoder), labels and depth in
//! each output camera, the calib, all written atomically and hashed for the manifest; and the
//! files a failed frame must not leave behind.

use super::context::{relative, Context};
use super::labels::label_text;
use super::read::Prepared;
use super::views::OutputView;
use crate::camera::{ImageSize, OutputCamera};
use crate::codec::png::{self as png};
use crate::convert::view_depth::{view_depth, DepthDomain, ViewLidar};
use crate::convert::view_pass::{write_views, PassView, ViewFiles, ViewImage, ViewSink};
use crate::error::{Error, Result};
use crate::fs;
use crate::fs::read_file;
use crate::geometry::augment::view_id;
use crate::image::RgbImage;
use crate::kitti::Cam;
use crate::kitti::KittiFrame;
use crate::kitti::OutputKind;
use crate::kitti::Split;
use crate::run::manifest::FrameRecord;
use crate::warp::PngSource;
use nalgebra::Vector3;
use std::path::PathBuf;

/// What a finished frame gives the run: its manifest record.
pub(super) struct FrameOutput {
    pub(super) record: FrameRecord,
}

/// Every file `convert` may write for a frame.
fn output_paths(ctx: &Context, split: &Split, id: &str) -> Vec<PathBuf> {
    let dir = ctx.job.output.join(&split.name);
    let ids: Vec<String> = match &ctx.job.augment {
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

pub(super) fn remove_outputs(ctx: &Context, split: &Split, id: &str) {
    for path in output_paths(ctx, split, id) {
        let _ = std::fs::remove_file(path);
    }
}

/// The calib of a layout that has one per split (raw drives), from its first frame's size.
pub(super) fn write_split_calib(ctx: &Context, split: &Split) -> Result<()> {
    let (Some(rel), Some(calib), Some(first)) = (
        split.split_calib_output(),
        split.drive_calib(),
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
    for &n in &ctx.job.cameras {
        let cam = calib.camera(n).map_err(setup)?;
        let mapping = ctx
            .views
            .mapping(&calib.path, cam.k, size_of(n).map_err(setup)?)
            .map_err(setup)?;
        cameras.push((n, mapping.output.clone(), cam.centre));
    }
    let cameras: Vec<(Cam, &dyn OutputCamera, Vector3<f64>)> = cameras
        .iter()
        .map(|(n, c, v)| (*n, c.as_ref(), *v))
        .collect();
    let text = calib.render_output(&cameras);
    let path = ctx.job.output.join(&split.name).join(rel);
    fs::write_atomic(&path, text.as_bytes())?;
    let entry = (
        relative(&ctx.job.output, &path),
        fs::hash_hex(text.as_bytes()),
    );
    ctx.split_files
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(split.name.clone(), entry);
    Ok(())
}

/// A KITTI frame's files for each output view: every rig camera's image and mask, camera 2's
/// labels and depth, the calib of all.
struct KittiViewFiles<'a, 'c> {
    ctx: &'a Context<'c>,
    split: &'a Split,
    kitti: &'a KittiFrame,
    views: &'a [Vec<OutputView>],
    /// The style pass's images (see `Prepared::images`).
    images: &'a [RgbImage],
    /// The rig cameras' source PNGs without a style pass.
    sources: &'a mut [PngSource],
    /// The frame's LiDAR points.
    points: Vec<Vector3<f64>>,
}

impl KittiViewFiles<'_, '_> {
    fn out(&self, kind: OutputKind, view_id: &str) -> Option<PathBuf> {
        let out_split = self.ctx.job.output.join(&self.split.name);
        self.split
            .output_path(kind, view_id)
            .map(|p| out_split.join(p))
    }
}

impl ViewFiles for KittiViewFiles<'_, '_> {
    /// The view's index among each rig camera's views.
    type View = usize;

    fn view_files(&mut self, i: usize, sink: &mut ViewSink) -> Result<()> {
        let after_warp = self.ctx.style_after_warp();
        let cameras_per_view = self.views.len();
        let (kitti, views) = (self.kitti, self.views);
        let frame = &kitti.frame;
        let view_id = &views[0][i].id;
        // Labels and depth belong to camera 2, rig camera 0 (centre C2).
        let (centre, source) = (frame.rig[0].centre(), frame.rig[0].model.as_ref());
        let mut cameras = Vec::with_capacity(views.len());
        for (j, camera_views) in views.iter().enumerate() {
            let (cam, mapping) = (kitti.cams[j], &camera_views[i].mapping);
            if let Some(path) = self.out(OutputKind::Image(cam), view_id) {
                // the styled warped image, or the source warped row by row as the encoder
                // takes the rows
                let image = if after_warp {
                    ViewImage::Warped(&self.images[i * cameras_per_view + j])
                } else if let Some(source) = self.sources.get_mut(j) {
                    ViewImage::Streamed(&mapping.table, source)
                } else {
                    ViewImage::Mapped(mapping.image(), vec![&self.images[j]])
                };
                sink.image(path, image)?;
            }
            if self.ctx.job.mask {
                sink.mask(
                    self.out(OutputKind::Mask(cam), view_id)
                        .expect("every layout has masks"),
                    mapping.image(),
                );
            }
            cameras.push((cam, mapping.output.clone(), frame.rig[j].centre()));
            if j > 0 {
                continue;
            }
            let output = mapping.output.as_ref();
            if let Some(labels) = &kitti.labels {
                let text = label_text(labels, frame, &centre, output);
                if let Some(path) = self.out(OutputKind::Label, view_id) {
                    sink.file(path, text.into_bytes());
                }
            }
            if let Some(depth) = &self.ctx.job.depth {
                let lidar = ViewLidar {
                    points: &self.points,
                    non_finite: kitti.dropped_non_finite,
                    filter: depth.occlusion_filter.as_ref(),
                };
                sink.depth(
                    self.out(OutputKind::Depth, view_id)
                        .expect("every layout has depth maps"),
                    view_depth(&lidar, &centre, output, DepthDomain::Source(source)),
                );
            }
        }
        let cameras: Vec<(Cam, &dyn OutputCamera, Vector3<f64>)> = cameras
            .iter()
            .map(|(n, c, v)| (*n, c.as_ref(), *v))
            .collect();
        let calib_text = kitti.calib.render_output(&cameras);
        if let Some(path) = self.out(OutputKind::Calib, view_id) {
            sink.file(path, calib_text.into_bytes());
        }
        Ok(())
    }
}

/// Warps (unless `prepare` did), transforms labels and depth, encodes and writes a frame
/// whose `images` have been through the style pass, if any.
pub(super) fn finish(
    ctx: &Context,
    split: &Split,
    id: &str,
    frame: Prepared,
) -> Result<FrameOutput> {
    let Prepared {
        kitti,
        inputs,
        views,
        images,
        mut sources,
    } = frame;
    let points = kitti.frame.lidar.iter().map(|p| p.position).collect();
    let pass_views: Vec<PassView<usize>> = views
        .first()
        .map(|camera_views| {
            camera_views
                .iter()
                .enumerate()
                .map(|(i, v)| PassView {
                    id: v.id.clone(),
                    view: v.view,
                    files: i,
                })
                .collect()
        })
        .unwrap_or_default();
    let mut files = KittiViewFiles {
        ctx,
        split,
        kitti: &kitti,
        views: &views,
        images: &images,
        sources: &mut sources,
        points,
    };
    let mut written = write_views(
        &ctx.job.output,
        ctx.job.png_compression,
        pass_views,
        &mut files,
    )?;
    if let Some(file) = ctx
        .split_files
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .get(&split.name)
    {
        written.outputs.push(file.clone());
    }
    Ok(FrameOutput {
        record: written.record(split.name.clone(), id.to_owned(), inputs),
    })
}
