//! A [`RemapTable`]'s blocks as plain data, for callers that resample other pixel formats
//! than the kernels' 8-bit RGB (one channel, four, 16-bit or float images) with the very
//! taps and weights the kernels apply.

use super::RemapTable;
use crate::warp::kernel::{LANES, WEIGHT_BITS, WEIGHT_ONE};

impl RemapTable {
    /// The sum of a fully covered pixel's block weights (weights are in 1/`WEIGHT_ONE`).
    pub const WEIGHT_ONE: i32 = WEIGHT_ONE;
    /// log2 of [`RemapTable::WEIGHT_ONE`]: the 8-bit kernels round a sum `s` to
    /// `(s + WEIGHT_ONE / 2) >> WEIGHT_BITS`.
    pub const WEIGHT_BITS: u32 = WEIGHT_BITS;

    /// Calls `f(u, pixel, weights)` for every block of output row `v`: output column `u` takes
    /// `weights` (top-left, bottom-left, top-right, bottom-right, in 1/[`RemapTable::WEIGHT_ONE`])
    /// of the 2×2 source pixels whose top-left is source pixel index `pixel` (row-major). A
    /// weight is zero where its pixel may lie outside the source (the last column or row).
    /// Padding blocks (all-zero weights) are skipped, so a pixel outside the source has none.
    pub fn row_blocks(&self, v: usize, mut f: impl FnMut(usize, usize, [i16; 4])) {
        let w = self.size.width as usize;
        let groups = w.div_ceil(LANES);
        let rounds = &self.rounds[self.row_starts[v] as usize..self.row_starts[v + 1] as usize];
        let depth = &self.depth[v * groups..(v + 1) * groups];
        let mut r = 0;
        for (g, &k) in depth.iter().enumerate() {
            for round in &rounds[r..r + k as usize] {
                for lane in 0..LANES.min(w - g * LANES) {
                    let weights = round.w[lane];
                    if weights != [0; 4] {
                        f(g * LANES + lane, round.offset[lane] as usize / 3, weights);
                    }
                }
            }
            r += k as usize;
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::camera::{Fisheye, ImageSize, Intrinsics, Perspective, RadialModel};
    use crate::image::RgbImage;
    use crate::warp::{RemapTable, Wrap};
    use nalgebra::Matrix3;

    #[test]
    fn the_blocks_resample_as_the_kernels_do() {
        let source = Perspective::new(
            Intrinsics::new(90.0, 90.0, 63.5, 40.5),
            ImageSize::new(128, 80),
        );
        let lens = Fisheye::new(
            RadialModel::Equidistant,
            Intrinsics::new(40.0, 40.0, 60.0, 45.0),
            ImageSize::new(121, 91),
            190f64.to_radians(),
        )
        .expect("lens");
        let table = RemapTable::build(&lens, &source, &Matrix3::identity(), Wrap::None);
        let mut img = RgbImage::new(128, 80);
        for (i, b) in img.as_raw_mut().iter_mut().enumerate() {
            *b = (i * 37 % 251) as u8;
        }
        let want = table.apply(&img);
        let src = img.as_raw();
        let (w, h) = (121usize, 91usize);
        let mut sums = vec![[0i32; 3]; w * h];
        let mut blocks = 0;
        for v in 0..h {
            table.row_blocks(v, |u, pixel, weights| {
                blocks += 1;
                // tl, bl, tr, br
                let taps = [pixel, pixel + 128, pixel + 1, pixel + 129];
                for (&p, &wt) in taps.iter().zip(&weights) {
                    if wt != 0 {
                        for c in 0..3 {
                            sums[v * w + u][c] += src[p * 3 + c] as i32 * wt as i32;
                        }
                    }
                }
            });
        }
        let half = RemapTable::WEIGHT_ONE / 2;
        let got: Vec<u8> = sums
            .iter()
            .flat_map(|s| s.map(|x| ((x + half) >> RemapTable::WEIGHT_BITS) as u8))
            .collect();
        assert!(blocks > w * h / 10, "{blocks} blocks");
        assert_eq!(got, want.as_raw());
    }
}
