//! A frame's stitch: each camera's image remapped, then blended by the weights and the exposure
//! gains (step 4 of the stitch's model).
//!
//! A camera is read only within its table's stored spans (`RemapTable::stored_spans`): its
//! pixels beyond them take nothing from its image, so its weight there is 0 (a pixel it weighs
//! lies wholly inside its image). Its remapped image is written only there, into buffers a
//! thread keeps from frame to frame, and the blend, the gains and the figures visit only
//! there: a camera's cost follows the part of the output it reaches.

use super::centre_fill::{bilinear, CentreSample};
use super::{Stitch, Stitched, FALLBACK_SOURCE, FAR_SOURCE};
use crate::image::RgbImage;
use rayon::prelude::*;
use std::cell::RefCell;
use std::ops::Range;

thread_local! {
    /// A thread's remapped images of its last frame, for the next: written only where a
    /// camera reaches, never cleared.
    static REMAPPED: RefCell<Vec<RgbImage>> = const { RefCell::new(Vec::new()) };
}

/// One output row's running blend: per pixel the weighted sums of its three channels, the
/// total weight, and the camera of the largest weight.
#[derive(Default)]
struct RowSums {
    acc: Vec<[f64; 3]>,
    total: Vec<f64>,
    best: Vec<(f32, u8)>,
}

impl RowSums {
    fn clear(&mut self, w: usize) {
        self.acc.clear();
        self.acc.resize(w, [0.0; 3]);
        self.total.clear();
        self.total.resize(w, 0.0);
        self.best.clear();
        self.best.resize(w, (0.0, 255));
    }
}

impl Stitch {
    /// The stitch of one frame's `images` (in the cameras' order, each of its camera's size).
    pub fn apply(&self, images: &[&RgbImage]) -> Stitched {
        self.with_remapped(images, |remapped| self.blend(remapped, images))
    }

    /// `f` of each camera's image remapped into the output (in the cameras' order), in the
    /// thread's kept buffers: valid within each table's stored spans only.
    pub(super) fn with_remapped<T>(
        &self,
        images: &[&RgbImage],
        f: impl FnOnce(&[RgbImage]) -> T,
    ) -> T {
        assert_eq!(images.len(), self.tables.len(), "one image per camera");
        let mut remapped = REMAPPED.with(|kept| std::mem::take(&mut *kept.borrow_mut()));
        let (w, h) = (self.size.width, self.size.height);
        remapped.retain(|img| (img.width(), img.height()) == (w, h));
        remapped.resize_with(images.len(), || RgbImage::new(w, h));
        for ((t, img), out) in self.tables.iter().zip(images).zip(&mut remapped) {
            t.apply_stored_into(img, out);
        }
        let result = f(&remapped);
        REMAPPED.with(|kept| *kept.borrow_mut() = remapped);
        result
    }

    /// The pixels of output row `v` camera `k` may weigh: its table's stored spans (the whole
    /// row for a stitch without tables, the tests' blends).
    pub(super) fn spans(&self, k: usize, v: usize) -> impl Iterator<Item = Range<usize>> + '_ {
        let table = self.tables.get(k).map(|t| t.stored_spans(v));
        let whole = table.is_none().then_some(0..self.size.width as usize);
        table.into_iter().flatten().chain(whole)
    }

    /// The remapped images blended by the weights and the frame's exposure gains; the centre
    /// fill's pixels sampled from the cameras' `images` (`centre_fill.rs`).
    pub(super) fn blend(&self, remapped: &[RgbImage], images: &[&RgbImage]) -> Stitched {
        let gains = self.gains(remapped);
        let (w, h) = (self.size.width as usize, self.size.height as usize);
        let mut out = RgbImage::new(self.size.width, self.size.height);
        let mut source = vec![255u8; w * h];
        out.as_raw_mut()
            .par_chunks_mut((w * 3).max(1))
            .zip(source.par_chunks_mut(w.max(1)))
            .enumerate()
            .for_each_init(RowSums::default, |sums, (v, (row, src_row))| {
                self.blend_row(remapped, &gains, v, sums);
                for (u, px) in row.chunks_exact_mut(3).enumerate() {
                    let total = sums.total[u];
                    if total > 0.0 {
                        for (p, acc) in px.iter_mut().zip(sums.acc[u]) {
                            *p = to_u8(acc / total);
                        }
                    }
                }
                let [fallback, far] =
                    [&self.fallback, &self.far].map(|f| f.as_ref().map(|f| &f[v * w..(v + 1) * w]));
                let source_of = |u: usize, camera: u8| {
                    if far.is_some_and(|f| f[u]) {
                        camera | FAR_SOURCE
                    } else if fallback.is_some_and(|f| f[u]) {
                        camera | FALLBACK_SOURCE
                    } else {
                        camera
                    }
                };
                for (u, s) in src_row.iter_mut().enumerate() {
                    *s = source_of(u, sums.best[u].1);
                }
                for c in self.centre_row(v) {
                    let u = c.at - v * w;
                    let k = c.camera as usize;
                    let sample = bilinear(images[k], c.x, c.y);
                    for (p, x) in row[u * 3..u * 3 + 3].iter_mut().zip(sample) {
                        *p = to_u8(gains[k] * x);
                    }
                    src_row[u] = source_of(u, c.camera);
                }
            });
        Stitched {
            image: out,
            source,
            gains,
        }
    }

    /// The centre fill's pixels of output row `v`.
    fn centre_row(&self, v: usize) -> &[CentreSample] {
        let w = self.size.width as usize;
        let from = self.centre.partition_point(|c| c.at < v * w);
        let to = self.centre.partition_point(|c| c.at < (v + 1) * w);
        &self.centre[from..to]
    }

    /// Row `v`'s sums over the cameras, camera by camera (each camera's weights and samples
    /// read in one sweep of its spans), each pixel's terms added in the cameras' order: the
    /// same sums, bit for bit, as a pixel's loop over the cameras.
    fn blend_row(&self, remapped: &[RgbImage], gains: &[f64], v: usize, sums: &mut RowSums) {
        let w = self.size.width as usize;
        sums.clear(w);
        let RowSums { acc, total, best } = sums;
        for (k, img) in remapped.iter().enumerate() {
            let weights = &self.weights[k][v * w..(v + 1) * w];
            let pixels = &img.as_raw()[v * w * 3..(v + 1) * w * 3];
            let gain = gains[k];
            for span in self.spans(k, v) {
                for u in span {
                    let wk = weights[u];
                    if !(wk > 0.0) {
                        continue;
                    }
                    let px = &pixels[u * 3..u * 3 + 3];
                    for c in 0..3 {
                        acc[u][c] += wk as f64 * gain * px[c] as f64;
                    }
                    total[u] += wk as f64;
                    if wk > best[u].0 {
                        best[u] = (wk, k as u8);
                    }
                }
            }
        }
    }
}

/// `x.round().clamp(0.0, 255.0) as u8` (ties away from zero, NaN to 0) without a call to
/// libm's `round` per channel: for 0 < x < 255 the truncation t and the fraction x − t are
/// exact, and x rounds to t + 1 exactly where x − t ≥ 0.5.
#[inline]
fn to_u8(x: f64) -> u8 {
    if !(x > 0.0) {
        return 0;
    }
    if x >= 255.0 {
        return 255;
    }
    let t = x as u32;
    (t + (x - t as f64 >= 0.5) as u32) as u8
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::ImageSize;

    /// Four cameras' weights over a 37×11 output: zero, negative (a fallback weight), NaN and
    /// positive, in runs and alone, so that one, two, three and four cameras overlap; a
    /// fallback and a far fill at some pixels.
    fn stitch_and_images() -> (Stitch, Vec<RgbImage>) {
        let (w, h, n) = (37u32, 11u32, 4usize);
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let pixels = (w * h) as usize;
        let weights: Vec<Vec<f32>> = (0..n)
            .map(|k| {
                (0..pixels)
                    .map(|p| match (next() % 7, (p + 5 * k) % 37 < 20) {
                        (_, false) => 0.0,
                        (0, _) => -0.5,
                        (1, _) => f32::NAN,
                        (r, _) => (r as f32) / 7.0 + (next() % 1000) as f32 * 1e-4,
                    })
                    .collect()
            })
            .collect();
        let images = (0..n)
            .map(|_| {
                let mut img = RgbImage::new(w, h);
                img.as_raw_mut().iter_mut().for_each(|b| *b = next() as u8);
                img
            })
            .collect();
        let flags = |m: u64| -> Vec<bool> { (0..pixels).map(|p| p as u64 % m == 3).collect() };
        let stitch = Stitch {
            size: ImageSize::new(w, h),
            tables: Vec::new(),
            weights,
            even_exposure: true,
            distances: None,
            fallback: Some(flags(5)),
            far: Some(flags(11)),
            centre: Vec::new(),
        };
        (stitch, images)
    }

    /// The blend pixel by pixel, each pixel's loop over the cameras.
    fn blend_by_pixel(stitch: &Stitch, remapped: &[RgbImage], gains: &[f64]) -> (Vec<u8>, Vec<u8>) {
        let (w, h) = (stitch.size.width as usize, stitch.size.height as usize);
        let (mut out, mut source) = (vec![0u8; w * h * 3], vec![255u8; w * h]);
        for i in 0..w * h {
            let (mut acc, mut total, mut best) = ([0f64; 3], 0f64, (0f32, 255u8));
            for (k, img) in remapped.iter().enumerate() {
                let wk = stitch.weights[k][i];
                if !(wk > 0.0) {
                    continue;
                }
                let px = &img.as_raw()[i * 3..i * 3 + 3];
                for c in 0..3 {
                    acc[c] += wk as f64 * gains[k] * px[c] as f64;
                }
                total += wk as f64;
                if wk > best.0 {
                    best = (wk, k as u8);
                }
            }
            if total > 0.0 {
                for c in 0..3 {
                    out[i * 3 + c] = (acc[c] / total).round().clamp(0.0, 255.0) as u8;
                }
            }
            let (fell_back, far) = (
                stitch.fallback.as_ref().is_some_and(|f| f[i]),
                stitch.far.as_ref().is_some_and(|f| f[i]),
            );
            source[i] = if far {
                best.1 | FAR_SOURCE
            } else if fell_back {
                best.1 | FALLBACK_SOURCE
            } else {
                best.1
            };
        }
        (out, source)
    }

    #[test]
    fn a_threads_kept_buffers_give_what_fresh_images_give() {
        use crate::camera::{Equirect, Intrinsics, Perspective};
        use crate::warp::{StitchCamera, StitchOptions};
        use nalgebra::Vector3;
        let output = Equirect::new(
            Intrinsics::new(30.0, 30.0, 94.0, 47.0),
            ImageSize::new(188, 94),
        );
        let pinhole = Perspective::new(
            Intrinsics::new(60.0, 60.0, 59.5, 39.5),
            ImageSize::new(120, 80),
        );
        let turn = |deg: f64| *nalgebra::Rotation3::from_euler_angles(0.0, deg, 0.0).matrix();
        let cameras: Vec<StitchCamera> = (0..3)
            .map(|k| StitchCamera {
                model: &pinhole,
                rotation: turn(k as f64 * 2.1),
                translation: Vector3::new(0.1 * k as f64, 0.0, 0.05),
                max_theta: None,
            })
            .collect();
        let stitch = Stitch::build(
            &output,
            &Vector3::new(0.1, 0.0, 0.0),
            &cameras,
            StitchOptions::default(),
        );
        let image = |seed: usize| {
            let mut img = RgbImage::new(120, 80);
            for (i, b) in img.as_raw_mut().iter_mut().enumerate() {
                *b = ((i * 31 + seed * 97) % 251) as u8;
            }
            img
        };
        let (a, b) = (
            [image(1), image(2), image(3)],
            [image(4), image(5), image(6)],
        );
        // a frame of other images leaves its pixels in the thread's buffers
        let first = stitch.apply(&[&a[0], &a[1], &a[2]]);
        let got = stitch.apply(&[&b[0], &b[1], &b[2]]);
        // the whole remapped images, black beyond each camera's reach
        let remapped: Vec<RgbImage> = (stitch.tables.iter().zip(&b))
            .map(|(t, img)| t.apply(img))
            .collect();
        let gains = stitch.gains(&remapped);
        let (want, source) = blend_by_pixel(&stitch, &remapped, &gains);
        assert_eq!(got.gains, gains);
        assert!(got.image.as_raw() == &want[..]);
        assert_eq!(got.source, source);
        assert!(first.image.as_raw() != got.image.as_raw());
        // the tables leave most of each camera's rows out: the buffers keep pixels there
        let (w, h) = (188, 94);
        let stored: usize = (stitch.tables.iter())
            .map(|t| {
                (0..h)
                    .flat_map(|v| t.stored_spans(v))
                    .map(|s| s.len())
                    .sum::<usize>()
            })
            .sum();
        assert!(stored < 3 * w * h / 2, "{stored} stored pixels");
    }

    #[test]
    fn the_rounding_to_bytes_is_rounds_then_clamps() {
        let below = |x: f64| f64::from_bits(x.to_bits() - 1);
        let mut xs = vec![
            0.0,
            -0.0,
            0.5,
            below(0.5),
            -0.5,
            -0.7,
            1.5,
            below(1.5),
            254.5,
            below(254.5),
            below(255.0),
            255.0,
            255.5,
            1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        xs.extend((0..100_000).map(|i| i as f64 * 0.002_718_281_8 - 5.0));
        for x in xs {
            assert_eq!(to_u8(x), x.round().clamp(0.0, 255.0) as u8, "{x:e}");
        }
    }

    #[test]
    fn the_blend_by_rows_and_the_overlap_sums_by_bit_sets_are_the_per_pixel_ones() {
        let (stitch, images) = stitch_and_images();
        assert_eq!(
            stitch.pair_sums(&images),
            stitch.pair_sums_by_pixel(&images)
        );
        // every pair overlaps somewhere, and the fallback's pixels are left out
        let count = stitch.pair_sums(&images).counts();
        assert!(
            count
                .iter()
                .enumerate()
                .all(|(k, c)| (k % 5 == 0) == (*c == 0)),
            "{count:?}"
        );
        let refs: Vec<&RgbImage> = images.iter().collect();
        let stitched = stitch.blend(&images, &refs);
        assert!(
            stitched.gains.iter().any(|g| (g - 1.0).abs() > 1e-3),
            "{:?}",
            stitched.gains
        );
        let (image, source) = blend_by_pixel(&stitch, &images, &stitched.gains);
        assert!(stitched.image.as_raw() == &image[..]);
        assert_eq!(stitched.source, source);
    }
}
