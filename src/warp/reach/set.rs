//! A set of the output grid's positions, a bit each, row by row: a camera's reach. A 2048-wide
//! output's row is 33 words, so that the widening, the spans of a row and the runs a table's
//! row reads are a word's operations per 64 positions, and six cameras' sets take 1.6 MB
//! instead of 13.

/// Positions of a `width` × `height` grid, bit `i % 64` of word `i / 64` of row j's words
/// for position (i, j); the bits beyond the width are clear.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(in crate::warp) struct PositionSet {
    width: usize,
    words: usize,
    bits: Vec<u64>,
}

/// Bits of a word.
const BITS: usize = 64;

impl PositionSet {
    /// The empty set of a `width` × `height` grid.
    pub(super) fn new(width: usize, height: usize) -> Self {
        let words = width.div_ceil(BITS);
        Self {
            width,
            words,
            bits: vec![0; words * height],
        }
    }

    /// Words a row.
    pub(super) fn words(&self) -> usize {
        self.words
    }

    /// The rows' words, to be written (`words()` a row).
    pub(super) fn bits_mut(&mut self) -> &mut [u64] {
        &mut self.bits
    }

    /// Whether position (i, j) is in the set.
    #[inline]
    pub(super) fn contains(&self, i: usize, j: usize) -> bool {
        self.bits[j * self.words + i / BITS] >> (i % BITS) & 1 != 0
    }

    /// How many positions the set holds.
    #[cfg(test)]
    pub(super) fn len(&self) -> usize {
        self.bits.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// The first and the end of row j's positions in the set (equal where it holds none).
    pub(super) fn span(&self, j: usize) -> (u32, u32) {
        let row = &self.bits[j * self.words..(j + 1) * self.words];
        let Some(first) = row.iter().position(|&w| w != 0) else {
            return (0, 0);
        };
        let last = row.iter().rposition(|&w| w != 0).unwrap_or(first);
        let start = first * BITS + row[first].trailing_zeros() as usize;
        let end = last * BITS + (BITS - row[last].leading_zeros() as usize);
        (start as u32, end as u32)
    }

    /// The first position from `i` on (before `end`) of row j whose membership is not `on`,
    /// `end` where there is none.
    pub(super) fn run_end(&self, j: usize, i: usize, end: usize, on: bool) -> usize {
        let row = &self.bits[j * self.words..(j + 1) * self.words];
        let flip = if on { !0 } else { 0 };
        let mut k = i / BITS;
        // the bits of word k from i on
        let mut word = (row[k] ^ flip) & (!0u64 << (i % BITS));
        loop {
            if word != 0 {
                return (k * BITS + word.trailing_zeros() as usize).min(end);
            }
            k += 1;
            if k * BITS >= end {
                return end;
            }
            word = row[k] ^ flip;
        }
    }

    /// The set widened by `by` positions in x and in y (a square's max filter, within the
    /// grid), by shifts and ORs of whole words.
    pub(super) fn widened(&self, by: usize) -> PositionSet {
        let (words, height) = (self.words, self.bits.len() / self.words.max(1));
        let mut across = vec![0u64; self.bits.len()];
        let tail = match self.width % BITS {
            0 => !0,
            r => !(!0u64 << r),
        };
        for (out, row) in across.chunks_mut(words).zip(self.bits.chunks(words)) {
            for (k, o) in out.iter_mut().enumerate() {
                let (prev, here) = (k.checked_sub(1).map_or(0, |p| row[p]), row[k]);
                let next = row.get(k + 1).copied().unwrap_or(0);
                let mut x = here;
                for s in 1..=by {
                    // bit i gathers bits i - s (up) and i + s (down) of the row
                    x |= here << s | prev >> (BITS - s);
                    x |= here >> s | next << (BITS - s);
                }
                *o = x;
            }
            if let Some(last) = out.last_mut() {
                *last &= tail;
            }
        }
        let mut bits = vec![0u64; self.bits.len()];
        for (j, out) in bits.chunks_mut(words).enumerate() {
            let (lo, hi) = (j.saturating_sub(by), (j + by).min(height - 1));
            for k in lo..=hi {
                for (o, x) in out.iter_mut().zip(&across[k * words..(k + 1) * words]) {
                    *o |= *x;
                }
            }
        }
        PositionSet {
            width: self.width,
            words,
            bits,
        }
    }
}

/// Sets positions `i0..i1` of a row's words.
#[inline]
pub(super) fn set_range(row: &mut [u64], i0: usize, i1: usize) {
    let mut i = i0;
    while i < i1 {
        let (k, b) = (i / BITS, i % BITS);
        let n = (BITS - b).min(i1 - i);
        let mask = if n == BITS {
            !0
        } else {
            ((1u64 << n) - 1) << b
        };
        row[k] |= mask;
        i += n;
    }
}

/// Sets position `i` of a row's words.
#[inline]
pub(super) fn set(row: &mut [u64], i: usize) {
    row[i / BITS] |= 1 << (i % BITS);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A set of `w` × `h` from a predicate, and the predicate's grid.
    fn both(w: usize, h: usize, f: impl Fn(usize, usize) -> bool) -> (PositionSet, Vec<bool>) {
        let mut set = PositionSet::new(w, h);
        let words = set.words();
        let mut grid = vec![false; w * h];
        for j in 0..h {
            for i in 0..w {
                if f(i, j) {
                    set_range(&mut set.bits_mut()[j * words..(j + 1) * words], i, i + 1);
                    grid[j * w + i] = true;
                }
            }
        }
        (set, grid)
    }

    #[test]
    fn widening_spans_and_runs_are_the_positions_ones() {
        for (w, h) in [(130, 9), (64, 5), (200, 12), (3, 4)] {
            let (set, grid) = both(w, h, |i, j| {
                (i * 7 + j * 13) % 23 == 0 || (i > 60 && i < 70)
            });
            let wide = set.widened(2);
            for j in 0..h {
                for i in 0..w {
                    let near = (j.saturating_sub(2)..=(j + 2).min(h - 1)).any(|y| {
                        (i.saturating_sub(2)..=(i + 2).min(w - 1)).any(|x| grid[y * w + x])
                    });
                    assert_eq!(wide.contains(i, j), near, "{w}x{h} ({i}, {j})");
                    assert_eq!(set.contains(i, j), grid[j * w + i]);
                }
                let row: Vec<usize> = (0..w).filter(|&i| wide.contains(i, j)).collect();
                let span = match (row.first(), row.last()) {
                    (Some(&a), Some(&b)) => (a as u32, b as u32 + 1),
                    _ => (0, 0),
                };
                assert_eq!(wide.span(j), span, "{w}x{h} row {j}");
                for i in 0..w {
                    for end in [i + 1, w] {
                        let on = wide.contains(i, j);
                        let want = (i..end).find(|&x| wide.contains(x, j) != on).unwrap_or(end);
                        assert_eq!(wide.run_end(j, i, end, on), want, "{w}x{h} ({i}, {j})");
                    }
                }
            }
        }
        // set_range across words, and one position
        let mut row = [0u64; 3];
        set_range(&mut row, 60, 130);
        set(&mut row, 2);
        assert_eq!(row, [(0b1111 << 60) | 4, !0, 0b11]);
    }
}
