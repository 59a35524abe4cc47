//! The two-tap pixels of a pyramid table's groups in lanes (see `pyramid.rs`): which pixels
//! take two taps, their taps interpolated along their axis (`Builder::local_pair`'s
//! operations) and their blocks at half weight (`Builder::pair_quads`'s), and the group's
//! rounds.

use super::super::super::pair::{HALF, HALF_SCALE};
use super::super::super::{local, tap_offset, Builder};
use super::super::{quantize_as, tail, Lanes};
use super::Levels;
use crate::warp::kernel::{Round, LANES, WEIGHT_ONE};
use crate::warp::table::Cover;

impl Builder<'_> {
    /// Appends the rounds of a group whose pixels take one tap (`one`: their round, made by
    /// [`Builder::one_tap_group`], and which have a block inside) or two (`paired`, at `taps`,
    /// levels `level`), as `Builder::pair_quads` and [`RemapTable::push_group`] make them:
    /// a second round where a pixel has two blocks. Marks the `n` pixels' covers; gives the
    /// largest block offset of the pairs.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn pair_group(
        &self,
        (round, inside): (&Round, [bool; LANES]),
        (taps, paired): ([[Lanes; 2]; 2], [bool; LANES]),
        levels: &Levels,
        level: [u32; LANES],
        n: usize,
        cover: &mut [Cover],
        (rounds, depth): (&mut Vec<Round>, &mut Vec<u8>),
    ) -> u32 {
        // each tap's blocks, a level at a time
        let mut present = 0u32;
        for l in 0..LANES {
            present |= (paired[l] as u32) << level[l];
        }
        let mut blocks = [([0u32; LANES], [[0.0; LANES]; 4], [false; LANES]); 2];
        for k in (0..LANES as u32).filter(|&k| present & (1 << k) != 0) {
            let at: [bool; LANES] = std::array::from_fn(|l| paired[l] && level[l] == k);
            for (tap, b) in taps.iter().zip(&mut blocks) {
                let (offset, w, ins) = self.blocks_level(*tap, levels, k, at);
                for l in (0..LANES).filter(|&l| at[l]) {
                    (b.0[l], b.2[l]) = (offset[l], ins[l]);
                    for (to, from) in b.1.iter_mut().zip(&w) {
                        to[l] = from[l];
                    }
                }
            }
        }
        let (mut first, mut second) = (*round, *round);
        second.w = [[0; 4]; LANES];
        let (mut deep, mut far) = (false, 0);
        for l in 0..LANES {
            if l < n {
                cover[l] = match (paired[l], inside[l]) {
                    (false, true) => Cover::Full,
                    (false, false) => Cover::None,
                    (true, _) => match blocks[0].2[l] as u8 + blocks[1].2[l] as u8 {
                        0 => Cover::None,
                        1 => Cover::Part,
                        _ => Cover::Full,
                    },
                };
            }
            if !paired[l] {
                continue;
            }
            let at = |(o, w, i): &([u32; LANES], [Lanes; 4], [bool; LANES])| {
                (o[l], [w[0][l], w[1][l], w[2][l], w[3][l]], i[l])
            };
            let [(o0, w0, in0), (o1, w1, in1)] = [at(&blocks[0]), at(&blocks[1])];
            let same = in0 && in1 && o0 == o1;
            let (o, q) = match (in0, in1) {
                _ if same => {
                    let w = [w0[0] + w1[0], w0[1] + w1[1], w0[2] + w1[2], w0[3] + w1[3]];
                    (o0, quantize_as(w, HALF_SCALE, WEIGHT_ONE))
                }
                (true, _) => (o0, quantize_as(w0, HALF_SCALE, HALF)),
                (false, true) => (o1, quantize_as(w1, HALF_SCALE, HALF)),
                (false, false) => (0, [0; 4]),
            };
            // (three times an offset fits a u32: see `one_tap_level`)
            first.offset[l] = o.wrapping_mul(3);
            first.w[l] = [q[0] as i16, q[1] as i16, q[2] as i16, q[3] as i16];
            second.offset[l] = first.offset[l];
            far = far.max(o);
            if in0 && in1 && !same {
                second.offset[l] = o1.wrapping_mul(3);
                let q = quantize_as(w1, HALF_SCALE, HALF);
                second.w[l] = [q[0] as i16, q[1] as i16, q[2] as i16, q[3] as i16];
                far = far.max(o1);
                deep = true;
            }
        }
        rounds.push(tail(first, n));
        if deep {
            rounds.push(tail(second, n));
        }
        depth.push(1 + deep as u8);
        far
    }
}

/// Whether a pixel takes two taps, and along which axis.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Pair {
    No,
    /// 2×1: side by side.
    Across,
    /// 1×2: one above the other.
    Down,
}

/// Where `local_pair` (`local.rs`) interpolates the two taps of the lanes `pairs` (their axes
/// `pair`, levels `level`) of a group of centres `c`, from their neighbours `across` (left,
/// right) and `down` (above, below): its taps' x and y lanes, with its operations (the same
/// bits), and which lanes it gives them.
#[inline(always)]
pub(super) fn pair_taps(
    b: &Builder,
    c: [Lanes; 2],
    [across, down]: [[[Lanes; 2]; 2]; 2],
    (pair, level): ([Pair; LANES], [u32; LANES]),
    pairs: [bool; LANES],
) -> ([[Lanes; 2]; 2], [bool; LANES]) {
    let (w, h) = (b.source_size.width as f64, b.source_size.height as f64);
    let [minus, plus] = [0, 1].map(|i| local::lagrange(tap_offset(i, 2)));
    let mut taps = [[[0.0; LANES]; 2]; 2];
    let mut fits = [false; LANES];
    for l in 0..LANES {
        let [a, b] = if pair[l] == Pair::Down { down } else { across };
        // the neighbours relative to the centre
        let (ax, ay) = (a[0][l] - c[0][l], a[1][l] - c[1][l]);
        let (bx, by) = (b[0][l] - c[0][l], b[1][l] - c[1][l]);
        let (sx, sy) = (ax + bx, ay + by);
        let bend = sx * sx + sy * sy;
        let unit = (1u32 << (level[l] % 32)) as f64;
        let margin = local::BORDER_MARGIN * unit;
        let close = |x: f64, edge: f64| (x - edge).abs() < margin;
        let mut near = false;
        for (tap, t) in taps.iter_mut().zip([minus, plus]) {
            let x = c[0][l] + (ax * t[0] + bx * t[2]);
            let y = c[1][l] + (ay * t[0] + by * t[2]);
            // (the lanes' source does not wrap: its columns have borders too)
            near |= close(y, -0.5) || close(y, h - 0.5) || close(x, -0.5) || close(x, w - 0.5);
            tap[0][l] = x;
            tap[1][l] = y;
        }
        // (a missing neighbour's NaN fails the bend)
        let limit = (local::MAX_BEND * unit) * (local::MAX_BEND * unit);
        fits[l] = pairs[l] && bend <= limit && !near;
    }
    (taps, fits)
}
