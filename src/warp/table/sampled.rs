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

/// The blocks of a band of consecutive rows ([`SampledRows::band`]), made on any thread, pushed
/// in row order ([`SampledRows::push`]). A band, not a row, is the unit of work, its vectors
/// sized once: every thread allocates from one heap (`run::alloc`), so a row's vector grown by
/// reallocation kept the other threads waiting on the heap's lock.
#[derive(Debug, Default)]
pub(crate) struct RowBlocks {
    quads: Vec<Quad>,
    counts: Vec<u8>,
    cover: Vec<Cover>,
    gaps: Vec<(u32, u32)>,
    /// Per row, where it ends in the vectors above, and its reach.
    rows: Vec<RowEnd>,
    top_level: u32,
    /// The rounds the rows' groups take (each its pixels' most blocks).
    rounds: usize,
}

/// One row's end in its band's vectors.
#[derive(Debug, Clone, Copy)]
struct RowEnd {
    quads: usize,
    counts: usize,
    gaps: usize,
    reach: u32,
}

impl RowBlocks {
    /// The rounds the rows add to their table.
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

    /// The blocks of a band of consecutive rows, each its `samples` (one per output column)
    /// and the columns `span` outside which every sample is None (their groups are not looked
    /// at). The band's vectors are sized before they are filled: one allocation each. Needs
    /// no state but the source's shape: bands may be made in parallel.
    pub(crate) fn band<'s, I>(&self, rows: I) -> RowBlocks
    where
        I: Iterator<Item = (&'s [Option<Sample>], Range<usize>)> + Clone,
    {
        let (mut pixels, mut most_quads, mut gaps, mut count) = (0, 0, 0, 0);
        for (samples, span) in rows.clone() {
            for group in active_groups(samples, &span) {
                pixels += group.len();
                most_quads += group
                    .iter()
                    .map(|s| 1 + usize::from(s.is_some()))
                    .sum::<usize>();
                gaps += 1;
            }
            gaps += 1;
            count += 1;
        }
        let mut out = RowBlocks {
            quads: Vec::with_capacity(most_quads),
            counts: Vec::with_capacity(pixels),
            cover: Vec::with_capacity(pixels),
            gaps: Vec::with_capacity(gaps),
            rows: Vec::with_capacity(count),
            ..RowBlocks::default()
        };
        for (samples, span) in rows {
            self.row(samples, span, &mut out);
        }
        out
    }

    /// Appends to `out` the blocks of the next row of `samples` ([`SampledRows::band`]).
    fn row(&self, samples: &[Option<Sample>], span: Range<usize>, out: &mut RowBlocks) {
        let groups = samples.len().div_ceil(LANES);
        let mut gap: Option<u32> = None;
        let mut reach = 0;
        for (g, group) in samples.chunks(LANES).enumerate() {
            if !is_active(g, group, &span) {
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
                    Some(s) => reach = reach.max(self.blocks(s, out)),
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
        out.rows.push(RowEnd {
            quads: out.quads.len(),
            counts: out.counts.len(),
            gaps: out.gaps.len(),
            reach,
        });
    }

    /// Makes room for `rounds` more rounds (the rows' [`RowBlocks::rounds`] to come): the
    /// table grows once, not by doubling copies.
    pub(crate) fn reserve(&mut self, rounds: usize) {
        self.table.rounds.reserve_exact(rounds);
    }

    /// Appends the band's rows, the next rows of the table.
    pub(crate) fn push(&mut self, band: &RowBlocks) {
        self.table.levels = self.table.levels.max(band.top_level + 1);
        let (mut quads, mut counts, mut gaps) = (0, 0, 0);
        for end in &band.rows {
            self.table.push_row(
                (
                    &band.quads[quads..end.quads],
                    &band.counts[counts..end.counts],
                    &band.cover[counts..end.counts],
                ),
                &band.gaps[gaps..end.gaps],
                end.reach,
            );
            (quads, counts, gaps) = (end.quads, end.counts, end.gaps);
        }
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

    /// Appends the one or two quads of sample `s`; their farthest offset.
    fn blocks(&self, s: &Sample, out: &mut RowBlocks) -> u32 {
        let top = self.shapes.len() as u32 - 1;
        let lod = if s.lod.is_finite() {
            s.lod.max(0.0)
        } else {
            0.0
        };
        let k = (lod as u32).min(top);
        let f = if k == top { 0.0 } else { lod - k as f32 };
        // (non-negative: + 0.5 and the cast round half up as round() does, without libm's call)
        let fine = ((1.0 - f as f64) * WEIGHT_ONE as f64 + 0.5) as i32;
        let mut reach = 0;
        for (level, total) in [(k, fine), (k + 1, WEIGHT_ONE - fine)] {
            if total == 0 {
                continue;
            }
            let (offset, w) = self.block_at(s, level);
            let quad = quantize_block(offset, w, total, total as f64);
            reach = reach.max(quad.offset);
            out.top_level = out.top_level.max(level);
            out.quads.push(quad);
        }
        reach
    }

    /// The bilinear block of `s`'s position at `level`: its top-left pixel's index in the
    /// pyramid's buffer (the source's row stride) and the weights of top-left, bottom-left,
    /// top-right, bottom-right. A position beyond the level's outer pixel centres is clamped
    /// to them (a caller samples within the source).
    fn block_at(&self, s: &Sample, level: u32) -> (u32, [f64; 4]) {
        let (lw, lh, row) = self.shapes[level as usize];
        // (a power of two: the product is the quotient exactly)
        let per = 1.0 / (1u32 << level) as f64;
        let x = ((s.x as f64 + 0.5) * per - 0.5).clamp(0.0, lw as f64 - 1.0);
        let y = ((s.y as f64 + 0.5) * per - 0.5).clamp(0.0, lh as f64 - 1.0);
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

/// Whether group `g` of a row (its `group` of samples) holds blocks: it meets the row's `span`
/// and samples something.
fn is_active(g: usize, group: &[Option<Sample>], span: &Range<usize>) -> bool {
    let outside = g * LANES >= span.end || (g + 1) * LANES <= span.start;
    !outside && group.iter().any(Option::is_some)
}

/// The groups of a row that hold blocks ([`is_active`]).
fn active_groups<'s>(
    samples: &'s [Option<Sample>],
    span: &'s Range<usize>,
) -> impl Iterator<Item = &'s [Option<Sample>]> + 's {
    samples
        .chunks(LANES)
        .enumerate()
        .filter(|(g, group)| is_active(*g, group, span))
        .map(|(_, group)| group)
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
            let band = rows.band([(&samples[..], 0..samples.len())].into_iter());
            rows.push(&band);
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

    /// Rows of samples at levels 0-4, the columns outside 3..29 of row 2 and all of row 4
    /// None, every fifth sample None, a group of row 1 all None.
    fn band_rows() -> Vec<(Vec<Option<Sample>>, Range<usize>)> {
        (0..5)
            .map(|v| {
                let span = match v {
                    2 => 3..29,
                    4 => 0..0,
                    _ => 0..40,
                };
                let samples = (0..40)
                    .map(|u| {
                        let hole = u % 5 == 3 || (v == 1 && (16..24).contains(&u));
                        (span.contains(&u) && !hole).then_some(Sample {
                            x: 1.3 * u as f32 + 0.2 * v as f32,
                            y: 4.0 + 7.7 * v as f32,
                            lod: (u * 7 + v * 3) as f32 % 5.0 - 0.5,
                        })
                    })
                    .collect();
                (samples, span)
            })
            .collect()
    }

    #[test]
    fn a_band_of_rows_is_the_table_of_its_rows_one_by_one() {
        let (size, source_size) = (ImageSize::new(40, 5), ImageSize::new(64, 48));
        let rows = band_rows();
        let mut whole = SampledRows::new(size, source_size);
        let band = whole.band(rows.iter().map(|(s, span)| (&s[..], span.clone())));
        assert_eq!(band.rows.len(), 5);
        whole.push(&band);
        let mut single = SampledRows::new(size, source_size);
        for row in &rows {
            let band = single.band(std::iter::once((&row.0[..], row.1.clone())));
            single.push(&band);
        }
        let (whole, single) = (whole.finish(), single.finish());
        assert_eq!(whole, single);
        assert!(whole.levels() >= 4, "levels {}", whole.levels());
        let src = source();
        assert_eq!(whole.apply(&src).as_raw(), single.apply(&src).as_raw());
        // (row 4 samples nothing, row 2 nothing outside its span)
        assert!((0..40).all(|u| !whole.is_inside(u, 4)));
        assert!(!whole.is_inside(1, 2) && whole.is_inside(4, 2));
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
        let band = rows.band([(&samples[..], 0..samples.len())].into_iter());
        rows.push(&band);
        let table = rows.finish();
        assert!(table.levels() >= 4, "levels {}", table.levels());
        let out = table.apply(&flat);
        assert!(out.as_raw().iter().all(|&b| b == 173));
    }
}
