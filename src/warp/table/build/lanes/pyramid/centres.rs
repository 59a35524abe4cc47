//! A row of output pixel centres mapped into the source, for the lanes' build: in lanes where
//! the output has column and row shares, else as `Builder::centres` maps them one by one.

use super::super::super::{Builder, Parts};
use super::Lanes;
use crate::camera::{Intrinsics, Separable};
use crate::warp::kernel::LANES;
use nalgebra::Point2;

/// A row's pixel centres in the source: at index i column i - 1 (columns -1..=width), then
/// NaN up to a group's reads past the row's end; x NaN where a centre has no position.
#[derive(Default)]
pub(super) struct Centres {
    pub(super) x: Vec<f64>,
    pub(super) y: Vec<f64>,
    /// The indices mapped (the columns the footprint keeps); NaN x elsewhere.
    pub(super) kept: std::ops::Range<usize>,
}

impl Centres {
    /// The lanes of coordinate `c` from index `at`.
    #[inline(always)]
    pub(super) fn lanes(c: &[f64], at: usize) -> Lanes {
        <Lanes>::try_from(&c[at..at + LANES]).expect("a group")
    }

    /// The centre at index `i`, as `Builder::centres` gives it.
    #[inline(always)]
    pub(super) fn at(&self, i: usize) -> Option<Point2<f64>> {
        (!self.x[i].is_nan()).then(|| Point2::new(self.x[i], self.y[i]))
    }
}

impl Builder<'_> {
    /// The source positions of output row `v`'s centres into `out` (see [`Centres`]), as
    /// `Builder::centres` maps them: [`Builder::centres_lanes`]'s lanes where the output has
    /// column and row shares (`sep`), else `Builder::centres` itself.
    pub(super) fn centres_soa(
        &self,
        sep: Option<&dyn Separable>,
        k: &Intrinsics,
        v: isize,
        scratch: &mut CentreScratch,
        out: &mut Centres,
    ) {
        let w = self.dst.size().width as isize;
        let len = (w as usize + 2).next_multiple_of(LANES) + LANES;
        for c in [&mut out.x, &mut out.y] {
            c.clear();
            c.resize(len, f64::NAN);
        }
        let Some(sep) = sep else {
            self.centres(v, &mut scratch.parts, &mut scratch.row);
            let mapped = |c: &Option<Point2<f64>>| c.is_some();
            out.kept = match scratch.row.iter().position(mapped) {
                Some(lo) => lo..scratch.row.iter().rposition(mapped).map_or(lo, |hi| hi + 1),
                None => 0..0,
            };
            for (i, c) in scratch.row.iter().enumerate() {
                if let Some(c) = c {
                    (out.x[i], out.y[i]) = (c.x, c.y);
                }
            }
            return;
        };
        let (lo, hi) = self.seen.map_or((-1, w), |seen| seen.columns(v, -1, w));
        let kept = &self.centre_columns[(lo + 1) as usize..(hi + 2).max(lo + 1) as usize];
        let start = (lo + 1) as usize;
        out.kept = match kept.len() {
            0 => 0..0,
            n => start..start + n,
        };
        self.pinhole_groups(sep, k, v, kept, &mut scratch.xyz, |g, [px, py], count| {
            let at = start + g * LANES;
            out.x[at..at + count].copy_from_slice(&px[..count]);
            out.y[at..at + count].copy_from_slice(&py[..count]);
        });
    }
}

/// Scratch space of [`Builder::centres_soa`]: the bearings in lanes, or `Builder::centres`'s
/// parts and row.
#[derive(Default)]
pub(super) struct CentreScratch {
    xyz: [Vec<f64>; 3],
    parts: Parts,
    row: Vec<Option<Point2<f64>>>,
}
