//! The exposure gains of a frame's stitch (step 5 of the stitch's model).

use super::Stitch;
use crate::image::RgbImage;
use rayon::prelude::*;

/// Per ordered pair of cameras (i, j), row-major n × n: the pixels both weigh, and the sum of
/// camera i's channel values over them.
type PairSums = (Vec<u64>, Vec<u64>);

impl Stitch {
    /// Step 5 of the model: the gains that even the exposure of the `remapped` images.
    pub(super) fn gains(&self, remapped: &[RgbImage]) -> Vec<f64> {
        let n = remapped.len();
        let ones = vec![1.0; n];
        if !self.even_exposure || n < 2 {
            return ones;
        }
        let (count, sum) = self.pair_sums(remapped);
        let mean = |i: usize, j: usize| sum[i * n + j] as f64 / (3.0 * count[i * n + j] as f64);
        let total: u64 = (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .map(|(i, j)| count[i * n + j])
            .sum();
        let mu = 1e-6 * total.max(1) as f64;
        let mut a = nalgebra::DMatrix::<f64>::zeros(n, n);
        let b = nalgebra::DVector::<f64>::from_element(n, mu);
        for i in 0..n {
            a[(i, i)] += mu;
            for j in (0..n).filter(|&j| j != i && count[i * n + j] > 0) {
                let nij = count[i * n + j] as f64;
                let (mij, mji) = (mean(i, j), mean(j, i));
                a[(i, i)] += nij * mij * mij;
                a[(i, j)] -= nij * mij * mji;
            }
        }
        let Some(g) = a.lu().solve(&b) else {
            return ones;
        };
        let g0 = g[0];
        let gains: Vec<f64> = g.iter().map(|gi| gi / g0).collect();
        if gains.iter().all(|gi| gi.is_finite() && *gi > 0.0) {
            gains
        } else {
            ones
        }
    }

    /// The overlap sums of every pair of cameras, row by row: per row a bit set of the
    /// cameras that weigh each pixel (camera by camera, each weight row read in one sweep of
    /// its table's stored spans),
    /// then the pairs of the pixels two or more cameras weigh. Integer sums: exact, so they do
    /// not depend on the order or the thread count.
    pub(super) fn pair_sums(&self, remapped: &[RgbImage]) -> PairSums {
        let n = remapped.len();
        let w = self.size.width as usize;
        let h = self.size.height as usize;
        let zero = || (vec![0u64; n * n], vec![0u64; n * n]);
        if n > 64 || w == 0 {
            return self.pair_sums_by_pixel(remapped);
        }
        (0..h)
            .into_par_iter()
            .fold(
                || (zero(), Vec::new()),
                |((mut count, mut sum), mut sets), v| {
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
                            let px = &remapped[i].as_raw()[p * 3..p * 3 + 3];
                            let level = px.iter().map(|&c| c as u64).sum::<u64>();
                            let mut others = set & !(1 << i);
                            while others != 0 {
                                let j = others.trailing_zeros() as usize;
                                others &= others - 1;
                                count[i * n + j] += 1;
                                sum[i * n + j] += level;
                            }
                        }
                    }
                    ((count, sum), sets)
                },
            )
            .map(|(sums, _)| sums)
            .reduce(zero, add_sums)
    }

    /// [`Stitch::pair_sums`] pixel by pixel, for more cameras than a bit set holds.
    pub(super) fn pair_sums_by_pixel(&self, remapped: &[RgbImage]) -> PairSums {
        let n = remapped.len();
        let pixels = self.size.width as usize * self.size.height as usize;
        let zero = || (vec![0u64; n * n], vec![0u64; n * n]);
        (0..pixels)
            .into_par_iter()
            .fold(zero, |(mut count, mut sum), p| {
                if self.fallback.as_ref().is_some_and(|f| f[p]) {
                    return (count, sum);
                }
                for i in 0..n {
                    if !(self.weights[i][p] > 0.0) {
                        continue;
                    }
                    let px = &remapped[i].as_raw()[p * 3..p * 3 + 3];
                    let level = px.iter().map(|&c| c as u64).sum::<u64>();
                    for j in (0..n).filter(|&j| j != i) {
                        if self.weights[j][p] > 0.0 {
                            count[i * n + j] += 1;
                            sum[i * n + j] += level;
                        }
                    }
                }
                (count, sum)
            })
            .reduce(zero, add_sums)
    }
}

/// Two partial [`PairSums`] added.
fn add_sums((mut c1, mut s1): PairSums, (c2, s2): PairSums) -> PairSums {
    for k in 0..c1.len() {
        c1[k] += c2[k];
        s1[k] += s2[k];
    }
    (c1, s1)
}
