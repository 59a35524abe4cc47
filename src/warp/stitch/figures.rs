//! A stitch's figures on real images, where no reference render exists: how much of what the
//! cameras cover is left black, how much of it as isolated holes, how much the fallback rule
//! and the far fill filled, and how well two cameras agree where both give a pixel.

use super::{Stitch, FALLBACK_SOURCE, FAR_SOURCE};
use crate::image::RgbImage;
use crate::warp::NO_SOURCE;
use serde::Serialize;

/// One frame's stitch figures ([`Stitch::figures`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StitchFigures {
    /// Output pixels some camera's table holds: the camera's image contains the stitched point
    /// (with the far fill, the point at the proxy distance where none holds the scene's).
    pub covered: usize,
    /// Covered pixels no camera gives (black).
    pub black: usize,
    /// Black covered pixels whose eight neighbours are all given: holes in the image.
    pub isolated: usize,
    /// Pixels the fallback rule filled ([`FALLBACK_SOURCE`]).
    pub fallback: usize,
    /// Pixels the far fill took ([`FAR_SOURCE`]): stitched at the proxy distance.
    pub far: usize,
    /// Pixels two cameras or more give (the fallback's and the far fill's aside).
    pub overlap: usize,
    /// Over those, the mean absolute difference of the two largest-weight cameras'
    /// gain-matched samples, levels (0-255, the mean of the three channels).
    pub seam_levels: f64,
}

impl StitchFigures {
    /// Black pixels, per cent of the covered ones.
    pub fn black_percent(&self) -> f64 {
        100.0 * self.black as f64 / self.covered.max(1) as f64
    }

    /// Isolated holes, per cent of the covered pixels.
    pub fn isolated_percent(&self) -> f64 {
        100.0 * self.isolated as f64 / self.covered.max(1) as f64
    }

    /// Far-filled pixels, per cent of the covered ones.
    pub fn far_percent(&self) -> f64 {
        100.0 * self.far as f64 / self.covered.max(1) as f64
    }

    /// Fallback pixels, per cent of the covered ones.
    pub fn fallback_percent(&self) -> f64 {
        100.0 * self.fallback as f64 / self.covered.max(1) as f64
    }
}

impl Stitch {
    /// The figures of this stitch of `images` (as [`Stitch::apply`] takes them).
    pub fn figures(&self, images: &[&RgbImage]) -> StitchFigures {
        self.with_remapped(images, |remapped| self.figures_of(remapped, images))
    }

    /// [`Stitch::figures`] of the cameras' `remapped` images (valid where they weigh).
    fn figures_of(&self, remapped: &[RgbImage], images: &[&RgbImage]) -> StitchFigures {
        let stitched = self.blend(remapped, images);
        let (w, h) = (self.size.width as usize, self.size.height as usize);
        let covered: Vec<bool> = (0..w * h)
            .map(|i| {
                let (u, v) = ((i % w) as u32, (i / w) as u32);
                self.tables.iter().any(|t| t.is_inside(u, v))
            })
            .collect();
        let source = &stitched.source;
        let black = |i: usize| covered[i] && source[i] == NO_SOURCE;
        let mut f = StitchFigures {
            covered: covered.iter().filter(|c| **c).count(),
            black: 0,
            isolated: 0,
            fallback: 0,
            far: 0,
            overlap: 0,
            seam_levels: 0.0,
        };
        let mut diff = 0.0;
        for i in 0..w * h {
            if black(i) {
                f.black += 1;
                let (u, v) = (i % w, i / w);
                let given = |x: usize, y: usize| source[y * w + x] != NO_SOURCE;
                let inner = u > 0 && v > 0 && u + 1 < w && v + 1 < h;
                if inner
                    && (v - 1..=v + 1)
                        .all(|y| (u - 1..=u + 1).all(|x| (x, y) == (u, v) || given(x, y)))
                {
                    f.isolated += 1;
                }
                continue;
            }
            if source[i] != NO_SOURCE && source[i] & FAR_SOURCE != 0 {
                f.far += 1;
                continue;
            }
            if source[i] != NO_SOURCE && source[i] & FALLBACK_SOURCE != 0 {
                f.fallback += 1;
                continue;
            }
            let mut best = [(0f32, 0usize); 2];
            for k in 0..self.weights.len() {
                let wk = self.weights[k][i];
                if wk > best[0].0 {
                    best = [(wk, k), best[0]];
                } else if wk > best[1].0 {
                    best[1] = (wk, k);
                }
            }
            if best[1].0 > 0.0 {
                let (a, b) = (best[0].1, best[1].1);
                let pa = &remapped[a].as_raw()[i * 3..i * 3 + 3];
                let pb = &remapped[b].as_raw()[i * 3..i * 3 + 3];
                let (ga, gb) = (stitched.gains[a], stitched.gains[b]);
                diff += (0..3)
                    .map(|c| (ga * pa[c] as f64 - gb * pb[c] as f64).abs())
                    .sum::<f64>()
                    / 3.0;
                f.overlap += 1;
            }
        }
        f.seam_levels = diff / f.overlap.max(1) as f64;
        f
    }
}
