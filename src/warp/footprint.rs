//! Where a pinhole source can appear in an output image: per output row, the columns outside
//! which no pixel takes anything from the source.
//!
//! A wide lens as output sees far more than a KITTI camera: about 90 % of a 190° fisheye's
//! pixels look where the source never looked, and each costs a lens inversion in the table
//! build. Their table entries are the all-zero block whatever the inversion gives, so the
//! builder may skip them, provided it still maps every pixel whose value or scale estimate
//! depends on the source. This bound is computed the cheap way round: the source's image border
//! (one source pixel beyond the valid area) is projected forward into the output, where it is a
//! closed curve around every output position the source can reach; each output row keeps the
//! extent of the curve's points within [`MARGIN`] rows of it, widened by [`MARGIN`] columns.

use crate::camera::{CameraModel, Perspective};
use nalgebra::{Matrix3, Point2, Vector3};

/// Output pixels of slack around the border curve. A pixel whose supersampled taps reach the
/// source has a tap within half a pixel of its centre, and its scale estimate reads the centres
/// one pixel further: 1.5 pixels from the curve at most, plus half a pixel between two of the
/// curve's points ([`STEP`]), plus the round trip of a lens inversion (far below a pixel).
const MARGIN: f64 = 4.0;
/// Largest distance, in output pixels, between consecutive points of the border curve.
const STEP: f64 = 0.5;
/// Halvings of one source-pixel step of the border before the curve is judged discontinuous.
const MAX_DEPTH: u32 = 40;

/// Per output row, the columns an output pixel must lie within to take anything from the
/// source (see the module's notes).
#[derive(Debug, Clone, PartialEq)]
pub struct Footprint {
    /// (lowest, highest) column of rows -1..=height (index v + 1); empty spans (lowest above
    /// highest) for rows the source cannot reach.
    spans: Vec<(f64, f64)>,
}

impl Footprint {
    /// The footprint of the pinhole camera `src` in `dst`, where `src_from_dst` rotates a
    /// bearing from `dst`'s axes to `src`'s. `dst` must map the rays it projects one-to-one
    /// (every lens model does within its field of view), and the rays it cannot project must
    /// form a cap around `blind` (in `dst`'s axes): a wide-angle lens's cap around its
    /// backward axis. None when the bound cannot be shown (a part of the source's border has
    /// no image in `dst`, the curve jumps, or the source sees `blind`): then every pixel is
    /// mapped.
    pub fn new(
        dst: &dyn CameraModel,
        src: &Perspective,
        src_from_dst: &Matrix3<f64>,
        blind: &Vector3<f64>,
    ) -> Option<Footprint> {
        let size = src.size();
        let (x0, y0) = (-1.5, -1.5);
        let (x1, y1) = (size.width as f64 + 0.5, size.height as f64 + 0.5);
        // The source cone is convex and its border has an image, so the cap of rays without
        // one is either wholly outside the cone or wholly inside it, around `blind`.
        if let Ok(p) = src.project(&(src_from_dst * blind)) {
            if p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1 {
                return None;
            }
        }
        let out = dst.size();
        let mut f = Footprint {
            spans: vec![(f64::INFINITY, f64::NEG_INFINITY); out.height as usize + 2],
        };
        let dst_from_src = src_from_dst.transpose();
        let map = |p: Point2<f64>| -> Option<Point2<f64>> {
            let d = src.unproject(&p).ok()?;
            let q = dst.project(&(dst_from_src * d)).ok()?;
            (q.x.is_finite() && q.y.is_finite()).then_some(q)
        };
        let corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)].map(|(x, y)| Point2::new(x, y));
        for i in 0..4 {
            let (a, b) = (corners[i], corners[(i + 1) % 4]);
            let steps = (b - a).norm().ceil().max(1.0) as usize;
            let at = |k: usize| a + (b - a) * (k as f64 / steps as f64);
            let mut prev = (at(0), map(at(0))?);
            f.mark(prev.1);
            for k in 1..=steps {
                let next = (at(k), map(at(k))?);
                f.walk(&map, prev, next, MAX_DEPTH)?;
                prev = next;
            }
        }
        Some(f)
    }

    /// Marks the points of the border between source positions `a` and `b` (with their images),
    /// `b` included, at most [`STEP`] apart in the output.
    fn walk(
        &mut self,
        map: &impl Fn(Point2<f64>) -> Option<Point2<f64>>,
        a: (Point2<f64>, Point2<f64>),
        b: (Point2<f64>, Point2<f64>),
        depth: u32,
    ) -> Option<()> {
        if (b.1 - a.1).norm() <= STEP {
            self.mark(b.1);
            return Some(());
        }
        if depth == 0 {
            return None;
        }
        let m = Point2::from((a.0.coords + b.0.coords) * 0.5);
        let m = (m, map(m)?);
        self.walk(map, a, m, depth - 1)?;
        self.walk(map, m, b, depth - 1)
    }

    /// Widens the spans of the rows within [`MARGIN`] of output point `q`.
    fn mark(&mut self, q: Point2<f64>) {
        let last = self.spans.len() as f64 - 2.0;
        let first = (q.y - MARGIN).ceil().max(-1.0);
        let end = (q.y + MARGIN).floor().min(last);
        if !(first <= end) {
            return;
        }
        for v in first as i64..=end as i64 {
            let s = &mut self.spans[(v + 1) as usize];
            s.0 = s.0.min(q.x - MARGIN);
            s.1 = s.1.max(q.x + MARGIN);
        }
    }

    /// Whether output pixel centre (u, v) (v from -1 to the height) may take anything from the
    /// source or serve as a neighbour of one that does.
    #[inline]
    pub(super) fn may_see(&self, u: isize, v: isize) -> bool {
        self.spans
            .get((v + 1) as usize)
            .is_some_and(|&(lo, hi)| u as f64 >= lo && u as f64 <= hi)
    }

    /// The columns `u` of row `v` within `first..=last` for which [`Footprint::may_see`]
    /// holds, as (lowest, highest): lowest above highest when there are none.
    pub(super) fn columns(&self, v: isize, first: isize, last: isize) -> (isize, isize) {
        match self.spans.get((v + 1) as usize) {
            Some(&(lo, hi)) if lo <= hi => (
                (lo.ceil().max(first as f64) as isize).min(last + 1),
                (hi.floor().min(last as f64) as isize).max(first - 1),
            ),
            _ => (last + 1, last),
        }
    }

    /// Fraction of the output's pixels inside the footprint (for reports and benchmarks).
    pub fn share(&self, width: u32) -> f64 {
        let rows = &self.spans[1..self.spans.len() - 1];
        let inside: f64 = rows
            .iter()
            .map(|&(lo, hi)| {
                (hi.min(width as f64 - 1.0).floor() - lo.max(0.0).ceil() + 1.0).max(0.0)
            })
            .sum();
        inside / (width as f64 * rows.len().max(1) as f64)
    }
}
