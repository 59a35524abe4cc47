//! A ray from a point on the output centre's vertical meets the local ground in closed form:
//! its horizontal track runs straight out from the centre along one bearing, so its sector
//! and the weight between the sector's two knot columns are fixed, the raise along it is
//! linear in the distance between knots, and its crossing is the root of one line (the
//! first knot interval whose far end lies under the ground): exact, without the walk through
//! the bound grid and its iterations. Every output pixel's distance is such a ray.

use super::{walk, LocalGround, KNOT, KNOTS, SECTORS};
use nalgebra::Vector3;

impl LocalGround {
    /// Whether `o` lies on the centre's vertical (its horizontal offset exactly 0): a ray from
    /// it is radial.
    pub(super) fn on_axis(&self, o: &Vector3<f64>) -> bool {
        o.x == self.centre.x && o.z == self.centre.z
    }

    /// The first crossing of the local ground by unit ray `d` from a point on the centre's
    /// vertical ([`LocalGround::on_axis`]) that lies `h` above the plane and above the local
    /// ground, the ray falling by `fall` (> 0) a metre: None where the root is not a finite
    /// positive distance.
    pub(super) fn hit_radial(&self, d: &Vector3<f64>, h: f64, fall: f64) -> Option<f64> {
        // the knot position per metre along the ray, and its sector (as `polar` gives them)
        let rate = (d.x * d.x + d.z * d.z).sqrt() * (1.0 / KNOT);
        let sector = walk::turn(d.x, d.z) * (SECTORS as f64 / std::f64::consts::TAU);
        let j0 = sector.floor();
        let fj = sector - j0;
        let j0 = j0 as usize % SECTORS;
        let j1 = (j0 + 1) % SECTORS;
        // the raise at knot k along the ray's bearing, as `raise_at` blends the two columns
        let column = |k: usize| {
            let (a, b) = (self.raise[j0 * KNOTS + k], self.raise[j1 * KNOTS + k]);
            a + (b - a) * fj
        };
        // the intervals ending before the ray reaches the raise's top lie above the ground
        // (one interval earlier, for the rounding of t·rate)
        let top = (h - self.band.1) / fall;
        let first = match top * rate {
            k if k >= 1.0 => (k as usize - 1).min(KNOTS - 1),
            _ => 0,
        };
        let mut c0 = column(first);
        for k in first..KNOTS - 1 {
            let c1 = column(k + 1);
            // the ray's height above the ground at the interval's far end (t = (k + 1) / rate)
            if h - fall * ((k + 1) as f64 / rate) - c1 <= 0.0 {
                // h − fall·t − (c0 + (c1 − c0)(t·rate − k)) = 0
                let t = (h - c0 + (c1 - c0) * k as f64) / (fall + (c1 - c0) * rate);
                return (t > 0.0 && t.is_finite()).then_some(t);
            }
            c0 = c1;
        }
        // beyond the last knot its raise holds
        let t = (h - c0) / fall;
        (t > 0.0 && t.is_finite()).then_some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::super::walk::tests::rough;
    use super::*;

    #[test]
    fn a_ray_from_the_centres_vertical_meets_the_polar_ground_at_its_first_exact_root() {
        let (ground, mut next) = rough(0x5851_f42d_4c95_7f2d);
        let centre = Vector3::new(1.0, 0.0, -2.0);
        let (mut inside, mut beyond) = (0, 0);
        for k in 0..2000 {
            // from the centre and up to 0.75 m above or 0.25 m below it, down at 1-89°
            let o = centre + Vector3::new(0.0, next() - 0.75, 0.0);
            assert!(ground.on_axis(&o));
            let e = (1.0 + next() * 88.0).to_radians();
            let azimuth = if k % 50 == 0 {
                0.0
            } else {
                next() * std::f64::consts::TAU
            };
            let d = Vector3::new(azimuth.sin() * e.cos(), e.sin(), azimuth.cos() * e.cos());
            let t = ground.hit(&o, &d).expect("a falling ray meets the ground");
            let f = |t: f64| ground.height(&(o + d * t));
            // the root, to the rounding of the height (the walk solves to 10 µm only)
            assert!(f(t).abs() < 1e-9, "ray {k}: height {} at {t}", f(t));
            // and the first: the ray above the ground all the way before it (1 cm steps)
            let steps = (t / 0.01) as usize;
            for s in 0..steps {
                let ts = s as f64 * 0.01;
                assert!(f(ts) > 0.0, "ray {k}: under the ground at {ts}, root {t}");
            }
            if t * e.cos() > (KNOTS - 1) as f64 * KNOT {
                beyond += 1;
            } else {
                inside += 1;
            }
        }
        // both sides of the knots' disc are tried
        assert!(inside > 1500 && beyond > 10, "{inside} {beyond}");
    }

    #[test]
    fn the_bound_per_knot_interval_holds_every_hit_in_its_cone_and_stays_positive_past_a_hill() {
        let (rough, mut next) = rough(0x2545_f491_4f6c_dd1d);
        // two sectors' far knots raised 2.5 m: above the centre, 1.6 m over the plane
        let mut raise = rough.raise.clone();
        for j in [3, 4] {
            for k in KNOTS / 2..KNOTS {
                raise[j * KNOTS + k] = 2.5;
            }
        }
        let ground = LocalGround::with_raise(rough.plane, rough.centre, raise);
        let o = ground.centre;
        assert!(ground.raised(ground.band.1).height(&o) < 0.0);
        let (mut positive, mut met) = (0, 0);
        for k in 0..4000 {
            // a cone of up to 3° about a bearing from 80° down to 30° up
            let e = (-30.0 + next() * 110.0).to_radians();
            let azimuth = next() * std::f64::consts::TAU;
            let d = Vector3::new(azimuth.sin() * e.cos(), e.sin(), azimuth.cos() * e.cos());
            let radius = (next() * 3.0).to_radians();
            let bound = ground.nearest_within(&o, &d, radius);
            if bound > 0.0 {
                positive += 1;
            }
            // rays on the cone's rim and inside it
            let (a, b) = crate::camera::perpendiculars(&d);
            for r in 0..16 {
                let turn = r as f64 * std::f64::consts::TAU / 16.0;
                let off = radius * if r % 2 == 0 { 1.0 } else { next() };
                let ray =
                    (d * off.cos() + (a * turn.cos() + b * turn.sin()) * off.sin()).normalize();
                if let Some(t) = ground.hit(&o, &ray) {
                    met += 1;
                    assert!(t >= bound, "cone {k}: hit {t} before the bound {bound}");
                }
            }
        }
        // the plane raised by the largest knot bounds nothing (the centre lies under it), the
        // knot intervals most cones
        assert!(positive > 3000 && met > 20_000, "{positive} {met}");
    }
}
