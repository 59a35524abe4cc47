//! The ground plane of a frame's scene ([`Ground`]): fitted to the scan's lowest dense layer,
//! it holds near the vehicle where the scan has no returns (`scene_depth.rs`).

use nalgebra::{Matrix3, Vector3};

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

    pub(super) fn hit(&self, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<f64> {
        let along = self.normal.dot(d);
        let h = self.height(o);
        // a ray from above the plane meets it going down, one from below going up
        let t = -h / along;
        (t > 0.0 && t.is_finite()).then_some(t)
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
