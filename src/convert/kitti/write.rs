//! Writing a frame: its views warped (row by row into the PNG encoder), labels and depth in
//! each output camera, the calib, all written atomically and hashed for the manifest; and the
//! files a failed frame must not leave behind.

use super::frame::{relative, Context, FrameOutput};
use super::read::{Prepared, RightCamera};
use super::views::OutputView;
use crate::camera::{ImageSize, OutputCamera};
use crate::codec::png::{self as png};
use crate::error::{Error, Result};
use crate::fs;
use crate::fs::read_file;
use crate::geometry::augment::view_id;
use crate::kitti::Cam;
use crate::kitti::Split;
use crate::kitti::{Layout, OutputKind};
use crate::reproject::depth::depth_map;
use crate::reproject::labels::transform_label;
use crate::run::manifest::{FrameRecord, FrameStatus, LidarRecord, ViewRecord};
use crate::warp::{warp_encode, RemapTable};
use nalgebra::Vector3;
use std::path::PathBuf;

impl Context<'_> {
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
            mut sources,
        } = frame;
        let cameras_per_view = if right.is_some() { 2 } else { 1 };
        let compression = self.job.png_compression;
        // The PNG of view i's camera 2 (cam 0) or 3 (cam 1): the styled warped image, or the
        // source warped row by row as the encoder takes the rows.
        let mut encode_view = |i: usize, cam: usize, table: &RemapTable| -> Result<Vec<u8>> {
            if after_warp {
                Ok(png::encode_rgb8(
                    &images[i * cameras_per_view + cam],
                    compression,
                ))
            } else if let Some(source) = sources.get_mut(cam) {
                source.warp_encode(table, compression)
            } else {
                Ok(warp_encode(table, &images[cam], compression))
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
        for (i, out_view) in views2.into_iter().enumerate() {
            let OutputView {
                id: view_id,
                mapping,
                view,
            } = out_view;
            if let Some(path) = out(OutputKind::Image(Cam::C2), &view_id) {
                outputs.push((path, encode_view(i, 0, &mapping.table)?));
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
            if let (Some(lidar), Some(depth)) = (&lidar, &self.job.depth) {
                let (points, non_finite) = (&lidar.points, &lidar.dropped_non_finite);
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
            if let Some(RightCamera {
                camera: cam3,
                views: views3,
            }) = &right
            {
                outputs.push((
                    out(OutputKind::Image(Cam::C3), &view_id).expect("every layout has image 3"),
                    encode_view(i, 1, &views3[i].mapping.table)?,
                ));
                if self.job.mask {
                    outputs.push((
                        out(OutputKind::Mask(Cam::C3), &view_id).expect("every layout has masks"),
                        encode_mask(&views3[i].mapping.table),
                    ));
                }
                cameras.push((Cam::C3, views3[i].mapping.output.clone(), cam3.centre));
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
}

/// The mask of a table's output: white where every tap of the pixel lies inside the source.
fn encode_mask(table: &RemapTable) -> Vec<u8> {
    let size = table.size();
    png::encode_mask(size.width, size.height, |u, v| table.is_inside(u, v))
}
