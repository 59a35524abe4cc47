//! Writing a frame: its views warped (row by row into the PNG encoder), labels and depth in
//! each output camera, the calib, all written atomically and hashed for the manifest; and the
//! files a failed frame must not leave behind.

use super::context::{relative, Context};
use super::labels::label_text;
use super::read::Prepared;
use crate::camera::{ImageSize, OutputCamera};
use crate::codec::png::{self as png};
use crate::convert::view_depth::{view_depth, DepthDomain, ViewLidar};
use crate::error::{Error, Result};
use crate::fs;
use crate::fs::read_file;
use crate::geometry::augment::view_id;
use crate::kitti::Cam;
use crate::kitti::OutputKind;
use crate::kitti::Split;
use crate::run::manifest::{FrameRecord, FrameStatus, ViewRecord};
use crate::warp::ImageMapping;
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

/// Warps (unless `prepare` did), transforms labels and depth, encodes and writes a frame
/// whose `images` have been through the style pass, if any.
pub(super) fn finish(
    ctx: &Context,
    split: &Split,
    id: &str,
    frame: Prepared,
) -> Result<FrameOutput> {
    let after_warp = ctx.style_after_warp();
    let Prepared {
        kitti,
        inputs,
        views,
        images,
        mut sources,
    } = frame;
    let cameras_per_view = views.len();
    let compression = ctx.job.png_compression;
    // The PNG of view i's rig camera j: the styled warped image, or the source warped row
    // by row as the encoder takes the rows.
    let mut encode_view = |i: usize, j: usize, mapping: ImageMapping| -> Result<Vec<u8>> {
        if after_warp {
            Ok(png::encode_rgb8(
                &images[i * cameras_per_view + j],
                compression,
            ))
        } else if let Some(source) = sources.get_mut(j) {
            mapping.encode_png_source(source, compression)
        } else {
            Ok(mapping.encode(&[&images[j]], compression))
        }
    };
    let mut outputs: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let out_split = ctx.job.output.join(&split.name);
    let out = |kind: OutputKind, view_id: &str| {
        split.output_path(kind, view_id).map(|p| out_split.join(p))
    };
    let mut view_records = Vec::new();
    let mut lidar_record = None;
    let frame = &kitti.frame;
    // Labels and depth belong to camera 2, rig camera 0 (centre C2).
    let (centre, source) = (frame.rig[0].centre(), frame.rig[0].model.as_ref());
    let points: Vec<Vector3<f64>> = frame.lidar.iter().map(|p| p.position).collect();
    let view_count = views.first().map_or(0, Vec::len);
    for i in 0..view_count {
        let view_id = &views[0][i].id;
        let mut cameras = Vec::with_capacity(views.len());
        for (j, camera_views) in views.iter().enumerate() {
            let (cam, mapping) = (kitti.cams[j], &camera_views[i].mapping);
            if let Some(path) = out(OutputKind::Image(cam), view_id) {
                outputs.push((path, encode_view(i, j, mapping.image())?));
            }
            if ctx.job.mask {
                outputs.push((
                    out(OutputKind::Mask(cam), view_id).expect("every layout has masks"),
                    mapping.image().encode_mask(),
                ));
            }
            cameras.push((cam, mapping.output.clone(), frame.rig[j].centre()));
            if j > 0 {
                continue;
            }
            let output = mapping.output.as_ref();
            if let Some(labels) = &kitti.labels {
                let text = label_text(labels, frame, &centre, output);
                if let Some(path) = out(OutputKind::Label, view_id) {
                    outputs.push((path, text.into_bytes()));
                }
            }
            if let Some(depth) = &ctx.job.depth {
                let lidar = ViewLidar {
                    points: &points,
                    non_finite: kitti.dropped_non_finite,
                    filter: depth.occlusion_filter.as_ref(),
                };
                let (map, record) =
                    view_depth(&lidar, &centre, output, DepthDomain::Source(source));
                lidar_record = Some(record);
                outputs.push((
                    out(OutputKind::Depth, view_id).expect("every layout has depth maps"),
                    png::encode_gray16(
                        map.width,
                        map.height,
                        &map.to_u16(),
                        ctx.job.png_compression,
                    ),
                ));
            }
        }
        let cameras: Vec<(Cam, &dyn OutputCamera, Vector3<f64>)> = cameras
            .iter()
            .map(|(n, c, v)| (*n, c.as_ref(), *v))
            .collect();
        let calib_text = kitti.calib.render_output(&cameras);
        if let Some(path) = out(OutputKind::Calib, view_id) {
            outputs.push((path, calib_text.into_bytes()));
        }
        if let Some(view) = views[0][i].view {
            view_records.push(ViewRecord {
                id: view_id.clone(),
                view: Some(view),
            });
        }
    }

    let mut record_outputs = Vec::new();
    for (path, bytes) in &outputs {
        fs::write_atomic(path, bytes)?;
        record_outputs.push((relative(&ctx.job.output, path), fs::hash_hex(bytes)));
    }
    if let Some(file) = ctx
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
            views: view_records,
            lidar: lidar_record,
        },
    })
}
