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

/// Pixels per piece of [`resolve`]'s one pass: every camera's weights of a piece stay in the
/// cache while it is resolved.
const PIECE: usize = 4096;

/// Resolves the weights built with fallbacks as negative values: per pixel, the positive
/// weights where there is one (negatives set to 0), else the negated fallbacks. Returns the
/// pixels that took fallbacks.
pub(super) fn resolve(weights: &mut [Vec<f32>]) -> Vec<bool> {
    let n = weights.first().map_or(0, Vec::len);
    // per piece of the output, every camera's share of it
    let mut pieces: Vec<Vec<&mut [f32]>> = (0..n.div_ceil(PIECE)).map(|_| Vec::new()).collect();
    for w in weights.iter_mut() {
        for (piece, part) in pieces.iter_mut().zip(w.chunks_mut(PIECE)) {
            piece.push(part);
        }
    }
    let mut fallback = vec![false; n];
    pieces
        .into_par_iter()
        .zip(fallback.par_chunks_mut(PIECE))
        .for_each(|(mut parts, fallback)| {
            let mut seen = [false; PIECE];
            resolve_pixels(&mut parts, fallback, &mut seen[..fallback.len()]);
        });
    fallback
}

/// [`resolve`] of some pixels: `weights` every camera's weights of them, `fallback` their
/// flags (false on entry), `seen` as many pixels' room (false on entry, left as it was
/// computed). Camera by camera over the pixels: loops the compiler vectorises.
pub(super) fn resolve_pixels(weights: &mut [&mut [f32]], fallback: &mut [bool], seen: &mut [bool]) {
    for w in weights.iter() {
        for (s, x) in seen.iter_mut().zip(w.iter()) {
            *s |= *x > 0.0;
        }
    }
    for w in weights.iter_mut() {
        for (x, s) in w.iter_mut().zip(seen.iter()) {
            if *x < 0.0 {
                *x = if *s { 0.0 } else { -*x };
            }
        }
    }
    for w in weights.iter() {
        for (flag, x) in fallback.iter_mut().zip(w.iter()) {
            *flag |= *x > 0.0;
        }
    }
    for (flag, s) in fallback.iter_mut().zip(seen.iter()) {
        *flag &= !*s;
    }
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

    #[test]
    fn the_pieces_resolve_as_a_pass_per_pixel_does() {
        // four cameras over a few pieces and a partial one: every pixel resolved as its own
        // loop over the cameras resolves it
        let n = 3 * PIECE + 17;
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut weights: Vec<Vec<f32>> = (0..4)
            .map(|_| {
                (0..n)
                    .map(|_| {
                        state ^= state << 13;
                        state ^= state >> 7;
                        state ^= state << 17;
                        // zero, positive and negative (a fallback) about equally
                        [0.0, 0.25, -0.5, 1.0, -1.0, 0.0][(state >> 40) as usize % 6]
                    })
                    .collect()
            })
            .collect();
        let mut want = weights.clone();
        let mut flags = vec![false; n];
        for (i, flag) in flags.iter_mut().enumerate() {
            let seen = want.iter().any(|w| w[i] > 0.0);
            for w in want.iter_mut() {
                if w[i] < 0.0 {
                    w[i] = if seen { 0.0 } else { -w[i] };
                }
            }
            *flag = !seen && want.iter().any(|w| w[i] > 0.0);
        }
        let fallback = resolve(&mut weights);
        assert_eq!(weights, want);
        assert_eq!(fallback, flags);
        assert!(flags.iter().filter(|f| **f).count() > 100);
    }
}
