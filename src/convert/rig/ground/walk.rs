//! A ray's crossing of the local ground found without marching it: a Cartesian grid of
//! [`CELL`]-metre cells over the knots' disc holds, per cell, bounds of the polar raise over
//! the cell (from the knots its polar cells use: the raise is bilinear between knots, so it
//! lies between their least and largest). A ray is walked cell by cell along its horizontal
//! track (no trigonometry); the local ground is evaluated only in the cells where the ray
//! passes through that band, between the points where it enters and leaves it, and the
//! crossing there is solved by false position.

use super::{LocalGround, KNOT, KNOTS, SECTORS};
use nalgebra::Vector3;

/// Side of the bound grid's cells, metres: a cell's band spans about one polar cell's knots
/// (2.5 m by 22.5°), so finer cells would tighten it little.
pub(super) const CELL: f64 = 1.0;
/// Most false-position steps of one crossing.
const MAX_STEPS: usize = 12;
/// A crossing is found when the ray's height above the local ground is within this, metres
/// (10 µm: a millionth of a radian seen from 10 m).
const SOLVED: f64 = 1e-5;

/// The local ground's raise bounds per cell of a square grid around the centre.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Bounds {
    /// The grid's corner (least x and z).
    x0: f64,
    z0: f64,
    /// Cells per side.
    n: usize,
    /// Per cell (row-major: z then x), the least and largest raise over it.
    band: Vec<(f64, f64)>,
}

impl Bounds {
    /// The bounds of `raise` (sector-major knot heights) over the square around `centre` that
    /// holds the knots' disc.
    pub(super) fn new(centre: &Vector3<f64>, raise: &[f64]) -> Bounds {
        let radius = (KNOTS - 1) as f64 * KNOT;
        let n = (2.0 * radius / CELL).ceil() as usize;
        let (x0, z0) = (centre.x - radius, centre.z - radius);
        let mut band = Vec::with_capacity(n * n);
        for j in 0..n {
            for i in 0..n {
                // the cell relative to the centre
                let (xa, za) = (
                    x0 + i as f64 * CELL - centre.x,
                    z0 + j as f64 * CELL - centre.z,
                );
                band.push(cell_band(raise, (xa, xa + CELL), (za, za + CELL)));
            }
        }
        Bounds { x0, z0, n, band }
    }
}

/// The least and largest of the knots the polar bilinear raise uses anywhere in the rectangle
/// `xs` × `zs` (relative to the centre), widened by rounding's share.
fn cell_band(raise: &[f64], xs: (f64, f64), zs: (f64, f64)) -> (f64, f64) {
    let nearest = |lo: f64, hi: f64| {
        if lo > 0.0 {
            lo
        } else if hi < 0.0 {
            -hi
        } else {
            0.0
        }
    };
    let r_min = nearest(xs.0, xs.1).hypot(nearest(zs.0, zs.1));
    let r_max = xs.0.abs().max(xs.1.abs()).hypot(zs.0.abs().max(zs.1.abs()));
    let last = KNOTS - 1;
    let k_lo = (((r_min / KNOT - 1e-6).max(0.0)).floor() as usize).min(last);
    let k_hi = ((r_max / KNOT + 1e-6).floor() as usize + 1).min(last);
    // the sectors: every one where the cell holds the centre, else those its corners span
    let sectors: Vec<usize> = if r_min == 0.0 {
        (0..SECTORS).collect()
    } else {
        let corners = [(xs.0, zs.0), (xs.0, zs.1), (xs.1, zs.0), (xs.1, zs.1)];
        let (mx, mz) = ((xs.0 + xs.1) / 2.0, (zs.0 + zs.1) / 2.0);
        let mid = mx.atan2(mz);
        // corner angles about the middle's (the cell spans less than half a turn)
        let (lo, hi) = corners.iter().fold((0.0f64, 0.0f64), |(lo, hi), &(x, z)| {
            let a = (x.atan2(z) - mid + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            (lo.min(a), hi.max(a))
        });
        let per = SECTORS as f64 / std::f64::consts::TAU;
        let (s_lo, s_hi) = ((mid + lo) * per, (mid + hi) * per);
        // a point's sector j0 lies between these (to the angles' rounding), its bilinear
        // takes j0 and j0 + 1
        let (a, b) = (
            (s_lo - 1e-6).floor() as i64,
            (s_hi + 1e-6).floor() as i64 + 1,
        );
        (a..=b)
            .map(|j| j.rem_euclid(SECTORS as i64) as usize)
            .collect()
    };
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for j in sectors {
        for k in k_lo..=k_hi {
            let r = raise[j * KNOTS + k];
            lo = lo.min(r);
            hi = hi.max(r);
        }
    }
    let slack = 1e-9 * (1.0 + lo.abs().max(hi.abs()));
    (lo - slack, hi + slack)
}

impl LocalGround {
    /// Whether `p`, at `h` above the plane, lies above its cell's band (false off the grid):
    /// above the local ground, without evaluating it.
    pub(super) fn above_cell(&self, p: &Vector3<f64>, h: f64) -> bool {
        let b = &self.bounds;
        let (x, z) = ((p.x - b.x0) / CELL, (p.z - b.z0) / CELL);
        if !(x >= 0.0 && z >= 0.0 && x < b.n as f64 && z < b.n as f64) {
            return false;
        }
        h > b.band[z as usize * b.n + x as usize].1
    }

    /// The first crossing of the local ground by unit ray (o, d) between `t0` and `t1`, the
    /// ray's plane height `h` at o falling by `-along` a metre (`along` < 0), the ray's height
    /// above the local ground positive at `t0`; None where it stays above (or where the ray
    /// leaves the grid: the caller marches instead). Some(None): walked, no crossing. Without
    /// `solved`, the end of the first stretch the ray ends under the ground instead of the
    /// crossing in it (a bound: the crossing lies at or before it).
    pub(super) fn walk(
        &self,
        o: &Vector3<f64>,
        d: &Vector3<f64>,
        (h, along): (f64, f64),
        (t0, t1): (f64, f64),
        solved: bool,
    ) -> Option<Option<f64>> {
        let b = &self.bounds;
        let f = |t: f64| self.height(&(o + d * t));
        // the track's position in the grid, in cells
        let (px, pz) = (
            (o.x + d.x * t0 - b.x0) / CELL,
            (o.z + d.z * t0 - b.z0) / CELL,
        );
        if !(px >= 0.0 && pz >= 0.0 && px < b.n as f64 && pz < b.n as f64) {
            return None;
        }
        let (mut i, mut j) = (px as usize, pz as usize);
        // per axis: the step, the t of the next boundary and t between boundaries
        let axis = |p: f64, dp: f64, c: usize| -> (isize, f64, f64) {
            if dp > 0.0 {
                (1, t0 + ((c + 1) as f64 - p) * CELL / dp, CELL / dp)
            } else if dp < 0.0 {
                (-1, t0 + (c as f64 - p) * CELL / dp, -CELL / dp)
            } else {
                (0, f64::INFINITY, f64::INFINITY)
            }
        };
        let (si, mut next_x, dx) = axis(px, d.x, i);
        let (sj, mut next_z, dz) = axis(pz, d.z, j);
        let fall = -along;
        let mut ta = t0;
        while ta < t1 {
            let tb = next_x.min(next_z).min(t1);
            let (lo, hi) = b.band[j * b.n + i];
            if h - fall * tb <= hi {
                // the ray within the cell's band: between entering it and leaving it
                let a = ta.max((h - hi) / fall);
                let end = tb.min((h - lo) / fall).max(a);
                let fb = f(end);
                if fb <= 0.0 && !solved {
                    return Some(Some(end));
                }
                if fb <= 0.0 {
                    return Some(Some(solve(&f, (a, f(a)), (end, fb))).filter(|t| *t > 0.0));
                }
            }
            if tb >= t1 {
                break;
            }
            if next_x <= next_z {
                next_x += dx;
                match i.checked_add_signed(si).filter(|i| *i < b.n) {
                    Some(k) => i = k,
                    None => return None,
                }
            } else {
                next_z += dz;
                match j.checked_add_signed(sj).filter(|j| *j < b.n) {
                    Some(k) => j = k,
                    None => return None,
                }
            }
            ta = tb;
        }
        Some(None)
    }
}

/// (−1)^k / (2k + 1), k = 0..=10: atan's series in y².
const ATAN_SERIES: [f64; 11] = [
    1.0,
    -1.0 / 3.0,
    1.0 / 5.0,
    -1.0 / 7.0,
    1.0 / 9.0,
    -1.0 / 11.0,
    1.0 / 13.0,
    -1.0 / 15.0,
    1.0 / 17.0,
    -1.0 / 19.0,
    1.0 / 21.0,
];

/// atan2(x, z) in [0, 2π) to 1e-10 rad, without libm's call (the local ground's sector of
/// every point a ray is tested at): atan of the smaller over the larger component, reduced
/// past tan(π/8) by atan(r) = π/4 + atan((r − 1)/(r + 1)), as its series to the 21st power.
pub(in crate::convert::rig) fn turn(x: f64, z: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};
    let (ax, az) = (x.abs(), z.abs());
    if !(ax > 0.0 || az > 0.0) {
        return 0.0;
    }
    let (small, large, flip) = if ax > az {
        (az, ax, true)
    } else {
        (ax, az, false)
    };
    // r = small / large; past tan(π/8), (r − 1)/(r + 1) from the components (one division)
    let (y, shift) = if small > 0.414_213_562_373_095_1 * large {
        ((small - large) / (small + large), FRAC_PI_4)
    } else {
        (small / large, 0.0)
    };
    let y2 = y * y;
    // Σ (−1)^k y^(2k+1) / (2k+1), k = 0..=10 (the rest under |y|^23 / 23 < 7e-11), by
    // Estrin's scheme: pairs, then pairs of pairs, in parallel rather than one long chain of
    // dependent steps (this sits in every evaluation of the ground's raise)
    let c = &ATAN_SERIES;
    let (x2, x4) = (y2 * y2, y2 * y2 * (y2 * y2));
    let pairs = [
        c[0] + c[1] * y2,
        c[2] + c[3] * y2,
        c[4] + c[5] * y2,
        c[6] + c[7] * y2,
        c[8] + c[9] * y2,
    ];
    let low = (pairs[0] + pairs[1] * x2) + (pairs[2] + pairs[3] * x2) * x4;
    let series = low + (pairs[4] + c[10] * x2) * (x4 * x4);
    let atan = shift + y * series;
    let base = if flip { FRAC_PI_2 - atan } else { atan };
    let angle = match (x >= 0.0, z >= 0.0) {
        (true, true) => base,
        (true, false) => PI - base,
        (false, false) => PI + base,
        (false, true) => TAU - base,
    };
    if angle >= TAU {
        angle - TAU
    } else {
        angle
    }
}

/// The crossing of zero by `f` between `a` (f ≥ 0) and `b` (f ≤ 0): false position with the
/// Illinois rule (the kept end's value halved when one end is kept twice), to [`SOLVED`].
fn solve(f: &impl Fn(f64) -> f64, (mut a, mut fa): (f64, f64), (mut b, mut fb): (f64, f64)) -> f64 {
    let mut t = b;
    let mut side = 0i8;
    for _ in 0..MAX_STEPS {
        if !(fa - fb > 0.0) {
            break;
        }
        t = a + (b - a) * fa / (fa - fb);
        let ft = f(t);
        if ft.abs() <= SOLVED {
            break;
        }
        if ft > 0.0 {
            (a, fa) = (t, ft);
            if side == 1 {
                fb /= 2.0;
            }
            side = 1;
        } else {
            (b, fb) = (t, ft);
            if side == -1 {
                fa /= 2.0;
            }
            side = -1;
        }
    }
    t
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::Ground;
    use super::*;

    /// A local ground 1.6 m below the centre (1, 0, −2), its knots raised by up to ±0.4 m
    /// (xorshift from `seed`): crests, dips and steps far rougher than a road's.
    pub(in crate::convert::rig::ground) fn rough(seed: u64) -> (LocalGround, impl FnMut() -> f64) {
        let mut state = seed;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let raise = (0..SECTORS * KNOTS).map(|_| (next() - 0.5) * 0.8).collect();
        let plane = Ground {
            normal: Vector3::new(0.01, -1.0, 0.005).normalize(),
            offset: -1.6,
        };
        let centre = Vector3::new(1.0, 0.0, -2.0);
        (LocalGround::with_raise(plane, centre, raise), next)
    }

    #[test]
    fn the_turn_is_atan2_to_a_tenth_of_a_nanoradian() {
        let mut state = 0x1234_5678_9abc_def1_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut worst = 0.0f64;
        for k in 0..200_000 {
            let scale = [1e-6, 1.0, 40.0, 1e4][k % 4];
            let (x, z) = ((next() - 0.5) * scale, (next() - 0.5) * scale);
            // the axes and the diagonals exactly too
            let (x, z) = match k % 50 {
                0 => (0.0, z),
                1 => (x, 0.0),
                2 => (x, x),
                3 => (x, -x),
                _ => (x, z),
            };
            let exact = x.atan2(z).rem_euclid(std::f64::consts::TAU);
            let got = turn(x, z);
            assert!(
                (0.0..std::f64::consts::TAU).contains(&got),
                "{x} {z}: {got}"
            );
            let diff = (got - exact).abs();
            worst = worst.max(diff.min(std::f64::consts::TAU - diff));
        }
        assert!(worst < 1e-10, "{worst}");
        assert_eq!(turn(0.0, 0.0), 0.0);
    }

    #[test]
    fn every_cells_band_holds_the_raise_anywhere_in_it() {
        let (ground, mut next) = rough(0x9e37_79b9_7f4a_7c15);
        let b = &ground.bounds;
        let mut tight = 0;
        for _ in 0..200_000 {
            let (x, z) = (next() * b.n as f64 * CELL, next() * b.n as f64 * CELL);
            let p = Vector3::new(b.x0 + x, 0.0, b.z0 + z);
            let (lo, hi) = b.band[(z / CELL) as usize * b.n + (x / CELL) as usize];
            let r = ground.raise_at(&p);
            assert!(lo <= r && r <= hi, "{r} outside {lo}..{hi} at {p}");
            tight += usize::from(hi - lo < 0.8);
        }
        // the bands are local: most are narrower than the whole raise's
        assert!(tight > 100_000, "{tight}");
    }

    /// The first crossing of `ground` by ray (o, d) by a march of 1 cm steps through the raise's
    /// band, bisected to 1e-12 m; and whether the ray comes back above the ground within 1.5 m
    /// after it (a graze, which a cell's two ends, a diagonal apart at most, may both miss).
    fn reference(ground: &LocalGround, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<(f64, bool)> {
        let f = |t: f64| ground.height(&(o + d * t));
        let (h, fall) = (ground.plane.height(o), -ground.plane.normal.dot(d));
        // (beyond the disc the walk does not answer: the march stops a metre past it)
        let end = ((h - ground.band.0) / fall).min(ground.disc_exit(o, d) + 1.0);
        let mut a = ((h - ground.band.1) / fall).max(0.0);
        while a < end {
            let b = a + 0.01;
            if f(b) <= 0.0 {
                let (mut a, mut b) = (a, b);
                while b - a > 1e-12 {
                    let m = (a + b) / 2.0;
                    if f(m) > 0.0 {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                let grazes = (1..=150).any(|k| f(b + k as f64 * 0.01) > 0.0);
                return Some((b, grazes));
            }
            a = b;
        }
        None
    }

    #[test]
    fn a_walked_crossing_is_the_first_crossing_of_the_polar_ground() {
        let (ground, mut next) = rough(0x2545_f491_4f6c_dd1d);
        let (mut exact, mut grazes, mut beyond) = (0, 0, 0);
        for k in 0..3000 {
            // from the centre and from eyes up to 1.5 m beside it, down at 2-80°, half of them
            // grazing (under 6°)
            let off = if k % 3 == 0 { 0.0 } else { 3.0 };
            let o = ground.centre
                + Vector3::new(next() - 0.5, next() - 0.75, next() - 0.5)
                    .component_mul(&Vector3::new(off, 1.0, off));
            let elevation = if k % 2 == 0 {
                2.0 + next() * 4.0
            } else {
                2.0 + next() * 78.0
            };
            let (azimuth, e) = (next() * std::f64::consts::TAU, elevation.to_radians());
            let d = Vector3::new(azimuth.sin() * e.cos(), e.sin(), azimuth.cos() * e.cos());
            let got = ground.hit(&o, &d);
            // beyond the knots' disc the raised plane's iteration takes over: not compared
            let out = ground.disc_exit(&o, &d);
            match (got, reference(&ground, &o, &d)) {
                (_, Some((want, _))) if want > out => beyond += 1,
                (Some(t), Some((want, graze))) => {
                    if (t - want).abs() < 1e-3 {
                        exact += 1;
                    } else {
                        // a ray that clips a crest and comes back out within a cell: missed
                        assert!(graze && t > want, "ray {k}: {t} vs {want}");
                        grazes += 1;
                    }
                    assert!(ground.height(&(o + d * t)).abs() <= SOLVED, "ray {k}");
                }
                (got, want) => {
                    assert!(got.is_none_or(|t| t > out), "ray {k}: {got:?} vs {want:?}")
                }
            }
        }
        // (grazes: 1.3 % of these rays over knots ±0.4 m apart, far rougher than a road)
        assert!(
            exact > 2000 && grazes < 60 && beyond < 900,
            "{exact} {grazes} {beyond}"
        );
    }

    #[test]
    fn an_occlusion_test_against_the_ground_answers_as_the_crossing_does() {
        let (ground, mut next) = rough(0x6a09_e667_f3bc_c909);
        let (mut same, mut grazes, mut before) = (0, 0, 0);
        for k in 0..3000 {
            // from eyes up to 1.5 m beside the centre, down at 2-80°
            let o = ground.centre
                + Vector3::new(next() - 0.5, next() - 0.75, next() - 0.5)
                    .component_mul(&Vector3::new(3.0, 1.0, 3.0));
            let (azimuth, e) = (
                next() * std::f64::consts::TAU,
                (2.0 + next() * 78.0).to_radians(),
            );
            let d = Vector3::new(azimuth.sin() * e.cos(), e.sin(), azimuth.cos() * e.cos());
            let hit = ground.hit(&o, &d);
            // a limit 1 cm either side of the crossing, and one anywhere
            let t = hit.unwrap_or(50.0);
            for limit in [t - 0.01, t + 0.01, next() * 100.0] {
                let got = ground.meets_before(&o, &d, limit);
                if got == hit.is_some_and(|t| t < limit) {
                    same += 1;
                    before += usize::from(got);
                    continue;
                }
                // otherwise the ray grazes a crest: the march's first crossing says which
                let first = reference(&ground, &o, &d).map(|(t, _)| t);
                assert_eq!(
                    got,
                    first.is_some_and(|t| t < limit),
                    "ray {k}, limit {limit}"
                );
                grazes += 1;
            }
        }
        // (grazes: under 1 % over knots ±0.4 m apart, far rougher than a road)
        assert!(
            same > 8900 && grazes < 90 && before > 3000,
            "{same} {grazes} {before}"
        );
    }
}
