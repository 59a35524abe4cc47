//! A unified (MEI) lens's projection of a depth-guided table's row of centres in lanes
//! (`guided_lanes.rs`): `Proxy::pixel` of the lens with the very operations of its per-pixel
//! path (`Proxy::within`'s cosine test of the field of view, `CameraModel::project_point`'s
//! unit bearing, `bearing_within`'s, then `MeiModel::project`'s lift, distortion and affine
//! map, each product and sum in its order), then `in_image`. The lanes decide every point but
//! those the per-pixel path decides by an angle (`atan2`): a point within `FOV_SLACK` of the
//! field of view's edge, or one whose bearing the lens's own bound must measure; those, and a
//! point not finite, are projected alone.

use super::guided_lanes::{Decided, LaneCamera, Lanes, LANES};
use crate::camera::{Intrinsics, MeiDistortion, Unified};
use crate::warp::table::{column_inside, row_inside};

/// Radians inside the lens's own half field of view within which a bearing's cosine decides
/// that `bearing_within` keeps it: far beyond the rounding of the cosine and of its angle.
const LENS_SLACK: f64 = 1e-6;

/// What a MEI lens's projection in lanes reads.
#[derive(Debug, Clone, Copy)]
pub(super) struct LensLanes {
    xi: f64,
    distortion: MeiDistortion,
    skew: f64,
    k: Intrinsics,
    /// The image size (width, height).
    size: (f64, f64),
    /// `Proxy::within`'s cosines: of the stitch's half field of view less and plus
    /// [`FOV_SLACK`](super::proxy::FOV_SLACK).
    fov_cos: (f64, f64),
    /// Whether the lens sees 90° or more (`bearing_within` keeps a bearing in front of it).
    sees_front: bool,
    /// The cosine of the lens's half field of view less [`LENS_SLACK`].
    lens_cos: f64,
}

impl LensLanes {
    /// The lanes of `lens`, whose stitch proxy tests its field of view by `fov_cos`; None
    /// where the lens's half field of view is too near 0 or π for a cosine to decide it.
    pub(super) fn of(lens: &Unified, fov_cos: (f64, f64)) -> Option<LensLanes> {
        let t = lens.max_theta;
        if !(t > 1e-3 && t < 3.0) {
            return None;
        }
        Some(LensLanes {
            xi: lens.model.xi,
            distortion: lens.model.distortion,
            skew: lens.model.skew,
            k: lens.k,
            size: (lens.size.width as f64, lens.size.height as f64),
            fov_cos,
            sees_front: t >= std::f64::consts::FRAC_PI_2,
            lens_cos: (t - LENS_SLACK).cos(),
        })
    }
}

impl LaneCamera for LensLanes {
    #[inline(always)]
    fn pixels(&self, q: [Lanes; 3]) -> (Decided, [Lanes; 2]) {
        let MeiDistortion { k1, k2, p1, p2 } = self.distortion;
        let (xi, skew, k) = (self.xi, self.skew, &self.k);
        let ((w, h), (inner, outer)) = (self.size, self.fov_cos);
        let mut decided = [false; LANES];
        let mut inside = [false; LANES];
        let mut px = [[0.0; LANES]; 2];
        for l in 0..LANES {
            let (x, y, z) = (q[0][l], q[1][l], q[2][l]);
            // `Proxy::within` by its cosines (a point not finite, or between them, is not
            // decided here)
            let n = (x * x + y * y + z * z).sqrt();
            let finite = x.is_finite() & y.is_finite() & z.is_finite();
            let within = finite & (z >= inner * n) & (n > 0.0);
            let beyond = finite & !within & (z < outer * n);
            // `project_point`'s unit bearing (refused at a norm of 1e-12 or less)
            let long = n > 1e-12;
            let (bx, by, bz) = (x / n, y / n, z / n);
            // `bearing_within`'s (refused at a norm not finite or 0), kept without its angle in
            // front of a lens that sees 90° or more, or well within its half field of view
            let m = (bx * bx + by * by + bz * bz).sqrt();
            let unit = m.is_finite() & (m > 0.0);
            let (sx, sy, sz) = (bx / m, by / m, bz / m);
            let s = (sx * sx + sy * sy + sz * sz).sqrt();
            let kept = ((sz > 0.0) & self.sees_front) | (sz >= self.lens_cos * s);
            // `MeiModel::project`: the lift, Mei's distortion, the affine map
            let den = sz + xi;
            let (a, b) = (sx / den, sy / den);
            let r2 = a * a + b * b;
            let radial = 1.0 + r2 * (k1 + k2 * r2);
            let xd = a * radial + 2.0 * p1 * a * b + p2 * (r2 + 2.0 * a * a);
            let yd = b * radial + p1 * (r2 + 2.0 * b * b) + 2.0 * p2 * a * b;
            let u = k.fu * xd + skew * yd + k.cu;
            let v = k.fv * yd + k.cv;
            let projected = within & long & unit & kept;
            let image = (den > 0.0) & column_inside(u, w) & row_inside(v, h);
            // refused by the field of view, by a norm, or projected: decided
            decided[l] = beyond | (within & !long) | (within & long & !unit) | projected;
            inside[l] = projected & image;
            (px[0][l], px[1][l]) = (u, v);
        }
        (Decided { decided, inside }, px)
    }
}

#[cfg(test)]
mod tests {
    use super::super::guided_lanes::tests::{draws, rows_output, Drawn, ROWS_OUTPUT};
    use super::super::guided_lanes::{Alone, Centres, LANES};
    use super::super::proxy::Proxy;
    use super::super::StitchCamera;
    use super::*;
    use crate::camera::{CameraModel, ImageSize, Lens};
    use crate::warp::reach::Gated;
    use nalgebra::{Matrix3, Point2, Rotation3, Vector3};
    use std::cell::Cell;

    /// A drawn MEI lens (ξ below and above 1, distortion, skew or none), seeing up to its
    /// usable limit or less, on either side of 90°.
    fn drawn_lens(next: &mut impl FnMut() -> f64, rig: usize) -> Unified {
        let xi = [0.4, 0.9, 1.4, 2.2][rig % 4] + 0.1 * next();
        let distortion = MeiDistortion {
            k1: 0.1 * next(),
            k2: 0.2 * next().abs(),
            p1: 1e-3 * next(),
            p2: 1e-3 * next(),
        };
        let (limit, _) = Unified::fov_limit(xi, &distortion);
        let max_theta = (limit * 0.97).min([1.3, 1.7, 2.0][rig % 3]);
        let k = Intrinsics::new(
            330.0 + 30.0 * next(),
            330.0 + 30.0 * next(),
            178.0 + 9.0 * next(),
            176.0 + 9.0 * next(),
        );
        let skew = if rig.is_multiple_of(2) {
            0.0
        } else {
            0.4 * next()
        };
        Unified::new(xi, distortion, k, skew, ImageSize::new(350, 350), max_theta).unwrap()
    }

    /// Every row of centres of drawn rigs (a MEI lens anywhere, turned any way, still or moved
    /// by the depth, the stitch's field of view the lens's or wider, the lens alone or boxed)
    /// over drawn distance maps (some without a distance: 0, infinite, NaN), and the rows with
    /// some bearings changed by a bit (cast instead), None or not a row of centres: the lanes'
    /// positions are the per-pixel path's to the bit, some of them from points the lanes
    /// leave to the per-pixel path (beyond the lens's own field of view, within the stitch's).
    #[test]
    fn the_lens_lanes_give_the_per_pixel_positions_bit_for_bit() {
        let (w, h) = (ROWS_OUTPUT.0 as usize, ROWS_OUTPUT.1 as usize);
        let (output, reach) = rows_output();
        let gated = Gated {
            output: &output,
            reach: &reach,
            camera: 0,
        };
        let mut next = draws(0x9e37_79b9_7f4a_7c15);
        let (mut seen, mut alone, mut cast, mut compared) = (0usize, 0usize, 0usize, 0usize);
        for rig in 0..8 {
            let lens = drawn_lens(&mut next, rig);
            let boxed: Lens = lens.clone().into();
            let model: &dyn CameraModel = if rig % 3 == 0 { &boxed } else { &lens };
            let angles = [next() * 3.2, next() * 1.6, next() * 3.2];
            let camera = StitchCamera {
                model,
                rotation: *Rotation3::from_euler_angles(angles[0], angles[1], angles[2]).matrix(),
                translation: Vector3::new(next(), next(), next()) * 0.8,
                max_theta: Some(lens.max_theta + if rig % 4 == 1 { 0.05 } else { 0.0 }),
            };
            let centre = Vector3::new(next(), next(), next()) * 0.2;
            let distances: Vec<f64> = (0..w * h)
                .map(|i| match i % 97 {
                    0 => 0.0,
                    1 => f64::INFINITY,
                    2 => f64::NAN,
                    _ => 10f64.powf(1.2 + next()),
                })
                .collect();
            let depth = Drawn {
                moving: rig % 2 == 1,
            };
            let centres = Centres {
                output: &output,
                reach: &reach,
                distances: &distances,
            };
            let proxy =
                Proxy::guided((0, camera), centre, 10.0, Some(&depth)).with_centres(centres);
            let lanes = proxy.guided_lens().expect("a MEI lens's lanes");
            for v in -1..=h as isize {
                let mut row = Vec::new();
                assert!(gated.stored_centres(v, &mut row));
                // the table's turn into the source (the identity here)
                let row: Vec<_> = (row.iter())
                    .map(|d| d.map(|d| Matrix3::identity() * d))
                    .collect();
                let mut changed = row.clone();
                for (i, d) in changed.iter_mut().enumerate() {
                    match (i as isize + v).rem_euclid(13) {
                        0 => *d = None,
                        5 => *d = d.map(|d| d.map(|x| f64::from_bits(x.to_bits() ^ 1))),
                        _ => {}
                    }
                }
                for ds in [&row, &changed, &row[3..]] {
                    let (mut got, mut want, mut lanes_got) = (Vec::new(), Vec::new(), Vec::new());
                    proxy.project_all(ds, &mut got);
                    proxy.project_all_each(ds, &mut want);
                    let bits = |p: &Option<Point2<f64>>| p.map(|p| (p.x.to_bits(), p.y.to_bits()));
                    assert_eq!(got.len(), want.len());
                    for (u, (g, w)) in got.iter().zip(&want).enumerate() {
                        assert_eq!(bits(g), bits(w), "rig {rig}, row {v}, column {u}");
                    }
                    // the lanes themselves, counting the centres they leave alone
                    if v >= 0 && (v as usize) < h && ds.len() == w + 2 {
                        let size = (350.0, 350.0);
                        let inside = |p: &Point2<f64>| {
                            crate::warp::table::column_inside(p.x, size.0)
                                && crate::warp::table::row_inside(p.y, size.1)
                        };
                        let left = Cell::new(0usize);
                        let at = |d: &Vector3<f64>, t| {
                            left.set(left.get() + 1);
                            proxy.project_at(d, t).ok().filter(inside)
                        };
                        let cast = |d: &Vector3<f64>| proxy.project(d).ok().filter(inside);
                        let alone_ways = Alone {
                            cast: &cast,
                            at: &at,
                        };
                        lanes.project_row(ds, (centres, v as usize), &mut lanes_got, alone_ways);
                        assert!(lanes_got.iter().map(bits).eq(want.iter().map(bits)));
                        alone += left.get();
                    }
                    seen += want.iter().flatten().count();
                    compared += want.len();
                }
                cast += changed.iter().step_by(13).count();
            }
        }
        // (enough of them within an image to mean something)
        assert!(
            seen > 40_000 && seen < compared * 3 / 4,
            "{seen} of {compared}"
        );
        assert!(alone > 200 && alone < seen / 10, "{alone} alone of {seen}");
        assert!(cast > 1000, "{cast}");
    }

    /// Points of drawn lenses within a few 1e-7 rad of the stitch's field of view's edge and of
    /// the lens's own (the stitch's the lens's, wider or narrower), in every direction about
    /// the axis and at two distances: each point the lanes decide has the per-pixel path's
    /// answer (`Proxy::within`, then the lens's `project_point` within its image) to the bit,
    /// and the lanes leave some of them to it.
    #[test]
    fn the_lens_lanes_decide_by_the_field_of_views_edges_as_the_per_pixel_path() {
        let mut next = draws(0x2545_f491_4f6c_dd1d);
        let (mut decided, mut left) = (0usize, 0usize);
        for rig in 0..9 {
            let lens = drawn_lens(&mut next, rig);
            let wider = [0.0, 0.05, -0.05][rig / 3 % 3];
            let camera = StitchCamera {
                model: &lens,
                rotation: Matrix3::identity(),
                translation: Vector3::zeros(),
                max_theta: Some(lens.max_theta + wider),
            };
            let depth = Drawn { moving: false };
            let proxy = Proxy::guided((0, camera), Vector3::zeros(), 10.0, Some(&depth));
            let lanes = proxy.guided_lens().expect("a MEI lens's lanes").camera;
            let inside = |p: &Point2<f64>| {
                crate::warp::table::column_inside(p.x, 350.0)
                    && crate::warp::table::row_inside(p.y, 350.0)
            };
            let mut points = Vec::new();
            for edge in [lens.max_theta, lens.max_theta + wider] {
                for k in -8..=8 {
                    let theta = edge + k as f64 * 3e-7;
                    for j in 0..16 {
                        let phi = j as f64 * std::f64::consts::TAU / 16.0 + 0.01 * next();
                        let r = if j % 2 == 0 { 1.0 } else { 7.3 };
                        let (s, c) = theta.sin_cos();
                        points.push(Vector3::new(s * phi.cos(), s * phi.sin(), c) * r);
                    }
                }
            }
            for group in points.chunks(LANES) {
                let mut q = [[0.0; LANES]; 3];
                for (l, p) in group.iter().enumerate() {
                    (q[0][l], q[1][l], q[2][l]) = (p.x, p.y, p.z);
                }
                let (got, [u, v]) = lanes.pixels(q);
                for (l, p) in group.iter().enumerate() {
                    if !got.decided[l] {
                        left += 1;
                        continue;
                    }
                    decided += 1;
                    let want = (proxy.within(p))
                        .then(|| lens.project_point(p).ok().filter(inside))
                        .flatten();
                    let got = got.inside[l].then(|| Point2::new(u[l], v[l]));
                    let bits = |p: Option<Point2<f64>>| p.map(|p| (p.x.to_bits(), p.y.to_bits()));
                    assert_eq!(bits(got), bits(want), "rig {rig}, {p:?}");
                }
            }
        }
        assert!(
            decided > 2000 && left > 1000,
            "{decided} decided, {left} left"
        );
    }
}
