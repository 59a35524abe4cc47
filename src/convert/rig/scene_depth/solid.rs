//! A 3D box as a depth-guided stitch's rays meet it: the exact ray–box intersection, a lower
//! bound of it over a cone of rays, and which points the box holds.

use crate::source::SourceBox;
use nalgebra::{Matrix3, Vector3};

/// A box as rays meet it.
#[derive(Debug, Clone)]
pub(super) struct Solid {
    pub(super) centre: Vector3<f64>,
    /// box_from_reference.
    pub(super) box_from_reference: Matrix3<f64>,
    pub(super) half: Vector3<f64>,
    /// Radius of the bounding sphere.
    pub(super) radius: f64,
}

impl Solid {
    pub(super) fn new(b: &SourceBox) -> Self {
        let half = b.size / 2.0;
        Self {
            centre: b.centre,
            box_from_reference: b.rotation.transpose(),
            half,
            radius: half.norm(),
        }
    }

    /// Distance along unit ray (o, d) to where it enters the box (None: it misses, or starts
    /// inside).
    pub(super) fn hit(&self, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<f64> {
        let oc = self.centre - o;
        let along = oc.dot(d);
        self.hit_beside(o, d, along, oc.norm_squared() - along * along)
    }

    /// [`Solid::hit`] given the centre's distance `along` the ray and squared distance `off2`
    /// off it (as `hit` computes them).
    pub(super) fn hit_beside(
        &self,
        o: &Vector3<f64>,
        d: &Vector3<f64>,
        along: f64,
        off2: f64,
    ) -> Option<f64> {
        if along < -self.radius || off2 > self.radius * self.radius {
            return None;
        }
        let lo = self.box_from_reference * (o - self.centre);
        let ld = self.box_from_reference * d;
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        for a in 0..3 {
            if ld[a].abs() < 1e-15 {
                if lo[a].abs() > self.half[a] {
                    return None;
                }
                continue;
            }
            let (ta, tb) = (
                (-self.half[a] - lo[a]) / ld[a],
                (self.half[a] - lo[a]) / ld[a],
            );
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        (t0 <= t1 && t0 > 0.0).then_some(t0)
    }

    /// Whether the points of unit ray (o, d) from 0 to `length` may lie within `reach` of the
    /// box: false only where none does (the box grown by `reach` and a micrometre in every
    /// axis, the segment by a micrometre at each end, far beyond the arithmetic's rounding).
    pub(super) fn near_segment(
        &self,
        o: &Vector3<f64>,
        d: &Vector3<f64>,
        length: f64,
        reach: f64,
    ) -> bool {
        const SLACK: f64 = 1e-6;
        let lo = self.box_from_reference * (o - self.centre);
        let ld = self.box_from_reference * d;
        let (mut t0, mut t1) = (-SLACK, length + SLACK);
        for a in 0..3 {
            let grown = self.half[a] + reach + SLACK;
            if ld[a].abs() < 1e-15 {
                if lo[a].abs() > grown {
                    return false;
                }
                continue;
            }
            let (ta, tb) = ((-grown - lo[a]) / ld[a], (grown - lo[a]) / ld[a]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        t0 <= t1
    }

    /// A lower bound of [`Solid::hit`] over the unit rays from `o` within `radius` of unit
    /// `d` (infinite: none of them meets the bounding sphere): an entry point lies in the box,
    /// no nearer than the box's nearest point to `o` ([`Solids::lower_within`] computes it from
    /// the origin's parts kept).
    #[cfg(test)]
    pub(super) fn nearest_within(&self, o: &Vector3<f64>, d: &Vector3<f64>, radius: f64) -> f64 {
        let oc = self.centre - o;
        let far = oc.norm();
        if far > self.radius {
            let off_axis = (oc.dot(d) / far).clamp(-1.0, 1.0).acos();
            if off_axis > radius + (self.radius / far).asin() + 1e-9 {
                return f64::INFINITY;
            }
        }
        self.nearest_from(o)
    }

    /// A lower bound of the distance from `o` to any point of the box: its nearest point's
    /// (a part in 1e9 and a nanometre cover the rounding of the box's frame).
    fn nearest_from(&self, o: &Vector3<f64>) -> f64 {
        (self.distance_from(o) * (1.0 - 1e-9) - 1e-9).max(0.0)
    }

    /// The distance from `p` to the box's nearest point (0 inside it).
    fn distance_from(&self, p: &Vector3<f64>) -> f64 {
        let l = self.box_from_reference * (p - self.centre);
        let out = |a: usize| (l[a].abs() - self.half[a]).max(0.0);
        Vector3::new(out(0), out(1), out(2)).norm()
    }

    /// `t.min(self.nearest_within(o, d, radius))`, without the cone's test where the box's
    /// nearest distance from `o` could not lower `t` ([`Solids::lower_within`] of every box
    /// at once).
    #[cfg(test)]
    pub(super) fn lower_within(
        &self,
        o: &Vector3<f64>,
        d: &Vector3<f64>,
        radius: f64,
        t: f64,
    ) -> f64 {
        let far = (self.centre - o).norm();
        if far > self.radius && (far - self.radius) * (1.0 - 1e-9) >= t {
            return t;
        }
        t.min(self.nearest_within(o, d, radius))
    }

    /// The parts of [`Solid::nearest_within`] that depend only on `o`.
    fn seen_from(&self, o: &Vector3<f64>) -> SeenFrom {
        let oc = self.centre - o;
        let far = oc.norm();
        let inside = !(far > self.radius);
        SeenFrom {
            near: if inside {
                f64::NEG_INFINITY
            } else {
                (far - self.radius) * (1.0 - 1e-9)
            },
            nearest: self.nearest_from(o),
            oc,
            far,
            spread: (self.radius / far).asin(),
        }
    }

    pub(super) fn contains(&self, p: &Vector3<f64>, margin: f64) -> bool {
        if (p - self.centre).norm() > self.radius + margin {
            return false;
        }
        let l = self.box_from_reference * (p - self.centre);
        (0..3).all(|a| l[a].abs() <= self.half[a] + margin)
    }
}

/// A box's bounding sphere seen from a fixed origin: what [`Solid::nearest_within`] computes
/// from the origin alone.
#[derive(Debug, Clone)]
struct SeenFrom {
    /// The sphere's nearest distance (−∞: the origin lies in it).
    near: f64,
    /// The box's nearest point's distance ([`Solid::nearest_from`]).
    nearest: f64,
    oc: Vector3<f64>,
    far: f64,
    /// Its angular radius.
    spread: f64,
}

/// The boxes seen from one origin, nearest first: [`Solids::lower_within`] stops at the
/// first box that cannot lower its bound.
#[derive(Debug, Clone)]
pub(super) struct Solids(Vec<SeenFrom>);

impl Solids {
    pub(super) fn new(solids: &[Solid], o: &Vector3<f64>) -> Self {
        let mut seen: Vec<SeenFrom> = solids.iter().map(|s| s.seen_from(o)).collect();
        seen.sort_by(|a, b| a.near.total_cmp(&b.near));
        Solids(seen)
    }

    /// `t` lowered by [`Solid::lower_within`] of every box from the origin, the same value
    /// (a box nearest-first no nearer than the bound so far, and every box after it, leaves
    /// it as it is).
    pub(super) fn lower_within(&self, d: &Vector3<f64>, radius: f64, mut t: f64) -> f64 {
        for b in &self.0 {
            if b.near == f64::NEG_INFINITY {
                t = t.min(b.nearest);
                continue;
            }
            if b.near >= t {
                break;
            }
            let off_axis = (b.oc.dot(d) / b.far).clamp(-1.0, 1.0).acos();
            let beyond = off_axis > radius + b.spread + 1e-9;
            t = t.min(if beyond { f64::INFINITY } else { b.nearest });
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_boxes_nearest_first_lower_a_bound_as_each_box_does() {
        let mut state = 0x6c8e_9cf5_7093_2bd5_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let o = Vector3::new(0.2, -0.3, 0.1);
        // boxes all around, one holding the origin in its bounding sphere
        let mut solids: Vec<Solid> = (0..60)
            .map(|_| {
                let c = Vector3::new(next() - 0.5, 0.2 * (next() - 0.5), next() - 0.5) * 60.0;
                let b = SourceBox::from_kitti("Car", [1.5, 1.8, 4.0], c, next() * 6.0);
                Solid::new(&b)
            })
            .collect();
        solids.push(Solid::new(&SourceBox::from_kitti(
            "Car",
            [1.5, 1.8, 4.0],
            Vector3::new(0.0, 0.5, 1.0),
            0.0,
        )));
        let all = Solids::new(&solids, &o);
        let (mut lowered, mut zero) = (0, 0);
        for k in 0..20_000 {
            let d = Vector3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            let radius = [0.002, 0.02, 0.2][k % 3];
            let t = [f64::INFINITY, 5.0 + 40.0 * next(), f64::NAN][k / 3 % 3];
            let sphere = if k % 2 == 0 {
                &solids[..60]
            } else {
                &solids[..]
            };
            let want = sphere
                .iter()
                .fold(t, |t, s| s.lower_within(&o, &d, radius, t));
            let got = if k % 2 == 0 {
                Solids::new(sphere, &o).lower_within(&d, radius, t)
            } else {
                all.lower_within(&d, radius, t)
            };
            assert_eq!(got.to_bits(), want.to_bits(), "{d} {radius} {t}");
            lowered += usize::from(want < t || (t.is_nan() && want.is_finite()));
            zero += usize::from(want == 0.0);
        }
        assert!(lowered > 2000 && zero > 5000, "{lowered} {zero}");
    }

    #[test]
    fn the_nearest_distance_within_a_cone_is_the_boxs_nearest_point_and_bounds_every_hit() {
        // a car nearly broadside, 8 m ahead and 2 m aside (its bounding sphere 2.3 m, its side
        // 0.9 m from its centre)
        let car = SourceBox::from_kitti("Car", [1.5, 1.8, 4.0], Vector3::new(2.0, 1.0, 8.0), 0.3);
        let s = Solid::new(&car);
        let mut state = 0x853c_49e6_748f_ea9b_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut hits, mut tighter) = (0, 0);
        for k in 0..20_000 {
            let o = Vector3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 4.0;
            let aim = s.centre + Vector3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 5.0;
            let d = (aim - o).normalize();
            let radius = [0.002, 0.02, 0.2][k % 3];
            let bound = s.nearest_within(&o, &d, radius);
            // the nearest point's distance, measured by a grid over the box's faces
            let near = (0..=20)
                .flat_map(|i| (0..=20).map(move |j| (i, j)))
                .flat_map(|(i, j)| {
                    let (a, b) = (i as f64 / 10.0 - 1.0, j as f64 / 10.0 - 1.0);
                    [
                        Vector3::new(1.0, a, b),
                        Vector3::new(-1.0, a, b),
                        Vector3::new(a, 1.0, b),
                        Vector3::new(a, -1.0, b),
                        Vector3::new(a, b, 1.0),
                        Vector3::new(a, b, -1.0),
                    ]
                });
            let nearest = near
                .map(|u| (car.rotation * u.component_mul(&s.half) + s.centre - o).norm())
                .fold(f64::INFINITY, f64::min);
            // the bound is the nearest point's distance (the grid's points lie up to 0.2 m
            // apart on a face, so up to 0.15 m farther), or infinite
            assert!(
                bound.is_infinite() || (bound <= nearest + 1e-9 && bound > nearest - 0.15),
                "{bound} {nearest}"
            );
            // and it bounds the hits of rays within the cone
            let a = d.cross(&Vector3::new(0.36, 0.48, 0.8)).normalize();
            let b = d.cross(&a);
            for _ in 0..10 {
                let (angle, turn) = (radius * next().sqrt(), next() * std::f64::consts::TAU);
                let e =
                    (d * angle.cos() + (a * turn.cos() + b * turn.sin()) * angle.sin()).normalize();
                if let Some(t) = s.hit(&o, &e) {
                    assert!(t >= bound, "{t} < {bound}");
                    hits += 1;
                }
            }
            // (the bounding sphere's bound, far − radius, is looser by up to a metre here)
            let far = (s.centre - o).norm();
            tighter += usize::from(bound.is_finite() && bound > far - s.radius + 0.5);
        }
        assert!(hits > 20_000 && tighter > 5000, "{hits} {tighter}");
    }
}
