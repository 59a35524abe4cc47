//! Which boxes a ray may meet, per cell of a cube map around a viewpoint: the ray casts of a
//! depth-guided stitch test those boxes only, not every box of the frame. A box is listed in
//! every cell that holds a bearing within its bounding sphere's angular radius plus [`REACH`]
//! of its centre's bearing, so a ray that meets the box, or passes within [`REACH`] of it, is
//! always in a cell that lists it: a cast gives what testing every box gives. A cell is found
//! from a bearing without a transcendental function (its largest axis, two divisions).

use nalgebra::Vector3;
use std::f64::consts::FRAC_PI_2;
use std::sync::OnceLock;

/// Cells per side of a cube face.
const SIDE: usize = 32;
/// Angle around a bearing within which a ray's boxes are listed, radians: the widest footprint
/// [`crate::warp::StitchDepth::hidden_near`] is asked about through the grid.
pub(super) const REACH: f64 = 0.02;
/// Radians added to every cell's radius: far beyond a bearing's rounding near a cell's edge.
const SLACK: f64 = 1e-6;

/// Per cell, a bit per box (`words` 64-bit words a cell).
#[derive(Debug, Clone)]
pub(super) struct BoxGrid {
    words: usize,
    bits: Vec<u64>,
}

/// The cell of bearing `d` (any length; None for a zero or non-finite one): its face (the
/// axis of its largest component and that component's sign) and its position on the face.
fn cell(d: &Vector3<f64>) -> Option<usize> {
    let a = d.map(f64::abs);
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let m = d[axis];
    if !(a[axis] > 0.0 && a[axis].is_finite()) {
        return None;
    }
    let (p, q) = (d[(axis + 1) % 3] / a[axis], d[(axis + 2) % 3] / a[axis]);
    // (truncation is the floor of a non-negative value)
    let at = |s: f64| (((s + 1.0) / 2.0 * SIDE as f64).max(0.0) as usize).min(SIDE - 1);
    let face = axis * 2 + usize::from(m < 0.0);
    Some((face * SIDE + at(p)) * SIDE + at(q))
}

/// Every cell's centre bearing (unit) and the cosine and sine of its angular radius (plus
/// [`SLACK`]): a cell is a spherical quadrilateral with great-circle sides, its farthest
/// point from any inner point one of its corners.
fn cells() -> Vec<(Vector3<f64>, f64, f64)> {
    let mut out = Vec::with_capacity(6 * SIDE * SIDE);
    let edge = |k: usize| k as f64 / SIDE as f64 * 2.0 - 1.0;
    for face in 0..6 {
        let (axis, sign) = (face / 2, if face % 2 == 0 { 1.0 } else { -1.0 });
        let bearing = |p: f64, q: f64| {
            let mut d = Vector3::zeros();
            d[axis] = sign;
            d[(axis + 1) % 3] = p;
            d[(axis + 2) % 3] = q;
            d.normalize()
        };
        for i in 0..SIDE {
            for j in 0..SIDE {
                let (p0, p1, q0, q1) = (edge(i), edge(i + 1), edge(j), edge(j + 1));
                let centre = bearing((p0 + p1) / 2.0, (q0 + q1) / 2.0);
                let radius = [(p0, q0), (p0, q1), (p1, q0), (p1, q1)]
                    .iter()
                    .map(|&(p, q)| centre.dot(&bearing(p, q)).clamp(-1.0, 1.0).acos())
                    .fold(0.0, f64::max)
                    + SLACK;
                out.push((centre, radius.cos(), radius.sin()));
            }
        }
    }
    out
}

impl BoxGrid {
    /// The grid of the boxes `spheres` (centre, radius) seen from `origin`.
    pub(super) fn new(origin: &Vector3<f64>, spheres: &[(Vector3<f64>, f64)]) -> Self {
        // (the same for every grid: computed once)
        static CELLS: OnceLock<Vec<(Vector3<f64>, f64, f64)>> = OnceLock::new();
        let cells = CELLS.get_or_init(cells);
        let words = spheres.len().div_ceil(64).max(1);
        let mut bits = vec![0u64; cells.len() * words];
        for (k, (centre, radius)) in spheres.iter().enumerate() {
            let (word, bit) = (k / 64, 1u64 << (k % 64));
            let v = centre - origin;
            let far = v.norm();
            // the cone of the bearings near the box; the origin within the sphere: any
            let cone = if far > *radius && far.is_finite() {
                (radius / far).asin() + REACH
            } else {
                FRAC_PI_2
            };
            let c = v / far;
            let (cc, sc) = (cone.cos(), cone.sin());
            for (at, (centre, cr, sr)) in cells.iter().enumerate() {
                // the cell reaches the cone: angle(c, centre) ≤ cone + its radius (< π)
                if cone >= FRAC_PI_2 || c.dot(centre) >= cc * cr - sc * sr {
                    bits[at * words + word] |= bit;
                }
            }
        }
        BoxGrid { words, bits }
    }

    /// Whether `test` holds for one of the boxes listed in bearing `d`'s cell, tried in
    /// increasing order (every box for a bearing without a cell).
    pub(super) fn any(
        &self,
        d: &Vector3<f64>,
        count: usize,
        mut test: impl FnMut(usize) -> bool,
    ) -> bool {
        let Some(at) = cell(d) else {
            return (0..count).any(test);
        };
        for (word, &bits) in self.bits[at * self.words..][..self.words]
            .iter()
            .enumerate()
        {
            let mut m = bits;
            while m != 0 {
                let k = word * 64 + m.trailing_zeros() as usize;
                m &= m - 1;
                if test(k) {
                    return true;
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_box_is_listed_wherever_a_bearing_near_it_falls() {
        let spheres = [
            (Vector3::new(0.0, 0.0, 10.0), 2.0),
            (Vector3::new(3.0, -9.0, 1.0), 0.5),
            (Vector3::new(0.1, 0.1, 0.1), 1.0),
            (Vector3::new(-20.0, 1.0, -0.5), 3.0),
            (Vector3::new(10.0, 10.0, 10.2), 0.3),
        ];
        let origin = Vector3::new(0.2, 0.0, -0.1);
        let grid = BoxGrid::new(&origin, &spheres);
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let (mut near, mut listed_far) = (0, 0);
        for n in 0..200_000 {
            let mut d = Vector3::new(next(), next(), next());
            // some bearings on the cube's edges and corners
            if n % 10 == 0 {
                d[n % 3] = d[(n + 1) % 3];
            }
            let mut listed = Vec::new();
            grid.any(&d, spheres.len(), |k| {
                listed.push(k);
                false
            });
            let d = d.normalize();
            for (k, (c, r)) in spheres.iter().enumerate() {
                let v = c - origin;
                let angle = (v.dot(&d) / v.norm()).clamp(-1.0, 1.0).acos();
                let cone = (r / v.norm()).min(1.0).asin() + REACH;
                if angle <= cone {
                    assert!(listed.contains(&k), "box {k} at {d}");
                    near += 1;
                } else if k != 2 && listed.contains(&k) {
                    listed_far += 1;
                }
            }
            // the box around the origin everywhere
            assert!(listed.contains(&2));
        }
        // (the box around the origin is listed everywhere, needed or not)
        assert!(near > 100_000 && listed_far < 20_000, "{near} {listed_far}");
        // a bearing without a cell tries every box
        let mut tried = 0;
        grid.any(&Vector3::zeros(), spheres.len(), |_| {
            tried += 1;
            false
        });
        assert_eq!(tried, spheres.len());
    }
}
