//! Reading a frame: the KITTI reader's neutral frame (calib, labels, images, scan, with the
//! hash of every file read), and each rig camera's output views.

use super::context::{relative, Context};
use super::labels::objects_in;
use super::views::{Draw, OutputView};
use crate::camera::CameraModel;
use crate::error::Result;
use crate::image::RgbImage;
use crate::kitti::{KittiFrame, Split, Wants};
use crate::warp::PngSource;

/// Reads, parses and decodes a frame: everything before the style pass. Styling after the
/// warp, the views are warped here too, so `images` is always what the style pass takes.
pub(super) fn prepare(ctx: &Context, split: &Split, id: &str) -> Result<Prepared> {
    let mut kitti = split.read_frame(
        id,
        Wants {
            cameras: &ctx.job.cameras,
            lidar: ctx.job.depth.is_some(),
        },
    )?;
    let root = &ctx.dataset.root;
    let inputs = kitti
        .frame
        .provenance
        .iter()
        .zip(&kitti.hashes)
        .map(|(path, hash)| (relative(root, path), hash.clone()))
        .collect();
    let sources = std::mem::take(&mut kitti.images);

    // Camera 2 (rig camera 0) draws its views, the others follow its draws.
    let frame = &kitti.frame;
    let centre = frame.rig[0].centre();
    let objects = |camera: &dyn CameraModel| -> u32 {
        kitti.labels.as_ref().map_or(0, |l| {
            objects_in(l, frame, &centre, camera, &ctx.job.visibility)
        })
    };
    let mut views: Vec<Vec<OutputView>> = Vec::with_capacity(frame.rig.len());
    let mut attempts: Vec<u32> = Vec::new();
    for (j, camera) in frame.rig.iter().enumerate() {
        let size = camera.model.size();
        let draw = match (j, &kitti.labels) {
            (0, Some(_)) => Draw::Fewest(&objects),
            // (views of an unlabelled split have no objects to count: their first draws stand)
            (0, None) => Draw::First,
            _ => Draw::As(&attempts),
        };
        let k = kitti.intrinsics[j];
        let camera_views = ctx.views.of(split, id, &kitti.calib.path, k, size, draw)?;
        if j == 0 {
            attempts = camera_views
                .iter()
                .map(|out| out.view.map_or(0, |v| v.attempt))
                .collect();
        }
        views.push(camera_views);
    }

    let mut frame = Prepared {
        kitti,
        inputs,
        views,
        images: Vec::new(),
        sources,
    };
    if ctx.style.is_some() {
        frame.images = std::mem::take(&mut frame.sources)
            .into_iter()
            .map(PngSource::decode)
            .collect::<Result<_>>()?;
        if ctx.style_after_warp() {
            frame.images = frame.warp_all();
        }
    }
    Ok(frame)
}

/// A frame read and decoded, waiting for the style pass and the rest of its conversion.
pub(super) struct Prepared {
    /// The frame (its `images` moved to `sources` or `images`).
    pub(super) kitti: KittiFrame,
    /// (path relative to the input, blake3) of every file read.
    pub(super) inputs: Vec<(String, String)>,
    /// Per rig camera (camera 2, then camera 3 with `--cameras 2,3`), its output views.
    pub(super) views: Vec<Vec<OutputView>>,
    /// What the style pass takes, in order: each rig camera's source image; or, when styling
    /// after the warp, each view's warped images, rig camera by rig camera. Empty without a
    /// style pass.
    pub(super) images: Vec<RgbImage>,
    /// Without a style pass: each rig camera's source PNG, decoded by its first warp. Empty
    /// with a style pass (`images` holds them).
    pub(super) sources: Vec<PngSource>,
}

impl crate::convert::style_pass::StyleImages for Prepared {
    fn style_images(&mut self) -> &mut Vec<RgbImage> {
        &mut self.images
    }
}

impl Prepared {
    /// Each view's warped images, rig camera by rig camera, from the source `images`.
    fn warp_all(&self) -> Vec<RgbImage> {
        let cameras = self.views.len();
        let count = self.views.first().map_or(0, Vec::len);
        let mut warped = Vec::with_capacity(cameras * count);
        for i in 0..count {
            for (j, views) in self.views.iter().enumerate() {
                warped.push(views[i].mapping.image().image(&[&self.images[j]]));
            }
        }
        warped
    }
}
