//! The depth-guided stitch's fallback: never black where a camera covers the ray.
//!
//! A camera whose image holds a pixel's sample but which fails the occlusion test there
//! (something of the scene lies nearer on its own ray, or its footprint's rim) gives the pixel
//! a *fallback* weight, its margin's weight as usual. Where some camera passes the test the
//! fallback weights are dropped; where none does, the fallback weights blend instead: the
//! cameras' samples at the stitched distance, what each of them sees along that ray. Such a
//! pixel's colour may show a nearer surface than the output centre sees (a parallax copy), so
//! its source index carries [`FALLBACK_SOURCE`].

use rayon::prelude::*;

/// Added to a pixel's source index (the camera of largest weight) when the fallback rule
/// filled it: its colour is a camera's sample at the stitched distance though no camera was
/// shown to see that point.
pub const FALLBACK_SOURCE: u8 = 128;

/// Resolves the weights built with fallbacks as negative values: per pixel, the positive
/// weights where there is one (negatives set to 0), else the negated fallbacks. Returns the
/// pixels that took fallbacks.
pub(super) fn resolve(weights: &mut [Vec<f32>]) -> Vec<bool> {
    let n = weights.first().map_or(0, Vec::len);
    let seen: Vec<bool> = (0..n)
        .into_par_iter()
        .map(|i| weights.iter().any(|w| w[i] > 0.0))
        .collect();
    for w in weights.iter_mut() {
        w.par_iter_mut().zip(&seen).for_each(|(x, &seen)| {
            if *x < 0.0 {
                *x = if seen { 0.0 } else { -*x };
            }
        });
    }
    (0..n)
        .into_par_iter()
        .map(|i| !seen[i] && weights.iter().any(|w| w[i] > 0.0))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fallbacks_fill_only_pixels_no_camera_sees() {
        // pixel 0: camera 0 sees it, camera 1 only falls back; pixel 1: both fall back;
        // pixel 2: neither covers it
        let mut w = vec![vec![0.5, -0.25, 0.0], vec![-1.0, -0.75, 0.0]];
        let fallback = resolve(&mut w);
        assert_eq!(w, vec![vec![0.5, 0.25, 0.0], vec![0.0, 0.75, 0.0]]);
        assert_eq!(fallback, vec![false, true, false]);
    }
}
