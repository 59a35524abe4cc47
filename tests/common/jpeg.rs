//! A minimal baseline JPEG writer for the tests (no encoder is a dependency): grey, each 8x8
//! block one flat level (only its DC coefficient), with its own small Huffman tables. Real
//! decoders read it; what matters to the tests is a well-formed file that can then be cut.

use panoconv::image::RgbImage;

/// A greyscale JPEG of `img`: each 8x8 block holds the mean grey of its pixels.
pub fn jpeg_blocks(img: &RgbImage) -> Vec<u8> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let mut out = vec![0xFF, 0xD8];
    // quantisation table 0: every step 1
    segment(&mut out, 0xDB, &[[0u8].as_slice(), &[1; 64]].concat());
    let mut sof = vec![8, (h >> 8) as u8, h as u8, (w >> 8) as u8, w as u8, 1];
    sof.extend_from_slice(&[1, 0x11, 0]);
    segment(&mut out, 0xC0, &sof);
    // DC table 0: categories 0..=11, four bits each; AC table 0: the end of block alone, '0'
    let mut dc = vec![0x00, 0, 0, 0, 12];
    dc.extend_from_slice(&[0; 12]);
    dc.extend(0..12u8);
    segment(&mut out, 0xC4, &dc);
    let mut ac = vec![0x10, 1];
    ac.extend_from_slice(&[0; 15]);
    ac.push(0x00);
    segment(&mut out, 0xC4, &ac);
    segment(&mut out, 0xDA, &[1, 1, 0x00, 0, 63, 0]);
    let mut bits = Bits::default();
    let mut previous = 0i32;
    for by in 0..h.div_ceil(8) {
        for bx in 0..w.div_ceil(8) {
            let dc = (block_mean(img, bx, by) - 128) * 8;
            let diff = dc - previous;
            previous = dc;
            let size = 32 - diff.unsigned_abs().leading_zeros();
            bits.put(size, 4);
            let magnitude = if diff >= 0 {
                diff
            } else {
                diff + (1 << size) - 1
            };
            bits.put(magnitude as u32, size);
            bits.put(0, 1);
        }
    }
    out.extend(bits.finish());
    out.extend_from_slice(&[0xFF, 0xD9]);
    out
}

fn segment(out: &mut Vec<u8>, marker: u8, body: &[u8]) {
    out.extend_from_slice(&[0xFF, marker]);
    out.extend_from_slice(&((body.len() + 2) as u16).to_be_bytes());
    out.extend_from_slice(body);
}

/// The mean grey (0..=255) of the block's pixels inside the image.
fn block_mean(img: &RgbImage, bx: usize, by: usize) -> i32 {
    let (mut sum, mut n) = (0u32, 0u32);
    for y in by * 8..(by * 8 + 8).min(img.height() as usize) {
        for x in bx * 8..(bx * 8 + 8).min(img.width() as usize) {
            let p = img.pixel(x as u32, y as u32);
            sum += (p[0] as u32 + p[1] as u32 + p[2] as u32) / 3;
            n += 1;
        }
    }
    (sum / n) as i32
}

/// Entropy-coded bits, most significant first, with a zero stuffed after every 0xFF byte.
#[derive(Default)]
struct Bits {
    bytes: Vec<u8>,
    acc: u32,
    n: u32,
}

impl Bits {
    fn put(&mut self, value: u32, count: u32) {
        for i in (0..count).rev() {
            self.acc = self.acc << 1 | (value >> i & 1);
            self.n += 1;
            if self.n == 8 {
                self.push();
            }
        }
    }

    fn push(&mut self) {
        let b = self.acc as u8;
        self.bytes.push(b);
        if b == 0xFF {
            self.bytes.push(0);
        }
        self.acc = 0;
        self.n = 0;
    }

    fn finish(mut self) -> Vec<u8> {
        while self.n != 0 {
            self.put(1, 1);
        }
        self.bytes
    }
}
