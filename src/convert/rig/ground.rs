//! The ground of a frame's scene: a plane ([`Ground`]) fitted to the scan's lowest dense layer,
//! and the ground fitted locally ([`LocalGround`]), that plane raised to the scan's own ground
//! returns per knot of a polar grid, which holds near the vehicle where the scan has no returns
//! (`scene_depth.rs`).

use nalgebra::{Matrix3, Vector3};

mod radial;
mod walk;

pub(super) use walk::turn;

/// Half-height of the band around the first fit whose cells the ground's second fit uses, m.
pub const GROUND_BAND: f64 = 0.15;
/// Points within this of the first fit make the second, and are the ground, metres.
pub const GROUND_FIT: f64 = 0.05;
/// The ground is fitted to points this far from the output centre, horizontally, metres.
const GROUND_RANGE: (f64, f64) = (2.0, 40.0);
/// Fewest points a ground fit takes.
const GROUND_MIN_POINTS: usize = 50;

/// The ground plane: normal · x = offset, normal a unit vector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ground {
    /// Unit normal (towards the side the output centre is on).
    pub normal: Vector3<f64>,
    /// normal · x on the plane.
    pub offset: f64,
}

impl Ground {
    /// The signed height of `p` above the plane (the normal's side positive).
    pub fn height(&self, p: &Vector3<f64>) -> f64 {
        self.normal.dot(p) - self.offset
    }

    /// A lower bound of the hit distance over the unit rays from `o` within `radius` of unit
    /// `d`: |h| / cos ψ, ψ the least angle such a ray makes with the way to the plane.
    pub(super) fn nearest_within(&self, o: &Vector3<f64>, d: &Vector3<f64>, radius: f64) -> f64 {
        let h = self.height(o);
        let towards = if h >= 0.0 { -self.normal } else { self.normal };
        let angle = (towards.dot(d).clamp(-1.0, 1.0).acos() - radius - 1e-9).max(0.0);
        if angle >= std::f64::consts::FRAC_PI_2 {
            return f64::INFINITY;
        }
        h.abs() / angle.cos() * (1.0 - 1e-9)
    }

    /// The plane fitted to `points` (y down, the reference frame's): the lowest point of each
    /// 1 m cell (horizontally, within `GROUND_RANGE` of `centre`: a wall's or a car's
    /// lowest return is the ground beside or under it, or near it), fitted as y = a·x + b·z + c
    /// by least squares, refitted over the cells within `GROUND_BAND` of the fit, then over
    /// every point within `GROUND_FIT` of that. None with too few points.
    pub fn fit(points: &[Vector3<f64>], centre: &Vector3<f64>) -> Option<Ground> {
        let mut lowest = std::collections::BTreeMap::<(i64, i64), Vector3<f64>>::new();
        for p in points {
            let r = (p.x - centre.x).hypot(p.z - centre.z);
            if !(r >= GROUND_RANGE.0 && r <= GROUND_RANGE.1 && p.y > centre.y) {
                continue;
            }
            let cell = (p.x.floor() as i64, p.z.floor() as i64);
            let low = lowest.entry(cell).or_insert(*p);
            if p.y > low.y {
                *low = *p;
            }
        }
        let cells: Vec<&Vector3<f64>> = lowest.values().collect();
        let mut fit = Self::least_squares(cells.iter().copied())?;
        for band in [4.0 * GROUND_BAND, GROUND_BAND] {
            fit = Self::least_squares(
                cells
                    .iter()
                    .copied()
                    .filter(|p| fit.height(p).abs() <= band),
            )?;
        }
        let on = points.iter().filter(|p| {
            fit.height(p).abs() <= GROUND_FIT
                && (p.x - centre.x).hypot(p.z - centre.z) <= GROUND_RANGE.1
        });
        Some(Self::least_squares(on)?.facing(centre))
    }

    /// y = a·x + b·z + c over `points`, as a plane.
    fn least_squares<'p>(points: impl Iterator<Item = &'p Vector3<f64>>) -> Option<Ground> {
        let mut ata = Matrix3::<f64>::zeros();
        let mut aty = Vector3::<f64>::zeros();
        let mut n = 0usize;
        for p in points {
            let row = Vector3::new(p.x, p.z, 1.0);
            ata += row * row.transpose();
            aty += row * p.y;
            n += 1;
        }
        if n < GROUND_MIN_POINTS {
            return None;
        }
        let [a, b, c] = ata.lu().solve(&aty)?.into();
        // a·x − y + b·z + c = 0
        let normal = Vector3::new(a, -1.0, b);
        let norm = normal.norm();
        Some(Ground {
            normal: normal / norm,
            offset: -c / norm,
        })
    }

    /// The same plane with its normal towards `p`.
    fn facing(self, p: &Vector3<f64>) -> Ground {
        if self.height(p) >= 0.0 {
            self
        } else {
            Ground {
                normal: -self.normal,
                offset: -self.offset,
            }
        }
    }
}

/// Sectors of the local ground's polar grid around the output centre.
const SECTORS: usize = 16;
/// Radial spacing of the local ground's knots, metres (knot k at k·KNOT from the centre).
const KNOT: f64 = 2.5;
/// Knots per sector: out to `GROUND_RANGE.1`; beyond it the last knot's height holds.
const KNOTS: usize = (GROUND_RANGE.1 / KNOT) as usize + 1;
/// Fewest ground returns that set a knot.
const KNOT_MIN_POINTS: usize = 8;
/// A knot's returns lie within this of the height its sector's nearer knots predict, metres:
/// a grade change of 10 % over a knot's spacing.
const KNOT_BAND: f64 = 0.25;
/// Longest march step of a ray through the local ground's height band, metres.
const MARCH_STEP: f64 = 1.0;

/// The ground fitted locally: the plane ([`Ground::fit`]) raised by a height per knot of a
/// polar grid around the output centre ([`SECTORS`] × [`KNOTS`], [`KNOT`] apart), bilinear
/// between knots. A knot's height is the median of the returns near it that lie on the ground
/// its sector's nearer knots predict (the first: its lowest dense layer), so a crest, a dip or
/// a camber follows the scan; a knot without returns is interpolated between its sector's
/// knots that have them, and those nearer than the first (no returns near the car) lie on a
/// plane fitted through every sector's first knot.
#[derive(Debug, Clone, PartialEq)]
pub struct LocalGround {
    /// The plane the heights are measured from.
    pub plane: Ground,
    centre: Vector3<f64>,
    /// Height above the plane per sector, per knot (sector-major).
    raise: Vec<f64>,
    /// The least and largest raise.
    band: (f64, f64),

    /// The raise's bounds per cell of a Cartesian grid, which a ray is walked through.
    bounds: walk::Bounds,
}

impl LocalGround {
    /// The local ground of `points` (see [`LocalGround`]), None without a plane; its knots
    /// from the points `ground` lets through, by index (those in no object's box: a parked
    /// car's low returns would lift the road beside it).
    pub fn fit(
        points: &[Vector3<f64>],
        centre: &Vector3<f64>,
        ground: impl Fn(usize) -> bool,
    ) -> Option<LocalGround> {
        let plane = Ground::fit(points, centre)?;
        let mut heights = vec![Vec::new(); SECTORS * KNOTS];
        for (i, p) in points.iter().enumerate() {
            let (sector, knot) = polar(centre, p);
            let (j, k) = (sector.round() as usize % SECTORS, knot.round() as usize);
            if (1..KNOTS).contains(&k) && ground(i) {
                heights[j * KNOTS + k].push(plane.height(p));
            }
        }
        let mut known: Vec<Vec<(usize, f64)>> = Vec::with_capacity(SECTORS);
        for j in 0..SECTORS {
            known.push(sector_knots(&mut heights[j * KNOTS..(j + 1) * KNOTS]));
        }
        // each sector's first two knots' grade continued inwards: one value at the centre
        // where the ground near the car is a plane
        let inward: Vec<Option<(usize, f64, f64)>> = known.iter().map(|k| inward(k)).collect();
        let starts: Vec<f64> = inward.iter().flatten().map(|(_, h, _)| *h).collect();
        let middle = match starts.len() {
            0 => 0.0,
            n => starts.iter().sum::<f64>() / n as f64,
        };
        let mut raise = vec![middle; SECTORS * KNOTS];
        for (j, knots) in known.iter().enumerate() {
            let Some((first, start, grade)) = inward[j] else {
                continue;
            };
            for k in 0..KNOTS {
                let before = knots.iter().rev().find(|(kk, _)| *kk <= k);
                let after = knots.iter().find(|(kk, _)| *kk >= k);
                raise[j * KNOTS + k] = match (before, after) {
                    (Some(&(a, ha)), Some(&(b, hb))) if b > a => {
                        ha + (hb - ha) * (k - a) as f64 / (b - a) as f64
                    }
                    (Some(&(_, h)), _) => h,
                    // nearer than the first knot: the grade continued, bent to the centre's
                    // value at the centre
                    (None, _) => {
                        let s = k as f64 * KNOT;
                        start + grade * s + (middle - start) * (1.0 - k as f64 / first as f64)
                    }
                };
            }
        }
        Some(LocalGround::with_raise(plane, *centre, raise))
    }

    /// The local ground of `plane` raised by `raise` (sector-major knot heights) around
    /// `centre`.
    fn with_raise(plane: Ground, centre: Vector3<f64>, raise: Vec<f64>) -> LocalGround {
        let band = raise
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &r| {
                (lo.min(r), hi.max(r))
            });
        LocalGround {
            plane,
            centre,
            bounds: walk::Bounds::new(&centre, &raise),
            raise,
            band,
        }
    }

    /// The local ground's height above the plane under `p`.
    fn raise_at(&self, p: &Vector3<f64>) -> f64 {
        let (sector, knot) = polar(&self.centre, p);
        let knot = knot.min((KNOTS - 1) as f64);
        let (j0, k0) = (sector.floor(), knot.floor());
        let (fj, fk) = (sector - j0, knot - k0);
        let (j0, k0) = (j0 as usize % SECTORS, (k0 as usize).min(KNOTS - 1));
        let (j1, k1) = ((j0 + 1) % SECTORS, (k0 + 1).min(KNOTS - 1));
        let r = |j: usize, k: usize| self.raise[j * KNOTS + k];
        let near = r(j0, k0) + (r(j1, k0) - r(j0, k0)) * fj;
        let far = r(j0, k1) + (r(j1, k1) - r(j0, k1)) * fj;
        near + (far - near) * fk
    }

    /// The signed height of `p` above the local ground (the centre's side positive).
    pub fn height(&self, p: &Vector3<f64>) -> f64 {
        self.plane.height(p) - self.raise_at(p)
    }

    /// Distance along unit ray (o, d) to the local ground (None: it does not meet it going
    /// down from above): the ray is marched through the band between the lowest and highest
    /// raise in steps of at most [`MARCH_STEP`], the crossing then found by false position.
    pub(super) fn hit(&self, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<f64> {
        let (lo, hi) = self.band;
        let along = self.plane.normal.dot(d);
        let h = self.plane.height(o);
        // (above the band's top the viewpoint is above the ground: no lookup)
        if h <= hi && !self.above_cell(o, h) && self.height(o) <= 0.0 {
            // from below (a viewpoint under the ground, as the plane alone meets it): the plane
            // through the ground under it
            let t = -self.height(o) / along;
            return (t > 0.0 && t.is_finite()).then_some(t);
        }
        if !(along < 0.0) {
            return None;
        }
        // (from the centre's vertical, every output pixel's ray: its crossing in closed form)
        if self.on_axis(o) {
            return self.hit_radial(d, h, -along);
        }
        if hi - lo < 1e-9 {
            let t = (h - hi) / -along;
            return (t > 0.0 && t.is_finite()).then_some(t);
        }
        let f = |t: f64| self.height(&(o + d * t));
        let t0 = ((h - hi) / -along).max(0.0);
        let t1 = ((h - lo) / -along).min(t0 + 1000.0);
        // beyond the knots' disc the raise varies only by sector, slowly along a ray: a grazing
        // ray's crossing there is found by iterating the raised plane, not walked
        let t_out = self.disc_exit(o, d);
        let end = t1.min(t_out.max(t0));
        // walked through the bound grid (marched where the ray starts off it)
        let found = match self.walk(o, d, (h, along), (t0, end), true) {
            Some(found) => found,
            None => self.march(&f, t0, end),
        };
        if found.is_some() || t1 <= t_out {
            return found;
        }
        let mut t = t_out.max(t0);
        for _ in 0..3 {
            t = (h - self.raise_at(&(o + d * t))) / -along;
        }
        (t > 0.0 && t.is_finite()).then_some(t)
    }

    /// Whether unit ray (o, d) meets the local ground before distance `limit`
    /// ([`LocalGround::hit`] < `limit`, an occlusion test), without solving for the crossing
    /// where the walk finds the ray under the ground by then.
    pub(super) fn meets_before(&self, o: &Vector3<f64>, d: &Vector3<f64>, limit: f64) -> bool {
        let (lo, hi) = self.band;
        let along = self.plane.normal.dot(d);
        let h = self.plane.height(o);
        let under = h <= hi && !self.above_cell(o, h) && self.height(o) <= 0.0;
        if under || !(along < 0.0) || self.on_axis(o) || hi - lo < 1e-9 {
            return self.hit(o, d).is_some_and(|t| t < limit);
        }
        // (above the band's top before t0: no crossing there)
        let t0 = ((h - hi) / -along).max(0.0);
        if !(t0 < limit) {
            return false;
        }
        let t1 = ((h - lo) / -along).min(t0 + 1000.0);
        let t_out = self.disc_exit(o, d);
        let end = t1.min(t_out.max(t0));
        let f = |t: f64| self.height(&(o + d * t));
        let stop = end.min(limit);
        let found = match self.walk(o, d, (h, along), (t0, stop), false) {
            Some(found) => found,
            None => self.march(&f, t0, stop),
        };
        if let Some(t) = found {
            return t <= limit;
        }
        if limit <= end || t1 <= t_out {
            return false;
        }
        // beyond the knots' disc: `hit`'s iteration on the raised plane
        let mut t = t_out.max(t0);
        for _ in 0..3 {
            t = (h - self.raise_at(&(o + d * t))) / -along;
        }
        t > 0.0 && t.is_finite() && t < limit
    }

    /// Distance along unit ray (o, d) at which it leaves, horizontally, the disc of the knots
    /// around the centre (0 when it starts outside).
    fn disc_exit(&self, o: &Vector3<f64>, d: &Vector3<f64>) -> f64 {
        let radius = (KNOTS - 1) as f64 * KNOT;
        let (px, pz) = (o.x - self.centre.x, o.z - self.centre.z);
        let (a, b, c) = (
            d.x * d.x + d.z * d.z,
            px * d.x + pz * d.z,
            px * px + pz * pz - radius * radius,
        );
        if !(a > 1e-18) {
            return if c < 0.0 { f64::INFINITY } else { 0.0 };
        }
        ((-b + (b * b - a * c).max(0.0).sqrt()) / a).max(0.0)
    }

    /// The first crossing of the local ground between t0 and t1 along a ray whose height above
    /// it is `f`: marched in steps of at most [`MARCH_STEP`], then a few steps of false
    /// position.
    fn march(&self, f: &impl Fn(f64) -> f64, t0: f64, t1: f64) -> Option<f64> {
        let steps = ((t1 - t0) / MARCH_STEP).ceil().clamp(1.0, 1000.0) as usize;
        let (mut a, mut fa) = (t0, f(t0));
        for k in 1..=steps {
            let b = t0 + (t1 - t0) * k as f64 / steps as f64;
            let fb = f(b);
            if fb <= 0.0 {
                // the ground is bilinear between knots, near a plane over a step: a few steps
                // of false position find the crossing
                let (mut a, mut b, mut fa, mut fb) = (a, b, fa, fb);
                let mut t = b;
                for _ in 0..3 {
                    if !(fa - fb > 0.0) {
                        break;
                    }
                    t = a + (b - a) * fa / (fa - fb);
                    let ft = f(t);
                    if ft > 0.0 {
                        (a, fa) = (t, ft);
                    } else {
                        (b, fb) = (t, ft);
                    }
                }
                return (t > 0.0).then_some(t);
            }
            (a, fa) = (b, fb);
        }
        None
    }

    /// A lower bound of [`LocalGround::hit`] over the unit rays from `o` within `radius` of
    /// unit `d`: the plane raised by the largest raise bounds it, and from the centre's
    /// vertical the ground per knot interval the rays may meet ([`LocalGround::radial_within`]).
    pub(super) fn nearest_within(&self, o: &Vector3<f64>, d: &Vector3<f64>, radius: f64) -> f64 {
        let top = self.raised(self.band.1);
        let plain = match top.height(o) {
            h if h <= 0.0 => 0.0,
            _ => top.nearest_within(o, d, radius),
        };
        // (a viewpoint under the ground meets it at once)
        if !self.on_axis(o) || self.height(o) <= 0.0 {
            return plain;
        }
        self.radial_within(o, d, radius)
            .map_or(plain, |t| t.max(plain))
    }

    /// From `o` on the centre's vertical, a lower bound of [`LocalGround::hit`] over the unit
    /// rays within `radius` of unit `d` (None where the cone holds a pole). Such a ray keeps
    /// its azimuth, so the ground it meets is blended from the knots of the two sectors about
    /// it ([`LocalGround::hit_radial`]): those of the sectors about the cone's azimuths
    /// (sin Δ = sin(radius) / cos φ about d's, φ its latitude, a nanoradian to spare). A
    /// crossing within knot interval k lies k·[`KNOT`] or more away horizontally, so as far
    /// along the ray, and on or under the plane raised by the interval's largest raise: the
    /// least over the intervals (and beyond the last knot) of the larger of the two.
    fn radial_within(&self, o: &Vector3<f64>, d: &Vector3<f64>, radius: f64) -> Option<f64> {
        let n = d.norm();
        let lat = (d.y / n).clamp(-1.0, 1.0).asin();
        let reach = radius + 1e-9;
        if !(lat.abs() + reach < std::f64::consts::FRAC_PI_2 - 1e-6) {
            return None;
        }
        let per = SECTORS as f64 / std::f64::consts::TAU;
        let spread = ((reach.sin() / lat.cos()).min(1.0).asin() + 1e-9) * per;
        let sector = walk::turn(d.x, d.z) * per;
        let (first, last) = (
            (sector - spread).floor() as i64,
            (sector + spread).floor() as i64 + 1,
        );
        if last - first + 1 >= SECTORS as i64 {
            return None;
        }
        // the plane raised by m bounds a crossing at (h − m) / cos ψ, ψ the least angle a
        // ray of the cone makes with the way down (as `Ground::nearest_within`)
        let h = self.plane.height(o);
        let down = (-self.plane.normal.dot(d) / n).clamp(-1.0, 1.0).acos();
        let angle = (down - radius - 1e-9).max(0.0);
        let under = |m: f64| match h - m {
            above if above <= 0.0 => 0.0,
            _ if angle >= std::f64::consts::FRAC_PI_2 => f64::INFINITY,
            above => above / angle.cos() * (1.0 - 1e-9),
        };
        let highest = |k: usize| {
            (first..=last)
                .map(|j| self.raise[j.rem_euclid(SECTORS as i64) as usize * KNOTS + k])
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let mut t = f64::INFINITY;
        let mut near = highest(0);
        for k in 0..KNOTS {
            // interval k (beyond the last knot, its raise)
            let far = if k + 1 < KNOTS { highest(k + 1) } else { near };
            let along = k as f64 * KNOT * (1.0 - 1e-9);
            t = t.min(along.max(under(near.max(far))));
            near = far;
        }
        Some(t)
    }

    /// A lower bound of the distance from `o` to the local ground.
    pub(super) fn nearest(&self, o: &Vector3<f64>) -> f64 {
        self.raised(self.band.1).height(o).max(0.0)
    }

    fn raised(&self, by: f64) -> Ground {
        Ground {
            normal: self.plane.normal,
            offset: self.plane.offset + by,
        }
    }
}

/// `p`'s position in the polar grid around `centre`: fractional sector and knot.
fn polar(centre: &Vector3<f64>, p: &Vector3<f64>) -> (f64, f64) {
    let (x, z) = (p.x - centre.x, p.z - centre.z);
    (
        walk::turn(x, z) * (SECTORS as f64 / std::f64::consts::TAU),
        (x * x + z * z).sqrt() * (1.0 / KNOT),
    )
}

/// A sector's knots that its returns set, nearest first (`heights`: per knot the plane
/// heights of the returns near it): walking outwards, a knot's returns within [`KNOT_BAND`]
/// of the height its nearer knots predict (their grade continued; the first knot: its lowest
/// fifth) are the ground, their median refined over those within [`GROUND_FIT`] · 2.
fn sector_knots(heights: &mut [Vec<f64>]) -> Vec<(usize, f64)> {
    let mut known: Vec<(usize, f64)> = Vec::new();
    for (k, h) in heights.iter_mut().enumerate() {
        if h.len() < KNOT_MIN_POINTS {
            continue;
        }
        h.sort_by(f64::total_cmp);
        let predicted = match known.as_slice() {
            [] => h[h.len() / 5],
            [(_, ha)] => *ha,
            [.., (a, ha), (b, hb)] => {
                let grade = ((hb - ha) / ((b - a) as f64 * KNOT)).clamp(-0.15, 0.15);
                hb + grade * (k - b) as f64 * KNOT
            }
        };
        let Some(first) = median_within(h, predicted, KNOT_BAND) else {
            continue;
        };
        if let Some(value) = median_within(h, first, GROUND_FIT * 2.0) {
            known.push((k, value));
        }
    }
    known
}

/// The median of the sorted `h` within `band` of `around` (None: fewer than
/// [`KNOT_MIN_POINTS`]).
fn median_within(h: &[f64], around: f64, band: f64) -> Option<f64> {
    let lo = h.partition_point(|x| *x < around - band);
    let hi = h.partition_point(|x| *x <= around + band);
    (hi - lo >= KNOT_MIN_POINTS).then(|| h[(lo + hi) / 2])
}

/// A sector's first set knot, the raise its grade (first two knots, else flat, at most 15 %)
/// gives at the centre, and that grade (None: no knot).
fn inward(knots: &[(usize, f64)]) -> Option<(usize, f64, f64)> {
    let &(a, ha) = knots.first()?;
    let grade = knots.get(1).map_or(0.0, |&(b, hb)| {
        ((hb - ha) / ((b - a) as f64 * KNOT)).clamp(-0.15, 0.15)
    });
    Some((a, ha - grade * a as f64 * KNOT, grade))
}
