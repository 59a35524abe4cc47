//! The serial build of a table whose pixels take one tap each (no supersampling) from a
//! source where a tap is one block: each row's rounds written straight from the source
//! positions of its pixel centres. The same table as the general build (bands of per-pixel
//! quads, then [`RemapTable::push_row`]), without its per-pixel bookkeeping: a camera drawn per
//! training sample (the Python package's `Warp` at supersample 1) builds its table this way.

use super::{quantize_block, Builder, Parts};
use crate::warp::kernel::{Quad, Round, LANES, WEIGHT_ONE};
use crate::warp::table::{Cover, RemapTable};
use nalgebra::Point2;

impl Builder<'_> {
    /// Whether [`Builder::plain_table`] builds this table: one tap a pixel, one block a tap.
    pub(super) fn plain(&self) -> bool {
        self.cap == 1 && self.one_block
    }

    /// An empty table of one block a pixel (so one round a group of [`LANES`]), its rows to be
    /// pushed.
    pub(super) fn one_round_a_group(&self) -> RemapTable {
        let size = self.dst.size();
        let (w, h) = (size.width as usize, size.height as usize);
        let groups = w.div_ceil(LANES);
        let mut t = RemapTable {
            size,
            source_size: self.source_size,
            rounds: Vec::with_capacity(groups * h),
            depth: vec![1; groups * h],
            row_starts: Vec::with_capacity(h + 1),
            row_reach: Vec::with_capacity(h),
            cover: vec![Cover::None; w * h],
            levels: 1,
        };
        t.row_starts.push(0);
        t
    }

    /// The table, row by row, on the calling thread (see the module's notes).
    pub(super) fn plain_table(&self) -> RemapTable {
        // (block offsets times 3 fit a u32 there: the lanes' rounds do not check them)
        let small =
            self.source_size.width as u64 * self.source_size.height as u64 * 3 <= u32::MAX as u64;
        if let (Some(sep), Some(k), true) = (self.by_parts, &self.pinhole, small) {
            return self.lanes_table(sep, k);
        }
        let size = self.dst.size();
        let (w, h) = (size.width as usize, size.height as usize);
        let groups = w.div_ceil(LANES);
        let mut t = self.one_round_a_group();
        let mut parts = Parts::default();
        let mut centres = Vec::new();
        for v in 0..h {
            let reach = if self.blank(v) {
                // every pixel the all-zero block at offset 0
                t.rounds.resize(t.rounds.len() + groups, Round::default());
                0
            } else {
                self.centres(v as isize, &mut parts, &mut centres);
                let cover = &mut t.cover[v * w..(v + 1) * w];
                self.plain_row(&centres[1..=w], &mut t.rounds, cover)
            };
            t.row_reach.push(reach);
            t.row_starts.push(t.rounds.len() as u32);
        }
        t
    }

    /// Whether the footprint leaves no centre of output row `v` to map (then
    /// [`Builder::centres`] gives none).
    fn blank(&self, v: usize) -> bool {
        let w = self.dst.size().width as isize;
        self.seen.is_some_and(|seen| {
            let (lo, hi) = seen.columns(v as isize, -1, w);
            lo > hi
        })
    }

    /// Appends the rounds of a row from the source positions of its pixel centres and marks
    /// the pixels they cover; gives the row's largest block offset.
    fn plain_row(
        &self,
        centres: &[Option<Point2<f64>>],
        rounds: &mut Vec<Round>,
        cover: &mut [Cover],
    ) -> u32 {
        let width = self.source_size.width;
        let mut reach = 0;
        for (group, cover) in centres.chunks(LANES).zip(cover.chunks_mut(LANES)) {
            if group.iter().all(Option::is_none) {
                // (most groups of a wide view: outside the footprint)
                rounds.push(Round::default());
                continue;
            }
            let mut quads = [Quad::default(); LANES];
            for ((quad, cover), p) in quads.iter_mut().zip(cover).zip(group) {
                if let Some((x0, y0, w)) = p.and_then(|p| self.block(p)) {
                    // `quantize` of one tap, inside: its total and scale
                    *quad = quantize_block(y0 * width + x0, w, WEIGHT_ONE, WEIGHT_ONE as f64);
                    *cover = Cover::Full;
                    reach = reach.max(quad.offset);
                }
            }
            rounds.push(RemapTable::round(&quads[..group.len()]));
        }
        reach
    }
}
