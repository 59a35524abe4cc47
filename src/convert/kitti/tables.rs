//! The remap tables of the source cameras, built before the first frame.
//!
//! Built lazily, a table is made inside the cache's once-cell, serially (a parallel build there
//! could let rayon run, on the same thread, a frame that waits on that very cell), while the
//! frames needing it wait. Built here, ahead of the frames, all the cores build it, even for
//! a one-frame run. The set of
//! cameras comes from each frame's calib and PNG header; a frame whose files cannot be read is
//! skipped here and fails in its turn with the full error.

use super::context::Context;
use crate::camera::{ImageSize, Intrinsics};
use crate::codec::png;
use crate::kitti::Cam;
use crate::kitti::Split;
use crate::run::Progress;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

/// At most this many frames, evenly spaced, are read for their cameras: the first frame waits
/// for the scan, which at 100 000 frames would read 200 000 files first. A camera that many
/// frames share is still seen twice; one the sample misses is built by its first frame (the
/// same table: `build_parallel` is exactly `build`).
const SCAN_AT_MOST: usize = 2048;

/// A camera only one scanned frame uses is built ahead when its image has at most this many
/// pixels (KITTI's have 0.47 M), or when the output size does not depend on it (a fisheye
/// target): the size comes from an unchecked PNG header (the decoder may refuse the file), and
/// a linear target's table grows with it.
const ALONE_AT_MOST_PIXELS: u64 = 4_000_000;

/// Builds, in parallel, the table of every (camera, image size) of `frames`.
pub(super) fn build_ahead(
    ctx: &Context,
    frames: &[(&Split, &str)],
    cameras: &[Cam],
    progress: &dyn Progress,
) {
    let found: Vec<(Intrinsics, ImageSize)> = frames
        .par_iter()
        .step_by(frames.len().div_ceil(SCAN_AT_MOST).max(1))
        .flat_map_iter(|&(split, id)| source_cameras(split, id, cameras))
        .collect();
    // Distinct, in a fixed order (the tables do not depend on it; the work split does).
    let mut distinct: BTreeMap<_, (Intrinsics, ImageSize, usize)> = BTreeMap::new();
    for (k, size) in found {
        distinct
            .entry((k.key(), size.width, size.height))
            .or_insert((k, size, 0))
            .2 += 1;
    }
    // A corrupt PNG header (an absurd size, read before the decoder has refused the file)
    // must not cost a huge table.
    let fixed_size = ctx.job.target.has_fixed_size();
    let todo: Vec<_> = distinct
        .into_values()
        .filter(|&(_, size, frames)| {
            let pixels = size.width as u64 * size.height as u64;
            frames > 1 || fixed_size || pixels <= ALONE_AT_MOST_PIXELS
        })
        .map(|(k, size, _)| (k, size))
        .collect::<Vec<_>>();
    match todo.len() {
        0 => return,
        1 => progress.note("building the camera table"),
        n => progress.note(&format!("building {n} camera tables")),
    }
    let built: Vec<_> = todo
        .into_par_iter()
        .filter_map(|(k, size)| {
            // A panic here (a bug) must not end the run: the frames then build the table
            // themselves, each failing alone.
            let build = || ctx.views.build_mapping(k, size, true);
            let mapping = std::panic::catch_unwind(std::panic::AssertUnwindSafe(build)).ok()?;
            Some((k, size, mapping))
        })
        .collect();
    for (k, size, mapping) in built {
        ctx.views.insert_mapping(k, size, mapping);
    }
    progress.note("");
}

/// The (K, image size) of each camera of a frame, as far as its files can be read.
pub(super) fn source_cameras(
    split: &Split,
    id: &str,
    cameras: &[Cam],
) -> Vec<(Intrinsics, ImageSize)> {
    let Ok((calib, _)) = split.read_calib(id) else {
        return Vec::new();
    };
    let mut found: Vec<(Intrinsics, ImageSize)> = cameras
        .iter()
        .filter_map(|&n| {
            let k = calib.camera(n).ok()?.k;
            let size = png_size(&split.image_path(n, id))?;
            Some((k, size))
        })
        .collect();
    // Counted once a frame (KITTI's cameras 2 and 3 share K and size).
    found.dedup_by_key(|(k, size)| (k.key(), size.width, size.height));
    found
}

/// Width and height from the PNG's header.
fn png_size(path: &Path) -> Option<ImageSize> {
    let mut head = [0u8; 33];
    std::fs::File::open(path).ok()?.read_exact(&mut head).ok()?;
    let header = png::read_header(&head)?;
    let size = ImageSize::new(header.width, header.height);
    // The header is untrusted: an image the decoder will refuse gets no table.
    let pixels = size.width as u64 * size.height as u64;
    (pixels <= png::MAX_PIXELS).then_some(size)
}
