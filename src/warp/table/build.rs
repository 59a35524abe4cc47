//! Building a [`RemapTable`]: every output pixel centre mapped to the source once (by
//! column and row shares where the output camera is separable), the supersampling each pixel
//! needs from its neighbours' mapped centres, its taps (interpolated from those centres where
//! the mapping is smooth enough: `local.rs`) merged into 2×2 blocks with integer weights
//! ([`Quad`]s, through a dense grid: `dense.rs`; made integers in `quantize.rs`), band by band of rows, serially or on rayon's
//! pool.

use super::{column_inside, pyramid, row_inside, Cover, RemapTable, Wrap, MAX_SUPERSAMPLE};
use crate::camera::{CameraModel, ImageSize, Intrinsics, Separable, Share};
use crate::warp::footprint::Footprint;
use crate::warp::kernel::{Quad, LANES, WEIGHT_ONE};
use nalgebra::{Matrix3, Point2, Vector3};
use rayon::prelude::*;
use std::sync::OnceLock;

mod band;
mod dense;
mod entry;
mod gate;
mod lanes;
mod level;

use level::{count, scales2};
mod local;
mod pair;
mod plain;
mod quantize;
mod surface;

pub(crate) use surface::Surfaces;

use band::{Band, CentreRow};
pub(in crate::warp::table) use quantize::quantize_block;
use quantize::{merge, quantize};

/// Rows built together by one task of [`RemapTable::build_parallel`]: each band maps the rows
/// just above and below it too, so wider bands repeat less of that work.
const BAND_ROWS: usize = 16;

impl Builder<'_> {
    /// The table, serially or with bands of rows in parallel.
    fn build(&self, parallel: bool) -> RemapTable {
        let b = self;
        let h = b.dst.size().height as usize;
        if !parallel && b.plain() {
            return b.plain_table();
        }
        if let Some(table) = b.pyramid_lanes_table(parallel) {
            return table;
        }
        if !parallel {
            // the last serial build's band, reused: a fresh one's pages cost a fault each
            let mut band = SPARE_BAND.with(|s| std::mem::take(&mut *s.borrow_mut()));
            b.band(0..h, &mut band);
            let table = b.finish(std::slice::from_ref(&band));
            if band.counts.capacity() <= SPARE_MAX_PIXELS {
                SPARE_BAND.with(|s| *s.borrow_mut() = band);
            }
            return table;
        }
        let bands: Vec<Band> = (0..h.div_ceil(BAND_ROWS))
            .into_par_iter()
            .map(|i| {
                let mut band = Band::default();
                b.band(i * BAND_ROWS..((i + 1) * BAND_ROWS).min(h), &mut band);
                band
            })
            .collect();
        b.finish(&bands)
    }
}

/// Largest band (in output pixels) a thread keeps for its next serial build.
const SPARE_MAX_PIXELS: usize = 1 << 20;

thread_local! {
    /// A thread's band of its last serial build, for the next (tables drawn one after another,
    /// a camera per training sample, would otherwise fault in fresh pages each time).
    static SPARE_BAND: std::cell::RefCell<Band> = std::cell::RefCell::new(Band::default());
}

/// The camera mapping and tap rules shared by the serial and the parallel build.
struct Builder<'a> {
    dst: &'a dyn CameraModel,
    src: &'a dyn CameraModel,
    src_from_dst: &'a Matrix3<f64>,
    wrap: Wrap,
    cap: u32,
    source_size: ImageSize,
    /// Every tap inside the source is one block: no 360° wrap, no one-pixel-wide source (see
    /// [`Builder::add_tap`]).
    one_block: bool,
    /// Pixels outside it are not mapped (they take nothing from the source).
    seen: Option<&'a Footprint>,
    /// The output camera's unprojection by columns and rows, where it has one: then each
    /// column's and each row's share of the bearings is computed once, not once a pixel.
    by_parts: Option<&'a dyn Separable>,
    /// With `by_parts`: the column shares of the pixel centres, columns -1..=width.
    centre_columns: Vec<Share>,
    /// `by_parts`, or where the output is not separable itself the unprojection of its taps
    /// by columns and rows that `surfaces` gives ([`Surfaces::tap_output`]): a supersampled
    /// pixel's taps share their columns' and rows' shares.
    tap_parts: Option<&'a dyn Separable>,
    /// The source's intrinsics where it is a pinhole ([`CameraModel::pinhole`]).
    pinhole: Option<Intrinsics>,
    /// With `tap_parts`: at index n, the column shares of the n taps of an n-wide supersampled
    /// pixel, n per column (column-major), made by the first band that needs them.
    tap_columns: [OnceLock<Vec<Share>>; MAX_SUPERSAMPLE as usize + 1],
    /// The source pyramid's levels (width, height, first row) a coarse pixel may sample; empty
    /// (or level 0 alone) where it takes a tap per source pixel (see `level.rs`).
    shapes: Vec<(u32, u32, u32)>,
    /// The squared smaller scale below which a pixel takes its taps from the source (level 0)
    /// whatever `shapes` holds (0: the pyramid from `level_at2` on).
    taps_below2: f64,
    /// A pyramid sample's coverage is its taps' (`taps_cover`), so that which pixels lie
    /// wholly inside the source is [`RemapTable::build_within`]'s.
    taps_cover: bool,
    /// With a depth-guided source, which pixels' footprints lie on one surface: the others
    /// keep their taps (level 0) whatever their scale.
    surfaces: Option<&'a dyn Surfaces>,
}

/// Scratch space of one pixel's taps: merged blocks (offset, float weights), or the taps'
/// blocks (top-left column and row, weights) and the dense grid they are added into.
#[derive(Default)]
struct Scratch {
    blocks: Vec<(u32, [f64; 4])>,
    cells: Vec<(u32, u32, [f64; 4])>,
    grid: Vec<f64>,
    ints: Vec<[i32; 4]>,
    order: Vec<(usize, f64)>,
}

/// Scratch space of a band's unprojections by columns and rows.
#[derive(Default)]
struct Parts {
    bearings: Vec<Option<Vector3<f64>>>,
    taps: Vec<Option<Point2<f64>>>,
    /// The row shares of the current row's taps, at index n for an n-tall supersampled pixel.
    tap_rows: [Vec<Share>; MAX_SUPERSAMPLE as usize + 1],
    /// A row's bearing coordinates (x, y, z) for the centres mapped in lanes.
    lanes: [Vec<f64>; 3],
    /// The source positions of a span of a row's centres.
    span: Vec<Option<Point2<f64>>>,
    /// The output positions of a pixel's taps (row by row), for [`Surfaces::project_taps`].
    at: Vec<Point2<f64>>,
    /// Whether each mapped pixel of the current row lies on one surface, from the first that
    /// asked.
    one_surface: Vec<bool>,
}

impl<'a> Builder<'a> {
    fn new(
        dst: &'a dyn CameraModel,
        src: &'a dyn CameraModel,
        src_from_dst: &'a Matrix3<f64>,
        wrap: Wrap,
        max_supersample: u32,
        seen: Option<&'a Footprint>,
    ) -> Self {
        let by_parts = dst.separable();
        let w = dst.size().width as i64;
        let centre_columns = match by_parts {
            Some(sep) => (-1..=w).map(|u| sep.column(u as f64)).collect(),
            None => Vec::new(),
        };
        Self {
            dst,
            src,
            src_from_dst,
            wrap,
            cap: max_supersample.clamp(1, MAX_SUPERSAMPLE),
            source_size: src.size(),
            one_block: wrap == Wrap::None && src.size().width >= 2,
            seen,
            by_parts,
            centre_columns,
            tap_parts: by_parts,
            pinhole: src.pinhole(),
            tap_columns: Default::default(),
            shapes: Vec::new(),
            taps_below2: 0.0,
            taps_cover: false,
            surfaces: None,
        }
    }

    /// The output camera's bearing at position (u, v), one position alone.
    #[inline]
    fn bearing(&self, u: f64, v: f64) -> Option<Vector3<f64>> {
        self.dst.unproject(&Point2::new(u, v)).ok()
    }

    /// Appends the source positions of output bearings `ds` to `out` (`ds` is rotated in place).
    fn bearings_to_src(&self, ds: &mut [Option<Vector3<f64>>], out: &mut Vec<Option<Point2<f64>>>) {
        for d in ds.iter_mut().flatten() {
            *d = self.src_from_dst * *d;
        }
        self.src.project_all(ds, out);
    }

    /// Appends the bearings of the `nu`×`nv` taps of pixel (u, v), row by row, each alone.
    #[inline(never)]
    fn tap_bearings(&self, u: f64, v: f64, nu: u32, nv: u32, out: &mut Vec<Option<Vector3<f64>>>) {
        for j in 0..nv {
            for i in 0..nu {
                out.push(self.bearing(u + tap_offset(i, nu), v + tap_offset(j, nv)));
            }
        }
    }

    /// The column shares of the taps of an `n`-wide supersampled pixel, n per column.
    fn tap_columns(&self, sep: &dyn Separable, n: u32) -> &[Share] {
        self.tap_columns[n as usize].get_or_init(|| {
            let w = self.dst.size().width;
            (0..w)
                .flat_map(|u| (0..n).map(move |i| sep.column(u as f64 + tap_offset(i, n))))
                .collect()
        })
    }

    /// The source positions of the centres of output row `v`, columns -1..=width (one beyond
    /// each side, for the scale estimate of the edge pixels).
    fn centres(&self, v: isize, parts: &mut Parts, out: &mut Vec<Option<Point2<f64>>>) {
        let w = self.dst.size().width as isize;
        let sees = |u: isize| self.seen.is_none_or(|seen| seen.may_see(u, v));
        parts.bearings.clear();
        match self.by_parts {
            Some(sep) => {
                // only the columns the footprint keeps are unprojected (None elsewhere)
                let (lo, hi) = self.seen.map_or((-1, w), |seen| seen.columns(v, -1, w));
                let kept = &self.centre_columns[(lo + 1) as usize..(hi + 2).max(lo + 1) as usize];
                if let Some(k) = &self.pinhole {
                    // the same positions, a group of lanes at a time (`lanes.rs`)
                    self.centres_lanes(sep, k, (v, lo), kept, &mut parts.lanes, out);
                    return;
                }
                parts.bearings.resize((lo + 1) as usize, None);
                if !kept.is_empty() {
                    sep.bearings(kept, sep.row(v as f64), &mut parts.bearings);
                }
                parts.bearings.resize((w + 2) as usize, None);
            }
            None if gate::stored_centres(self.dst, v, self.seen, &mut parts.bearings) => {}
            // a lens is unprojected only where the source may be seen (most of it is not)
            None => parts.bearings.extend(
                (-1..=w).map(|u| sees(u).then(|| self.bearing(u as f64, v as f64)).flatten()),
            ),
        }
        out.clear();
        self.bearings_to_src(&mut parts.bearings, out);
    }

    /// Builds output rows `rows` into `band` (its old contents dropped). Each pixel centre is mapped once: it is the tap of a pixel
    /// that is not supersampled (most of them), and the centres of its four neighbours give
    /// the local scale. A band maps the rows above and below it itself, with the same values
    /// its neighbouring bands compute, so any split into bands gives the same table.
    fn band(&self, rows: std::ops::Range<usize>, band: &mut Band) {
        let w = self.dst.size().width as usize;
        let n = rows.len() * w;
        band.quads.clear();
        band.counts.clear();
        band.row_lens.clear();
        band.row_reach.clear();
        band.cover.clear();
        band.gaps.clear();
        band.row_gaps.clear();
        band.row_gaps.push(0);
        band.top_level = 0;
        // room for the second blocks of some supersampled pixels: growing would copy it all
        band.quads.reserve(n + n / 4);
        band.counts.reserve(n);
        band.row_lens.reserve(rows.len());
        band.row_reach.reserve(rows.len());
        band.cover.reserve(n);
        let mut scratch = Scratch::default();
        let mut parts = Parts::default();
        let [mut above, mut here, mut below] = <[CentreRow; 3]>::default();
        self.centres_row(rows.start as isize - 1, &mut parts, &mut above);
        self.centres_row(rows.start as isize, &mut parts, &mut here);
        for v in rows {
            let row_start = band.quads.len();
            self.centres_row(v as isize + 1, &mut parts, &mut below);
            let centres = [&above, &here, &below].map(|r| &r.positions[..]);
            self.row(v, centres, &mut scratch, &mut parts, band);
            let row = &band.quads[row_start..];
            band.row_lens.push(row.len() as u32);
            band.row_reach
                .push(row.iter().map(|q| q.offset).max().unwrap_or(0));
            band.row_gaps.push(band.gaps.len() as u32);
            std::mem::swap(&mut above, &mut here);
            std::mem::swap(&mut here, &mut below);
        }
    }

    /// Output row `v` of the band, pixel by pixel, from the source positions of the centres of
    /// rows v - 1, v and v + 1 (columns -1..=width).
    fn row(
        &self,
        v: usize,
        [above, here, below]: [&[Option<Point2<f64>>]; 3],
        scratch: &mut Scratch,
        parts: &mut Parts,
        band: &mut Band,
    ) {
        let w = self.dst.size().width as usize;
        let period = (self.wrap == Wrap::Horizontal).then_some(self.source_size.width as f64);
        parts.tap_rows.iter_mut().for_each(Vec::clear);
        // which of the row's mapped pixels lie on one surface: the first few pixels that ask
        // alone (only a depth edge's ask where no footprint reaches the pyramid, as a lens's
        // magnified pixels), then the rest of the row at once
        let (mut asked, mut surface_from) = (0, None);
        let mut next = 0;
        while next < w {
            let u = next;
            next += 1;
            let centre = here[u + 1];
            if centre.is_none() {
                // no tap (what the general path below gives such a pixel, cheaply), for the
                // whole run of such pixels at once (most of a wide view)
                let run = 1 + here[u + 2..=w].iter().take_while(|c| c.is_none()).count();
                band.blank(u, run, w);
                next = u + run;
                continue;
            }
            // (no scale estimate where the cap allows one tap)
            let (nu, nv, level, scales) = match self.cap {
                1 => (1, 1, 0, (0.0, 0.0)),
                _ => {
                    let (su, sv) = scales2(
                        centre,
                        [here[u], here[u + 2]],
                        [above[u + 1], below[u + 1]],
                        period,
                    );
                    let by_edge = || {
                        let Some(s) = self.surfaces else { return false };
                        if surface_from.is_none() && asked < s.asked_alone() {
                            asked += 1;
                            return !s.one_surface(u, v);
                        }
                        let from = *surface_from.get_or_insert_with(|| {
                            let tail = here[1..=w].iter().rev().position(Option::is_some);
                            let end = w - tail.unwrap_or(0);
                            s.one_surface_row(v, u..end, &mut parts.one_surface);
                            u
                        });
                        !parts.one_surface[u - from]
                    };
                    let (nu, nv, level) = self.footprint(by_edge, (su, sv));
                    (nu, nv, level, (su, sv))
                }
            };
            let taps = nu * nv;
            let before = band.quads.len();
            let inside = if (nu, nv) == (1, 1) && self.one_block {
                // `quantize` of one block (a tap is one block here), without the scratch
                let block = self.block_at(centre.expect("mapped"), level);
                let width = self.source_size.width;
                band.quads.push(match block {
                    Some((x0, y0, w)) => {
                        quantize_block(y0 * width + x0, w, WEIGHT_ONE, WEIGHT_ONE as f64)
                    }
                    None => Quad::default(),
                });
                block.is_some() as u32
            } else if (nu, nv) == (1, 1) {
                scratch.blocks.clear();
                let inside = self.add_tap(centre, level, scratch) as u32;
                quantize(scratch, inside, taps, &mut band.quads);
                inside
            } else {
                let near = local::near([above, here, below], u);
                let (quads, at) = (&mut band.quads, (u, v, level));
                self.supersampled(at, (nu, nv), &near, scratch, parts, quads)
            };
            band.counts.push((band.quads.len() - before) as u8);
            // (a pixel with nothing inside samples no level: which levels the table reads does
            // not depend on how far beyond the source it maps pixels)
            if inside > 0 {
                band.top_level = band.top_level.max(level);
            }
            // a pyramid sample near the border covers what its taps would have covered
            let (inside, taps) = match self.taps_cover && level > 0 {
                true => self
                    .taps_cover((u, v), centre, scales, [above, here, below], parts)
                    .unwrap_or((inside, taps)),
                false => (inside, taps),
            };
            band.cover.push(match inside {
                0 => Cover::None,
                k if k == taps => Cover::Full,
                _ => Cover::Part,
            });
        }
    }

    /// Appends the quads of supersampled pixel (u, v) (`nu`×`nv` taps at pyramid level
    /// `level`, its neighbourhood of mapped centres `near`) and gives how many of its taps lie
    /// inside the source. The taps are interpolated from `near` where that is exact enough
    /// (see `local.rs`), else each mapped; a pair's are its blocks at half weight (see
    /// `pair.rs`), more taps are merged in a dense grid where it fits (see `dense.rs`), else
    /// by offset.
    fn supersampled(
        &self,
        (u, v, level): (usize, usize, u32),
        (nu, nv): (u32, u32),
        near: &local::Near,
        scratch: &mut Scratch,
        parts: &mut Parts,
        quads: &mut Vec<Quad>,
    ) -> u32 {
        parts.taps.clear();
        match (nu * nv == 2).then(|| self.local_pair(near, nu == 2, level)) {
            Some(Some(pair)) => parts.taps.extend_from_slice(&pair),
            _ => self.tap_positions((u, v, level), (nu, nv), near, parts),
        }
        if let (2, &[a, b]) = (nu * nv, &parts.taps[..]) {
            if let Some(inside) = self.pair_quads(&[a, b], level, quads) {
                return inside;
            }
        }
        if let Some(inside) = self.dense_quads(&parts.taps, level, scratch, quads) {
            return inside;
        }
        scratch.blocks.clear();
        let mut inside = 0;
        for &p in &parts.taps {
            inside += self.add_tap(p, level, scratch) as u32;
        }
        quantize(scratch, inside, nu * nv, quads);
        inside
    }

    /// The source positions of the `nu`×`nv` taps of pixel (u, v) (at pyramid level `level`,
    /// its neighbourhood of mapped centres `near`) into `parts.taps`, row by row: interpolated
    /// from `near` where that is exact enough (see `local.rs`), else each mapped.
    fn tap_positions(
        &self,
        (u, v, level): (usize, usize, u32),
        (nu, nv): (u32, u32),
        near: &local::Near,
        parts: &mut Parts,
    ) {
        parts.taps.clear();
        if !self.local_taps(near, (nu, nv, level), &mut parts.taps) {
            // the taps row by row, each row's columns left to right
            parts.bearings.clear();
            match self.tap_parts {
                Some(sep) => {
                    let columns = &self.tap_columns(sep, nu)[u * nu as usize..][..nu as usize];
                    let rows = &mut parts.tap_rows[nv as usize];
                    if rows.is_empty() {
                        rows.extend((0..nv).map(|j| sep.row(v as f64 + tap_offset(j, nv))));
                    }
                    for &row in rows.iter() {
                        sep.bearings(columns, row, &mut parts.bearings);
                    }
                }
                None => self.tap_bearings(u as f64, v as f64, nu, nv, &mut parts.bearings),
            }
            match self.surfaces {
                // a depth-guided source places the taps by their output positions too
                Some(s) => self.taps_through(s, (u, v), (nu, nv), parts),
                None => self.bearings_to_src(&mut parts.bearings, &mut parts.taps),
            }
        }
    }

    /// Adds the bilinear weights of a tap at source position `p` (sampled at pyramid level
    /// `level`) to the pixel's blocks, at unit scale (the pixel's taps are averaged when
    /// quantized). Whether it was inside.
    #[inline(always)]
    fn add_tap(&self, p: Option<Point2<f64>>, level: u32, s: &mut Scratch) -> bool {
        let Some(p) = p else { return false };
        let Some((x0, y0, [tl, bl, tr, br])) = self.block_at(p, level) else {
            return false;
        };
        let size = self.source_size;
        let offset = y0 * size.width + x0;
        if x0 + 1 == self.level_width(level) {
            // The right neighbour is column 0 (across a 360° source's wrap, at any level, or
            // the same column of a one-pixel-wide source): a block of its own, left column only.
            merge(&mut s.blocks, offset, [tl, bl, 0.0, 0.0]);
            merge(&mut s.blocks, y0 * size.width, [tr, br, 0.0, 0.0]);
        } else {
            merge(&mut s.blocks, offset, [tl, bl, tr, br]);
        }
        true
    }

    /// The width of pyramid level `level` (the source's at level 0): a block whose top-left
    /// column is its last wraps (see [`Builder::add_tap`]).
    #[inline(always)]
    fn level_width(&self, level: u32) -> u32 {
        match level {
            0 => self.source_size.width,
            k => self.shapes[k as usize].0,
        }
    }

    /// The bilinear block of a tap at source position `p`: its top-left source pixel (x0, y0)
    /// and the weights of top-left, bottom-left, top-right, bottom-right; None outside.
    #[inline(always)]
    fn block(&self, p: Point2<f64>) -> Option<(u32, u32, [f64; 4])> {
        let size = self.source_size;
        let (sw, sh) = (size.width as f64, size.height as f64);
        let (mut x, y) = (p.x, p.y);
        if self.wrap == Wrap::Horizontal {
            x = x.rem_euclid(sw);
        } else if !column_inside(x, sw) {
            return None;
        }
        if !row_inside(y, sh) {
            return None;
        }
        // Within half a pixel of the border the edge pixel is repeated (it covers that area).
        let y = y.clamp(0.0, sh - 1.0);
        // y, x and the weights are >= 0 here, where `as` truncation is floor (and no libm call)
        let y0 = (y as u32).min(size.height.saturating_sub(2));
        let fy = if size.height > 1 { y - y0 as f64 } else { 0.0 };
        let x0 = if self.wrap == Wrap::Horizontal {
            (x as u32).min(size.width - 1)
        } else {
            x = x.clamp(0.0, sw - 1.0);
            (x as u32).min(size.width.saturating_sub(2))
        };
        let fx = x - x0 as f64;
        let (tl, bl) = ((1.0 - fx) * (1.0 - fy), (1.0 - fx) * fy);
        let (tr, br) = (fx * (1.0 - fy), fx * fy);
        Some((x0, y0, [tl, bl, tr, br]))
    }

    /// Concatenates the bands (in row order) into the table, its rows in groups of pixels.
    fn finish(&self, bands: &[Band]) -> RemapTable {
        let size = self.dst.size();
        let (w, h) = (size.width as usize, size.height as usize);
        let groups = w.div_ceil(LANES) * h;
        // about one round a stored group, a few more at the supersampled sides
        let total: usize = bands.iter().map(|b| b.quads.len()).sum();
        let stored: usize = bands.iter().map(|b| b.counts.len()).sum();
        let mut t = RemapTable {
            size,
            source_size: self.source_size,
            rounds: Vec::with_capacity(stored.div_ceil(LANES) + (total - stored) / 2),
            depth: Vec::with_capacity(groups),
            row_starts: Vec::with_capacity(h + 1),
            row_reach: Vec::with_capacity(h),
            cover: Vec::with_capacity(w * h),
            levels: bands.iter().map(|b| b.top_level + 1).max().unwrap_or(1),
        };
        t.row_starts.push(0);
        for b in bands {
            let (mut quads, mut counts, mut cover) = (&b.quads[..], &b.counts[..], &b.cover[..]);
            for (i, (&len, &reach)) in b.row_lens.iter().zip(&b.row_reach).enumerate() {
                let gaps = &b.gaps[b.row_gaps[i] as usize..b.row_gaps[i + 1] as usize];
                let gap: usize = (gaps.iter())
                    .map(|&(g0, g1)| (g1 as usize * LANES).min(w) - g0 as usize * LANES)
                    .sum();
                let row;
                (row, quads) = quads.split_at(len as usize);
                let (row_counts, row_cover);
                (row_counts, counts) = counts.split_at(w - gap);
                (row_cover, cover) = cover.split_at(w - gap);
                t.push_row((row, row_counts, row_cover), gaps, reach);
            }
        }
        t
    }
}

/// Offset from a pixel's centre of tap `i` of the `n` along one axis of its supersampling grid.
#[inline]
fn tap_offset(i: u32, n: u32) -> f64 {
    (i as f64 + 0.5) / n as f64 - 0.5
}
