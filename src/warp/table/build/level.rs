//! An output pixel's scale, the pyramid level a coarse one samples (see `table/pyramid.rs`),
//! a tap's bilinear block at a level, and how much of a border pixel's footprint a pyramid
//! sample counts as inside (its taps' share, `taps_cover`). A pixel s source pixels wide (the smaller of its two axes'
//! scales) samples level k, 1.5 · 2^(k-1) ≤ s < 1.5 · 2^k (level 0, the source, below 1.5:
//! there it is the table of `RemapTable::build_within`), where it spans 0.75 to 1.5 level
//! pixels: one bilinear tap of the level (more along the longer axis of an anisotropic
//! footprint, one a level pixel). The pyramid's box and the tap's tent blur about as the
//! Gaussian of 0.55 output pixel an exact render integrates over; the taps per source pixel
//! blur less and cost s² taps. Against the exact render of 640×480 views of a synthetic KITTI
//! frame (`tests/table_parts.rs`) the thresholds at 1.5 · 2^(k-1) gave 44.34, 47.96 and 48.98
//! dB (fisheye, equirect crop, cylindrical; per-source-pixel taps 43.65, 47.55, 48.91) and a
//! checkerboard's moiré of 15.2 grey levels (taps 26.6); at 2^k, one or two taps a level
//! pixel, 44.31, 47.59, 49.12 dB and 25.2, at several times the build cost.

use super::{local, Builder, Parts};
use crate::warp::table::{column_inside, row_inside, Wrap, MAX_SUPERSAMPLE};
use nalgebra::Point2;

/// The squared smaller scale (source pixels an output pixel) from which level 1 is sampled,
/// 1.5²; level k from 4^(k-1) times it.
const LEVEL_AT2: f64 = 2.25;

impl Builder<'_> {
    /// The level of a pixel whose smaller squared scale is `scale2`: the largest k with
    /// 4^(k-1) · [`LEVEL_AT2`] ≤ `scale2` among the levels the table may sample (0 where it
    /// samples the source alone). Exact comparisons: the same choice on every machine.
    #[inline]
    pub(super) fn level_of(&self, scale2: f64) -> u32 {
        if scale2 < self.taps_below2 {
            return 0;
        }
        let mut k = 0;
        while k + 1 < self.shapes.len() && scale2 >= LEVEL_AT2 * (1u64 << (2 * k)) as f64 {
            k += 1;
        }
        k as u32
    }

    /// For a pyramid sample of pixel (u, v) (source position `centre`, squared scales
    /// `(su, sv)`, rows of mapped centres `rows`) within its footprint of a source border:
    /// how many of the taps [`RemapTable::build_within`] gives it lie inside the source, and
    /// of how many; None farther in or out, where the taps all lie on the centre's side of
    /// every border (they are within half a step along each axis of it; twice that and a
    /// pixel is kept for the mapping's bend).
    pub(super) fn taps_cover(
        &self,
        (u, v): (usize, usize),
        centre: Option<Point2<f64>>,
        (su, sv): (f64, f64),
        rows: [&[Option<Point2<f64>>]; 3],
        parts: &mut Parts,
    ) -> Option<(u32, u32)> {
        let c = centre?;
        let reach = su.sqrt() + sv.sqrt() + 1.0;
        let (w, h) = (
            self.source_size.width as f64,
            self.source_size.height as f64,
        );
        let far = |x: f64, edge: f64| (x - edge).abs() >= reach;
        if far(c.x, -0.5) && far(c.x, w - 0.5) && far(c.y, -0.5) && far(c.y, h - 0.5) {
            return None;
        }
        let (nu, nv) = (count(su).min(self.cap), count(sv).min(self.cap));
        self.tap_positions((u, v, 0), (nu, nv), &local::near(rows, u), parts);
        let inside = (parts.taps.iter().flatten())
            .filter(|p| column_inside(p.x, w) && row_inside(p.y, h))
            .count();
        Some((inside as u32, nu * nv))
    }

    /// The bilinear block at pyramid level `level` of a tap at source position `p` (level-0
    /// pixels): its top-left pixel's column and buffer row, and the weights of top-left,
    /// bottom-left, top-right, bottom-right; None outside the source (level 0's border: which
    /// taps are inside does not depend on the level). A 360° source's columns wrap at every
    /// level (its levels' widths divide the source's: see `wrapping_level_shapes`): a block
    /// at a level's last column has column 0 on its right ([`Builder::add_tap`] splits it).
    #[inline(always)]
    pub(super) fn block_at(&self, p: Point2<f64>, level: u32) -> Option<(u32, u32, [f64; 4])> {
        if level == 0 {
            return self.block(p);
        }
        let size = self.source_size;
        let wraps = self.wrap == Wrap::Horizontal;
        if !(wraps || column_inside(p.x, size.width as f64)) || !row_inside(p.y, size.height as f64)
        {
            return None;
        }
        let (lw, lh, row) = self.shapes[level as usize];
        // level pixel x covers level-0 pixels 2^k·x to 2^k·(x + 1) - 1: its centre is at
        // 2^k·(x + 0.5) - 0.5
        let f = (1u32 << level) as f64;
        let x = (p.x + 0.5) / f - 0.5;
        let x = match wraps {
            // (rem_euclid may give lw itself for a tiny negative x: column 0, weight fx = 1)
            true => x.rem_euclid(lw as f64),
            false => x.clamp(0.0, lw as f64 - 1.0),
        };
        let y = ((p.y + 0.5) / f - 0.5).clamp(0.0, lh as f64 - 1.0);
        // (x, y >= 0: truncation is floor; a level is at least 2×2)
        let x0 = (x as u32).min(lw - 1 - (!wraps) as u32);
        let y0 = (y as u32).min(lh - 2);
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let (tl, bl) = ((1.0 - fx) * (1.0 - fy), (1.0 - fx) * fy);
        let (tr, br) = (fx * (1.0 - fy), fx * fy);
        Some((x0, row + y0, [tl, bl, tr, br]))
    }
}

/// Squared scale of an output pixel along its u and v axes: the squared distance (source
/// pixels) one output step spans in each direction, from the table's own mapping of the
/// pixel's centre and its neighbours' (a central difference; one-sided where a neighbour has
/// no image). [`count`] makes a supersampling of it, anisotropic: at a KITTI frame's edges an
/// equirect pixel spans 1.8 source pixels across but 1.3 down, and needs 2×1 samples, not 2×2.
/// `period`: the source width of a 360° source, across whose wrap a step is taken the short
/// way.
pub(super) fn scales2(
    centre: Option<Point2<f64>>,
    across: [Option<Point2<f64>>; 2],
    down: [Option<Point2<f64>>; 2],
    period: Option<f64>,
) -> (f64, f64) {
    let Some(c) = centre else {
        return (0.0, 0.0);
    };
    // Squared distances: the square root is needed only for the (rare) counts above 1.
    let dist2 = |a: Point2<f64>, b: Point2<f64>| {
        let mut d = b - a;
        if let Some(w) = period {
            d.x -= w * (d.x / w).round();
        }
        d.norm_squared()
    };
    let step2 = |[a, b]: [Option<Point2<f64>>; 2]| match (a, b) {
        (Some(a), Some(b)) => dist2(a, b) / 4.0,
        (Some(a), None) => dist2(a, c),
        (None, Some(b)) => dist2(c, b),
        (None, None) => 0.0,
    };
    (step2(across), step2(down))
}

/// Taps along an axis whose squared scale is `scale2`: the scale rounded, 1 below 1.5 (and
/// where it is not finite), at most [`MAX_SUPERSAMPLE`].
pub(super) fn count(scale2: f64) -> u32 {
    if !scale2.is_finite() || scale2 < 1.5 * 1.5 {
        1
    } else {
        (scale2.sqrt().round() as u32).min(MAX_SUPERSAMPLE)
    }
}
