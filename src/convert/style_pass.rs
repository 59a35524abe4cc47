//! Groups of frames through one conversion, whatever the dataset: prepared one by one, styled
//! together (equal-size images in one model run), finished one by one.
//!
//! A group is a fixed run of consecutive frames of the selection (`--style-batch` of them), so
//! what goes into a model run depends on the frame order and the options, never on thread
//! timing. A batch is used for an image size only if the model gives, at that size, the same
//! bytes batched as run singly (checked once per size on a fixed pattern): `--shard`,
//! `--resume` and the batch size then cannot change an output. `kitti/` and `rig/` both run
//! their frames through [`convert_group`].

use crate::error::{Error, Result};
use crate::image::RgbImage;
use crate::run::OnceMap;
use crate::style::{StyleError, StyleModel};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

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

    /// Styles one frame's `images` as [`StylePass::stylize`] does; where that fails, image by
    /// image (the same bytes: a batch is used only where it gives the single runs'), so that
    /// the error is that of the first image that fails, with its index.
    fn stylize_frame(
        &self,
        images: &[&RgbImage],
    ) -> std::result::Result<Vec<RgbImage>, (usize, StyleError)> {
        match self.stylize(images) {
            Ok(styled) => Ok(styled),
            Err(e) if images.len() < 2 => Err((0, e)),
            Err(_) => images
                .iter()
                .enumerate()
                .map(|(i, image)| {
                    self.stylize(&[*image])
                        .map(|mut one| one.swap_remove(0))
                        .map_err(|e| (i, e))
                })
                .collect(),
        }
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

/// A prepared frame as the style pass sees it: the images it styles, in order.
pub(super) trait StyleImages {
    /// The images the style pass takes, replaced by their styled versions (same order).
    fn style_images(&mut self) -> &mut Vec<RgbImage>;

    /// This frame's error for a failed style pass over its image at `_index` (in
    /// [`StyleImages::style_images`]' order).
    fn style_error(&self, _index: usize, e: StyleError) -> Error {
        e.into()
    }
}

/// Converts consecutive frames of one group: `prepare` each (read, decode), the style pass over
/// all their images, then `finish` each. Each result belongs to the frame at the same index; a
/// frame's failure (an error or a panic, reported on the path `name` gives) fails that frame
/// only.
pub(super) fn convert_group<K, P: StyleImages, O>(
    style: Option<&StylePass>,
    frames: &[K],
    name: impl Fn(&K) -> PathBuf,
    prepare: impl Fn(&K) -> Result<P>,
    finish: impl Fn(&K, P) -> Result<O>,
) -> Vec<Result<O>> {
    let mut prepared: Vec<Result<P>> = frames
        .iter()
        .map(|k| guarded(&name(k), || prepare(k)))
        .collect();
    if let Some(pass) = style {
        style_group(pass, frames, &name, &mut prepared);
    }
    prepared
        .into_iter()
        .zip(frames)
        .map(|(p, k)| p.and_then(|p| guarded(&name(k), || finish(k, p))))
        .collect()
}

fn style_group<K, P: StyleImages>(
    pass: &StylePass,
    frames: &[K],
    name: &impl Fn(&K) -> PathBuf,
    prepared: &mut [Result<P>],
) {
    if prepared.iter().flatten().count() > 1 {
        let taken: Vec<Vec<RgbImage>> = prepared
            .iter_mut()
            .flatten()
            .map(|p| std::mem::take(p.style_images()))
            .collect();
        let images: Vec<&RgbImage> = taken.iter().flatten().collect();
        if let Ok(Ok(styled)) = catch_unwind(AssertUnwindSafe(|| pass.stylize(&images))) {
            let mut styled = styled.into_iter();
            for (frame, own) in prepared.iter_mut().flatten().zip(&taken) {
                *frame.style_images() = styled.by_ref().take(own.len()).collect();
            }
            return;
        }
        // Frame by frame, so that the error names its frame.
        for (frame, own) in prepared.iter_mut().flatten().zip(taken) {
            *frame.style_images() = own;
        }
    }
    for (k, slot) in frames.iter().zip(prepared.iter_mut()) {
        let Ok(frame) = slot else { continue };
        let styled = guarded(&name(k), || {
            let images = std::mem::take(frame.style_images());
            let refs: Vec<&RgbImage> = images.iter().collect();
            pass.stylize_frame(&refs)
                .map_err(|(i, e)| frame.style_error(i, e))
        });
        match styled {
            Ok(images) => *frame.style_images() = images,
            Err(e) => *slot = Err(e),
        }
    }
}

/// Runs `f`, turning a panic (a bug) into this frame's error, on `path`.
fn guarded<T>(path: &Path, f: impl FnOnce() -> Result<T>) -> Result<T> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|panic| {
        let what = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Err(Error::file(
            path,
            format!("internal error (please report): {what}"),
        ))
    })
}
