//! The exposure gains of a frame's stitch (step 5 of the stitch's model).
//!
//! Real overlaps are thin and seen from cameras a few decimetres apart, so at the proxy
//! distance two cameras often show different things there (a kerb against sky, the car's
//! body, a saturated sky in one of them). The gains therefore come from robust pair ratios:
//! per pixel the log ratio of the two cameras' levels (pixels saturated or near black in either
//! left out), per pair the mean of its histogram's middle half and the spread of that middle
//! half; a pair whose pixels disagree weighs less, and a prior holds every gain near 1 unless
//! the overlaps agree.

use super::Stitch;
use crate::image::RgbImage;
use rayon::prelude::*;

/// Histogram bins of a pixel's log ratio ln(level_j / level_i) over [−RANGE, RANGE).
const BINS: usize = 512;
const RANGE: f64 = 1.0;
/// The fixed point of the log ratios' sums (integers: exact in any order).
const FIXED: f64 = (1u64 << 24) as f64;
/// A pixel counts where no channel reaches SATURATED and its three channels sum to DARK or more
/// in both cameras: a clipped or near-black pixel does not show the exposure.
const SATURATED: u8 = 250;
const DARK: u32 = 36;
/// The spread (in ln units) a pair's ratio carries even where its pixels agree: resampling and
/// noise; a pair whose middle half spreads more weighs less.
const SIGMA_PAIR: f64 = 0.05;
/// The prior's spread of ln g_i, per overlap pixel of camera i (OpenCV's gain compensator
/// holds gains to σ_g = 0.1 the same way).
const SIGMA_GAIN: f64 = 0.1;
/// A pair's ratio ρ weighs 1 / (1 + (ln ρ / RATIO_SCALE)²) of itself (a Cauchy weight): a rig's
/// cameras rarely differ in exposure by much, while an overlap showing two different things
/// (parallax at the proxy distance) gives ratios of 2-3 with a tight spread.
const RATIO_SCALE: f64 = 0.25;
/// No gain leaves [1/MAX_GAIN, MAX_GAIN].
const MAX_GAIN: f64 = 2.0;

/// Per pair of cameras i < j (index i·n + j): the histogram of ln(level_j / level_i) over the
/// pixels both weigh and both show unclipped, and per bin the sum of those log ratios in
/// fixed point.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct PairStats {
    n: usize,
    count: Vec<u64>,
    sum: Vec<i64>,
}

/// A pair's robust ratio: its pixels, the mean log ratio of its middle half and that half's
/// spread (the interquartile range / 1.349, a normal's σ).
#[derive(Clone, Copy, Debug)]
struct PairRatio {
    pixels: u64,
    log_ratio: f64,
    spread: f64,
}

impl PairStats {
    fn new(n: usize) -> Self {
        Self {
            n,
            count: vec![0; n * n * BINS],
            sum: vec![0; n * n * BINS],
        }
    }

    /// Adds one pixel both cameras i < j weigh, at their levels' sums and largest channels.
    fn add(&mut self, i: usize, j: usize, (li, mi): (u32, u8), (lj, mj): (u32, u8)) {
        if li < DARK || lj < DARK || mi >= SATURATED || mj >= SATURATED {
            return;
        }
        let r = (lj as f64 / li as f64).ln();
        let bin = ((r + RANGE) * (BINS as f64 / (2.0 * RANGE))).floor();
        let bin = bin.clamp(0.0, (BINS - 1) as f64) as usize;
        let k = (i * self.n + j) * BINS + bin;
        self.count[k] += 1;
        self.sum[k] += (r * FIXED).round() as i64;
    }

    fn merge(mut self, other: Self) -> Self {
        for (a, b) in self.count.iter_mut().zip(&other.count) {
            *a += b;
        }
        for (a, b) in self.sum.iter_mut().zip(&other.sum) {
            *a += b;
        }
        self
    }

    #[cfg(test)]
    /// The pixels that count for each ordered pair, row-major n × n (symmetric).
    pub(super) fn counts(&self) -> Vec<u64> {
        let n = self.n;
        let mut counts = vec![0; n * n];
        for i in 0..n {
            for j in i + 1..n {
                let c = self.count[(i * n + j) * BINS..(i * n + j + 1) * BINS]
                    .iter()
                    .sum();
                counts[i * n + j] = c;
                counts[j * n + i] = c;
            }
        }
        counts
    }

    /// The robust ratio of the pair i < j; None where no pixel counts.
    fn ratio(&self, i: usize, j: usize) -> Option<PairRatio> {
        let k = (i * self.n + j) * BINS;
        let (count, sum) = (&self.count[k..k + BINS], &self.sum[k..k + BINS]);
        let pixels: u64 = count.iter().sum();
        if pixels == 0 {
            return None;
        }
        // the bins holding the first and the third quartile
        let quartile = |q: u64| {
            let mut seen = 0;
            count.iter().position(|c| {
                seen += c;
                4 * seen > q * pixels
            })
        };
        let (lo, hi) = (quartile(1)?, quartile(3)?);
        let middle: u64 = count[lo..=hi].iter().sum();
        let total: i64 = sum[lo..=hi].iter().sum();
        let width = 2.0 * RANGE / BINS as f64;
        Some(PairRatio {
            pixels,
            log_ratio: total as f64 / (FIXED * middle as f64),
            spread: (hi - lo) as f64 * width / 1.349,
        })
    }
}

impl Stitch {
    /// Step 5 of the model: the gains that even the exposure of the `remapped` images.
    pub(super) fn gains(&self, remapped: &[RgbImage]) -> Vec<f64> {
        let n = remapped.len();
        let ones = vec![1.0; n];
        if !self.even_exposure || n < 2 {
            return ones;
        }
        let stats = self.pair_sums(remapped);
        let ratios: Vec<_> = (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .filter_map(|(i, j)| stats.ratio(i, j).map(|r| (i, j, r)))
            .collect();
        solve(n, &ratios).unwrap_or(ones)
    }

    /// The pair statistics of every pair of cameras, row by row: per row a bit set of the
    /// cameras that weigh each pixel (camera by camera, each weight row read in one sweep of
    /// its table's stored spans), then the pairs of the pixels two or more cameras weigh.
    /// Integer sums: exact, so they do not depend on the order or the thread count.
    pub(super) fn pair_sums(&self, remapped: &[RgbImage]) -> PairStats {
        let n = remapped.len();
        let w = self.size.width as usize;
        let h = self.size.height as usize;
        if n > 64 || w == 0 {
            return self.pair_sums_by_pixel(remapped);
        }
        (0..h)
            .into_par_iter()
            .fold(
                || (PairStats::new(n), Vec::new()),
                |(mut stats, mut sets), v| {
                    sets.clear();
                    sets.resize(w, 0u64);
                    // (a camera weighs nothing beyond its table's stored spans)
                    for k in 0..n {
                        let weights = &self.weights[k][v * w..(v + 1) * w];
                        for span in self.spans(k, v) {
                            let sets = &mut sets[span.clone()];
                            for (set, &wk) in sets.iter_mut().zip(&weights[span]) {
                                *set |= ((wk > 0.0) as u64) << k;
                            }
                        }
                    }
                    for (u, &set) in sets.iter().enumerate() {
                        let p = v * w + u;
                        // the fallback's samples do not show one point in every camera
                        if set.count_ones() < 2 || self.fallback.as_ref().is_some_and(|f| f[p]) {
                            continue;
                        }
                        let mut rest = set;
                        while rest != 0 {
                            let i = rest.trailing_zeros() as usize;
                            rest &= rest - 1;
                            let mut others = rest;
                            while others != 0 {
                                let j = others.trailing_zeros() as usize;
                                others &= others - 1;
                                stats.add(i, j, level(&remapped[i], p), level(&remapped[j], p));
                            }
                        }
                    }
                    (stats, sets)
                },
            )
            .map(|(stats, _)| stats)
            .reduce(|| PairStats::new(n), PairStats::merge)
    }

    /// [`Stitch::pair_sums`] pixel by pixel, for more cameras than a bit set holds.
    pub(super) fn pair_sums_by_pixel(&self, remapped: &[RgbImage]) -> PairStats {
        let n = remapped.len();
        let pixels = self.size.width as usize * self.size.height as usize;
        (0..pixels)
            .into_par_iter()
            .fold(
                || PairStats::new(n),
                |mut stats, p| {
                    if self.fallback.as_ref().is_some_and(|f| f[p]) {
                        return stats;
                    }
                    let weighs = |i: usize| self.weights[i][p] > 0.0;
                    for i in (0..n).filter(|&i| weighs(i)) {
                        for j in (i + 1..n).filter(|&j| weighs(j)) {
                            stats.add(i, j, level(&remapped[i], p), level(&remapped[j], p));
                        }
                    }
                    stats
                },
            )
            .reduce(|| PairStats::new(n), PairStats::merge)
    }
}

/// Pixel p's level (its three channels summed) and its largest channel.
fn level(image: &RgbImage, p: usize) -> (u32, u8) {
    let px = &image.as_raw()[p * 3..p * 3 + 3];
    (
        px.iter().map(|&c| c as u32).sum(),
        px.iter().copied().max().unwrap_or(0),
    )
}

/// The gains from the pairs' robust ratios: ln g minimises
/// Σ_{i<j} w_ij (x_i − x_j − d_ij)² + Σ_i p_i x_i², then image_00 keeps its exposure and the
/// gains are bounded; None where the system is singular or a gain not finite and positive.
fn solve(n: usize, ratios: &[(usize, usize, PairRatio)]) -> Option<Vec<f64>> {
    let mut a = nalgebra::DMatrix::<f64>::identity(n, n);
    let mut b = nalgebra::DVector::<f64>::zeros(n);
    // (the identity: a camera without overlaps keeps its exposure)
    for &(i, j, r) in ratios {
        let pixels = r.pixels as f64;
        let w = pixels
            / (SIGMA_PAIR.powi(2) + r.spread.powi(2))
            / (1.0 + (r.log_ratio / RATIO_SCALE).powi(2));
        let p = pixels / SIGMA_GAIN.powi(2);
        a[(i, i)] += w + p;
        a[(j, j)] += w + p;
        a[(i, j)] -= w;
        a[(j, i)] -= w;
        b[i] += w * r.log_ratio;
        b[j] -= w * r.log_ratio;
    }
    let x = a.lu().solve(&b)?;
    let bound = MAX_GAIN.ln();
    let gains: Vec<f64> = (x.iter())
        .map(|xi| (xi - x[0]).clamp(-bound, bound).exp())
        .collect();
    gains
        .iter()
        .all(|g| g.is_finite() && *g > 0.0)
        .then_some(gains)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(pixels: u64, ratio: f64, spread: f64) -> PairRatio {
        PairRatio {
            pixels,
            log_ratio: ratio.ln(),
            spread,
        }
    }

    #[test]
    fn gains_a_pair_whose_overlap_shows_other_things_does_not_darken_the_chain() {
        // The real nuScenes sample's front pair: camera 1 three times brighter than camera 0
        // where they overlap, with a tight spread (the overlap shows different things), and
        // the other pairs near 1. The old model followed the chain to g = 1/3.2 behind it.
        let chain = [
            (0, 1, pair(5813, 3.19, 0.11)),
            (1, 2, pair(9303, 0.75, 0.21)),
            (0, 3, pair(6056, 1.05, 0.13)),
        ];
        let g = solve(4, &chain).unwrap();
        assert_eq!(g[0], 1.0);
        assert!(g.iter().all(|g| (0.8..1.25).contains(g)), "{g:?}");
    }

    #[test]
    fn gains_agreeing_overlaps_bring_a_darker_camera_most_of_the_way_back() {
        // camera 2 is 0.8 of the others' exposure; every overlap says so, tightly
        let ratios = [
            (0, 1, pair(10_000, 1.0, 0.02)),
            (1, 2, pair(10_000, 0.8, 0.02)),
            (0, 2, pair(10_000, 0.8, 0.02)),
        ];
        let g = solve(3, &ratios).unwrap();
        let back = g[2].ln() / 1.25f64.ln();
        assert!(
            (0.6..=1.0).contains(&back) && (g[1] - 1.0).abs() < 0.03,
            "{g:?}"
        );
        // no overlaps: every camera keeps its exposure
        assert_eq!(solve(3, &[]).unwrap(), vec![1.0; 3]);
    }

    #[test]
    fn gains_pair_ratios_leave_out_clipped_pixels_and_the_outer_halves() {
        let mut stats = PairStats::new(2);
        // 60 pixels at ratio 1.1, 20 far off each way, and saturated or near-black pixels
        for _ in 0..60 {
            stats.add(0, 1, (300, 100), (330, 110));
        }
        for _ in 0..20 {
            stats.add(0, 1, (300, 100), (90, 30));
            stats.add(0, 1, (90, 30), (600, 200));
        }
        for _ in 0..500 {
            stats.add(0, 1, (700, 255), (300, 100));
            stats.add(0, 1, (300, 100), (30, 10));
        }
        let r = stats.ratio(0, 1).unwrap();
        assert_eq!(r.pixels, 100);
        assert!((r.log_ratio - 1.1f64.ln()).abs() < 1e-6, "{r:?}");
        assert_eq!(stats.counts(), vec![0, 100, 100, 0]);
    }
}
