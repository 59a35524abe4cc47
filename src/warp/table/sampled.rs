//! A table from samples placed by the caller: each output pixel at most one trilinear sample
//! of the source's pyramid (a position in source pixels and a level of detail), for a caller
//! whose positions follow something the general build does not know (a grid-guided stitch's
//! per-frame distances). A level of detail of 0 or less is a bilinear tap of the source; l > 0
//! blends the bilinear taps of levels ⌊l⌋ and ⌊l⌋ + 1 by l's fraction (the coarsest level the
//! source has taking what lies beyond it).

use super::pyramid::level_shapes;
use super::{Cover, RemapTable};
use crate::camera::ImageSize;
use crate::warp::kernel::{Quad, LANES, WEIGHT_ONE};
use crate::warp::table::build::quantize_block;
use std::ops::Range;

/// The most levels a sampled table reads (level 0 the source): a pixel 16 or more source
/// pixels wide samples the last.
const MAX_LEVELS: u32 = 5;

/// One output pixel's sample: source position (level-0 pixels, centres at integers) and level
/// of detail (log2 of the source pixels an output pixel spans).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Sample {
    pub x: f32,
    pub y: f32,
    pub lod: f32,
}

/// A row's blocks, made on any thread, pushed in row order ([`SampledRows::push`]).
#[derive(Debug, Default)]
pub(crate) struct RowBlocks {
    quads: Vec<Quad>,
    counts: Vec<u8>,
    cover: Vec<Cover>,
    gaps: Vec<(u32, u32)>,
    reach: u32,
    top_level: u32,
    /// The rounds the row's groups take (each its pixels' most blocks).
    rounds: usize,
}

impl RowBlocks {
    /// The rounds the row adds to its table.
    pub(crate) fn rounds(&self) -> usize {
        self.rounds
    }
}

/// A table being built row by row from samples.
#[derive(Debug)]
pub(crate) struct SampledRows {
    table: RemapTable,
    shapes: Vec<(u32, u32, u32)>,
}

impl SampledRows {
    /// An empty table from a source of `source_size` into an output of `size`.
    pub(crate) fn new(size: ImageSize, source_size: ImageSize) -> Self {
        let (w, h) = (size.width as usize, size.height as usize);
        let mut table = RemapTable {
            size,
            source_size,
            rounds: Vec::new(),
            depth: Vec::with_capacity(w.div_ceil(LANES) * h),
            row_starts: Vec::with_capacity(h + 1),
            row_reach: Vec::with_capacity(h),
            cover: Vec::with_capacity(w * h),
            levels: 1,
        };
        table.row_starts.push(0);
        Self {
            table,
            shapes: level_shapes(source_size, MAX_LEVELS),
        }
    }

    /// The blocks of one row of `samples` (one per output column), every sample outside the
    /// columns `span` None (their groups are not looked at). Needs no state but the source's
    /// shape: rows may be made in parallel.
    pub(crate) fn row(&self, samples: &[Option<Sample>], span: Range<usize>) -> RowBlocks {
        let mut out = RowBlocks::default();
        let groups = samples.len().div_ceil(LANES);
        let mut gap: Option<u32> = None;
        for (g, group) in samples.chunks(LANES).enumerate() {
            let outside = g * LANES >= span.end || (g + 1) * LANES <= span.start;
            if outside || group.iter().all(Option::is_none) {
                gap.get_or_insert(g as u32);
                continue;
            }
            if let Some(first) = gap.take() {
                out.gaps.push((first, g as u32));
            }
            let mut depth = 0;
            for s in group {
                let before = out.quads.len();
                match s {
                    Some(s) => self.blocks(s, &mut out),
                    None => out.quads.push(Quad::default()),
                }
                let blocks = out.quads.len() - before;
                depth = depth.max(blocks);
                out.counts.push(blocks as u8);
                out.cover.push(match s {
                    Some(_) => Cover::Full,
                    None => Cover::None,
                });
            }
            out.rounds += depth;
        }
        if let Some(first) = gap {
            out.gaps.push((first, groups as u32));
        }
        out
    }

    /// Makes room for `rounds` more rounds (the rows' [`RowBlocks::rounds`] to come): the
    /// table grows once, not by doubling copies.
    pub(crate) fn reserve(&mut self, rounds: usize) {
        self.table.rounds.reserve_exact(rounds);
    }

    /// Appends the next row's blocks.
    pub(crate) fn push(&mut self, row: RowBlocks) {
        self.table.levels = self.table.levels.max(row.top_level + 1);
        self.table
            .push_row((&row.quads, &row.counts, &row.cover), &row.gaps, row.reach);
    }

    /// The table (every row pushed).
    pub(crate) fn finish(self) -> RemapTable {
        debug_assert_eq!(
            self.table.row_reach.len(),
            self.table.size.height as usize,
            "every row pushed"
        );
        self.table
    }

    /// Appends the one or two quads of sample `s`.
    fn blocks(&self, s: &Sample, out: &mut RowBlocks) {
        let top = self.shapes.len() as u32 - 1;
        let lod = if s.lod.is_finite() {
            s.lod.max(0.0)
        } else {
            0.0
        };
        let k = (lod as u32).min(top);
        let f = if k == top { 0.0 } else { lod - k as f32 };
        let fine = ((1.0 - f as f64) * WEIGHT_ONE as f64).round() as i32;
        for (level, total) in [(k, fine), (k + 1, WEIGHT_ONE - fine)] {
            if total == 0 {
                continue;
            }
            let (offset, w) = self.block_at(s, level);
            let quad = quantize_block(offset, w, total, total as f64);
            out.reach = out.reach.max(quad.offset);
            out.top_level = out.top_level.max(level);
            out.quads.push(quad);
        }
    }

    /// The bilinear block of `s`'s position at `level`: its top-left pixel's index in the
    /// pyramid's buffer (the source's row stride) and the weights of top-left, bottom-left,
    /// top-right, bottom-right. A position beyond the level's outer pixel centres is clamped
    /// to them (a caller samples within the source).
    fn block_at(&self, s: &Sample, level: u32) -> (u32, [f64; 4]) {
        let (lw, lh, row) = self.shapes[level as usize];
        let f = (1u32 << level) as f64;
        let x = ((s.x as f64 + 0.5) / f - 0.5).clamp(0.0, lw as f64 - 1.0);
        let y = ((s.y as f64 + 0.5) / f - 0.5).clamp(0.0, lh as f64 - 1.0);
        // (x, y >= 0: truncation is floor; a level is at least 2×2)
        let x0 = (x as u32).min(lw - 2);
        let y0 = (y as u32).min(lh - 2);
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let w = [
            (1.0 - fx) * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * (1.0 - fy),
            fx * fy,
        ];
        ((row + y0) * self.table.source_size.width + x0, w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::RgbImage;

    fn source() -> RgbImage {
        let mut img = RgbImage::new(64, 48);
        for (i, b) in img.as_raw_mut().iter_mut().enumerate() {
            *b = (i * 37 % 251) as u8;
        }
        img
    }

    #[test]
    fn a_sample_at_a_pixel_centre_of_level_zero_copies_it() {
        let size = ImageSize::new(10, 3);
        let mut rows = SampledRows::new(size, ImageSize::new(64, 48));
        for v in 0..3 {
            let samples: Vec<Option<Sample>> = (0..10)
                .map(|u| {
                    (u != 4).then_some(Sample {
                        x: (u * 5 + 1) as f32,
                        y: (v * 7 + 2) as f32,
                        lod: -1.0,
                    })
                })
                .collect();
            let row = rows.row(&samples, 0..samples.len());
            rows.push(row);
        }
        let table = rows.finish();
        let src = source();
        let out = table.apply(&src);
        for v in 0..3u32 {
            for u in 0..10u32 {
                let got = out.pixel(u, v);
                let want = if u == 4 {
                    [0, 0, 0]
                } else {
                    src.pixel(u * 5 + 1, v * 7 + 2)
                };
                assert_eq!(got, want, "pixel ({u}, {v})");
            }
        }
        assert!(!table.is_inside(4, 1) && table.is_inside(5, 1));
    }

    #[test]
    fn a_level_between_two_blends_them_and_a_flat_source_stays_flat() {
        let mut flat = RgbImage::new(64, 48);
        flat.as_raw_mut().fill(173);
        let size = ImageSize::new(16, 1);
        let mut rows = SampledRows::new(size, ImageSize::new(64, 48));
        let samples: Vec<Option<Sample>> = (0..16)
            .map(|u| {
                Some(Sample {
                    x: 3.3 * u as f32 + 0.7,
                    y: 20.4,
                    lod: u as f32 * 0.37,
                })
            })
            .collect();
        let row = rows.row(&samples, 0..samples.len());
        rows.push(row);
        let table = rows.finish();
        assert!(table.levels() >= 4, "levels {}", table.levels());
        let out = table.apply(&flat);
        assert!(out.as_raw().iter().all(|&b| b == 173));
    }
}
