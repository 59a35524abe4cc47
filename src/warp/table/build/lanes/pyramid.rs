//! The build of a pyramid table (see `level.rs`) of any output from a pinhole source
//! (serially, or in bands of rows as `Builder::band`), a group of [`LANES`] pixels at a time:
//! each row's centres mapped into columns of x and y (`centres.rs`: in lanes for a separable
//! output, one by one for a lens; NaN x where a centre has none), each group's scales and
//! levels taken from them, and its pixels' blocks made straight from the lanes with the very
//! operations of [`Builder::block_at`] and `quantize_block`, a level at a time. A group of one-tap pixels (a turned view drawn per
//! training sample: all but its anisotropic sides) is one round; its two-tap pixels (the
//! anisotropic sides: 2×1 or 1×2 taps, interpolated along their axis from the centres beside
//! them, as `Builder::local_pair`, each tap's block at half weight, as `Builder::pair_quads`)
//! add a second round where they have two blocks. A group with a pixel of three or more taps,
//! or of two whose interpolation does not hold, takes the per-pixel path (`Builder::row`'s)
//! for those, and [`RemapTable::push_row`]'s rounds: the same table, entry for entry, without
//! the band's per-pixel quads and counts. Groups without a mapped centre are stored without
//! rounds (depth 0), as the per-pixel build stores its runs of such pixels.

use super::super::{count, local, Builder, Parts, Scratch, BAND_ROWS};
use super::{clamp, quantize, round_of, tail, Lanes};
use crate::camera::{Intrinsics, Separable};
use crate::warp::kernel::{Quad, Round, LANES};
use crate::warp::table::{column_inside, row_inside, Cover, RemapTable, MAX_SUPERSAMPLE};
use rayon::prelude::*;

mod centres;
mod pairs;

use centres::{CentreScratch, Centres};
use pairs::{pair_taps, Pair};

#[cfg(test)]
thread_local! {
    /// Set by a test on its thread: [`Builder::pyramid_lanes_table`] declines, so that the
    /// table is the per-pixel build's, the reference the lanes must equal.
    pub(in crate::warp::table::build) static PER_PIXEL_ONLY: std::cell::Cell<bool> =
        const { std::cell::Cell::new(false) };
}

/// Scratch space of the groups built pixel by pixel.
#[derive(Default)]
struct Fallback {
    scratch: Scratch,
    parts: Parts,
    quads: Vec<Quad>,
    /// Each pixel's count of `quads`.
    counts: Vec<u8>,
}

/// Most levels a table samples: the source and 3 above it (`MAX_SUPERSAMPLE` source pixels a
/// level pixel at the last).
const MAX_LEVELS: usize = MAX_SUPERSAMPLE.ilog2() as usize + 1;

/// What a group's lanes need of the levels, indexed by level (at most 8 of them: a
/// supersampling of at most 8 samples 4 levels above the source).
struct Levels {
    /// At index k >= 1: the smallest squared scale (the smaller axis's) of a level-k pixel,
    /// NaN past the last level (no scale reaches it): `Builder::level_of`'s bounds.
    from: [f64; LANES],
    /// The smallest squared scale at a pixel's level from which `count` gives it two taps or
    /// more along that axis, and three or more.
    two_taps: f64,
    three_taps: f64,
    /// Each level's last column and row (as positions), and its last block's top-left ones.
    last: [[f64; LANES]; 2],
    last_block: [[i32; LANES]; 2],
    /// Each level's first row in the pyramid's buffer.
    row: [u32; LANES],
}

impl Builder<'_> {
    /// [`Levels`] of this table's pyramid. `level_of` and `count` are read through their
    /// bounds, found by bisection over the ordered bits of the non-negative doubles (each a
    /// monotone step of a squared scale): the very choices, in comparisons that vectorise.
    fn levels(&self) -> Levels {
        let mut l = Levels {
            from: [f64::NAN; LANES],
            two_taps: first_true(|s| count(s).min(self.cap) >= 2),
            three_taps: first_true(|s| count(s).min(self.cap) >= 3),
            last: [[0.0; LANES]; 2],
            last_block: [[0; LANES]; 2],
            row: [0; LANES],
        };
        for (k, &(w, h, row)) in self.shapes.iter().enumerate().take(MAX_LEVELS) {
            if k > 0 {
                l.from[k] = first_true(|s| self.level_of(s) >= k as u32);
            }
            l.last[0][k] = w as f64 - 1.0;
            l.last[1][k] = h as f64 - 1.0;
            l.last_block[0][k] = w as i32 - 2;
            l.last_block[1][k] = h as i32 - 2;
            l.row[k] = row;
        }
        l
    }

    /// The table, where this build makes it: of an output from a pinhole source whose
    /// pyramid the pixels sample (None elsewhere).
    pub(in crate::warp::table::build) fn pyramid_lanes_table(
        &self,
        parallel: bool,
    ) -> Option<RemapTable> {
        // (block offsets times 3 fit a u32 there: the lanes' rounds do not check them)
        let small =
            self.source_size.width as u64 * self.source_size.height as u64 * 3 <= u32::MAX as u64;
        // (an output without column and row shares, a lens, has its centres mapped one by one
        // as `Builder::centres` maps them; the rest is the same)
        let (sep, Some(k)) = (self.by_parts, &self.pinhole) else {
            return None;
        };
        #[cfg(test)]
        if PER_PIXEL_ONLY.get() {
            return None;
        }
        if !small || !self.one_block || !(2..=MAX_LEVELS).contains(&self.shapes.len()) {
            return None;
        }
        let h = self.dst.size().height as usize;
        if !parallel {
            return Some(self.pyramid_lanes_rows(sep, k, 0..h));
        }
        // bands of rows on rayon's pool, each mapping the rows beside it too (as `band`)
        let bands: Vec<RemapTable> = (0..h.div_ceil(BAND_ROWS))
            .into_par_iter()
            .map(|i| self.pyramid_lanes_rows(sep, k, i * BAND_ROWS..((i + 1) * BAND_ROWS).min(h)))
            .collect();
        let mut bands = bands.into_iter();
        let mut t = bands
            .next()
            .unwrap_or_else(|| self.pyramid_lanes_rows(sep, k, 0..0));
        for b in bands {
            let base = t.rounds.len() as u32;
            t.rounds.extend_from_slice(&b.rounds);
            t.depth.extend_from_slice(&b.depth);
            t.row_starts
                .extend(b.row_starts[1..].iter().map(|&s| base + s));
            t.row_reach.extend_from_slice(&b.row_reach);
            t.cover.extend_from_slice(&b.cover);
            t.levels = t.levels.max(b.levels);
        }
        Some(t)
    }

    /// The table's rows `rows` (the whole table where they are all its rows).
    fn pyramid_lanes_rows(
        &self,
        sep: Option<&dyn Separable>,
        k: &Intrinsics,
        rows: std::ops::Range<usize>,
    ) -> RemapTable {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2 (checked just above).
            return unsafe { self.pyramid_lanes_avx2(sep, k, rows) };
        }
        self.pyramid_lanes_any(sep, k, rows)
    }

    /// [`Builder::pyramid_lanes_rows`] compiled for AVX2 (the same IEEE operations, the
    /// same bits).
    ///
    /// # Safety
    ///
    /// The processor must have AVX2 (`is_x86_feature_detected!("avx2")`). It reads and writes
    /// only through safe slices.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn pyramid_lanes_avx2(
        &self,
        sep: Option<&dyn Separable>,
        k: &Intrinsics,
        rows: std::ops::Range<usize>,
    ) -> RemapTable {
        self.pyramid_lanes_any(sep, k, rows)
    }

    #[inline(always)]
    fn pyramid_lanes_any(
        &self,
        sep: Option<&dyn Separable>,
        k: &Intrinsics,
        rows: std::ops::Range<usize>,
    ) -> RemapTable {
        let size = self.dst.size();
        let (w, h) = (size.width as usize, rows.len());
        let groups = w.div_ceil(LANES);
        let mut t = RemapTable {
            size,
            source_size: self.source_size,
            // (room for the extra rounds of the groups with a supersampled pixel: growing
            // would copy them all)
            rounds: Vec::with_capacity(groups * h + groups * h / 4),
            depth: Vec::with_capacity(groups * h),
            row_starts: Vec::with_capacity(h + 1),
            row_reach: Vec::with_capacity(h),
            cover: vec![Cover::None; w * h],
            levels: 1,
        };
        t.row_starts.push(0);
        let mut scratch = CentreScratch::default();
        let mut centres: [Centres; 3] = Default::default();
        let v0 = rows.start as isize;
        self.centres_soa(sep, k, v0 - 1, &mut scratch, &mut centres[0]);
        self.centres_soa(sep, k, v0, &mut scratch, &mut centres[1]);
        let (mut fallback, mut top) = (Fallback::default(), 0);
        let levels = self.levels();
        for v in rows {
            self.centres_soa(sep, k, v as isize + 1, &mut scratch, &mut centres[2]);
            let reach = self.pyramid_row(v, &centres, &levels, &mut t, &mut fallback, &mut top);
            t.row_reach.push(reach);
            t.row_starts.push(t.rounds.len() as u32);
            centres.rotate_left(1);
        }
        t.levels = top + 1;
        t
    }

    /// Appends output row `v`'s rounds from the centres of rows v - 1, v and v + 1 and marks
    /// the pixels they cover; raises `top` to the highest level a pixel samples. Gives the
    /// row's largest block offset.
    #[inline(always)]
    fn pyramid_row(
        &self,
        v: usize,
        rows: &[Centres; 3],
        levels: &Levels,
        t: &mut RemapTable,
        fallback: &mut Fallback,
        top: &mut u32,
    ) -> u32 {
        let w = self.dst.size().width as usize;
        let [above, here, below] = rows;
        // (the row's tap rows of supersampled pixels, as `Builder::row` clears them)
        fallback.parts.tap_rows.iter_mut().for_each(Vec::clear);
        let mut reach = 0;
        // the groups with a pixel the footprint keeps; the others take nothing (most groups
        // of a wide view) and are stored without rounds (depth 0: what the per-pixel build's
        // runs of pixels without a centre give; nothing to write, nothing to apply)
        let (lo, hi) = (
            here.kept.start.saturating_sub(1),
            (here.kept.end.saturating_sub(1)).min(w),
        );
        let (g_lo, g_hi) = if lo < hi {
            (lo / LANES, hi.div_ceil(LANES))
        } else {
            (0, 0)
        };
        let blank = |t: &mut RemapTable, groups: usize| {
            t.depth.resize(t.depth.len() + groups, 0);
        };
        blank(t, g_lo);
        for first in (g_lo * LANES..g_hi * LANES).step_by(LANES) {
            let n = LANES.min(w - first);
            let centre = [&here.x, &here.y].map(|c| Centres::lanes(c, first + 1));
            let mut valid = [false; LANES];
            for (l, ok) in valid.iter_mut().enumerate().take(n) {
                *ok = !centre[0][l].is_nan();
            }
            if !valid.contains(&true) {
                // (most groups of a wide view: outside the footprint)
                t.depth.push(0);
                continue;
            }
            let at = |c: &Centres, i: usize| [&c.x, &c.y].map(|c| Centres::lanes(c, i));
            let across = [at(here, first), at(here, first + 2)];
            let down = [at(above, first + 1), at(below, first + 1)];
            let su = scales2_lanes(centre, across);
            let sv = scales2_lanes(centre, down);
            let (level, one_tap, pair) = levels_lanes(levels, su, sv, valid);
            // (the row's place in `t`, which may hold a band of rows from v)
            let at = t.row_reach.len() * w + first;
            let cover = &mut t.cover[at..at + n];
            let mut lanes = valid;
            for (lane, &one) in lanes.iter_mut().zip(&one_tap) {
                *lane &= one;
            }
            let (round, inside, far) = self.one_tap_group(centre, levels, level, lanes);
            // the two-tap pixels whose taps are interpolated, made from the lanes too
            let pairs: [bool; LANES] =
                std::array::from_fn(|l| valid[l] && !lanes[l] && pair[l] != Pair::No);
            let (taps, paired) = match pairs.contains(&true) {
                true => pair_taps(self, centre, [across, down], (pair, level), pairs),
                false => Default::default(),
            };
            if paired.contains(&true) && (0..LANES).all(|l| valid[l] == (lanes[l] || paired[l])) {
                let one = (&round, inside);
                let far = far.max(self.pair_group(
                    one,
                    (taps, paired),
                    levels,
                    level,
                    n,
                    cover,
                    (&mut t.rounds, &mut t.depth),
                ));
                *top = (*top).max(top_sampled(&level, cover));
                reach = reach.max(far);
                continue;
            }
            if lanes != valid {
                // a pixel of two taps or more: those pixel by pixel, the others from the lanes
                let group = (&round, lanes, inside);
                let scales = ([su, sv], level);
                let far = self.fallback_group((first, v), rows, group, scales, cover, fallback);
                *top = (*top).max(top_sampled(&level, cover));
                t.push_group(&fallback.quads, &fallback.counts);
                reach = reach.max(far);
                continue;
            }
            for (c, &inside) in cover.iter_mut().zip(&inside) {
                if inside {
                    *c = Cover::Full;
                }
            }
            *top = (*top).max(top_sampled(&level, cover));
            t.rounds.push(tail(round, n));
            t.depth.push(1);
            reach = reach.max(far);
        }
        blank(t, w.div_ceil(LANES) - g_hi);
        reach
    }

    /// The round of a group of one-tap pixels of centres `c` (x, y lanes; `valid` where a
    /// pixel has one) sampling pyramid levels `level`, which lanes have a block inside the
    /// source, and the largest block offset: each lane what [`Builder::block_at`] and
    /// `quantize_block` give it, a level at a time (most groups have one).
    #[inline(always)]
    fn one_tap_group(
        &self,
        c: [Lanes; 2],
        levels: &Levels,
        level: [u32; LANES],
        valid: [bool; LANES],
    ) -> (Round, [bool; LANES], u32) {
        let mut present = 0u32;
        for l in 0..LANES {
            present |= (valid[l] as u32) << level[l];
        }
        if present.count_ones() <= 1 {
            return self.one_tap_level(c, levels, present.trailing_zeros() % 8, valid);
        }
        let (mut round, mut inside, mut far) = (Round::default(), [false; LANES], 0);
        for k in (0..LANES as u32).filter(|&k| present & (1 << k) != 0) {
            let at: [bool; LANES] = std::array::from_fn(|l| valid[l] && level[l] == k);
            let (r, i, f) = self.one_tap_level(c, levels, k, at);
            for l in (0..LANES).filter(|&l| at[l]) {
                (round.offset[l], round.w[l], inside[l]) = (r.offset[l], r.w[l], i[l]);
            }
            far = far.max(f);
        }
        (round, inside, far)
    }

    /// [`Builder::one_tap_group`] of the lanes `valid` at level `k` (the others' blocks
    /// all-zero at offset 0).
    #[inline(always)]
    fn one_tap_level(
        &self,
        c: [Lanes; 2],
        levels: &Levels,
        k: u32,
        valid: [bool; LANES],
    ) -> (Round, [bool; LANES], u32) {
        let (offset, weights, inside) = self.blocks_level(c, levels, k, valid);
        let mut w = [[0i32; LANES]; 4];
        for l in 0..LANES {
            let q = quantize([weights[0][l], weights[1][l], weights[2][l], weights[3][l]]);
            for i in 0..4 {
                w[i][l] = if inside[l] { q[i] } else { 0 };
            }
        }
        // (three times an offset fits a u32: `pyramid_lanes_table` checks the source's size,
        // and a level's rows are the source's)
        (
            round_of(&offset, &w),
            inside,
            offset.into_iter().max().unwrap_or(0),
        )
    }

    /// The bilinear blocks at level `k` of the lanes `valid` at positions `c` (x, y lanes):
    /// each lane's top-left pixel's offset in the pyramid and float weights (top-left,
    /// bottom-left, top-right, bottom-right) as [`Builder::block_at`] gives them, and whether
    /// it is inside the source (the others' offsets 0).
    #[inline(always)]
    fn blocks_level(
        &self,
        [cx, cy]: [Lanes; 2],
        levels: &Levels,
        k: u32,
        valid: [bool; LANES],
    ) -> ([u32; LANES], [Lanes; 4], [bool; LANES]) {
        let size = self.source_size;
        let (sw, sh) = (size.width as f64, size.height as f64);
        // (a level below 8: no bounds check)
        let k = k as usize % LANES;
        let (last_x, last_y) = (levels.last[0][k], levels.last[1][k]);
        let (block_x, block_y) = (levels.last_block[0][k], levels.last_block[1][k]);
        let row = levels.row[k];
        // (dividing by 2^k is multiplying by 2^-k, bit for bit: both exact)
        let f = 1.0 / (1u32 << k) as f64;
        let mut inside = [false; LANES];
        let mut offset = [0u32; LANES];
        let mut w = [[0.0; LANES]; 4];
        for l in 0..LANES {
            let (x, y) = (cx[l], cy[l]);
            // `block_at`'s test: level 0's border whatever the level
            let ok = valid[l] && column_inside(x, sw) && row_inside(y, sh);
            let (x, y) = if ok { (x, y) } else { (0.0, 0.0) };
            // a level pixel's centre at 2^k·(x + 0.5) - 0.5 (level 0: the position itself)
            let (xk, yk) = ((x + 0.5) * f - 0.5, (y + 0.5) * f - 0.5);
            let (x, y) = if k == 0 { (x, y) } else { (xk, yk) };
            let x = clamp(x, last_x);
            let y = clamp(y, last_y);
            // SAFETY: 0 <= x, y < 2^31 (clamped to the level); truncation is floor here
            let x0 = unsafe { x.to_int_unchecked::<i32>() }.min(block_x);
            let y0 = unsafe { y.to_int_unchecked::<i32>() }.min(block_y);
            let (fx, fy) = (x - x0 as f64, y - y0 as f64);
            let b = [
                (1.0 - fx) * (1.0 - fy),
                (1.0 - fx) * fy,
                fx * (1.0 - fy),
                fx * fy,
            ];
            inside[l] = ok;
            // (below the pyramid's pixel count: no wrap, see `lanes_table`)
            let at = (row.wrapping_add(y0 as u32))
                .wrapping_mul(size.width)
                .wrapping_add(x0 as u32);
            offset[l] = if ok { at } else { 0 };
            for i in 0..4 {
                w[i][l] = b[i];
            }
        }
        (offset, w, inside)
    }

    /// The quads of a group's pixels (the `cover.len()` from column `first` of row `v`) into
    /// `fallback.quads` (their counts into `fallback.counts`, their covers into `cover`): a
    /// one-tap pixel's (`one_tap`) from the lanes' `round` (`inside`: whether it has a
    /// block), the others pixel by pixel as `Builder::row` makes them, from the lanes'
    /// squared scales and levels. Gives their largest block offset.
    #[inline(never)]
    fn fallback_group(
        &self,
        (first, v): (usize, usize),
        rows: &[Centres; 3],
        (round, one_tap, inside): (&Round, [bool; LANES], [bool; LANES]),
        ([su, sv], level): ([Lanes; 2], [u32; LANES]),
        cover: &mut [Cover],
        fallback: &mut Fallback,
    ) -> u32 {
        let Fallback {
            scratch,
            parts,
            quads,
            counts,
        } = fallback;
        quads.clear();
        counts.clear();
        for (l, c) in cover.iter_mut().enumerate() {
            let u = first + l;
            if one_tap[l] {
                quads.push(Quad {
                    offset: round.offset[l] / 3,
                    w: round.w[l],
                });
                counts.push(1);
                *c = if inside[l] { Cover::Full } else { Cover::None };
                continue;
            }
            let before = quads.len();
            let near: local::Near =
                std::array::from_fn(|r| std::array::from_fn(|d| rows[r].at(u + d)));
            if near[1][1].is_none() {
                quads.push(Quad::default());
                counts.push(1);
                *c = Cover::None;
                continue;
            }
            // `Builder::row`'s taps from the lanes' scales and level (a division by 4^k as
            // the exact product by 4^-k): two or more, the lanes found
            let down = 1.0 / (1u32 << (2 * level[l])) as f64;
            let (nu, nv) = (
                count(su[l] * down).min(self.cap),
                count(sv[l] * down).min(self.cap),
            );
            debug_assert!((nu, nv) != (1, 1), "a one-tap pixel of the lanes");
            let at = (u, v, level[l]);
            let inside = self.supersampled(at, (nu, nv), &near, scratch, parts, quads);
            counts.push((quads.len() - before) as u8);
            *c = match inside {
                0 => Cover::None,
                k if k == nu * nv => Cover::Full,
                _ => Cover::Part,
            };
        }
        quads.iter().map(|q| q.offset).max().unwrap_or(0)
    }
}

/// `scales2` (`level.rs`) along one axis of a group's pixels, centres `c` (x, y lanes) and
/// neighbours `[a, b]` (NaN x where one has no centre), with its operations: the squared
/// distance between the neighbours over 4, else to the one there is, else 0.
#[inline(always)]
fn scales2_lanes(c: [Lanes; 2], [a, b]: [[Lanes; 2]; 2]) -> Lanes {
    // (nalgebra's norm_squared of a 2-vector: dx·dx + dy·dy)
    let dist2 = |p: [&Lanes; 2], q: [&Lanes; 2], l: usize| {
        let (dx, dy) = (q[0][l] - p[0][l], q[1][l] - p[1][l]);
        dx * dx + dy * dy
    };
    let [a, b, c] = [&a, &b, &c].map(|p| [&p[0], &p[1]]);
    let mut out = [0.0; LANES];
    if (0..LANES).all(|l| !a[0][l].is_nan() && !b[0][l].is_nan()) {
        // (most groups: both neighbours of every pixel)
        for (l, out) in out.iter_mut().enumerate() {
            *out = dist2(a, b, l) / 4.0;
        }
        return out;
    }
    for (l, out) in out.iter_mut().enumerate() {
        let (has_a, has_b) = (!a[0][l].is_nan(), !b[0][l].is_nan());
        let both = dist2(a, b, l) / 4.0;
        let (to_a, to_b) = (dist2(a, c, l), dist2(c, b, l));
        *out = match (has_a, has_b) {
            (true, true) => both,
            (true, false) => to_a,
            (false, true) => to_b,
            (false, false) => 0.0,
        };
    }
    out
}

/// The levels of a group's pixels of squared scales `su` and `sv` (where `valid`; 0
/// elsewhere), whether each takes one tap there along both axes, and which take two taps side
/// by side ([`Pair::Across`]) or one above the other ([`Pair::Down`]): `Builder::row`'s
/// `level_of` and `count`, through their bounds (`levels`).
#[inline(always)]
fn levels_lanes(
    levels: &Levels,
    su: Lanes,
    sv: Lanes,
    valid: [bool; LANES],
) -> ([u32; LANES], [bool; LANES], [Pair; LANES]) {
    let mut level = [0u32; LANES];
    let mut one = [false; LANES];
    let mut pair = [Pair::No; LANES];
    for l in 0..LANES {
        let m = su[l].min(sv[l]);
        let mut k = 0u32;
        // (a supersampling of at most 8 samples has at most 4 levels)
        for &from in &levels.from[1..MAX_LEVELS] {
            k += (m >= from) as u32;
        }
        let k = if valid[l] { k } else { 0 };
        // (`row`'s division by 4^k, as the exact product by 4^-k)
        let down = 1.0 / (1u32 << (2 * k)) as f64;
        // (`count` gives one tap where a scale is not finite)
        let fine = |s: f64| !s.is_finite() || s < levels.two_taps;
        let two = |s: f64| s.is_finite() && s >= levels.two_taps && s < levels.three_taps;
        let (u, v) = (su[l] * down, sv[l] * down);
        one[l] = fine(u) && fine(v);
        pair[l] = match (two(u) && fine(v), fine(u) && two(v)) {
            (true, _) => Pair::Across,
            (_, true) => Pair::Down,
            _ => Pair::No,
        };
        level[l] = k;
    }
    (level, one, pair)
}

/// The smallest non-negative double at which `step` (false, then true from some point on:
/// monotone over the finite non-negative doubles, which order as their bits do) is true;
/// infinity where no finite one is.
fn first_true(step: impl Fn(f64) -> bool) -> f64 {
    if step(0.0) {
        return 0.0;
    }
    let (mut lo, mut hi) = (0u64, f64::MAX.to_bits());
    if !step(f64::MAX) {
        return f64::INFINITY;
    }
    // step(lo) false, step(hi) true
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if step(f64::from_bits(mid)) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    f64::from_bits(hi)
}

/// The highest level a group's pixels sample: those with something inside the source only
/// (as the per-pixel build counts them: which levels a table reads does not depend on how far
/// beyond the source it maps pixels).
fn top_sampled(level: &[u32; LANES], cover: &[Cover]) -> u32 {
    level
        .iter()
        .zip(cover)
        .filter(|(_, c)| !matches!(c, Cover::None))
        .map(|(&k, _)| k)
        .max()
        .unwrap_or(0)
}
