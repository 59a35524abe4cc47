//! A band's memory layout: its pixels stored but for the runs of whole groups without a mapped
//! centre, kept as gaps (a stitch camera's output beyond its reach, most of it), and the rows
//! of mapped centres it reads, written only across the span a gated output stores.

use super::{Builder, Parts};
use crate::warp::kernel::{Quad, LANES};
use crate::warp::table::Cover;
use nalgebra::Point2;

/// The fewest whole groups of pixels without a mapped centre a band keeps as a gap (the
/// table stores no round for them) rather than pixel by pixel.
pub(super) const MIN_GAP: usize = 2;

/// A band of consecutive output rows, built independently of the others. Its pixels are
/// stored but for the runs of [`MIN_GAP`] or more whole groups without a mapped centre (a
/// stitch camera's output beyond its reach: most of it), kept as gaps.
#[derive(Default)]
pub(super) struct Band {
    /// The stored pixels' blocks, block counts and covers.
    pub(super) quads: Vec<Quad>,
    pub(super) counts: Vec<u8>,
    pub(super) cover: Vec<Cover>,
    pub(super) row_lens: Vec<u32>,
    pub(super) row_reach: Vec<u32>,
    /// The gaps (first group, end group) of every row, in order; `row_gaps[i]..row_gaps[i + 1]`
    /// are row i's.
    pub(super) gaps: Vec<(u32, u32)>,
    pub(super) row_gaps: Vec<u32>,
    /// The highest pyramid level a pixel of the band samples.
    pub(super) top_level: u32,
}

/// The source positions of a row's centres, columns -1..=width, and the range written last
/// (the others are None).
#[derive(Default)]
pub(super) struct CentreRow {
    pub(super) positions: Vec<Option<Point2<f64>>>,
    written: std::ops::Range<usize>,
}

impl Builder<'_> {
    /// [`Builder::centres`] into `row`. Where the output stores its centres by spans (a
    /// stitch's output gated by its reach bound, [`stored_centre_span`]) and the
    /// source projects each bearing alone, only the span is mapped and written: the row's
    /// other positions are None, left so from the row it held before but for its last span.
    ///
    /// [`stored_centre_span`]: crate::camera::CameraModel::stored_centre_span
    pub(super) fn centres_row(&self, v: isize, parts: &mut Parts, row: &mut CentreRow) {
        let n = self.dst.size().width as usize + 2;
        parts.bearings.clear();
        let span = (self.seen.is_none() && self.src.projects_bearing_by_bearing())
            .then(|| self.dst.stored_centre_span(v, &mut parts.bearings))
            .flatten();
        let Some(span) = span else {
            self.centres(v, parts, &mut row.positions);
            row.written = 0..row.positions.len();
            return;
        };
        if row.positions.len() != n {
            row.positions.clear();
            row.positions.resize(n, None);
        }
        row.positions[row.written.clone()].fill(None);
        parts.span.clear();
        self.bearings_to_src(&mut parts.bearings, &mut parts.span);
        row.positions[span.clone()].copy_from_slice(&parts.span);
        row.written = span;
    }
}

impl Band {
    /// Adds `run` pixels without a mapped centre from column `u` of a row `w` pixels wide: a
    /// gap of the whole groups within them where there are [`MIN_GAP`] or more, the others
    /// stored as pixels taking nothing (one all-zero block each).
    pub(super) fn blank(&mut self, u: usize, run: usize, w: usize) {
        let end = u + run;
        let first = u.div_ceil(LANES);
        // (the row's last group, even if short, is whole when the run reaches the row's end)
        let last = if end == w {
            w.div_ceil(LANES)
        } else {
            end / LANES
        };
        let (before, after) = if last >= first + MIN_GAP {
            self.gaps.push((first as u32, last as u32));
            (first * LANES - u, end - (last * LANES).min(w))
        } else {
            (run, 0)
        };
        let n = before + after;
        self.quads.extend(std::iter::repeat_n(Quad::default(), n));
        self.counts.extend(std::iter::repeat_n(1, n));
        self.cover.extend(std::iter::repeat_n(Cover::None, n));
    }
}
