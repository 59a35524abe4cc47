//! A frame's stitch: each camera's image remapped, then blended by the weights and the exposure
//! gains (step 4 of the stitch's model).

use super::{Stitch, Stitched, FALLBACK_SOURCE, FAR_SOURCE};
use crate::image::RgbImage;
use rayon::prelude::*;

impl Stitch {
    /// The stitch of one frame's `images` (in the cameras' order, each of its camera's size).
    pub fn apply(&self, images: &[&RgbImage]) -> Stitched {
        self.blend(&self.remap(images))
    }

    /// Each camera's image remapped into the output (in the cameras' order).
    pub(super) fn remap(&self, images: &[&RgbImage]) -> Vec<RgbImage> {
        assert_eq!(images.len(), self.tables.len(), "one image per camera");
        (self.tables.iter().zip(images))
            .map(|(t, img)| t.apply(img))
            .collect()
    }

    /// The remapped images blended by the weights and the frame's exposure gains.
    pub(super) fn blend(&self, remapped: &[RgbImage]) -> Stitched {
        let gains = self.gains(remapped);
        let (w, h) = (self.size.width as usize, self.size.height as usize);
        let mut out = RgbImage::new(self.size.width, self.size.height);
        let mut source = vec![255u8; w * h];
        out.as_raw_mut()
            .par_chunks_mut((w * 3).max(1))
            .zip(source.par_chunks_mut(w.max(1)))
            .enumerate()
            .for_each(|(v, (row, src_row))| {
                for u in 0..w {
                    let i = v * w + u;
                    let (mut acc, mut total, mut best) = ([0f64; 3], 0f64, (0f32, 255u8));
                    for (k, img) in remapped.iter().enumerate() {
                        let wk = self.weights[k][i];
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
                            row[u * 3 + c] = (acc[c] / total).round().clamp(0.0, 255.0) as u8;
                        }
                    }
                    let fell_back = self.fallback.as_ref().is_some_and(|f| f[i]);
                    let far = self.far.as_ref().is_some_and(|f| f[i]);
                    src_row[u] = if far {
                        best.1 | FAR_SOURCE
                    } else if fell_back {
                        best.1 | FALLBACK_SOURCE
                    } else {
                        best.1
                    };
                }
            });
        Stitched {
            image: out,
            source,
            gains,
        }
    }
}
