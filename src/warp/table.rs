//! The remap table and its application.
//!
//! For every output pixel the table holds one or more bilinear taps into the source image. When
//! the output is locally coarser than the source (more than 1.5 source pixels per output pixel
//! along an axis) the pixel is supersampled on an nu×nv grid over its footprint (n = round(scale)
//! per axis, at most 8): a box prefilter that removes the moiré a plain bilinear lookup gives. Weights are fixed-point
//! integers, so the result is bit-exact on every machine and thread count.

use crate::camera::{CameraModel, ImageSize};
use crate::image::RgbImage;
use nalgebra::{Matrix3, Point2};
use rayon::prelude::*;

const FRAC_BITS: u32 = 10;
const ONE: u32 = 1 << FRAC_BITS;
/// Tap offset meaning "outside the source": contributes black.
const OUTSIDE: u32 = u32::MAX;
const MAX_SUPERSAMPLE: u32 = 8;

/// How source columns beyond the left and right edges are treated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrap {
    /// Black beyond the edges (rectilinear and fisheye sources).
    None,
    /// The source is a full 360° panorama: columns wrap around.
    Horizontal,
}

/// Set in `Tap::wx` when the right neighbour is at column offset 1 - width instead of 1: across
/// the wrap of a 360° source, or (1 - 1 = 0) in a one-pixel-wide source.
const WRAPS: u16 = 1 << 15;

/// One bilinear tap, 8 bytes (the table is streamed once per frame).
#[derive(Debug, Clone, Copy)]
struct Tap {
    /// Index of the top-left source pixel; its right and lower neighbours are read too.
    offset: u32,
    /// Horizontal weight of the right neighbour in 1/ONE, | WRAPS.
    wx: u16,
    /// Vertical weight of the lower neighbour in 1/ONE.
    wy: u16,
}

#[derive(Debug)]
pub struct RemapTable {
    size: ImageSize,
    source_size: ImageSize,
    /// taps[starts[i]..starts[i + 1]] belong to output pixel i; empty when every pixel has
    /// exactly one tap (then tap i is pixel i's).
    starts: Vec<u32>,
    taps: Vec<Tap>,
    /// Every tap's neighbours are at +1 column and +1 row (no WRAPS tap, source height >= 2):
    /// `apply` then reads them without a branch.
    plain: bool,
}

impl RemapTable {
    /// Builds the table mapping `dst` pixels to `src` pixels, where `src_from_dst` rotates a
    /// bearing from the output camera's axes to the source camera's (both cameras share their
    /// optical centre, as a pure reprojection must).
    pub fn build(
        dst: &dyn CameraModel,
        src: &dyn CameraModel,
        src_from_dst: &Matrix3<f64>,
        wrap: Wrap,
    ) -> RemapTable {
        Self::build_with(dst, src, src_from_dst, wrap, MAX_SUPERSAMPLE)
    }

    /// As [`RemapTable::build`], with at most `max_supersample`² samples per output pixel
    /// (1 turns the antialiasing off).
    pub fn build_with(
        dst: &dyn CameraModel,
        src: &dyn CameraModel,
        src_from_dst: &Matrix3<f64>,
        wrap: Wrap,
        max_supersample: u32,
    ) -> RemapTable {
        let size = dst.size();
        let source_size = src.size();
        let (sw, sh) = (source_size.width as f64, source_size.height as f64);
        let to_src = |u: f64, v: f64| -> Option<Point2<f64>> {
            let d = dst.unproject(&Point2::new(u, v)).ok()?;
            src.project(&(src_from_dst * d)).ok()
        };
        let make_tap = |p: Option<Point2<f64>>| -> Tap {
            let outside = Tap {
                offset: OUTSIDE,
                wx: 0,
                wy: 0,
            };
            let Some(p) = p else { return outside };
            let (mut x, y) = (p.x, p.y);
            if wrap == Wrap::Horizontal {
                x = x.rem_euclid(sw);
            } else if !(x >= -0.5 && x < sw - 0.5) {
                return outside;
            }
            // inclusive at the bottom edge: a ray exactly at a panorama's south pole lands there
            if !(y >= -0.5 && y <= sh - 0.5) {
                return outside;
            }
            // Within half a pixel of the border the edge pixel is repeated (it covers that area).
            let y = y.clamp(0.0, sh - 1.0);
            let y0 = (y.floor() as u32).min(source_size.height.saturating_sub(2));
            let wy = ((y - y0 as f64) * ONE as f64).round() as u16;
            let (x0, wx) = if wrap == Wrap::Horizontal {
                let x0 = (x.floor() as u32).min(source_size.width - 1);
                (x0, ((x - x0 as f64) * ONE as f64).round() as u16)
            } else {
                let x = x.clamp(0.0, sw - 1.0);
                let x0 = (x.floor() as u32).min(source_size.width.saturating_sub(2));
                (x0, ((x - x0 as f64) * ONE as f64).round() as u16)
            };
            let wy = if source_size.height > 1 { wy } else { 0 };
            Tap {
                offset: y0 * source_size.width + x0,
                // x0 + 1 == width: across the wrap, or a one-pixel-wide source.
                wx: if x0 + 1 == source_size.width {
                    wx | WRAPS
                } else {
                    wx
                },
                wy,
            }
        };
        // Sequential on purpose: tables are built inside the cache's once-cell, and a parallel
        // build could let rayon run another frame's lookup of the same cell on this thread.
        // The half-pixel points that measure the local scale are shared by neighbouring pixels
        // (u + 0.5 is u + 1 - 0.5 exactly), so each is computed once: 3 mappings a pixel, not 5.
        let (w, h) = (size.width as usize, size.height as usize);
        let mut starts = Vec::with_capacity(w * h + 1);
        let mut taps = Vec::with_capacity(w * h);
        starts.push(0u32);
        let mut above: Vec<_> = (0..w).map(|u| to_src(u as f64, -0.5)).collect();
        let mut below = Vec::with_capacity(w);
        let mut across = Vec::with_capacity(w + 1);
        for v in 0..h {
            let vf = v as f64;
            across.clear();
            across.extend((0..=w).map(|i| to_src(i as f64 - 0.5, vf)));
            below.clear();
            below.extend((0..w).map(|u| to_src(u as f64, vf + 0.5)));
            for u in 0..w {
                let uf = u as f64;
                let (nu, nv) = supersampling(
                    [across[u], across[u + 1], above[u], below[u]],
                    (wrap == Wrap::Horizontal).then_some(sw),
                );
                let cap = max_supersample.max(1);
                let (nu, nv) = (nu.min(cap), nv.min(cap));
                for j in 0..nv {
                    for i in 0..nu {
                        let du = (i as f64 + 0.5) / nu as f64 - 0.5;
                        let dv = (j as f64 + 0.5) / nv as f64 - 0.5;
                        taps.push(make_tap(to_src(uf + du, vf + dv)));
                    }
                }
                starts.push(taps.len() as u32);
            }
            std::mem::swap(&mut above, &mut below);
        }
        if taps.len() + 1 == starts.len() {
            starts = Vec::new();
        }
        taps.shrink_to_fit();
        let plain = source_size.height >= 2 && taps.iter().all(|t| t.wx & WRAPS == 0);
        RemapTable {
            size,
            source_size,
            starts,
            taps,
            plain,
        }
    }

    /// The taps of output pixel i.
    #[inline]
    fn taps_of(&self, i: usize) -> &[Tap] {
        if self.starts.is_empty() {
            std::slice::from_ref(&self.taps[i])
        } else {
            &self.taps[self.starts[i] as usize..self.starts[i + 1] as usize]
        }
    }

    pub fn size(&self) -> ImageSize {
        self.size
    }

    pub fn source_size(&self) -> ImageSize {
        self.source_size
    }

    /// Fraction of output pixels with at least one tap inside the source.
    pub fn coverage(&self) -> f64 {
        let n = self.size.width as usize * self.size.height as usize;
        let covered = (0..n)
            .filter(|&i| self.taps_of(i).iter().any(|t| t.offset != OUTSIDE))
            .count();
        covered as f64 / n as f64
    }

    /// Whether output pixel (u, v) is wholly inside the source (every tap valid).
    pub fn is_inside(&self, u: u32, v: u32) -> bool {
        let i = v as usize * self.size.width as usize + u as usize;
        self.taps_of(i).iter().all(|t| t.offset != OUTSIDE)
    }

    /// Resamples `src` (which must have the table's source size).
    pub fn apply(&self, src: &RgbImage) -> RgbImage {
        assert_eq!(
            (src.width(), src.height()),
            (self.source_size.width, self.source_size.height),
            "source image size differs from the table's"
        );
        let (w, h) = (self.size.width as usize, self.size.height as usize);
        let mut out = RgbImage::new(self.size.width, self.size.height);
        let stride = self.source_size.width as usize;
        let data = src.as_raw();
        out.as_raw_mut()
            .par_chunks_mut(w * 3)
            .enumerate()
            .with_min_len(8)
            .for_each(|(v, row)| {
                let pixels = row.chunks_exact_mut(3);
                match (self.plain, self.starts.is_empty()) {
                    // One tap a pixel, neighbours at +1: the common case, kept branch-light.
                    (true, true) => {
                        for (px, t) in pixels.zip(&self.taps[v * w..(v + 1) * w]) {
                            px.copy_from_slice(&sample_one_plain(data, stride, t));
                        }
                    }
                    (true, false) => {
                        for (u, px) in pixels.enumerate() {
                            let taps = self.taps_of(v * w + u);
                            let value = if let [t] = taps {
                                sample_one_plain(data, stride, t)
                            } else {
                                sample_many(taps, |t| bilinear_plain(data, stride, t))
                            };
                            px.copy_from_slice(&value);
                        }
                    }
                    (false, _) => {
                        for (u, px) in pixels.enumerate() {
                            let taps = self.taps_of(v * w + u);
                            let value = if let [t] = taps {
                                sample_one(data, stride, t)
                            } else {
                                sample_many(taps, |t| bilinear(data, stride, t))
                            };
                            px.copy_from_slice(&value);
                        }
                    }
                }
            });
        debug_assert_eq!(out.as_raw().len(), w * h * 3);
        out
    }
}

/// Supersampling of an output pixel along its u and v axes: the source pixels one output step
/// spans in each direction, rounded (1 below 1.5), from the table's own mapping of the pixel's
/// left, right, top and bottom edge midpoints. Anisotropic: at a KITTI frame's edges an equirect
/// pixel spans 1.8 source pixels across but 1.3 down, and needs 2×1 samples, not 2×2.
/// `period`: the source width of a 360° source, across whose wrap a step is taken the short way.
fn supersampling(edges: [Option<Point2<f64>>; 4], period: Option<f64>) -> (u32, u32) {
    let [Some(l), Some(r), Some(t), Some(b)] = edges else {
        return (1, 1);
    };
    let step = |a: Point2<f64>, b: Point2<f64>| {
        let mut d = b - a;
        if let Some(w) = period {
            d.x -= w * (d.x / w).round();
        }
        d.norm()
    };
    let count = |scale: f64| {
        if !scale.is_finite() || scale < 1.5 {
            1
        } else {
            (scale.round() as u32).min(MAX_SUPERSAMPLE)
        }
    };
    (count(step(l, r)), count(step(t, b)))
}

/// The bilinear sum of a tap, in 1/ONE² (general case: any neighbour layout).
#[inline]
fn bilinear(data: &[u8], stride: usize, t: &Tap) -> [u32; 3] {
    let base = t.offset as usize * 3;
    let right: isize = if t.wx & WRAPS != 0 {
        (1 - stride as isize) * 3
    } else {
        3
    };
    let (wx, wy) = ((t.wx & !WRAPS) as u32, t.wy as u32);
    let below = if wy == 0 { 0 } else { stride * 3 };
    let mut out = [0u32; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let i = base + c;
        let j = i.wrapping_add_signed(right);
        let top = data[i] as u32 * (ONE - wx) + data[j] as u32 * wx;
        let bottom = data[i + below] as u32 * (ONE - wx) + data[j + below] as u32 * wx;
        *o = top * (ONE - wy) + bottom * wy;
    }
    out
}

/// As [`bilinear`] for a plain table (right neighbour at +1 column, lower at +1 row, both
/// inside the source): two bounds checks instead of twelve. Same arithmetic, same result.
#[inline(always)]
fn bilinear_plain(data: &[u8], stride: usize, t: &Tap) -> [u32; 3] {
    let base = t.offset as usize * 3;
    let below = base + stride * 3;
    let top: &[u8; 6] = data[base..base + 6].try_into().expect("6 bytes");
    let bottom: &[u8; 6] = data[below..below + 6].try_into().expect("6 bytes");
    let (wx, wy) = (t.wx as u32, t.wy as u32);
    let (ix, iy) = (ONE - wx, ONE - wy);
    let mut out = [0u32; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let a = top[c] as u32 * ix + top[c + 3] as u32 * wx;
        let b = bottom[c] as u32 * ix + bottom[c + 3] as u32 * wx;
        *o = a * iy + b * wy;
    }
    out
}

#[inline(always)]
fn round_one(s: [u32; 3]) -> [u8; 3] {
    let half = 1 << (2 * FRAC_BITS - 1);
    s.map(|v| ((v + half) >> (2 * FRAC_BITS)) as u8)
}

#[inline]
fn sample_one(data: &[u8], stride: usize, t: &Tap) -> [u8; 3] {
    if t.offset == OUTSIDE {
        return [0; 3];
    }
    round_one(bilinear(data, stride, t))
}

#[inline(always)]
fn sample_one_plain(data: &[u8], stride: usize, t: &Tap) -> [u8; 3] {
    if t.offset == OUTSIDE {
        return [0; 3];
    }
    round_one(bilinear_plain(data, stride, t))
}

/// RECIP[n] = ceil(2^32 / n): x / n == (x · RECIP[n]) >> 32 exactly whenever x · n <= 2^32.
const RECIP: [u64; MAX_TAPS + 1] = {
    let mut r = [0u64; MAX_TAPS + 1];
    let mut n = 1;
    while n <= MAX_TAPS {
        r[n] = (1u64 << 32).div_ceil(n as u64);
        n += 1;
    }
    r
};
const MAX_TAPS: usize = (MAX_SUPERSAMPLE * MAX_SUPERSAMPLE) as usize;

/// The box average of a pixel's taps (outside ones count as black), rounded to nearest.
#[inline]
fn sample_many(taps: &[Tap], bilinear: impl Fn(&Tap) -> [u32; 3]) -> [u8; 3] {
    let mut acc = [0u64; 3];
    for t in taps {
        if t.offset != OUTSIDE {
            let s = bilinear(t);
            for c in 0..3 {
                acc[c] += s[c] as u64;
            }
        }
    }
    // round(acc / (n·2^20)) = floor((acc + n·2^19) / 2^20) / n (floors compose), and that
    // quotient x <= 255.5·n, so x·n <= 2^32 and the reciprocal gives it exactly: no division.
    let n = taps.len() as u64;
    let recip = RECIP[taps.len()];
    acc.map(|v| ((((v + (n << (2 * FRAC_BITS - 1))) >> (2 * FRAC_BITS)) * recip) >> 32) as u8)
}
