//! The remap table and its construction.
//!
//! Every output pixel is sampled at one or more points of the source (bilinear taps). When
//! the output is locally coarser than the source (more than 1.5 source pixels per output pixel
//! along an axis) the pixel is supersampled on an nu×nv grid over its footprint (n = round(scale)
//! per axis, at most 8): a box prefilter that removes the moiré a plain bilinear lookup gives.
//! Such a pixel's taps cost about what its bilinear lookup costs: they are interpolated from the
//! source positions of its own and its eight neighbours' centres, which the build maps anyway
//! (`build/local.rs`; each tap is mapped through the cameras only where the mapping bends too
//! sharply for that, near a pole or a lens's rim), and merged into a dense grid of the source
//! pixels under them instead of being sorted (`build/dense.rs`).
//! A table built by [`RemapTable::build_pyramid_within`] samples a pixel 1.5 or more source
//! pixels wide along both axes in the source's pyramid instead (`table/pyramid.rs`,
//! `build/level.rs`): one bilinear tap at the level where it spans 0.75 to 1.5 level pixels,
//! about a bilinear lookup's cost to build and to apply.
//! The taps of a pixel are merged at build time into 2×2 source blocks with integer weights
//! ([`Quad`]s, see `kernel.rs`), so applying the table is the same exact integer arithmetic on
//! every machine, thread count and code path. The finished table holds them in groups of
//! pixels ([`Round`]s), the layout the kernels stream.

use super::kernel::{self, Kernel, Quad, Round, LANES};
use crate::camera::{CameraModel, ImageSize};
use crate::image::RgbImage;
use nalgebra::Matrix3;
use rayon::prelude::*;

mod blocks;
mod build;
mod pyramid;
pub(crate) mod sampled;

pub(crate) use build::Surfaces;
pub use pyramid::{narrow_u8, pyramid};

/// Largest supersampling grid side (n of the nu×nv grid per output pixel).
pub const MAX_SUPERSAMPLE: u32 = 8;

/// Source pixels (along a pixel's shorter axis) under which the command's tables take a tap
/// per source pixel, and from which the source's pyramid ([`RemapTable::build_pyramid_above`]):
/// at 1.5 (the pyramid's own rule) KITTI-360's image_00 loses 0.77 dB against the exact
/// render (its pixels of 1.5 to 2 source pixels at level 1); from 2 on every zero-baseline
/// stitch figure is the taps' (tests/kitti360_stitch.rs, tests/nuscenes_stitch.rs), and a
/// KITTI target's too. A rig's stitch and a KITTI linear target use it.
pub const TAPS_BELOW: f64 = 2.0;

/// [`TAPS_BELOW`] of a fisheye target. A lens 2.5 source pixels a pixel lost 0.21 dB against
/// the exact render through the pyramid above 2 (0.36 dB away from the rim: the level's blur,
/// not the border), and gained 0.13 above 3; at 3.5 and 5 source pixels the pyramid gains 1.7
/// and 1.1 dB on the taps (`tests/fisheye_target/render.rs`).
pub const LENS_TAPS_BELOW: f64 = 3.0;

/// Whether a tap at source column `x` lies within a source `w` pixels wide that does not wrap
/// (its edges at -0.5 and w - 0.5; NaN does not).
#[inline(always)]
pub(crate) fn column_inside(x: f64, w: f64) -> bool {
    x >= -0.5 && x < w - 0.5
}

/// Whether a tap at source row `y` lies within a source `h` pixels tall (its edges at -0.5 and
/// h - 0.5, the bottom one included: a ray exactly at a panorama's south pole lands there).
#[inline(always)]
pub(crate) fn row_inside(y: f64, h: f64) -> bool {
    y >= -0.5 && y <= h - 0.5
}

/// How source columns beyond the left and right edges are treated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrap {
    /// Black beyond the edges (rectilinear and fisheye sources).
    None,
    /// The source is a full 360° panorama: columns wrap around.
    Horizontal,
}

/// How much of an output pixel's footprint the source covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
enum Cover {
    None,
    Part,
    Full,
}

/// Equality is of what the table samples (tests compare the serial and the parallel build, and
/// the builds of one table by different paths): a group stored without rounds (depth 0) equals
/// a group of one all-zero round.
#[derive(Debug)]
pub struct RemapTable {
    size: ImageSize,
    source_size: ImageSize,
    /// The blocks of every pixel, in groups of [`LANES`] pixels of a row, each group's
    /// [`Round`]s in turn (see `kernel.rs`); a pixel outside the source has one all-zero block.
    rounds: Vec<Round>,
    /// Rounds of each group, row by row (`width.div_ceil(LANES)` groups a row); 0 where the
    /// group takes nothing from the source and has no round (a camera's rows beyond its reach
    /// in a stitch: most of a wide output), so the table's size follows what it samples.
    depth: Vec<u8>,
    /// rounds[row_starts[v]..row_starts[v + 1]] belong to output row v.
    row_starts: Vec<u32>,
    /// Largest block offset of each row: bounds the row's source reads once.
    row_reach: Vec<u32>,
    /// Per pixel, for `is_inside` and `coverage` (never read by `apply`).
    cover: Vec<Cover>,
    /// Levels of the source's pyramid the blocks address (1: the source alone; see
    /// `pyramid.rs`).
    levels: u32,
}

impl RemapTable {
    /// Builds the table mapping `dst` pixels to `src` pixels, where `src_from_dst` rotates a
    /// bearing from the output camera's axes to the source camera's (both cameras share their
    /// optical centre, as a pure reprojection must).
    pub fn build(
        dst: &dyn CameraModel,
        src: &dyn CameraModel,
        src_from_dst: &Matrix3<f64>,
        wrap: Wrap,
    ) -> RemapTable {
        Self::build_with(dst, src, src_from_dst, wrap, MAX_SUPERSAMPLE)
    }

    /// As [`RemapTable::build`], with at most `max_supersample`² samples per output pixel
    /// (1 turns the antialiasing off). Single-threaded on purpose: tables are built inside the
    /// cache's once-cell, where a rayon build could let another frame's lookup of the same
    /// cell run on this thread. See [`RemapTable::build_parallel`].
    pub fn build_with(
        dst: &dyn CameraModel,
        src: &dyn CameraModel,
        src_from_dst: &Matrix3<f64>,
        wrap: Wrap,
        max_supersample: u32,
    ) -> RemapTable {
        Self::build_within(dst, src, src_from_dst, wrap, max_supersample, None, false)
    }

    /// Exactly [`RemapTable::build_with`], with bands of rows built in parallel on rayon's
    /// pool. Call it outside any once-cell that other rayon tasks may wait on.
    pub fn build_parallel(
        dst: &dyn CameraModel,
        src: &dyn CameraModel,
        src_from_dst: &Matrix3<f64>,
        wrap: Wrap,
        max_supersample: u32,
    ) -> RemapTable {
        Self::build_within(dst, src, src_from_dst, wrap, max_supersample, None, true)
    }

    /// Size of the output image the table fills, in pixels.
    pub fn size(&self) -> ImageSize {
        self.size
    }

    /// Size of the source image the table samples, in pixels.
    pub fn source_size(&self) -> ImageSize {
        self.source_size
    }

    /// Fraction of output pixels with at least one tap inside the source.
    pub fn coverage(&self) -> f64 {
        let covered = self.cover.iter().filter(|&&c| c != Cover::None).count();
        covered as f64 / self.cover.len() as f64
    }

    /// Whether output pixel (u, v) is wholly inside the source (every tap valid).
    pub fn is_inside(&self, u: u32, v: u32) -> bool {
        self.cover[v as usize * self.size.width as usize + u as usize] == Cover::Full
    }

    /// [`RemapTable::is_inside`] of every pixel, row by row.
    pub fn inside(&self) -> Vec<bool> {
        self.cover.iter().map(|&c| c == Cover::Full).collect()
    }

    /// Resamples `src` (which must have the table's source size).
    pub fn apply(&self, src: &RgbImage) -> RgbImage {
        let mut out = RgbImage::new(self.size.width, self.size.height);
        self.apply_into(src, &mut out);
        out
    }

    /// As [`RemapTable::apply`], writing into `out` (every byte is overwritten, so a buffer
    /// from an earlier frame can be reused); `out` is replaced by a new image if its size is
    /// not the table's.
    pub fn apply_into(&self, src: &RgbImage, out: &mut RgbImage) {
        self.apply_with(src, out, Kernel::Auto);
    }

    /// As [`RemapTable::apply_into`] with a given kernel: every kernel must give the same
    /// bytes (tests compare them).
    #[doc(hidden)]
    pub fn apply_with(&self, src: &RgbImage, out: &mut RgbImage, kernel: Kernel) {
        assert_eq!(
            (src.width(), src.height()),
            (self.source_size.width, self.source_size.height),
            "source image size differs from the table's"
        );
        if (out.width(), out.height()) != (self.size.width, self.size.height) {
            *out = RgbImage::new(self.size.width, self.size.height);
        }
        self.rows_into(src, out, kernel, true);
    }

    /// As [`RemapTable::apply_into`] (`out` must have the table's size), writing only the
    /// pixels of [`RemapTable::stored_spans`]: the others take nothing from the source, and
    /// keep what `out` held (a stitch reads a camera's image only where it weighs it, within
    /// them, and reuses the buffer frame after frame instead of clearing it).
    pub(crate) fn apply_stored_into(&self, src: &RgbImage, out: &mut RgbImage) {
        assert_eq!(
            (src.width(), src.height(), out.width(), out.height()),
            (
                self.source_size.width,
                self.source_size.height,
                self.size.width,
                self.size.height
            ),
            "image sizes differ from the table's"
        );
        self.rows_into(src, out, Kernel::Auto, false);
    }

    /// Every row of `out` (the table's size) resampled from `src`, the groups without rounds
    /// black where `blank`, else left as they are.
    fn rows_into(&self, src: &RgbImage, out: &mut RgbImage, kernel: Kernel, blank: bool) {
        let w = self.size.width as usize;
        if w == 0 {
            return;
        }
        let data = self.input(src.as_raw());
        out.as_raw_mut()
            .par_chunks_mut(w * 3)
            .enumerate()
            .with_min_len(8)
            .for_each(|(v, row)| self.row(&data, v, row, kernel, blank));
    }

    /// The pixels of output row `v` in runs of groups the table stores rounds for, in order:
    /// every other pixel of the row takes nothing from the source (it is black).
    pub(crate) fn stored_spans(&self, v: usize) -> StoredSpans<'_> {
        let w = self.size.width as usize;
        let groups = w.div_ceil(LANES);
        StoredSpans {
            depth: &self.depth[v * groups..(v + 1) * groups],
            next: 0,
            width: w,
        }
    }

    /// Levels of the source's pyramid the table samples: 1 where it samples the source alone
    /// (a table built without [`RemapTable::build_pyramid_within`], or one whose output is
    /// nowhere two or more source pixels a pixel).
    pub fn levels(&self) -> u32 {
        self.levels
    }

    /// Rows of the buffer the table reads, of the source's width: the source's height, or its
    /// pyramid's rows (see [`pyramid`]).
    pub fn input_rows(&self) -> u32 {
        pyramid::pyramid_rows(self.source_size, self.levels)
    }

    /// The buffer the table reads from the source's samples (3 bytes a pixel, rows top to
    /// bottom, the table's source size): the samples themselves, or their pyramid of
    /// [`RemapTable::levels`] levels.
    pub fn input<'a>(&self, src: &'a [u8]) -> std::borrow::Cow<'a, [u8]> {
        if self.levels <= 1 {
            return src.into();
        }
        pyramid::pyramid_u8(src, self.source_size, self.levels).into()
    }

    /// Resamples output row `v` into `row` (the table's width × 3 bytes), on the calling
    /// thread: for a consumer that takes an image row by row (the PNG encoder), so that the
    /// whole warped image never has to exist. A table of several [`RemapTable::levels`] builds
    /// the source's pyramid on each call: give it to [`RemapTable::apply_row_data`] instead.
    pub fn apply_row(&self, src: &RgbImage, v: usize, row: &mut [u8]) {
        assert_eq!(
            (src.width(), src.height()),
            (self.source_size.width, self.source_size.height),
            "source image size differs from the table's"
        );
        self.apply_row_data(&self.input(src.as_raw()), v, row);
    }

    /// As [`RemapTable::apply_row`], from [`RemapTable::input`]'s buffer (for a table of one
    /// level, the source's samples: 3 bytes a pixel, rows top to bottom, the table's source
    /// size) of which only the first [`RemapTable::source_rows`]`(v)` rows are read: for a
    /// source decoded row by row as the warp goes down.
    pub fn apply_row_data(&self, src: &[u8], v: usize, row: &mut [u8]) {
        let s = self.source_size;
        assert_eq!(
            src.len(),
            s.width as usize * self.input_rows() as usize * 3,
            "source image size differs from the table's"
        );
        assert_eq!(row.len(), self.size.width as usize * 3, "row length");
        assert!(v < self.size.height as usize, "row {v} beyond the table");
        self.row(src, v, row, Kernel::Auto, true);
    }

    /// How many rows of [`RemapTable::input`]'s buffer, from the top, output row `v` reads
    /// (every byte any kernel may load for it lies in them).
    pub fn source_rows(&self, v: usize) -> usize {
        let stride3 = self.source_size.width as usize * 3;
        if stride3 == 0 {
            return 0;
        }
        let end = self.row_reach[v] as usize * 3 + stride3 + kernel::SIMD_READ;
        end.div_ceil(stride3).min(self.input_rows() as usize)
    }

    /// Resamples output row `v` into `row`; the pixels of groups without rounds are black
    /// where `blank`, else left as they are.
    fn row(&self, src: &[u8], v: usize, row: &mut [u8], kernel: Kernel, blank: bool) {
        let groups = (self.size.width as usize).div_ceil(LANES);
        let rounds = &self.rounds[self.row_starts[v] as usize..self.row_starts[v + 1] as usize];
        let depth = &self.depth[v * groups..(v + 1) * groups];
        let stride = self.source_size.width as usize;
        let (mut g, mut r) = (0, 0);
        while g < groups {
            // a run of groups without rounds is black, then the run of groups with rounds up
            // to the next such group goes through the kernel
            let gaps = depth[g..].iter().take_while(|&&k| k == 0).count();
            let end = g + gaps;
            let runs = depth[end..].iter().take_while(|&&k| k != 0).count();
            let kept = &depth[end..end + runs];
            let n: usize = kept.iter().map(|&k| k as usize).sum();
            let len = row.len();
            let px = (end * LANES * 3).min(len)..((end + runs) * LANES * 3).min(len);
            if blank {
                row[(g * LANES * 3).min(len)..px.start].fill(0);
            }
            if runs > 0 {
                let out = &mut row[px];
                self.segment((&rounds[r..r + n], kept), (src, stride), v, out, kernel);
            }
            (g, r) = (end + runs, r + n);
        }
    }

    /// Resamples the pixels `row` of one run of groups with rounds (`rounds` the run's, its
    /// depths `kept`) of output row `v`. The groups at the run's ends that take nothing (one
    /// all-zero round each: most of a wide view's row beyond the source, in a table that
    /// stores them) are black without the kernel, which would give them zeros too.
    fn segment(
        &self,
        (rounds, kept): (&[Round], &[u8]),
        (src, stride): (&[u8], usize),
        v: usize,
        row: &mut [u8],
        kernel: Kernel,
    ) {
        let groups = kept.len();
        let blank = |(&k, round): (&u8, &Round)| k == 1 && is_zero(round);
        let lead = kept.iter().zip(rounds).take_while(|&g| blank(g)).count();
        if lead == groups {
            row.fill(0);
            return;
        }
        let trail = kept
            .iter()
            .rev()
            .zip(rounds.iter().rev())
            .take_while(|&g| blank(g))
            .count();
        let (first, last) = (lead * LANES * 3, (groups - trail) * LANES * 3);
        let last = last.min(row.len());
        row[..first].fill(0);
        row[last..].fill(0);
        kernel::apply_row(
            &rounds[lead..rounds.len() - trail],
            &kept[lead..groups - trail],
            src,
            stride,
            self.row_reach[v],
            &mut row[first..last],
            kernel,
        );
    }

    /// Appends one output row, from each of its stored pixels' blocks (`counts[u]` of `quads`
    /// for the row's u-th stored pixel; `reach` their largest offset) and covers, in groups of
    /// [`LANES`] pixels (see [`Round`]); the groups of `gaps` (first, end) are not stored
    /// (depth 0, no round, covered nowhere) and their pixels have no entry in `counts` or
    /// `cover`. The padding blocks repeat offsets of the row, so `reach` bounds them too.
    fn push_row(&mut self, (quads, counts, cover): RowParts, gaps: &[(u32, u32)], reach: u32) {
        let w = self.size.width as usize;
        let groups = w.div_ceil(LANES) as u32;
        let (mut rest, mut counts, mut cover) = (quads, counts, cover);
        let mut g = 0;
        for &(first, end) in gaps.iter().chain([&(groups, groups)]) {
            let stored = (first as usize * LANES).min(w) - (g as usize * LANES).min(w);
            let (row_counts, row_cover);
            (row_counts, counts) = counts.split_at(stored);
            (row_cover, cover) = cover.split_at(stored);
            for pixels in row_counts.chunks(LANES) {
                rest = self.push_group(rest, pixels);
            }
            self.cover.extend_from_slice(row_cover);
            let gap = (end as usize * LANES).min(w) - (first as usize * LANES).min(w);
            self.cover.resize(self.cover.len() + gap, Cover::None);
            self.depth
                .resize(self.depth.len() + (end - first) as usize, 0);
            g = end;
        }
        debug_assert!(
            rest.is_empty() && counts.is_empty(),
            "every block of the row placed"
        );
        self.row_reach.push(reach);
        self.row_starts.push(self.rounds.len() as u32);
    }

    /// Row `v`'s rounds, group by group (a group without rounds as one all-zero round).
    fn row_groups(&self, v: usize) -> impl Iterator<Item = &[Round]> + '_ {
        const BLANK: &[Round] = &[Round {
            offset: [0; LANES],
            w: [[0; 4]; LANES],
        }];
        let groups = (self.size.width as usize).div_ceil(LANES);
        let mut rounds = &self.rounds[self.row_starts[v] as usize..self.row_starts[v + 1] as usize];
        self.depth[v * groups..(v + 1) * groups]
            .iter()
            .map(move |&k| {
                let group;
                (group, rounds) = rounds.split_at(k as usize);
                if k == 0 {
                    BLANK
                } else {
                    group
                }
            })
    }

    /// Appends the rounds and depth of a group of pixels of a row (`pixels[i]` blocks for its
    /// pixel i, the first of `quads`); gives the quads after the group's.
    fn push_group<'q>(&mut self, quads: &'q [Quad], pixels: &[u8]) -> &'q [Quad] {
        let mut rest = quads;
        if pixels.iter().all(|&n| n == 1) {
            // one block a pixel (most groups): the one round the loop below makes of them
            let group;
            (group, rest) = rest.split_at(pixels.len());
            self.depth.push(1);
            self.rounds.push(Self::round(group));
            return rest;
        }
        let mut blocks = [&[][..]; LANES];
        for (b, &n) in blocks.iter_mut().zip(pixels) {
            (*b, rest) = rest.split_at(n as usize);
        }
        let k = pixels.iter().copied().max().expect("a pixel");
        self.depth.push(k);
        for i in 0..k as usize {
            let mut round = Round::default();
            for (lane, b) in blocks.iter().enumerate() {
                // a lane past the row's end repeats the group's first pixel, weightless
                let b = if lane < pixels.len() { b } else { &blocks[0] };
                let q = match b.get(i) {
                    Some(q) => *q,
                    None => Quad {
                        offset: b[0].offset,
                        w: [0; 4],
                    },
                };
                // (a source that large would not fit in memory, nor its offsets in u32)
                round.offset[lane] = q.offset.checked_mul(3).expect("source under 4 GB");
                round.w[lane] = q.w;
            }
            self.rounds.push(round);
        }
        rest
    }

    /// The round of a group of pixels with one block each; a lane past the row's end repeats
    /// the group's first block (as [`RemapTable::push_row`] pads a group).
    #[inline]
    fn round(group: &[Quad]) -> Round {
        let mut round = Round::default();
        for lane in 0..LANES {
            let q = group.get(lane).unwrap_or(&group[0]);
            round.offset[lane] = q.offset.checked_mul(3).expect("source under 4 GB");
            round.w[lane] = q.w;
        }
        round
    }
}

impl PartialEq for RemapTable {
    fn eq(&self, other: &Self) -> bool {
        let rows = self.row_reach.len();
        (self.size, self.source_size, self.levels) == (other.size, other.source_size, other.levels)
            && self.row_reach == other.row_reach
            && self.cover == other.cover
            && (0..rows).all(|v| self.row_groups(v).eq(other.row_groups(v)))
    }
}

/// The runs of a row's groups with rounds, as pixel ranges ([`RemapTable::stored_spans`]).
pub(crate) struct StoredSpans<'a> {
    depth: &'a [u8],
    next: usize,
    width: usize,
}

impl Iterator for StoredSpans<'_> {
    type Item = std::ops::Range<usize>;

    fn next(&mut self) -> Option<Self::Item> {
        let depth = self.depth;
        let start = self.next + depth[self.next..].iter().take_while(|&&k| k == 0).count();
        let end = start + depth[start..].iter().take_while(|&&k| k != 0).count();
        self.next = end;
        (end > start).then(|| start * LANES..(end * LANES).min(self.width))
    }
}

/// A row's stored pixels: their blocks, block counts and covers (see [`RemapTable::push_row`]).
type RowParts<'a> = (&'a [Quad], &'a [u8], &'a [Cover]);

/// Whether `round` is all zeros (`Round::default()`), by OR-folds that vectorise: `==` on the
/// 96-byte struct calls `memcmp`, once a group at a row's ends.
#[inline]
fn is_zero(round: &Round) -> bool {
    let offsets = round.offset.iter().fold(0, |a, &o| a | o);
    let weights = round.w.iter().flatten().fold(0, |a, &w| a | w);
    offsets == 0 && weights == 0
}

#[cfg(test)]
mod tests;
