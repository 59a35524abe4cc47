//! The remap table and its application.
//!
//! For every output pixel the table holds one or more bilinear taps into the source image. When
//! the output is locally coarser than the source (more than 1.5 source pixels per output pixel)
//! the pixel is supersampled on an n×n grid over its footprint (n = round(scale), at most 8):
//! a box prefilter that removes the moiré a plain bilinear lookup gives. Weights are fixed-point
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

#[derive(Debug, Clone, Copy)]
struct Tap {
    /// Index of the top-left source pixel; its right and lower neighbours are read too.
    offset: u32,
    /// Column offset of the right neighbour: 1, 0 for a one-pixel-wide source, or 1 - width
    /// across the wrap of a 360° source.
    right: i32,
    wx: u16,
    wy: u16,
}

#[derive(Debug)]
pub struct RemapTable {
    size: ImageSize,
    source_size: ImageSize,
    /// taps[starts[i]..starts[i + 1]] belong to output pixel i.
    starts: Vec<u32>,
    taps: Vec<Tap>,
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
                right: 0,
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
            if !(y >= -0.5 && y < sh - 0.5) {
                return outside;
            }
            // Within half a pixel of the border the edge pixel is repeated (it covers that area).
            let y = y.clamp(0.0, sh - 1.0);
            let y0 = (y.floor() as u32).min(source_size.height.saturating_sub(2));
            let wy = ((y - y0 as f64) * ONE as f64).round() as u16;
            let (x0, wx, right) = if wrap == Wrap::Horizontal {
                let x0 = (x.floor() as u32).min(source_size.width - 1);
                let wx = ((x - x0 as f64) * ONE as f64).round() as u16;
                let right = if x0 + 1 == source_size.width {
                    1 - source_size.width as i32
                } else {
                    1
                };
                (x0, wx, right)
            } else {
                let x = x.clamp(0.0, sw - 1.0);
                let x0 = (x.floor() as u32).min(source_size.width.saturating_sub(2));
                let right = i32::from(source_size.width > 1);
                (x0, ((x - x0 as f64) * ONE as f64).round() as u16, right)
            };
            let wy = if source_size.height > 1 { wy } else { 0 };
            Tap {
                offset: y0 * source_size.width + x0,
                right,
                wx,
                wy,
            }
        };
        // Sequential on purpose: tables are built inside the cache's once-cell, and a parallel
        // build could let rayon run another frame's lookup of the same cell on this thread.
        let rows: Vec<(Vec<u32>, Vec<Tap>)> = (0..size.height)
            .map(|v| {
                let mut counts = Vec::with_capacity(size.width as usize);
                let mut taps = Vec::with_capacity(size.width as usize);
                for u in 0..size.width {
                    let (uf, vf) = (u as f64, v as f64);
                    let n = supersampling(uf, vf, &to_src).min(max_supersample.max(1));
                    for j in 0..n {
                        for i in 0..n {
                            let du = (i as f64 + 0.5) / n as f64 - 0.5;
                            let dv = (j as f64 + 0.5) / n as f64 - 0.5;
                            taps.push(make_tap(to_src(uf + du, vf + dv)));
                        }
                    }
                    counts.push(n * n);
                }
                (counts, taps)
            })
            .collect();
        let mut starts = Vec::with_capacity(size.width as usize * size.height as usize + 1);
        let mut taps = Vec::new();
        starts.push(0u32);
        for (counts, row_taps) in rows {
            let mut at = *starts.last().expect("starts begins with 0");
            for c in counts {
                at += c;
                starts.push(at);
            }
            taps.extend(row_taps);
        }
        RemapTable {
            size,
            source_size,
            starts,
            taps,
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
        let n = self.starts.len() - 1;
        let covered = (0..n)
            .filter(|&i| {
                self.taps[self.starts[i] as usize..self.starts[i + 1] as usize]
                    .iter()
                    .any(|t| t.offset != OUTSIDE)
            })
            .count();
        covered as f64 / n as f64
    }

    /// Whether output pixel (u, v) is wholly inside the source (every tap valid).
    pub fn is_inside(&self, u: u32, v: u32) -> bool {
        let i = (v * self.size.width + u) as usize;
        self.taps[self.starts[i] as usize..self.starts[i + 1] as usize]
            .iter()
            .all(|t| t.offset != OUTSIDE)
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
                for u in 0..w {
                    let i = v * w + u;
                    let taps = &self.taps[self.starts[i] as usize..self.starts[i + 1] as usize];
                    let px = if let [t] = taps {
                        sample_one(data, stride, t)
                    } else {
                        sample_many(data, stride, taps)
                    };
                    row[u * 3..u * 3 + 3].copy_from_slice(&px);
                }
            });
        debug_assert_eq!(out.as_raw().len(), w * h * 3);
        out
    }
}

/// Supersampling factor at output pixel (u, v): the local source-per-output pixel scale,
/// rounded, from the table's own mapping.
fn supersampling(u: f64, v: f64, to_src: &impl Fn(f64, f64) -> Option<Point2<f64>>) -> u32 {
    let (Some(l), Some(r), Some(t), Some(b)) = (
        to_src(u - 0.5, v),
        to_src(u + 0.5, v),
        to_src(u, v - 0.5),
        to_src(u, v + 0.5),
    ) else {
        return 1;
    };
    let scale = (r - l).norm().max((b - t).norm());
    if !scale.is_finite() || scale < 1.5 {
        1
    } else {
        (scale.round() as u32).min(MAX_SUPERSAMPLE)
    }
}

#[inline]
fn bilinear(data: &[u8], stride: usize, t: &Tap) -> [u32; 3] {
    let base = t.offset as usize * 3;
    let right = t.right as isize * 3;
    let (wx, wy) = (t.wx as u32, t.wy as u32);
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

#[inline]
fn sample_one(data: &[u8], stride: usize, t: &Tap) -> [u8; 3] {
    if t.offset == OUTSIDE {
        return [0; 3];
    }
    let s = bilinear(data, stride, t);
    let half = 1 << (2 * FRAC_BITS - 1);
    s.map(|v| ((v + half) >> (2 * FRAC_BITS)) as u8)
}

fn sample_many(data: &[u8], stride: usize, taps: &[Tap]) -> [u8; 3] {
    let mut acc = [0u64; 3];
    for t in taps.iter().filter(|t| t.offset != OUTSIDE) {
        let s = bilinear(data, stride, t);
        for c in 0..3 {
            acc[c] += s[c] as u64;
        }
    }
    let div = (taps.len() as u64) << (2 * FRAC_BITS);
    acc.map(|v| ((v + div / 2) / div) as u8)
}
