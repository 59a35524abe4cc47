//! A tap between output pixel centres at their distances ([`Proxy::between_centres_at`]):
//! the cell of four centres it lies in, read once for the few taps of a pixel that share it
//! ([`Cells`]), then the tap's place in the cell.

use super::{Proxy, TAP_AGREE};
use nalgebra::Point2;

impl Proxy<'_> {
    /// [`Proxy::between_centres`] of the tap at output position `p`.
    pub(super) fn between_centres_at(&self, p: &Point2<f64>) -> Option<f64> {
        let (x, y) = (crate::warp::floor(p.x), crate::warp::floor(p.y));
        let s = self.cell_inverses(x, y)?;
        Some(between(s, p.x - x, p.y - y))
    }

    /// The inverse distances of the output pixel centres at the corners of the cell whose
    /// top-left centre is (x, y) (top-left, top-right, bottom-left, bottom-right), where they
    /// lie on one surface ([`TAP_AGREE`]); None where they do not, a centre has no distance or
    /// the cell is not within the output. What [`Proxy::between_centres_at`] reads of a tap's
    /// cell, the same for every tap in it.
    pub(super) fn cell_inverses(&self, x: f64, y: f64) -> Option<[f64; 4]> {
        let c = self.centres?;
        let size = c.output.size();
        let (w, h) = (size.width as usize, size.height as usize);
        if !(x >= 0.0 && y >= 0.0 && x + 1.0 < w as f64 && y + 1.0 < h as f64) {
            return None;
        }
        let (u, v) = (x as usize, y as usize);
        let i = v * w + u;
        let t = [
            c.distances[i],
            c.distances[i + 1],
            c.distances[i + w],
            c.distances[i + w + 1],
        ];
        if !t.iter().all(|t| *t > 0.0 && t.is_finite()) {
            return None;
        }
        let s = t.map(|t| 1.0 / t);
        let (lo, hi) = s.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), s| {
            (lo.min(*s), hi.max(*s))
        });
        // the pixel's angle: its diagonal's chord over √2
        let (a, b) = (c.reach.bearing(u, v)?, c.reach.bearing(u + 1, v + 1)?);
        let pixel = (a.normalize() - b.normalize()).norm() * std::f64::consts::FRAC_1_SQRT_2;
        if !((hi - lo) * self.baseline <= TAP_AGREE * pixel) {
            return None;
        }
        Some(s)
    }
}

/// The distance between four centres' inverse distances `s` (top-left, top-right,
/// bottom-left, bottom-right) at fractions `(fx, fy)` of the cell, bilinear in inverse
/// distance.
#[inline]
pub(super) fn between(s: [f64; 4], fx: f64, fy: f64) -> f64 {
    let top = s[0] + (s[1] - s[0]) * fx;
    let bottom = s[2] + (s[3] - s[2]) * fx;
    1.0 / (top + (bottom - top) * fy)
}

/// A cell's top-left centre's coordinates' bits.
type Key = (u64, u64);

/// The last few cells of centres a pixel's taps read ([`Proxy::cell_inverses`]), by their
/// top-left centre's coordinates' bits.
#[derive(Default)]
pub(super) struct Cells {
    kept: [(Key, Option<[f64; 4]>); 4],
    len: usize,
}

impl Cells {
    /// The kept value of cell `at`, else `compute`'s (kept in place of the oldest).
    #[inline]
    pub(super) fn get(
        &mut self,
        at: (f64, f64),
        compute: impl FnOnce() -> Option<[f64; 4]>,
    ) -> Option<[f64; 4]> {
        let key = (at.0.to_bits(), at.1.to_bits());
        let n = self.len.min(self.kept.len());
        if let Some((_, s)) = self.kept[..n].iter().find(|(k, _)| *k == key) {
            return *s;
        }
        let s = compute();
        self.kept[self.len % self.kept.len()] = (key, s);
        self.len += 1;
        s
    }
}
