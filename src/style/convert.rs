//! Pure (ONNX-free) parts of the style pass: the CycleGAN pixel convention, reflection padding,
//! and the tiling plan with its blending weights. Kept apart so they are unit-tested without an
//! ONNX Runtime library.

use crate::image::RgbImage;

/// Rounds `n` up to a multiple of 4 (a ResNet generator downsamples twice).
pub fn pad_to_4(n: u32) -> u32 {
    n.div_ceil(4) * 4
}

/// Smallest padded extent fed to a model: after two stride-2 convolutions a CycleGAN generator
/// reflect-pads its 1/4-scale features by 1, which needs at least 2 pixels there.
pub const MIN_EXTENT: u32 = 8;

/// The extent an image axis of length `n` is padded to: a multiple of 4, at least
/// [`MIN_EXTENT`]. (Only images under 8 pixels differ from plain `pad_to_4`.)
pub fn padded_extent(n: u32) -> u32 {
    pad_to_4(n).max(MIN_EXTENT)
}

/// Index into `0..n` of position `i` of a reflected (mirror without repeating the edge) signal,
/// the `numpy.pad(mode="reflect")` / ONNX `Pad(mode="reflect")` rule, extended periodically
/// when the padding exceeds the signal length.
#[inline]
pub fn reflect(i: i64, n: u32) -> u32 {
    let n = n as i64;
    if n <= 1 {
        return 0;
    }
    let period = 2 * (n - 1);
    let m = i.rem_euclid(period);
    (if m < n { m } else { period - m }) as u32
}

/// The input convention: `x / 127.5 - 1` (float32, the same operations as the Python reference).
#[inline]
pub fn to_unit(v: u8) -> f32 {
    v as f32 / 127.5 - 1.0
}

/// The output convention: `(y + 1) * 127.5`, clipped to `0..=255`, rounded half away from zero.
/// NaN maps to 0.
#[inline]
pub fn from_unit(y: f32) -> u8 {
    let v = (y + 1.0) * 127.5;
    // NaN fails `v >= 0.0` and becomes 0 (`clamp` would keep it).
    let v = if v >= 0.0 { v.min(255.0) } else { 0.0 };
    // Round half away from zero without a libm call: `as` truncates (= floor for v >= 0), and
    // `v - t` is exact, so this equals `v.round()` (and the Python reference) bit for bit.
    let t = v as u8;
    t + (v - t as f32 >= 0.5) as u8
}

/// Writes the `w x h` window of `img` whose top-left corner is `(x0, y0)` into `dst` as one
/// planar CHW float tensor (`dst.len() == 3 * w * h`). Pixels outside the image are taken by
/// reflection, so a window that overhangs the bottom/right edge is the reflect padding.
pub fn window_to_chw(img: &RgbImage, x0: i64, y0: i64, w: u32, h: u32, dst: &mut [f32]) {
    let (iw, ih) = (img.width(), img.height());
    let plane = w as usize * h as usize;
    assert_eq!(dst.len(), 3 * plane, "window_to_chw: destination size");
    let raw = img.as_raw();
    let (r, rest) = dst.split_at_mut(plane);
    let (g, b) = rest.split_at_mut(plane);
    let cols: Vec<usize> = (0..w as i64)
        .map(|x| reflect(x0 + x, iw) as usize * 3)
        .collect();
    for y in 0..h as usize {
        let sy = reflect(y0 + y as i64, ih) as usize;
        let row = &raw[sy * iw as usize * 3..(sy + 1) * iw as usize * 3];
        let o = y * w as usize;
        for (x, &c) in cols.iter().enumerate() {
            r[o + x] = to_unit(row[c]);
            g[o + x] = to_unit(row[c + 1]);
            b[o + x] = to_unit(row[c + 2]);
        }
    }
}

/// Whole image, reflect-padded at the bottom/right to `pw x ph` (each `>=` the image's size),
/// as a `[1, 3, ph, pw]` tensor's data.
pub fn image_to_chw(img: &RgbImage, pw: u32, ph: u32) -> Vec<f32> {
    let mut v = vec![0.0; 3 * pw as usize * ph as usize];
    window_to_chw(img, 0, 0, pw, ph, &mut v);
    v
}

/// Converts the top-left `w x h` corner of one CHW plane triple of size `pw x ph` (the model
/// output) into an image: the crop of the convention.
pub fn chw_to_image(src: &[f32], pw: u32, ph: u32, w: u32, h: u32) -> RgbImage {
    let plane = pw as usize * ph as usize;
    assert_eq!(src.len(), 3 * plane, "chw_to_image: source size");
    assert!(w <= pw && h <= ph);
    let mut out = vec![0u8; w as usize * h as usize * 3];
    for y in 0..h as usize {
        let s = y * pw as usize;
        let d = &mut out[y * w as usize * 3..(y + 1) * w as usize * 3];
        for x in 0..w as usize {
            d[3 * x] = from_unit(src[s + x]);
            d[3 * x + 1] = from_unit(src[plane + s + x]);
            d[3 * x + 2] = from_unit(src[2 * plane + s + x]);
        }
    }
    RgbImage::from_raw(w, h, out).expect("size computed above")
}

/// Tiles along one axis: the common tile length and the start offsets (increasing; neighbours
/// overlap, and [`AxisTiles::weights`] ramps across each overlap).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AxisTiles {
    /// Length of every tile, in pixels.
    pub tile: u32,
    /// Pixel offset of each tile's first row or column, increasing.
    pub starts: Vec<u32>,
}

impl AxisTiles {
    /// Plans the tiles covering `0..extent` (the image extent already padded to a multiple of
    /// 4, see [`padded_extent`]) with tiles of length `tile` overlapping by at least
    /// `min_overlap`. Tiles are spread evenly: the first starts at 0, the last ends at `extent`,
    /// and every start is a multiple of `align` (except the last when `tile` is not one) so that
    /// each tile sees the same stride-2 sampling grid as a whole-image run. When
    /// `extent <= tile` there is one tile at 0 (the rest of it is reflect padding).
    pub fn plan(extent: u32, tile: u32, min_overlap: u32, align: u32) -> AxisTiles {
        assert!(tile > 0 && align > 0);
        if extent <= tile {
            return AxisTiles {
                tile,
                starts: vec![0],
            };
        }
        let span = extent - tile;
        let ov = min_overlap.min(tile - 1);
        // Rounding each start to `align` can shrink a gap's overlap by up to `align - 1`, so
        // plan with a step short by that much.
        let step = (tile - ov).saturating_sub(align - 1).max(1);
        let count = span.div_ceil(step) + 1;
        let mut starts: Vec<u32> = (0..count as u64)
            .map(|i| {
                // Even spread, rounded to the nearest multiple of `align`.
                let ideal2 = 2 * i * span as u64 / (count as u64 - 1); // twice the ideal start
                let a = align as u64;
                (((ideal2 + a) / (2 * a)) * a) as u32
            })
            .map(|s| s.min(span))
            .collect();
        *starts.last_mut().expect("count >= 2") = span;
        starts.dedup();
        AxisTiles { tile, starts }
    }

    /// A single tile covering the whole (padded) axis.
    pub fn whole(padded: u32) -> AxisTiles {
        AxisTiles {
            tile: padded,
            starts: vec![0],
        }
    }

    /// Blending weight of local coordinate `t` of tile `k`: a linear ramp from the tile's edge
    /// across each overlap with a neighbour, 1 elsewhere (and at the image's own edges). Always
    /// positive; weights are normalised by their sum when blending.
    pub fn weights(&self, k: usize) -> Vec<f32> {
        let t_len = self.tile as i64;
        let s = self.starts[k] as i64;
        let left = if k > 0 {
            (self.starts[k - 1] as i64 + t_len - s).max(0)
        } else {
            0
        };
        let right = if k + 1 < self.starts.len() {
            (s + t_len - self.starts[k + 1] as i64).max(0)
        } else {
            0
        };
        (0..t_len)
            .map(|t| {
                let mut w = 1.0f32;
                if left > 0 {
                    w = w.min((t as f32 + 0.5) / left as f32);
                }
                if right > 0 {
                    w = w.min((t_len as f32 - t as f32 - 0.5) / right as f32);
                }
                w
            })
            .collect()
    }
}

/// Accumulates blended tile outputs for one image (planar CHW, float) and converts the result.
pub struct Blender {
    w: u32,
    h: u32,
    acc: Vec<f32>,
    wsum: Vec<f32>,
}

impl Blender {
    /// An empty accumulator for a `w` × `h` pixel image.
    pub fn new(w: u32, h: u32) -> Blender {
        let n = w as usize * h as usize;
        Blender {
            w,
            h,
            acc: vec![0.0; 3 * n],
            wsum: vec![0.0; n],
        }
    }

    /// Adds one tile output (`3 x th x tw` planar, `tw = wx.len()`, `th = wy.len()`) whose
    /// top-left corner sits at `(x0, y0)`, weighted by `wx[x] * wy[y]`. Parts of the tile
    /// outside the image (padding) are dropped.
    pub fn add(&mut self, tile: &[f32], (x0, y0): (u32, u32), wx: &[f32], wy: &[f32]) {
        let (tw, th) = (wx.len(), wy.len());
        let tplane = tw * th;
        assert_eq!(tile.len(), 3 * tplane);
        let plane = self.w as usize * self.h as usize;
        let xs = tw.min(self.w.saturating_sub(x0) as usize);
        let ys = th.min(self.h.saturating_sub(y0) as usize);
        for (ty, &wyv) in wy.iter().enumerate().take(ys) {
            let oy = (y0 as usize + ty) * self.w as usize + x0 as usize;
            let sy = ty * tw;
            for (tx, &wxv) in wx.iter().enumerate().take(xs) {
                let wgt = wxv * wyv;
                let o = oy + tx;
                self.wsum[o] += wgt;
                for c in 0..3 {
                    self.acc[c * plane + o] += wgt * tile[c * tplane + sy + tx];
                }
            }
        }
    }

    /// The weighted mean of the tiles at each pixel, converted to RGB8 by the output
    /// convention; pixels no tile covered are black.
    pub fn finish(self) -> RgbImage {
        let plane = self.w as usize * self.h as usize;
        let mut out = vec![0u8; plane * 3];
        for i in 0..plane {
            let s = self.wsum[i];
            for c in 0..3 {
                let v = if s > 0.0 {
                    self.acc[c * plane + i] / s
                } else {
                    -1.0
                };
                out[3 * i + c] = from_unit(v);
            }
        }
        RgbImage::from_raw(self.w, self.h, out).expect("size computed above")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflect_matches_numpy() {
        // np.pad(np.arange(4), (0, 7), mode="reflect") -> 0 1 2 3 2 1 0 1 2 3 2
        let got: Vec<u32> = (0..11).map(|i| reflect(i, 4)).collect();
        assert_eq!(got, vec![0, 1, 2, 3, 2, 1, 0, 1, 2, 3, 2]);
        assert_eq!(reflect(-1, 4), 1);
        assert_eq!(reflect(5, 1), 0);
    }

    #[test]
    fn pad_multiple_of_4() {
        assert_eq!(pad_to_4(375), 376);
        assert_eq!(pad_to_4(1242), 1244);
        assert_eq!(pad_to_4(1224), 1224);
        assert_eq!(pad_to_4(370), 372);
    }

    #[test]
    fn unit_round_trip() {
        for v in 0..=255u8 {
            assert_eq!(from_unit(to_unit(v)), v);
        }
        assert_eq!(from_unit(-3.0), 0);
        assert_eq!(from_unit(3.0), 255);
        assert_eq!(from_unit(f32::NAN), 0);
        // Same as f32::round on a dense sweep of the range, ties included.
        for i in 0..=(256 * 64) {
            let v = i as f32 / 64.0 - 0.5;
            let y = v / 127.5 - 1.0;
            let w = ((y + 1.0) * 127.5).clamp(0.0, 255.0);
            assert_eq!(from_unit(y), w.round() as u8, "v={v}");
        }
        let below_half = 0.5f32 - f32::EPSILON / 4.0;
        assert_eq!(
            from_unit(below_half / 127.5 - 1.0),
            (((below_half / 127.5 - 1.0) + 1.0) * 127.5).round() as u8
        );
    }

    #[test]
    fn tiles_cover_and_overlap() {
        for n in [1u32, 63, 64, 65, 100, 375, 1242, 4000] {
            let n = padded_extent(n);
            let p = AxisTiles::plan(n, 64, 16, 4);
            assert_eq!(p.starts[0], 0);
            let last = *p.starts.last().unwrap();
            if n > 64 {
                assert_eq!(last + 64, n, "n={n}");
                for w in p.starts.windows(2) {
                    assert!(
                        w[1] > w[0] && w[0] + 64 >= w[1] + 16,
                        "n={n} {:?}",
                        p.starts
                    );
                    assert_eq!(w[1] % 4, 0, "n={n} {:?}", p.starts);
                }
            }
            for k in 0..p.starts.len() {
                assert!(p.weights(k).iter().all(|&w| w > 0.0 && w <= 1.0));
            }
        }
    }

    #[test]
    fn blend_of_constant_tiles_is_constant() {
        let (w, h) = (150u32, 70u32);
        let px = AxisTiles::plan(padded_extent(w), 64, 16, 4);
        let py = AxisTiles::plan(padded_extent(h), 64, 16, 4);
        let mut b = Blender::new(w, h);
        let tile = vec![to_unit(77); 3 * 64 * 64];
        for (j, &y0) in py.starts.iter().enumerate() {
            for (i, &x0) in px.starts.iter().enumerate() {
                b.add(&tile, (x0, y0), &px.weights(i), &py.weights(j));
            }
        }
        let img = b.finish();
        assert!(img.as_raw().iter().all(|&v| v == 77));
    }

    #[test]
    fn window_reflects_past_the_edge() {
        let mut img = RgbImage::new(3, 2);
        img.put_pixel(2, 1, [255, 0, 0]);
        img.put_pixel(1, 1, [0, 255, 0]);
        let v = image_to_chw(&img, 4, 4);
        // Row 1, column 3 reflects to column 1 (green).
        assert_eq!(v[16 + 4 + 3], 1.0);
        // Row 3 reflects to row 1; column 2 is red.
        assert_eq!(v[3 * 4 + 2], 1.0);
    }
}
