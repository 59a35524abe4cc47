//! A pixel's taps turned into the table's quads: blocks of 2×2 source pixels merged by offset,
//! their float weights made integers that sum exactly to the pixel's share of
//! [`WEIGHT_ONE`] (a flat source stays flat, taps outside the source count as black).

use super::Scratch;
use crate::warp::kernel::{Quad, WEIGHT_ONE};

/// Adds `w` to the block at `offset`, or appends a new block.
pub(super) fn merge(blocks: &mut Vec<(u32, [f64; 4])>, offset: u32, w: [f64; 4]) {
    if let Some((_, acc)) = blocks.iter_mut().rev().find(|(o, _)| *o == offset) {
        for (a, b) in acc.iter_mut().zip(w) {
            *a += b;
        }
    } else {
        blocks.push((offset, w));
    }
}

/// Turns the pixel's blocks (`inside` of its `taps` taps, each weighing 1) into quads whose
/// integer weights sum to round(WEIGHT_ONE · inside / taps) exactly (largest remainders get
/// the rounding units, ties to the first), so a flat source stays flat and outside taps count
/// as black. Appends at least one quad (an all-zero one for a pixel with nothing inside).
pub(super) fn quantize(s: &mut Scratch, inside: u32, taps: u32, out: &mut Vec<Quad>) {
    let total = ((WEIGHT_ONE as u64 * inside as u64 + taps as u64 / 2) / taps as u64) as i32;
    let scale = WEIGHT_ONE as f64 / taps as f64;
    if let [(offset, w)] = s.blocks[..] {
        out.push(quantize_block(offset, w, total, scale));
        return;
    }
    s.ints.clear();
    let mut sum = 0;
    for (_, w) in &s.blocks {
        let q = w.map(|x| (x * scale) as i32);
        sum += q.iter().sum::<i32>();
        s.ints.push(q);
    }
    let missing = total - sum;
    if missing > 0 {
        s.order.clear();
        for (b, (_, w)) in s.blocks.iter().enumerate() {
            for (k, x) in w.iter().enumerate() {
                let y = x * scale;
                s.order.push((4 * b + k, y - (y as i32) as f64));
            }
        }
        if missing <= 4 {
            // the common case (a few units over a few weights): pick maxima, no sort
            for _ in 0..missing {
                let mut best = 0;
                for (j, o) in s.order.iter().enumerate() {
                    if o.1 > s.order[best].1 {
                        best = j;
                    }
                }
                let i = s.order[best].0;
                s.ints[i / 4][i % 4] += 1;
                s.order[best].1 = -1.0;
            }
        } else {
            // stable: equal remainders keep their order, as the first maximum above
            s.order.sort_by(|a, b| b.1.total_cmp(&a.1));
            for &(i, _) in s.order.iter().take(missing as usize) {
                s.ints[i / 4][i % 4] += 1;
            }
        }
    }
    let before = out.len();
    for ((offset, _), w) in s.blocks.iter().zip(&s.ints) {
        if w.iter().any(|&x| x != 0) {
            out.push(Quad {
                offset: *offset,
                w: w.map(|x| x as i16),
            });
        }
    }
    if out.len() == before {
        out.push(Quad::default());
    }
}

/// The quad of a pixel whose taps fell in one block (most pixels): each weight (times `scale`)
/// rounded, the largest one (first on ties) taking up the rounding error so that the sum is
/// `total` exactly; it moves by at most 1.5/16384.
#[inline(always)]
pub(in crate::warp::table) fn quantize_block(
    offset: u32,
    w: [f64; 4],
    total: i32,
    scale: f64,
) -> Quad {
    let y = w.map(|x| x * scale);
    let q = y.map(|x| (x + 0.5) as i32);
    // (the running maximum in a register: a select, not a load, per weight)
    let (mut big, mut top) = (0, y[0]);
    for (k, &x) in y.iter().enumerate().skip(1) {
        if x > top {
            (big, top) = (k, x);
        }
    }
    let fix = total - q.iter().sum::<i32>();
    // no store to q[big]: an indexed store sends the weights through memory
    let w = std::array::from_fn(|k| (q[k] + if k == big { fix } else { 0 }) as i16);
    Quad { offset, w }
}
