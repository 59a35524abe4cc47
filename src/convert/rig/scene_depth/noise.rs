//! A real scan's noise as the depth-guided stitch allows for it: the scan's ring spacing,
//! measured from the scan itself, widens the margin by which a return must lie in front of a
//! point to hide it ([`Noise::margin`]), and a return with no other return near it (dust, a
//! stray echo) is left out of the scene ([`Noise::lone`]): one return never makes an occluder.

use super::{SCAN_TOLERANCE, SPLAT_DEG};
use nalgebra::Vector3;
use std::collections::HashMap;

/// Returns nearer than this to the viewpoint do not measure the ring spacing (parallax between
/// the sensor and the output centre), metres.
const SPACING_RANGE: f64 = 5.0;
/// Azimuth bins that measure the ring spacing, degrees: narrower than a scan's azimuth step.
const SPACING_BIN_DEG: f64 = 0.1;
/// Elevation gaps below this are the same ring, degrees.
const SAME_RING_DEG: f64 = 0.05;
/// The ring spacing assumed when the scan shows too few rings, degrees.
const DEFAULT_SPACING_DEG: f64 = SPLAT_DEG;
/// A return belongs to a surface when another lies within this many ring spacings (at least
/// a splat's radius) and the range margin of it.
const NEIGHBOUR_SPACINGS: f64 = 2.0;
/// The share of a point's range by which a return must lie in front of it to hide it, before
/// the ring spacing's part.
const RANGE_SHARE: f64 = 0.05;

/// A scan's noise model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Noise {
    /// The median elevation gap between the scan's neighbouring rings, radians.
    pub(super) spacing: f64,
}

impl Noise {
    /// The noise of the scan `points` seen from `origin`: its ring spacing is the median of
    /// the elevation gaps above [`SAME_RING_DEG`] between returns of one azimuth bin.
    pub(super) fn measure(origin: &Vector3<f64>, points: &[Vector3<f64>]) -> Noise {
        let mut bins: HashMap<i64, Vec<f64>> = HashMap::new();
        for p in points {
            let v = p - origin;
            let range = v.norm();
            if !(range > SPACING_RANGE) {
                continue;
            }
            let azimuth = v.x.atan2(v.z).to_degrees();
            let elevation = (-v.y / range).asin().to_degrees();
            bins.entry((azimuth / SPACING_BIN_DEG).floor() as i64)
                .or_default()
                .push(elevation);
        }
        let mut gaps = Vec::new();
        for e in bins.values_mut() {
            e.sort_by(f64::total_cmp);
            gaps.extend(
                e.windows(2)
                    .map(|w| w[1] - w[0])
                    .filter(|g| *g > SAME_RING_DEG),
            );
        }
        let degrees = if gaps.len() < 100 {
            DEFAULT_SPACING_DEG
        } else {
            // (the median is the same whatever order the bins came in)
            let mid = gaps.len() / 2;
            *gaps.select_nth_unstable_by(mid, f64::total_cmp).1
        };
        Noise {
            spacing: degrees.clamp(0.1, 3.0).to_radians(),
        }
    }

    /// How far in front of a point `length` metres away a return must lie to hide it, metres:
    /// the LiDAR's range noise, and a share of the distance that grows with the ring spacing
    /// (a splat's bearing is uncertain by up to a spacing).
    pub(super) fn margin(&self, length: f64) -> f64 {
        SCAN_TOLERANCE + length * (RANGE_SHARE + self.spacing)
    }

    /// `points` without their lone returns ([`Noise::lone`] seen from `origin`): one return in
    /// front of a surface is noise, not an occluder.
    pub(super) fn without_lone_returns(
        &self,
        origin: &Vector3<f64>,
        points: Vec<Vector3<f64>>,
    ) -> Vec<Vector3<f64>> {
        let lone = self.lone(origin, &points);
        points
            .into_iter()
            .zip(lone)
            .filter_map(|(p, lone)| (!lone).then_some(p))
            .collect()
    }

    /// Which of `points` are lone returns seen from `origin`: no other return within
    /// [`NEIGHBOUR_SPACINGS`] ring spacings of its bearing (at least [`SPLAT_DEG`]) and within
    /// [`Noise::margin`] of its range.
    pub(super) fn lone(&self, origin: &Vector3<f64>, points: &[Vector3<f64>]) -> Vec<bool> {
        let reach = (NEIGHBOUR_SPACINGS * self.spacing).max(SPLAT_DEG.to_radians());
        let cos_reach = reach.cos();
        let rays: Vec<(Vector3<f64>, f64)> = points
            .iter()
            .map(|p| {
                let v = p - origin;
                let r = v.norm();
                (if r > 0.0 { v / r } else { v }, r)
            })
            .collect();
        // buckets of `reach` in elevation, and in azimuth at least `reach` wide across the
        // row's edge farthest from the horizon: a neighbour lies in the 3 × 3 around
        let row_of = |d: &Vector3<f64>| ((-d.y).clamp(-1.0, 1.0).asin() / reach).floor() as i64;
        let columns = |row: i64| {
            let far = ((row as f64).abs().max(((row + 1) as f64).abs()) * reach).min(1.5);
            ((std::f64::consts::TAU * far.cos()) / reach)
                .floor()
                .max(1.0)
        };
        let column = |d: &Vector3<f64>, n: f64| {
            let azimuth = d.x.atan2(d.z) + std::f64::consts::PI;
            ((azimuth / std::f64::consts::TAU * n).floor() as i64).min(n as i64 - 1)
        };
        let mut buckets: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        for (i, (d, r)) in rays.iter().enumerate() {
            if *r > 0.0 {
                let row = row_of(d);
                buckets
                    .entry((row, column(d, columns(row))))
                    .or_default()
                    .push(i);
            }
        }
        rays.iter()
            .enumerate()
            .map(|(i, (d, r))| {
                if !(*r > 0.0) {
                    return false;
                }
                let margin = self.margin(*r);
                let row = row_of(d);
                !(row - 1..=row + 1).any(|y| {
                    let n = columns(y);
                    let at = column(d, n);
                    (at - 1..=at + 1).any(|x| {
                        let x = x.rem_euclid(n as i64);
                        buckets.get(&(y, x)).is_some_and(|list| {
                            list.iter().any(|&j| {
                                j != i
                                    && rays[j].0.dot(d) >= cos_reach
                                    && (rays[j].1 - r).abs() <= margin
                            })
                        })
                    })
                })
            })
            .collect()
    }
}
