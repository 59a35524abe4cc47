//! The remap tables of every distinct source camera, built before the first frame.
//!
//! Built lazily, a table is made inside the cache's once-cell, serially (a parallel build there
//! could let rayon run, on the same thread, a frame that waits on that very cell), while the
//! frames needing it wait. Built here, ahead of the frames, all the cores build it. The set of
//! cameras comes from each frame's calib and PNG header; a frame whose files cannot be read is
//! skipped here and fails in its turn with the full error.

use super::frame::Context;
use crate::camera::{ImageSize, Intrinsics};
use crate::kitti::{Calib, Layout, Split};
use crate::warp::{RemapTable, MAX_SUPERSAMPLE};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

/// Builds, in parallel, the table of every distinct (camera, image size) of `frames`.
pub(super) fn build_ahead(ctx: &Context, frames: &[(&Split, &str)], cameras: &[usize]) {
    let found: Vec<(Intrinsics, ImageSize)> = frames
        .par_iter()
        .flat_map_iter(|&(split, id)| source_cameras(split, id, cameras))
        .collect();
    // Distinct, in a fixed order (the tables do not depend on it; the work split does).
    let distinct: BTreeMap<_, _> = found
        .into_iter()
        .map(|(k, size)| ((k.key(), size.width, size.height), (k, size)))
        .collect();
    let built: Vec<_> = distinct
        .into_values()
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|(k, size)| {
            (
                k,
                size,
                ctx.build_mapping(k, size, |dst, src, src_from_dst, wrap| {
                    RemapTable::build_parallel(dst, src, src_from_dst, wrap, MAX_SUPERSAMPLE)
                }),
            )
        })
        .collect();
    for (k, size, mapping) in built {
        ctx.insert_mapping(k, size, mapping);
    }
}

/// The (K, image size) of each camera of a frame, as far as its files can be read.
fn source_cameras(split: &Split, id: &str, cameras: &[usize]) -> Vec<(Intrinsics, ImageSize)> {
    let calib = match &split.layout {
        Layout::Object => {
            let path = split.calib_path(id);
            let Ok(bytes) = std::fs::read(&path) else {
                return Vec::new();
            };
            let Ok(lines) = crate::error::split_lines(&bytes, &path) else {
                return Vec::new();
            };
            match Calib::parse(&path, lines) {
                Ok(c) => c,
                Err(_) => return Vec::new(),
            }
        }
        Layout::Raw { calib } => (**calib).clone(),
    };
    cameras
        .iter()
        .filter_map(|&n| {
            let k = calib.camera(n).ok()?.k;
            let size = png_size(&split.image_path(n, id))?;
            Some((k, size))
        })
        .collect()
}

/// Width and height from a PNG's IHDR chunk (the first 24 bytes).
fn png_size(path: &Path) -> Option<ImageSize> {
    let mut head = [0u8; 24];
    std::fs::File::open(path).ok()?.read_exact(&mut head).ok()?;
    if head[..8] != *b"\x89PNG\r\n\x1a\n" || head[12..16] != *b"IHDR" {
        return None;
    }
    let be = |at: usize| u32::from_be_bytes(head[at..at + 4].try_into().expect("4 bytes"));
    let size = ImageSize::new(be(16), be(20));
    (size.width > 0 && size.height > 0).then_some(size)
}
