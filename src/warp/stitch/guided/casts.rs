//! The scene's distance at every output pixel centre, cast at the even rows and columns and
//! interpolated between them where the scene is smooth there.
//!
//! A pixel between two cast neighbours (or four) takes the mean of their inverse distances when
//! the inverse distance's second differences along the cast samples around it stay within a
//! tolerance: on a smooth surface the error of a linear interpolation at a midpoint is at most
//! a quarter of them (an eighth for a quadratic), so the interpolated point moves in any camera
//! by at most [`PARALLAX_PX`] of an output pixel (its parallax across the largest baseline) and
//! its distance by at most [`RELATIVE`] of itself. A plane's inverse distance is linear in the
//! bearing: the ground and a box's face interpolate almost exactly. (A splat buffer's range is
//! a step per cell: a small step passes the test and may take up to half of it, a few tenths
//! of a percent of the distance on real scans.) A depth edge (a wall
//! before the sky, a splat's rim) breaks the second differences and is cast per pixel, and so
//! is every sample the scene asks to cast ([`StitchDepth::may_interpolate`]: an exact object
//! narrower than the samples' spacing may lie between them).

use super::StitchDepth;
use crate::camera::ImageSize;
use crate::warp::reach::Reach;
use rayon::prelude::*;

/// The most an interpolated distance may move a camera's point, output pixels.
pub(crate) const PARALLAX_PX: f64 = 0.05;
/// The most an interpolated distance may differ from the cast one, a share of it.
pub(crate) const RELATIVE: f64 = 1e-3;

/// A cast sample: its distance (0 without a bearing) and inverse distance (NaN where it may
/// not be interpolated from).
#[derive(Clone, Copy)]
struct Sample {
    t: f64,
    inverse: f64,
}

/// The cast samples at the even rows and columns and the tolerance of their second
/// differences.
struct Samples {
    width: usize,
    height: usize,
    at: Vec<Sample>,
    /// Per metre⁻¹ of the largest baseline's parallax: [`PARALLAX_PX`] of a pixel.
    parallax: f64,
    /// Per sample, [`Samples::smooth`] along its row (bit 0) and its column (bit 1), each
    /// asked once (a pixel between four samples reads four).
    smooth: Vec<u8>,
}

impl Samples {
    fn get(&self, i: usize, j: usize) -> Sample {
        self.at[j * self.width + i]
    }

    /// The tolerance of a second difference around inverse distances `a` and `b`.
    fn tolerance(&self, a: f64, b: f64) -> f64 {
        4.0 * self.parallax.min(RELATIVE * a.min(b))
    }

    /// Whether the pixels between samples `first` and the next along `step` ((1, 0) a row,
    /// (0, 1) a column) may be interpolated: the samples before, at and after them (four)
    /// exist and their two second differences stay within the tolerance.
    fn smooth(&self, (i, j): (usize, usize), step: (usize, usize)) -> bool {
        let (i, j) = (i as i64, j as i64);
        let (di, dj) = (step.0 as i64, step.1 as i64);
        let mut s = [0.0; 4];
        for (k, s) in s.iter_mut().enumerate() {
            let (a, b) = (i + (k as i64 - 1) * di, j + (k as i64 - 1) * dj);
            if a < 0 || b < 0 || a >= self.width as i64 || b >= self.height as i64 {
                return false;
            }
            *s = self.get(a as usize, b as usize).inverse;
        }
        // (a NaN fails every comparison)
        let tolerance = self.tolerance(s[1], s[2]);
        (s[0] - 2.0 * s[1] + s[2]).abs() <= tolerance
            && (s[1] - 2.0 * s[2] + s[3]).abs() <= tolerance
    }

    /// Sets [`Samples::smooth`] from the samples.
    fn mark_smooth(&mut self) {
        let w = self.width;
        let mut smooth = vec![0u8; self.at.len()];
        smooth
            .par_chunks_mut(w.max(1))
            .enumerate()
            .for_each(|(j, row)| {
                for (i, s) in row.iter_mut().enumerate() {
                    *s = u8::from(self.smooth((i, j), (1, 0)))
                        | u8::from(self.smooth((i, j), (0, 1))) << 1;
                }
            });
        self.smooth = smooth;
    }

    /// [`Samples::smooth`] of sample (i, j) along `bit`'s way, as marked (false beyond the
    /// samples, as `smooth` answers there).
    fn marked(&self, i: usize, j: usize, bit: u8) -> bool {
        i < self.width && j < self.height && self.smooth[j * self.width + i] & bit != 0
    }

    /// Pixel (u, v)'s interpolated distance, None where it is to be cast.
    fn interpolated(&self, u: usize, v: usize) -> Option<f64> {
        let (i, j) = (u / 2, v / 2);
        let mean = |s: &[(usize, usize)]| {
            let sum: f64 = s.iter().map(|&(i, j)| self.get(i, j).inverse).sum();
            Some(s.len() as f64 / sum)
        };
        match (u % 2, v % 2) {
            (0, 0) => Some(self.get(i, j).t),
            (1, 0) if self.marked(i, j, 1) => mean(&[(i, j), (i + 1, j)]),
            (0, 1) if self.marked(i, j, 2) => mean(&[(i, j), (i, j + 1)]),
            (1, 1)
                if self.marked(i, j, 1)
                    && self.marked(i, j + 1, 1)
                    && self.marked(i, j, 2)
                    && self.marked(i + 1, j, 2) =>
            {
                mean(&[(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)])
            }
            _ => None,
        }
    }
}

/// The scene's distance at every output pixel centre (0 where the output has no bearing),
/// `baseline` the largest distance of a camera's centre (and the motion of a point it sees)
/// from the output centre, metres.
pub(super) fn pixel_distances(
    reach: &Reach,
    size: ImageSize,
    depth: &dyn StitchDepth,
    baseline: f64,
) -> Vec<f64> {
    let (w, h) = (size.width as usize, size.height as usize);
    let cast = |u: usize, v: usize| reach.bearing(u, v).map(|d| depth.distance(&d.normalize()));
    // (a pixel lies within two turns of each sample it is interpolated from)
    let (cw, ch, within) = (w.div_ceil(2), h.div_ceil(2), 2.0 * reach.step());
    let mut at = vec![
        Sample {
            t: 0.0,
            inverse: f64::NAN
        };
        cw * ch
    ];
    at.par_chunks_mut(cw.max(1))
        .enumerate()
        .for_each(|(j, row)| {
            for (i, s) in row.iter_mut().enumerate() {
                if let Some(d) = reach.bearing(2 * i, 2 * j) {
                    let (t, may) = depth.distance_and_may_interpolate(&d.normalize(), within);
                    let smooth = t > 0.0 && t.is_finite() && may;
                    let inverse = if smooth { 1.0 / t } else { f64::NAN };
                    *s = Sample { t, inverse };
                }
            }
        });
    let mut samples = Samples {
        width: cw,
        height: ch,
        at,
        parallax: PARALLAX_PX * reach.step() / baseline,
        smooth: Vec::new(),
    };
    samples.mark_smooth();
    let mut out = vec![0.0; w * h];
    out.par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(v, row)| {
            for (u, t) in row.iter_mut().enumerate() {
                *t = match samples.interpolated(u, v) {
                    Some(t) => t,
                    None => cast(u, v).unwrap_or(0.0),
                };
            }
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{CameraModel, Equirect, Intrinsics};
    use nalgebra::Vector3;
    use std::f64::consts::{PI, TAU};
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// A street: the ground 1.6 m below (y down), a wall 20 m ahead up to 6 m, a pole 8 m
    /// away narrower than a pixel (an exact object), the sky beyond; its casts counted.
    #[derive(Debug)]
    struct Street {
        pole: f64,
        casts: AtomicUsize,
    }

    impl Street {
        /// The pole's half-width, radians.
        const HALF: f64 = 0.001;
        fn off_pole(&self, d: &Vector3<f64>) -> f64 {
            let a = (d.x.atan2(d.z) - self.pole).abs();
            a.min(TAU - a)
        }
    }

    impl StitchDepth for Street {
        fn distance(&self, d: &Vector3<f64>) -> f64 {
            self.casts.fetch_add(1, Ordering::Relaxed);
            let mut t: f64 = 1e4;
            if d.y > 0.01 {
                t = t.min(1.6 / d.y);
            }
            if d.z > 0.2 && 20.0 / d.z * d.y >= -6.0 {
                t = t.min(20.0 / d.z);
            }
            let flat = d.x.hypot(d.z);
            if self.off_pole(d) < Self::HALF && (8.0 / flat * d.y).abs() < 3.0 {
                t = t.min(8.0 / flat);
            }
            t
        }
        fn sees(&self, _: usize, _: &Vector3<f64>) -> bool {
            true
        }
        fn nearest(&self) -> f64 {
            0.0
        }
        fn may_interpolate(&self, d: &Vector3<f64>, radius: f64) -> bool {
            self.off_pole(d) > Self::HALF + radius
        }
    }

    #[test]
    fn interpolated_distances_move_a_point_by_a_share_of_a_pixel_and_keep_every_edge() {
        let (w, h) = (1024u32, 512u32);
        let k = Intrinsics::new(
            w as f64 / TAU,
            h as f64 / PI,
            w as f64 / 2.0 - 0.5,
            h as f64 / 2.0 - 0.5,
        );
        let output = Equirect::new(k, ImageSize::new(w, h));
        let reach = Reach::new(&output, &[], None);
        // the pole 0.3 mrad beside a column's centres: that column alone meets it
        let b = reach.bearing(561, 256).unwrap();
        let street = Street {
            pole: b.x.atan2(b.z) + 3e-4,
            casts: AtomicUsize::new(0),
        };
        let baseline = 1.5;
        let got = pixel_distances(&reach, output.size(), &street, baseline);
        let casts = street.casts.load(Ordering::Relaxed);
        let n = (w * h) as usize;
        let (mut worst_px, mut worst_rel, mut pole) = (0.0f64, 0.0f64, 0);
        for (i, t) in got.iter().enumerate() {
            let d = reach.bearing(i % w as usize, i / w as usize).unwrap();
            let exact = street.distance(&d.normalize());
            // the parallax across the baseline, in pixels, and the relative error
            worst_px = worst_px.max(baseline * (1.0 / t - 1.0 / exact).abs() / reach.step());
            worst_rel = worst_rel.max((t - exact).abs() / exact);
            let d = d.normalize();
            if street.off_pole(&d) < Street::HALF && exact == 8.0 / d.x.hypot(d.z) {
                assert_eq!(*t, exact, "the pole at pixel {i}");
                pole += 1;
            }
        }
        // within the bounds (the second differences' quarter is a bound with room here)
        assert!(worst_px <= PARALLAX_PX, "{worst_px} px");
        assert!(worst_rel <= RELATIVE, "{worst_rel}");
        // the pole's pixels are cast, and the smooth scene is mostly interpolated
        assert!(pole > 50, "{pole} pole pixels");
        assert!(casts < n * 45 / 100, "{casts} casts of {n} pixels");
    }
}
