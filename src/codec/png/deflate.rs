//! The zlib stream of fdeflate's `Compressor` (0.3), bit for bit, written faster.
//!
//! fdeflate compresses PNG rows with one fixed Huffman code tuned for filtered data (short
//! codes for bytes near 0 and 255) and encodes runs of zero bytes as distance-1 matches. Its
//! output is a pure bit sequence, so any way of writing the same symbols gives the same bytes;
//! this one looks codes up two bytes at a time (one table entry holds both codes and their
//! total length), codes every byte of a word through those pairs whatever its zeros (a run's
//! zero bytes are cut off the ends: a zero's literal code is two zero bits), and writes the
//! bit buffer with one unconditional 8-byte store per group of symbols instead of a checked
//! `Write` call. The symbols themselves, including where runs
//! start and end (a run never spans two `write_data` calls, as in fdeflate), are fdeflate's:
//! the tests compare the bytes with fdeflate's on random rows cut in random pieces.

use std::sync::LazyLock;

/// fdeflate's code lengths of the literal/length alphabet (its `HUFFMAN_LENGTHS`); the
/// stream's header (below) describes exactly this code.
#[rustfmt::skip]
const LENGTHS: [u8; 286] = [
    2, 3, 4, 5, 5, 6, 6, 7, 7, 7, 8, 8, 8, 8, 8, 9, 9, 9, 9, 9, 9, 9, 10, 10, 10, 10, 10, 10, 10,
    10, 10, 11, 11, 11, 11, 11, 11, 11, 11, 11, 11, 11, 11, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12,
    12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12,
    12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12,
    12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12,
    12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12,
    12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12,
    12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12,
    12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 11, 11, 11, 11, 11, 11, 11,
    11, 11, 11, 10, 11, 10, 10, 10, 10, 10, 10, 10, 10, 10, 9, 9, 9, 9, 9, 8, 9, 8, 8, 8, 8, 8, 7,
    7, 7, 6, 6, 6, 5, 4, 3, 12, 12, 12, 9, 9, 11, 10, 11, 11, 10, 11, 11, 11, 11, 11, 11, 12, 11,
    12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 12, 9,
];

/// The zlib header and the dynamic block's header (the code above, one distance code of one
/// bit): 53 bytes, then 5 bits.
#[rustfmt::skip]
const HEADER: [u8; 54] = [
    120, 1, 237, 192, 3, 160, 36, 89, 150, 198, 241, 255, 119, 238, 141, 200, 204, 167,
    114, 75, 99, 174, 109, 219, 182, 109, 219, 182, 109, 219, 182, 109, 105, 140, 158, 150,
    74, 175, 158, 50, 51, 34, 238, 249, 118, 183, 106, 122, 166, 135, 59, 107, 213, 15,
];

/// The canonical code of each symbol, bit-reversed for deflate's LSB-first order.
const CODES: [u16; 286] = {
    let mut codes = [0u16; 286];
    let mut code = 0u32;
    let mut len = 1;
    while len <= 16 {
        let mut i = 0;
        while i < 286 {
            if LENGTHS[i] == len {
                codes[i] = (code as u16).reverse_bits() >> (16 - len);
                code += 1;
            }
            i += 1;
        }
        code <<= 1;
        len += 1;
    }
    codes
};

/// Code and length of every pair of literals (first byte low): code bits 0..24, length in
/// the top byte. 256 KiB; the pairs of filtered camera rows keep to a small part of it.
static PAIRS: LazyLock<Box<[u32; 1 << 16]>> = LazyLock::new(|| {
    let table: Box<[u32]> = (0..1u32 << 16)
        .map(|i| {
            let (a, b) = ((i & 0xff) as usize, (i >> 8) as usize);
            let (la, lb) = (LENGTHS[a] as u32, LENGTHS[b] as u32);
            (CODES[a] as u32 | (CODES[b] as u32) << la) | (la + lb) << 24
        })
        .collect();
    table.try_into().expect("2^16 entries")
});

/// Bits of a pair's code in a [`PAIRS`] entry.
const PAIR_CODE: u32 = (1 << 24) - 1;

/// A compressor giving the bytes of `fdeflate::Compressor` for the same `write_data` calls.
pub(super) struct Compressor {
    /// What was there before, then the stream; zeros past `bits.pos` (room for 8-byte stores).
    out: Vec<u8>,
    bits: BitState,
    checksum: simd_adler32::Adler32,
}

/// Where the bit writer stands.
#[derive(Clone, Copy)]
struct BitState {
    /// End of the complete bytes of the stream in the output.
    pos: usize,
    /// Bits not yet complete bytes (fewer than 8), also already stored at the output's `pos`.
    buf: u64,
    nbits: u32,
}

/// The bit writer over a borrowed output, so that its state lives in registers in the loop.
struct Bits<'a> {
    out: &'a mut [u8],
    s: BitState,
}

impl Bits<'_> {
    /// Appends the low `n` bits of `bits` (`n` <= 48; the bits above are zero). Needs 8 bytes
    /// of output from `pos` on.
    #[inline(always)]
    fn put(&mut self, bits: u64, n: u32) {
        let s = &mut self.s;
        s.buf |= bits << s.nbits;
        s.nbits += n;
        debug_assert!(s.pos + 8 <= self.out.len());
        // SAFETY: `Compressor::writer` reserved 8 bytes past the furthest `pos` its caller can
        // reach (at most 12 bits a byte of data, room for 2 bytes a byte), and `out` is that
        // buffer: the store is in bounds. (Checked, the two bound tests cost ~10 % here.)
        unsafe {
            std::ptr::write_unaligned(
                self.out.as_mut_ptr().add(s.pos) as *mut [u8; 8],
                s.buf.to_le_bytes(),
            )
        };
        let bytes = s.nbits >> 3;
        s.pos += bytes as usize;
        // at most 55 bits were buffered, so this shift is at most 48
        s.buf >>= bytes * 8;
        s.nbits &= 7;
    }

    #[inline(always)]
    fn literal(&mut self, b: u8) {
        self.put(CODES[b as usize] as u64, LENGTHS[b as usize] as u32);
    }

    /// `run` zero bytes: a literal zero, then distance-1 matches as fdeflate writes them.
    #[inline(never)]
    fn run(&mut self, mut run: u32) {
        self.put(CODES[0] as u64, LENGTHS[0] as u32);
        run -= 1;
        while run >= 258 {
            // length 258, then the one-bit distance code
            self.put(CODES[285] as u64, LENGTHS[285] as u32 + 1);
            run -= 258;
        }
        if run > 4 {
            let (sym, extra) = length_symbol(run);
            self.put(CODES[sym] as u64, LENGTHS[sym] as u32);
            self.put(((run - 3) & ((1 << extra) - 1)) as u64, extra + 1);
        } else {
            // literal zeros: code 0 is all zero bits
            self.put(0, run * LENGTHS[0] as u32);
        }
    }
}

impl Compressor {
    /// Starts the stream at the end of `out`.
    pub(super) fn new(out: Vec<u8>) -> Self {
        let mut c = Compressor {
            bits: BitState {
                pos: out.len(),
                buf: 0,
                nbits: 0,
            },
            out,
            checksum: simd_adler32::Adler32::new(),
        };
        let mut w = c.writer(HEADER.len());
        let pos = w.s.pos;
        w.out[pos..pos + 53].copy_from_slice(&HEADER[..53]);
        w.s.pos += 53;
        w.put(HEADER[53] as u64, 5);
        c.bits = w.s;
        c
    }

    /// The bit writer, with room for at least `n` more bytes of stream.
    fn writer(&mut self, n: usize) -> Bits<'_> {
        let need = self.bits.pos + n + 16;
        if self.out.len() < need {
            self.out.resize(need, 0);
        }
        Bits {
            out: &mut self.out,
            s: self.bits,
        }
    }

    /// Compresses `data` (fdeflate's `write_data`: a run of zeros ends with the call).
    pub(super) fn write_data(&mut self, data: &[u8]) {
        self.checksum.write(data);
        // each byte takes at most 12 bits, and a run less
        let mut w = self.writer(2 * data.len());
        let pairs: &[u32; 1 << 16] = &PAIRS;
        let pair = |v: u64| {
            let p = pairs[(v & 0xffff) as usize];
            (p & PAIR_CODE, p >> 24)
        };
        let mut run = 0;
        let mut chunks = data.chunks_exact(8);
        for chunk in &mut chunks {
            let word = u64::from_le_bytes(chunk.try_into().expect("8 bytes"));
            if word == 0 {
                run += 8;
                continue;
            }
            // fdeflate's symbols for a word: a run pending from the words before takes the
            // word's low zero bytes and ends; the zero bytes at the word's top start the next
            // run; the bytes between are literals, zeros included. A zero's literal code is two
            // zero bits, so every byte is coded through the pairs and the zero bytes that
            // belong to runs are cut off the codes' two ends: no branch on where zeros are.
            let low = if run > 0 {
                word.trailing_zeros() / 8
            } else {
                0
            };
            let high = word.leading_zeros() / 8;
            let ended = run + low;
            if ended > 5 {
                w.run(ended);
            } else {
                // a run of at most 5 is that many literal zeros (none: nothing is added)
                w.put(0, 2 * ended);
            }
            run = high;
            let (c0, n0) = pair(word);
            let (c1, n1) = pair(word >> 16);
            let (c2, n2) = pair(word >> 32);
            let (c3, n3) = pair(word >> 48);
            let (mut lo, mut lo_len) = (c0 as u64 | (c1 as u64) << n0, n0 + n1);
            let (mut hi, mut hi_len) = (c2 as u64 | (c3 as u64) << n2, n2 + n3);
            // the run's zero bytes at the start: bytes 0-3 are `lo`, 4-7 `hi`
            let (drop_lo, drop_hi) = (low.min(4), low - low.min(4));
            lo >>= 2 * drop_lo;
            lo_len -= 2 * drop_lo;
            hi >>= 2 * drop_hi;
            hi_len -= 2 * drop_hi;
            // the next run's zero bytes at the end (zero bits: only the lengths shrink)
            let (cut_hi, cut_lo) = (high.min(4), high - high.min(4));
            hi_len -= 2 * cut_hi;
            lo_len -= 2 * cut_lo;
            w.put(lo, lo_len);
            w.put(hi, hi_len);
        }
        if run > 0 {
            w.run(run);
        }
        for &b in chunks.remainder() {
            w.literal(b);
        }
        self.bits = w.s;
    }

    /// Ends the block and the stream (the Adler-32 of the data); returns `out` with it.
    pub(super) fn finish(mut self) -> Vec<u8> {
        let mut w = self.writer(8);
        w.put(CODES[256] as u64, LENGTHS[256] as u32);
        // the last partial byte is already stored, its unused bits zero
        let end = w.s.pos + (w.s.nbits > 0) as usize;
        self.out.truncate(end);
        self.out
            .extend_from_slice(&self.checksum.finish().to_be_bytes());
        self.out
    }
}

/// The length symbol of a match of `len` + 3 bytes (`len` + 3 in 5..=257) and its count of
/// extra bits (deflate's length table).
fn length_symbol(run: u32) -> (usize, u32) {
    let n = run - 3;
    if n < 8 {
        (257 + n as usize, 0)
    } else {
        let extra = 31 - n.leading_zeros() - 2;
        ((257 + 4 * (extra + 1) + ((n >> extra) - 4)) as usize, extra)
    }
}

#[cfg(test)]
mod tests {
    use super::Compressor;
    use proptest::prelude::*;

    fn fdeflate_bytes(pieces: &[Vec<u8>]) -> Vec<u8> {
        let mut z = fdeflate::Compressor::new(vec![7u8; 3]).unwrap();
        for p in pieces {
            z.write_data(p).unwrap();
        }
        z.finish().unwrap()
    }

    fn our_bytes(pieces: &[Vec<u8>]) -> Vec<u8> {
        let mut z = Compressor::new(vec![7u8; 3]);
        for p in pieces {
            z.write_data(p);
        }
        z.finish()
    }

    /// Bytes like filtered rows: mostly near 0 and 255, with runs of zeros of every length.
    fn piece() -> impl Strategy<Value = Vec<u8>> {
        let byte = prop_oneof![
            4 => Just(0u8),
            3 => 0u8..8,
            3 => 248u8..=255,
            2 => any::<u8>(),
        ];
        let run = (0usize..700).prop_map(|n| vec![0u8; n]);
        let bytes = prop::collection::vec(byte, 0..64);
        prop::collection::vec(prop_oneof![3 => bytes, 1 => run], 0..8)
            .prop_map(|parts| parts.concat())
    }

    proptest! {
        #[test]
        fn the_bytes_equal_fdeflates(pieces in prop::collection::vec(piece(), 0..12)) {
            prop_assert_eq!(our_bytes(&pieces), fdeflate_bytes(&pieces));
        }
    }

    #[test]
    fn every_run_length_and_every_literal_equal_fdeflates() {
        // each run length up to two maximal matches, cut at every phase of the 8-byte words
        for run in 0..600 {
            for lead in 0..8 {
                let mut row = vec![5u8; lead];
                row.extend(std::iter::repeat_n(0, run));
                row.push(200);
                let pieces = vec![row.clone(), row];
                assert_eq!(
                    our_bytes(&pieces),
                    fdeflate_bytes(&pieces),
                    "run {run} lead {lead}"
                );
            }
        }
        let all: Vec<u8> = (0..=255u8).chain((0..=255u8).rev()).collect();
        let pieces = vec![all.clone(), all[3..].to_vec(), all[..5].to_vec(), vec![]];
        assert_eq!(our_bytes(&pieces), fdeflate_bytes(&pieces));
    }

    #[test]
    fn every_placement_of_zero_bytes_in_a_word_equals_fdeflates() {
        // each of the 256 zero/non-zero patterns of a word, after a pending run of every
        // length that ends in it (0 to 17 zero bytes before it, across word boundaries), with
        // bytes whose codes are long (12 bits) and short (3 bits)
        for pattern in 0..256u32 {
            for before in 0..18 {
                for fill in [1u8, 100] {
                    let mut row = vec![fill; 8 - before % 8];
                    row.extend(std::iter::repeat_n(0, before));
                    row.extend((0..8).map(|i| if pattern >> i & 1 == 1 { fill } else { 0 }));
                    row.extend([fill; 8]);
                    let pieces = vec![row.clone(), row[3..].to_vec()];
                    assert_eq!(
                        our_bytes(&pieces),
                        fdeflate_bytes(&pieces),
                        "pattern {pattern:08b} before {before} fill {fill}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_stream_inflates_to_the_data() {
        let data: Vec<u8> = (0..5000u32).map(|i| (i * i % 251) as u8 & 0x87).collect();
        let out = our_bytes(std::slice::from_ref(&data));
        let mut d = fdeflate::Decompressor::new();
        let mut back = vec![0u8; data.len()];
        let (used, n) = d.read(&out[3..], &mut back, 0, true).unwrap();
        assert_eq!((used, n), (out.len() - 3, data.len()));
        assert!(d.is_done());
        assert_eq!(back, data);
    }
}
