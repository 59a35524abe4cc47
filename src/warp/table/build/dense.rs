//! A supersampled pixel's taps (three or more: a pair's are `pair.rs`'s) merged without a
//! sort: their bilinear weights are added into a
//! small dense grid of the source pixels under the taps' bounding box, which is then tiled with
//! 2×2 blocks ([`Quad`]s) whose integer weights are rounded cumulatively (each weight the
//! difference of two rounded running sums), so that they sum to the pixel's total exactly and
//! each stays within one unit of its share. A grid of n×n taps about a source pixel apart (the
//! supersampling's purpose) needs about (n + 1)²/4 blocks, against up to n² for the taps'
//! blocks merged by offset.

use super::{Builder, Scratch};
use crate::warp::kernel::{Quad, WEIGHT_ONE};
use nalgebra::Point2;

/// Largest number of source pixels in a pixel's grid: taps spread wider (a view far coarser
/// than 8 source pixels a pixel, or across a small 360° source's seam) are merged by offset.
const MAX_CELLS: usize = 20 * 20;

impl Builder<'_> {
    /// Appends the quads of a pixel whose `taps` (each weighing 1, sampled at pyramid level
    /// `level`) are given, and gives how
    /// many taps lie inside the source; None (nothing appended) where the grid does not fit
    /// (see [`MAX_CELLS`]) or a tap's block wraps (see [`Builder::add_tap`]).
    pub(super) fn dense_quads(
        &self,
        taps: &[Option<Point2<f64>>],
        level: u32,
        s: &mut Scratch,
        out: &mut Vec<Quad>,
    ) -> Option<u32> {
        let width = self.source_size.width;
        let last = self.level_width(level);
        s.cells.clear();
        let (mut x_lo, mut y_lo, mut x_hi, mut y_hi) = (u32::MAX, u32::MAX, 0, 0);
        for p in taps.iter().flatten() {
            if let Some((x0, y0, w)) = self.block_at(*p, level) {
                if x0 + 1 >= last {
                    return None;
                }
                (x_lo, x_hi) = (x_lo.min(x0), x_hi.max(x0));
                (y_lo, y_hi) = (y_lo.min(y0), y_hi.max(y0));
                s.cells.push((x0, y0, w));
            }
        }
        let inside = s.cells.len() as u32;
        if inside == 0 {
            out.push(Quad::default());
            return Some(0);
        }
        // the grid spans each block's second column and row too
        let (gw, gh) = ((x_hi - x_lo + 2) as usize, (y_hi - y_lo + 2) as usize);
        if gw * gh > MAX_CELLS {
            return None;
        }
        s.grid.clear();
        s.grid.resize(gw * gh, 0.0);
        for &(x0, y0, [tl, bl, tr, br]) in &s.cells {
            let at = (y0 - y_lo) as usize * gw + (x0 - x_lo) as usize;
            s.grid[at] += tl;
            s.grid[at + 1] += tr;
            s.grid[at + gw] += bl;
            s.grid[at + gw + 1] += br;
        }
        let n = taps.len() as u64;
        let total = ((WEIGHT_ONE as u64 * inside as u64 + n / 2) / n) as i32;
        let scale = WEIGHT_ONE as f64 / n as f64;
        let before = out.len();
        let offset = |x: usize, y: usize| (y_lo + y as u32) * width + x_lo + x as u32;
        tile(&s.grid, (gw, gh), scale, total, offset, out);
        if out.len() == before {
            out.push(Quad::default());
        }
        Some(inside)
    }
}

/// Appends to `out` the 2×2 blocks (top-left cell (x, y) at `offset(x, y)`; weights top-left,
/// bottom-left, top-right, bottom-right) tiling the `gw`×`gh` grid of float weights
/// (`gw`, `gh` >= 2), the blocks with a non-zero weight only. An odd side's last block starts
/// one cell back (inside the grid, so inside the source) and takes only its second cells.
/// The weights, times `scale`, are rounded cumulatively in emission order to sum to `total`,
/// the rounding error of the float sum (if any) going to the largest weight.
fn tile(
    grid: &[f64],
    (gw, gh): (usize, usize),
    scale: f64,
    total: i32,
    offset: impl Fn(usize, usize) -> u32,
    out: &mut Vec<Quad>,
) {
    let (mut sum, mut given) = (0.0, 0i32);
    // where the largest weight went (an index into `out`, a corner)
    let (mut big, mut top) = (None, 0.0);
    for by in (0..gh).step_by(2) {
        let (y, fresh_top) = if by + 1 < gh {
            (by, true)
        } else {
            (by - 1, false)
        };
        for bx in (0..gw).step_by(2) {
            let (x, fresh_left) = if bx + 1 < gw {
                (bx, true)
            } else {
                (bx - 1, false)
            };
            let at = y * gw + x;
            let cells = [
                (at, fresh_top && fresh_left),
                (at + gw, fresh_left),
                (at + 1, fresh_top),
                (at + gw + 1, true),
            ];
            // the block's weights packed in one register, a corner's i16 per 16 bits (stored
            // corner by corner, the test below would wait on four narrow stores)
            let mut w = 0u64;
            let mut holds_big = false;
            for (k, &(i, fresh)) in cells.iter().enumerate() {
                if !fresh || grid[i] == 0.0 {
                    continue;
                }
                let share = grid[i] * scale;
                sum += share;
                // (sum >= 0: truncation is floor, without a libm call)
                let r = (sum + 0.5) as i32;
                w |= ((r - given) as i16 as u16 as u64) << (16 * k);
                given = r;
                if share > top {
                    (big, top, holds_big) = (Some((out.len(), k)), share, true);
                }
            }
            if w != 0 || holds_big {
                out.push(Quad {
                    offset: offset(x, y),
                    w: std::array::from_fn(|k| (w >> (16 * k)) as u16 as i16),
                });
            }
        }
    }
    if let Some((b, k)) = big {
        out[b].w[k] += (total - given) as i16;
    }
}
