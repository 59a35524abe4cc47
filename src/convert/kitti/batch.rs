//! Groups of frames through one conversion: prepared one by one, styled together (equal-size
//! images in one model run), finished one by one.
//!
//! A group is a fixed run of consecutive frames of the selection (`--style-batch` of them), so
//! what goes into a model run depends on the frame order and the options, never on thread
//! timing. A batch is used for an image size only if the model gives, at that size, the same
//! bytes batched as run singly (checked once per size on a fixed pattern): `--shard`,
//! `--resume` and the batch size then cannot change an output.

use super::context::Context;
use super::read::{prepare, Prepared};
use super::write::{finish, FrameOutput};
use crate::error::{Error, Result};
use crate::image::RgbImage;
use crate::kitti::Cam;
use crate::kitti::Split;
use crate::run::OnceMap;
use crate::style::{StyleError, StyleModel};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// The style pass of a run.
pub(super) struct StylePass<'a> {
    model: &'a StyleModel,
    /// Images of one size per model run, at most.
    batch: usize,
    /// Per (width, height): whether a batch gives the bytes single runs give.
    exact: OnceMap<(u32, u32), bool>,
}

impl<'a> StylePass<'a> {
    pub(super) fn new(model: &'a StyleModel, batch: usize) -> Self {
        StylePass {
            model,
            batch: batch.clamp(1, crate::style::MAX_BATCH),
            exact: OnceMap::default(),
        }
    }

    /// How many consecutive frames form a group.
    pub(super) fn group_len(&self) -> usize {
        if self.model.batches() {
            self.batch
        } else {
            1
        }
    }

    /// Styles `images`, equal sizes batched where that is exact; results in input order.
    fn stylize(&self, images: &[&RgbImage]) -> std::result::Result<Vec<RgbImage>, StyleError> {
        self.model.stylize_batch_by(images, |width, height| {
            if self.batch > 1 && self.is_exact((width, height)) {
                self.batch
            } else {
                1
            }
        })
    }

    fn is_exact(&self, (width, height): (u32, u32)) -> bool {
        self.exact.get_or_build(&(width, height), || {
            // A failed probe (e.g. no memory for a batch) means single runs.
            self.model
                .batch_matches_single(width, height, self.batch)
                .unwrap_or(false)
        })
    }
}

/// Converts consecutive frames of one split group: each result belongs to the frame at the
/// same index. A frame's failure (an error or a panic) fails that frame only.
pub(super) fn convert_group(
    ctx: &Context,
    style: Option<&StylePass>,
    frames: &[(&Split, &str)],
) -> Vec<Result<FrameOutput>> {
    let mut prepared: Vec<Result<Prepared>> = frames
        .iter()
        .map(|&(split, id)| guarded(split, id, || prepare(ctx, split, id)))
        .collect();
    if let Some(pass) = style {
        style_group(pass, frames, &mut prepared);
    }
    prepared
        .into_iter()
        .zip(frames)
        .map(|(p, &(split, id))| p.and_then(|p| guarded(split, id, || finish(ctx, split, id, p))))
        .collect()
}

fn style_group(pass: &StylePass, frames: &[(&Split, &str)], prepared: &mut [Result<Prepared>]) {
    if prepared.iter().flatten().count() > 1 {
        let images: Vec<&RgbImage> = prepared.iter().flatten().flat_map(|p| &p.images).collect();
        if let Ok(Ok(styled)) = catch_unwind(AssertUnwindSafe(|| pass.stylize(&images))) {
            let mut styled = styled.into_iter();
            for frame in prepared.iter_mut().flatten() {
                for img in &mut frame.images {
                    *img = styled.next().expect("one styled image per image");
                }
            }
            return;
        }
        // Frame by frame, so that the error names its frame.
    }
    for (&(split, id), slot) in frames.iter().zip(prepared.iter_mut()) {
        let Ok(frame) = slot else { continue };
        let styled = guarded(split, id, || {
            let images = std::mem::take(&mut frame.images);
            let refs: Vec<&RgbImage> = images.iter().collect();
            Ok(pass.stylize(&refs)?)
        });
        match styled {
            Ok(images) => frame.images = images,
            Err(e) => *slot = Err(e),
        }
    }
}

/// Runs `f`, turning a panic (a bug) into this frame's error.
fn guarded<T>(split: &Split, id: &str, f: impl FnOnce() -> Result<T>) -> Result<T> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|panic| {
        let what = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Err(Error::file(
            &split.image_path(Cam::C2, id),
            format!("internal error (please report): {what}"),
        ))
    })
}
