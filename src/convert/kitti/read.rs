//! Reading a frame: its calib, labels, images and LiDAR scan, parsed and decoded, with the
//! hash of every file read (for the manifest).

use super::frame::{relative, Context};
use super::views::{Draw, OutputView};
use crate::camera::{CameraModel, ImageSize};
use crate::error::{Error, Result};
use crate::fs;
use crate::fs::{read_file, split_lines};
use crate::image::RgbImage;
use crate::kitti::calib::SourceCamera;
use crate::kitti::Cam;
use crate::kitti::{velodyne, Layout};
use crate::kitti::{Calib, LabelFile, Split};
use crate::reproject::depth::rect_from_velo;
use crate::reproject::labels::transform_label;
use crate::warp::PngSource;
use nalgebra::Vector3;
use std::path::Path;

impl Context<'_> {
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
        let size = {
            let (w, h) = image.size();
            ImageSize::new(w, h)
        };
        let objects = |camera: &dyn CameraModel| -> u32 {
            let source = cam2.camera(size);
            labels.as_ref().map_or(0, |l| {
                l.labels
                    .iter()
                    .filter(|label| !label.is_dont_care())
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
            .map(|out| out.view.map_or(0, |v| v.attempt))
            .collect();
        let mut sources = vec![image];

        // The right camera, converted about its own centre C3 (labels stay with camera 2).
        let right = if self.job.cameras.contains(&Cam::C3) {
            let cam3 = calib.camera(Cam::C3)?;
            let path = split.image_path(Cam::C3, id);
            let img = read_png(&path, |bytes| {
                inputs.push((relative(root, &path), fs::hash_hex(bytes)));
            })?;
            let size3 = {
                let (w, h) = img.size();
                ImageSize::new(w, h)
            };
            let views3 = self.views(split, id, &calib_path, cam3.k, size3, Draw::As(&attempts))?;
            sources.push(img);
            Some(RightCamera {
                camera: cam3,
                views: views3,
            })
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
            Some(LidarPoints {
                points: rect_from_velo(&scan.points, &r0, &tr),
                dropped_non_finite: scan.dropped_non_finite,
            })
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
            images: Vec::new(),
            sources,
        };
        if self.style.is_some() {
            frame.images = std::mem::take(&mut frame.sources)
                .into_iter()
                .map(PngSource::decode)
                .collect::<Result<_>>()?;
            if self.style_after_warp() {
                frame.images = frame.warp_all();
            }
        }
        Ok(frame)
    }
}

/// Reads an RGB PNG, handing its bytes to `seen` first (for the manifest's hash). Its pixels
/// are decoded by the warp, row by row as the warp reads them (or at once for the style pass).
fn read_png(path: &Path, seen: impl FnOnce(&[u8])) -> Result<PngSource> {
    let bytes = read_file(path)?;
    seen(&bytes);
    PngSource::new(bytes, path)
}

/// The right camera of a stereo frame (converted about its own centre C3; the labels stay
/// with camera 2).
pub(super) struct RightCamera {
    pub(super) camera: SourceCamera,
    /// Its views, one per camera 2 view, drawn alike.
    pub(super) views: Vec<OutputView>,
}

/// A frame's LiDAR points in rect.
pub(super) struct LidarPoints {
    pub(super) points: Vec<Vector3<f64>>,
    /// Points dropped for a NaN or infinite coordinate.
    pub(super) dropped_non_finite: usize,
}

/// A frame read and decoded, waiting for the style pass and the rest of its conversion.
pub(super) struct Prepared {
    pub(super) calib: Calib,
    pub(super) cam2: SourceCamera,
    pub(super) labels: Option<LabelFile>,
    /// (path relative to the input, blake3) of every file read.
    pub(super) inputs: Vec<(String, String)>,
    /// Camera 2's source size.
    pub(super) size: ImageSize,
    pub(super) views2: Vec<OutputView>,
    /// Camera 3, with `--cameras 2,3`.
    pub(super) right: Option<RightCamera>,
    pub(super) lidar: Option<LidarPoints>,
    /// What the style pass takes, in order: camera 2's source image then camera 3's; or, when
    /// styling after the warp, each view's warped camera 2 and camera 3 images. Empty without
    /// a style pass.
    pub(super) images: Vec<RgbImage>,
    /// Without a style pass: camera 2's source PNG then camera 3's, decoded by their first
    /// warp. Empty with a style pass (`images` holds them).
    pub(super) sources: Vec<PngSource>,
}

impl Prepared {
    /// Each view's warped camera 2 image, then its camera 3 image, from the source `images`.
    fn warp_all(&self) -> Vec<RgbImage> {
        let mut warped = Vec::with_capacity(self.images.len() * self.views2.len());
        for (i, out) in self.views2.iter().enumerate() {
            warped.push(out.mapping.table.apply(&self.images[0]));
            if let Some(right) = &self.right {
                warped.push(right.views[i].mapping.table.apply(&self.images[1]));
            }
        }
        warped
    }
}
