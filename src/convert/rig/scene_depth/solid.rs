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
    /// `d` (infinite: none of them meets the bounding sphere): an entry point lies in it.
    pub(super) fn nearest_within(&self, o: &Vector3<f64>, d: &Vector3<f64>, radius: f64) -> f64 {
        let oc = self.centre - o;
        let far = oc.norm();
        if !(far > self.radius) {
            return 0.0;
        }
        let off_axis = (oc.dot(d) / far).clamp(-1.0, 1.0).acos();
        if off_axis > radius + (self.radius / far).asin() + 1e-9 {
            return f64::INFINITY;
        }
        (far - self.radius) * (1.0 - 1e-9)
    }

    /// `t.min(self.nearest_within(o, d, radius))`, without the cone's test where the box's
    /// nearest distance from `o` could not lower `t`.
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

    pub(super) fn contains(&self, p: &Vector3<f64>, margin: f64) -> bool {
        if (p - self.centre).norm() > self.radius + margin {
            return false;
        }
        let l = self.box_from_reference * (p - self.centre);
        (0..3).all(|a| l[a].abs() <= self.half[a] + margin)
    }
}
