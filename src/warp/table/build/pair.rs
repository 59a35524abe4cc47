//! The quads of a pixel of two taps (2×1 or 1×2: the anisotropic pixels of a view a little
//! coarser than its source along one axis, most of a turned view's supersampled pixels): each
//! tap's bilinear block with half the pixel's weight, the two merged where they are one block.
//! No grid, no sort: the lanes build (`lanes/pyramid.rs`) makes the same quads from its lanes.
//! Against the dense grid's tiling (`dense.rs`) the weights are the same sums, rounded per
//! block instead of cumulatively (each within one unit of 2^-14), and a pixel has at most two
//! quads (the grid's tiling gave some three or four).

use super::quantize_block;
use super::Builder;
use crate::warp::kernel::{Quad, WEIGHT_ONE};
use nalgebra::Point2;

/// The integer total of one tap of two: half of [`WEIGHT_ONE`] (even).
pub(super) const HALF: i32 = WEIGHT_ONE / 2;

/// The float weights' scale of one tap of two.
pub(super) const HALF_SCALE: f64 = WEIGHT_ONE as f64 / 2.0;

impl Builder<'_> {
    /// Appends the quads of a pixel whose two taps, sampled at pyramid level `level`, lie at
    /// `taps` (None: no position), and gives how many lie inside the source: tap 0's block
    /// first, then tap 1's, one merged block where they share their top-left pixel (at the
    /// whole weight), an all-zero quad where neither is inside. None (nothing appended) where
    /// a block straddles a 360° source's wrap (the general rule splits it).
    pub(super) fn pair_quads(
        &self,
        taps: &[Option<Point2<f64>>; 2],
        level: u32,
        out: &mut Vec<Quad>,
    ) -> Option<u32> {
        let blocks = taps.map(|p| p.and_then(|p| self.block_at(p, level)));
        let last = self.level_width(level);
        if blocks.iter().flatten().any(|&(x0, _, _)| x0 + 1 >= last) {
            return None;
        }
        let width = self.source_size.width;
        let offset = |(x0, y0, _): (u32, u32, [f64; 4])| y0 * width + x0;
        match blocks {
            [None, None] => {
                out.push(Quad::default());
                Some(0)
            }
            [Some(a), Some(b)] if offset(a) == offset(b) => {
                let w = std::array::from_fn(|k| a.2[k] + b.2[k]);
                out.push(quantize_block(offset(a), w, WEIGHT_ONE, HALF_SCALE));
                Some(2)
            }
            [Some(a), Some(b)] => {
                out.push(quantize_block(offset(a), a.2, HALF, HALF_SCALE));
                out.push(quantize_block(offset(b), b.2, HALF, HALF_SCALE));
                Some(2)
            }
            [Some(a), None] | [None, Some(a)] => {
                out.push(quantize_block(offset(a), a.2, HALF, HALF_SCALE));
                Some(1)
            }
        }
    }
}
