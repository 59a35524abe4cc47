//! A real scan's noise as the depth-guided stitch allows for it: the scan's ring spacing,
//! measured from the scan itself, widens the margin by which a return must lie in front of a
//! point to hide it ([`Noise::margin`]), and a return with no other return near it (dust, a
//! stray echo) is left out of the scene ([`Noise::lone`]): one return never makes an occluder.

use super::{SCAN_TOLERANCE, SPLAT_DEG};
use nalgebra::Vector3;

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
        // per azimuth bin (from −180°), the elevations: binned by a counting sort into one
        // vector (a vector a bin grows by many small reallocations, and every thread allocates
        // from one heap, `run::alloc`)
        let count = (360.0 / SPACING_BIN_DEG).round() as usize + 2;
        let mut binned: Vec<(usize, f64)> = Vec::with_capacity(points.len());
        for p in points {
            let v = p - origin;
            let range = v.norm();
            if !(range > SPACING_RANGE) {
                continue;
            }
            let azimuth = v.x.atan2(v.z).to_degrees();
            let elevation = (-v.y / range).asin().to_degrees();
            let bin = (azimuth / SPACING_BIN_DEG).floor() as i64 + count as i64 / 2;
            binned.push((bin.clamp(0, count as i64 - 1) as usize, elevation));
        }
        let mut starts = vec![0; count + 1];
        for &(bin, _) in &binned {
            starts[bin + 1] += 1;
        }
        for k in 0..count {
            starts[k + 1] += starts[k];
        }
        let mut next = starts.clone();
        let mut elevations = vec![0.0; binned.len()];
        for (bin, elevation) in binned {
            elevations[next[bin]] = elevation;
            next[bin] += 1;
        }
        let mut gaps = Vec::with_capacity(elevations.len());
        for bin in starts.windows(2) {
            let e = &mut elevations[bin[0]..bin[1]];
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
        // per ray its row and azimuth (+π; None at the origin)
        let placed: Vec<Option<(i64, f64)>> = rays
            .iter()
            .map(|(d, r)| (*r > 0.0).then(|| (row_of(d), d.x.atan2(d.z) + std::f64::consts::PI)))
            .collect();
        let column = |azimuth: f64, n: f64| {
            ((azimuth / std::f64::consts::TAU * n).floor() as i64).min(n as i64 - 1)
        };
        let buckets = Buckets::new(&placed, columns, column);
        rays.iter()
            .zip(&placed)
            .enumerate()
            .map(|(i, ((d, r), placed))| {
                let Some((row, azimuth)) = *placed else {
                    return false;
                };
                let margin = self.margin(*r);
                !(row - 1..=row + 1).any(|y| {
                    let Some(n) = buckets.columns(y) else {
                        return false;
                    };
                    let at = column(azimuth, n);
                    (at - 1..=at + 1).any(|x| {
                        let x = x.rem_euclid(n as i64);
                        buckets.list(y, x).iter().any(|&j| {
                            j != i
                                && rays[j].0.dot(d) >= cos_reach
                                && (rays[j].1 - r).abs() <= margin
                        })
                    })
                })
            })
            .collect()
    }
}

/// [`Noise::lone`]'s buckets: per row of elevation its columns of azimuth, each cell the
/// rays in it in increasing order.
struct Buckets {
    /// The first row held.
    first: i64,
    /// Per row held, its column count and its first cell.
    rows: Vec<(f64, usize)>,
    /// Per cell, where its rays start in `rays` (one more: the end).
    starts: Vec<usize>,
    rays: Vec<usize>,
}

impl Buckets {
    /// The buckets of rays at `placed` (row, azimuth + π), `columns` a row's column count,
    /// `column` the column of an azimuth in a row of that many.
    fn new(
        placed: &[Option<(i64, f64)>],
        columns: impl Fn(i64) -> f64,
        column: impl Fn(f64, f64) -> i64,
    ) -> Self {
        let rows_held = placed.iter().flatten().map(|p| p.0);
        let (first, last) = rows_held.fold((i64::MAX, i64::MIN), |(a, b), r| (a.min(r), b.max(r)));
        let mut rows = Vec::new();
        let mut cells = 0;
        for row in first..=last {
            let n = columns(row);
            rows.push((n, cells));
            cells += n as usize;
        }
        let cell = |row: i64, azimuth: f64| {
            let (n, start) = rows[(row - first) as usize];
            start + column(azimuth, n) as usize
        };
        // (a counting sort of the rays by cell, each cell's in increasing order)
        let mut starts = vec![0usize; cells + 1];
        for &(row, azimuth) in placed.iter().flatten() {
            starts[cell(row, azimuth) + 1] += 1;
        }
        for k in 1..starts.len() {
            starts[k] += starts[k - 1];
        }
        let mut next = starts.clone();
        let mut rays = vec![0; starts[cells]];
        for (i, p) in placed.iter().enumerate() {
            if let Some((row, azimuth)) = p {
                let at = &mut next[cell(*row, *azimuth)];
                rays[*at] = i;
                *at += 1;
            }
        }
        Buckets {
            first,
            rows,
            starts,
            rays,
        }
    }

    /// Row `row`'s column count (None: no ray lies in it).
    fn columns(&self, row: i64) -> Option<f64> {
        let k = usize::try_from(row.checked_sub(self.first)?).ok()?;
        self.rows.get(k).map(|r| r.0)
    }

    /// The rays of cell (`row`, `x`), `x` within the row's columns.
    fn list(&self, row: i64, x: i64) -> &[usize] {
        let cell = self.rows[(row - self.first) as usize].1 + x as usize;
        &self.rays[self.starts[cell]..self.starts[cell + 1]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// [`Noise::lone`] as a map of buckets keyed by (row, column): the reference.
    fn lone_by_map(noise: &Noise, origin: &Vector3<f64>, points: &[Vector3<f64>]) -> Vec<bool> {
        let reach = (NEIGHBOUR_SPACINGS * noise.spacing).max(SPLAT_DEG.to_radians());
        let rays: Vec<(Vector3<f64>, f64)> = (points.iter())
            .map(|p| ((p - origin).normalize(), (p - origin).norm()))
            .collect();
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
        for (i, (d, _)) in rays.iter().enumerate() {
            let row = row_of(d);
            let key = (row, column(d, columns(row)));
            buckets.entry(key).or_default().push(i);
        }
        (rays.iter().enumerate())
            .map(|(i, (d, r))| {
                !(row_of(d) - 1..=row_of(d) + 1).any(|y| {
                    let n = columns(y);
                    (column(d, n) - 1..=column(d, n) + 1).any(|x| {
                        let list = buckets.get(&(y, x.rem_euclid(n as i64)));
                        list.is_some_and(|list| {
                            list.iter().any(|&j| {
                                j != i
                                    && rays[j].0.dot(d) >= reach.cos()
                                    && (rays[j].1 - r).abs() <= noise.margin(*r)
                            })
                        })
                    })
                })
            })
            .collect()
    }

    #[test]
    fn the_lone_returns_are_those_the_map_of_buckets_finds() {
        let mut state = 0x1f83_d9ab_fb41_bd6b_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        // scattered returns (many lone), a few dense patches (none lone), near the poles too
        let mut points = Vec::new();
        for k in 0..6000 {
            let d = Vector3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            let d = if k % 3 == 0 {
                Vector3::new(d.x * 0.05, -1.0, d.z * 0.05).normalize()
            } else {
                d
            };
            points.push(d * (3.0 + 30.0 * next()));
            if k % 4 == 0 {
                let e = (d + Vector3::new(next(), next(), next()) * 0.004).normalize();
                points.push(e * (points.last().unwrap().norm() + 0.05));
            }
        }
        let origin = Vector3::new(0.1, 0.2, -0.3);
        for spacing in [0.2f64, 1.0, 3.0] {
            let noise = Noise {
                spacing: spacing.to_radians(),
            };
            let got = noise.lone(&origin, &points);
            assert_eq!(got, lone_by_map(&noise, &origin, &points), "{spacing}");
            let lone = got.iter().filter(|l| **l).count();
            assert!(lone > 500 && lone < points.len() - 1000, "{lone}");
        }
    }
}
