//! The exposure gains of a frame's stitch (step 5 of the stitch's model).

use super::Stitch;
use crate::image::RgbImage;
use rayon::prelude::*;

impl Stitch {
    /// Step 5 of the model: the gains that even the exposure of the `remapped` images.
    pub(super) fn gains(&self, remapped: &[RgbImage]) -> Vec<f64> {
        let n = remapped.len();
        let ones = vec![1.0; n];
        if !self.even_exposure || n < 2 {
            return ones;
        }
        // integer sums: exact, so the gains do not depend on the thread count
        let pixels = self.size.width as usize * self.size.height as usize;
        let zero = || (vec![0u64; n * n], vec![0u64; n * n]);
        let (count, sum) = (0..pixels)
            .into_par_iter()
            .fold(zero, |(mut count, mut sum), p| {
                // the fallback's samples do not show one point in every camera
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
            .reduce(zero, |(mut c1, mut s1), (c2, s2)| {
                for k in 0..n * n {
                    c1[k] += c2[k];
                    s1[k] += s2[k];
                }
                (c1, s1)
            });
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
}
