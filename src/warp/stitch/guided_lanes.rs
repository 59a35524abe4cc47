//! A depth-guided table's row of output pixel centres seen by a pinhole camera without a
//! field-of-view bound, or by a unified (MEI) lens (`guided_lens.rs`), a group of lanes at a
//! time: each centre whose bearing is the one the reach bound stored for it takes the distance
//! map's distance, and its scene point (its unit bearing at that distance from the output
//! centre, where the camera saw it) is turned into the camera's axes and projected with the
//! very operations of `Proxy::project_at` (nalgebra's `normalize`, its products and sums in its
//! order, the camera's own projection), then kept where it lies within the image: the same
//! positions, bit for bit, in loops without branches that vectorise (with AVX2 where the
//! processor has it). A depth-guided stitch's tables project every reached pixel centre so;
//! the other bearings of the row (columns -1 and width, a bearing not stored) cast their own
//! ray, as the per-pixel path does, and a centre the lanes cannot decide (a lens's point within
//! a hair of its field of view's edge) is projected alone.

use super::StitchDepth;
use crate::camera::{CameraModel, Intrinsics};
use crate::warp::reach::Reach;
use crate::warp::table::{column_inside, row_inside};
use nalgebra::{Matrix3, Point2, Vector3};

/// The distances of a depth-guided stitch's output pixel centres (the proxy's, read here a
/// row at a time).
#[derive(Debug, Clone, Copy)]
pub(super) struct Centres<'a> {
    pub(super) output: &'a dyn CameraModel,
    pub(super) reach: &'a Reach,
    /// Row-major, as [`super::guided::pixel_distances`] gives them.
    pub(super) distances: &'a [f64],
}

/// Centres a group takes.
pub(super) const LANES: usize = 8;
/// One coordinate of a group, a lane each.
pub(super) type Lanes = [f64; LANES];

/// The pinhole's front test on a camera point, squared: z² above this share of its squared
/// norm (`Proxy::pixel`'s).
const MIN_FORWARD2: f64 = 1e-18;

/// A camera's projection of a group of camera points in lanes, with the very operations of
/// `Proxy::pixel` and the image bound `in_image` after it.
pub(super) trait LaneCamera {
    /// The pixels of camera points `q` (x, y, z lanes), per lane whether they decide it (else
    /// it is projected alone) and whether it has a pixel within the image.
    fn pixels(&self, q: [Lanes; 3]) -> (Decided, [Lanes; 2]);
}

/// Per lane of a group, whether its point was decided in lanes and whether it has a pixel
/// within the image there.
pub(super) struct Decided {
    pub(super) decided: [bool; LANES],
    pub(super) inside: [bool; LANES],
}

/// What a depth-guided proxy projecting its centres in lanes reads: the camera's pose, the
/// output centre, where the depth moves points, and the camera's projection in lanes.
#[derive(Clone, Copy)]
pub(super) struct GuidedLanes<'a, C> {
    /// camera_from_reference.
    pub(super) rotation: Matrix3<f64>,
    pub(super) translation: Vector3<f64>,
    /// The output centre.
    pub(super) centre: Vector3<f64>,
    /// Where the depth moves points for this camera: the depth and the camera's index
    /// ([`StitchDepth::seen_at`], asked centre by centre).
    pub(super) moved: Option<(&'a dyn StitchDepth, usize)>,
    pub(super) camera: C,
}

/// A pinhole camera's projection in lanes: its intrinsics and image size (width, height).
#[derive(Clone, Copy)]
pub(super) struct PinholeLanes {
    pub(super) k: Intrinsics,
    pub(super) size: (f64, f64),
}

/// What a depth-guided proxy of a pinhole camera without a field-of-view bound reads.
pub(super) type GuidedPinhole<'a> = GuidedLanes<'a, PinholeLanes>;

/// How a row's centres are projected one by one: a bearing not stored for its pixel (its own
/// ray, within the image; None for None), and a stored one the lanes leave undecided (at its
/// pixel's distance, within the image).
pub(super) struct Alone<'a> {
    pub(super) cast: &'a dyn Fn(&Vector3<f64>) -> Option<Point2<f64>>,
    pub(super) at: &'a AtDistance<'a>,
}

/// A bearing's position at a distance (within the image).
pub(super) type AtDistance<'a> = dyn Fn(&Vector3<f64>, f64) -> Option<Point2<f64>> + 'a;

impl<C: LaneCamera> GuidedLanes<'_, C> {
    /// Appends to `out` the positions of the output centres of row `v` (`bearings`, columns
    /// -1..=width, as the table's build gives them), `Proxy::project_all`'s: a bearing equal
    /// to the one `centres` stored for its pixel at the pixel's distance, any other through
    /// `alone.cast`; a centre the lanes leave undecided through `alone.at`.
    pub(super) fn project_row(
        &self,
        bearings: &[Option<Vector3<f64>>],
        (centres, v): (Centres, usize),
        out: &mut Vec<Option<Point2<f64>>>,
        alone: Alone,
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2 (checked just above).
            return unsafe { self.project_row_avx2(bearings, (centres, v), out, alone) };
        }
        self.project_row_any(bearings, (centres, v), out, alone)
    }

    /// [`GuidedLanes::project_row`] compiled for AVX2 (the same IEEE operations, the same
    /// bits).
    ///
    /// # Safety
    ///
    /// The processor must have AVX2 (`is_x86_feature_detected!("avx2")`). It reads and writes
    /// only through safe slices.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn project_row_avx2(
        &self,
        bearings: &[Option<Vector3<f64>>],
        row: (Centres, usize),
        out: &mut Vec<Option<Point2<f64>>>,
        alone: Alone,
    ) {
        self.project_row_any(bearings, row, out, alone)
    }

    #[inline(always)]
    fn project_row_any(
        &self,
        bearings: &[Option<Vector3<f64>>],
        (c, v): (Centres, usize),
        out: &mut Vec<Option<Point2<f64>>>,
        alone: Alone,
    ) {
        let w = bearings.len() - 2;
        let distances = &c.distances[v * w..(v + 1) * w];
        let same = |a: &Vector3<f64>, b: &Vector3<f64>| {
            (a.x.to_bits(), a.y.to_bits(), a.z.to_bits())
                == (b.x.to_bits(), b.y.to_bits(), b.z.to_bits())
        };
        let start = out.len();
        out.resize(start + bearings.len(), None);
        let out = &mut out[start..];
        for (g, (group, out)) in bearings
            .chunks(LANES)
            .zip(out.chunks_mut(LANES))
            .enumerate()
        {
            if group.iter().all(Option::is_none) {
                // (most of a row: beyond the camera's reach)
                continue;
            }
            // the lanes whose bearing is the stored one of a pixel (column k - 1)
            let mut d = [[0.0; LANES]; 3];
            let mut t = [1.0; LANES];
            let mut known = [false; LANES];
            for (l, b) in group.iter().enumerate() {
                let k = g * LANES + l;
                let Some(b) = b.filter(|_| k >= 1 && k <= w) else {
                    continue;
                };
                if c.reach.bearing(k - 1, v).is_some_and(|s| same(&s, &b)) {
                    (d[0][l], d[1][l], d[2][l]) = (b.x, b.y, b.z);
                    t[l] = distances[k - 1];
                    known[l] = true;
                }
            }
            let mut x = self.points(d, t);
            if let Some((depth, camera)) = self.moved {
                // (a point of a moving box lies where the camera saw it)
                for l in (0..group.len()).filter(|l| known[*l]) {
                    let p = Vector3::new(x[0][l], x[1][l], x[2][l]);
                    let q = depth.seen_at(camera, &p);
                    (x[0][l], x[1][l], x[2][l]) = (q.x, q.y, q.z);
                }
            }
            let (lanes, [u, y]) = self.camera.pixels(self.local(x));
            for (l, (b, p)) in group.iter().zip(out).enumerate() {
                *p = match (known[l], lanes.decided[l]) {
                    (true, true) => lanes.inside[l].then(|| Point2::new(u[l], y[l])),
                    (true, false) => b.as_ref().and_then(|b| (alone.at)(b, t[l])),
                    (false, _) => b.as_ref().and_then(alone.cast),
                };
            }
        }
    }

    /// The reference points of a group's bearings `d` (x, y, z lanes) at distances `t`:
    /// `centre + d.normalize() * t`.
    #[inline(always)]
    fn points(&self, d: [Lanes; 3], t: Lanes) -> [Lanes; 3] {
        let c = &self.centre;
        let mut x = [[0.0; LANES]; 3];
        for l in 0..LANES {
            // nalgebra's norm sums the squares in order; `normalize` divides by it
            let n = (d[0][l] * d[0][l] + d[1][l] * d[1][l] + d[2][l] * d[2][l]).sqrt();
            for i in 0..3 {
                x[i][l] = c[i] + d[i][l] / n * t[l];
            }
        }
        x
    }

    /// The camera points of a group's reference points `x`: `rotation * x + translation`.
    #[inline(always)]
    fn local(&self, x: [Lanes; 3]) -> [Lanes; 3] {
        let (r, tr) = (&self.rotation, &self.translation);
        let mut q = [[0.0; LANES]; 3];
        for l in 0..LANES {
            // nalgebra's product is (r0·x + r1·y) + r2·z
            for i in 0..3 {
                q[i][l] = r[(i, 0)] * x[0][l] + r[(i, 1)] * x[1][l] + r[(i, 2)] * x[2][l] + tr[i];
            }
        }
        q
    }
}

impl LaneCamera for PinholeLanes {
    /// `Proxy::pixel` of a pinhole (its front test and division), then `in_image`: every lane
    /// decided.
    #[inline(always)]
    fn pixels(&self, q: [Lanes; 3]) -> (Decided, [Lanes; 2]) {
        let k = &self.k;
        let (w, h) = self.size;
        let mut inside = [false; LANES];
        let mut px = [[0.0; LANES]; 2];
        for l in 0..LANES {
            let q = [q[0][l], q[1][l], q[2][l]];
            let norm2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
            let front = q[2] > 0.0 && q[2] * q[2] > MIN_FORWARD2 * norm2;
            let z = 1.0 / q[2];
            let (u, v) = k.to_pixel(q[0] * z, q[1] * z);
            inside[l] = front && column_inside(u, w) && row_inside(v, h);
            (px[0][l], px[1][l]) = (u, v);
        }
        let decided = [true; LANES];
        (Decided { decided, inside }, px)
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::proxy::Proxy;
    use super::super::StitchCamera;
    use super::*;
    use crate::camera::{CameraModel, Equirect, ImageSize, Perspective};
    use crate::warp::reach::{Cone, Gated, Reach};

    /// A scene 7 m away whose points within 9 m of a spot move 0.35 m for the camera (a box
    /// driving by), or none.
    #[derive(Debug)]
    pub(in crate::warp::stitch) struct Drawn {
        pub(in crate::warp::stitch) moving: bool,
    }

    const SPOT: [f64; 3] = [2.0, 0.5, 5.0];

    impl StitchDepth for Drawn {
        fn distance(&self, d: &Vector3<f64>) -> f64 {
            7.0 + d.x.sin()
        }
        fn sees(&self, _: usize, _: &Vector3<f64>) -> bool {
            true
        }
        fn nearest(&self) -> f64 {
            6.0
        }
        fn seen_at(&self, _: usize, x: &Vector3<f64>) -> Vector3<f64> {
            match (x - Vector3::from(SPOT)).norm() < 9.0 {
                true => x + Vector3::new(0.35, 0.0, -0.1),
                false => *x,
            }
        }
        fn motion_bound(&self, _: usize) -> f64 {
            if self.moving {
                0.4
            } else {
                0.0
            }
        }
    }

    /// xorshift draws in [-1, 1).
    pub(in crate::warp::stitch) fn draws(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    /// The size of [`rows_output`]'s panorama.
    pub(in crate::warp::stitch) const ROWS_OUTPUT: (u32, u32) = (250, 123);

    /// The bit-for-bit tests' output: a 250x123 equirect over the middle of the sphere, every
    /// bearing reached (one camera).
    pub(in crate::warp::stitch) fn rows_output() -> (Equirect, Reach) {
        let (w, h) = ROWS_OUTPUT;
        let output = Equirect::new(
            Intrinsics::new(
                w as f64 / std::f64::consts::TAU,
                h as f64 / 3.0,
                124.5,
                61.0,
            ),
            ImageSize::new(w, h),
        );
        let all = |d: &Vector3<f64>| *d;
        let cone = Cone {
            local: &all,
            half_angle: None,
            parallax: None,
            baseline: None,
            frustum: None,
        };
        let reach = Reach::new(&output, &[cone], None);
        (output, reach)
    }

    /// Every row of centres of drawn rigs (a pinhole anywhere, turned any way, still or moved by
    /// the depth) over drawn distance maps (some without a distance: 0, infinite, NaN), and
    /// the rows with some bearings changed by a bit (cast instead), None or not a row of
    /// centres: the lanes' positions are the per-pixel path's to the bit.
    #[test]
    fn the_lanes_give_the_per_pixel_positions_bit_for_bit() {
        let (w, h) = (ROWS_OUTPUT.0 as usize, ROWS_OUTPUT.1 as usize);
        let (output, reach) = rows_output();
        let gated = Gated {
            output: &output,
            reach: &reach,
            camera: 0,
        };
        let mut next = draws(0x2545_f491_4f6c_dd1d);
        let (mut seen, mut cast, mut compared) = (0usize, 0usize, 0usize);
        for rig in 0..6 {
            let k = Intrinsics::new(
                300.0 + 100.0 * next(),
                300.0 + 100.0 * next(),
                160.0 + 20.0 * next(),
                120.0 + 20.0 * next(),
            );
            let model = Perspective::new(k, ImageSize::new(320, 240));
            let angles = [next() * 3.2, next() * 1.6, next() * 3.2];
            let camera = StitchCamera {
                model: &model,
                rotation: *nalgebra::Rotation3::from_euler_angles(angles[0], angles[1], angles[2])
                    .matrix(),
                translation: Vector3::new(next(), next(), next()) * 0.8,
                max_theta: None,
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
            let proxy =
                Proxy::guided((0, camera), centre, 10.0, Some(&depth)).with_centres(Centres {
                    output: &output,
                    reach: &reach,
                    distances: &distances,
                });
            assert!(proxy.guided_pinhole().is_some());
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
                    let (mut got, mut want) = (Vec::new(), Vec::new());
                    proxy.project_all(ds, &mut got);
                    proxy.project_all_each(ds, &mut want);
                    let bits = |p: &Option<Point2<f64>>| p.map(|p| (p.x.to_bits(), p.y.to_bits()));
                    assert_eq!(got.len(), want.len());
                    for (u, (g, w)) in got.iter().zip(&want).enumerate() {
                        assert_eq!(bits(g), bits(w), "rig {rig}, row {v}, column {u}");
                    }
                    seen += want.iter().flatten().count();
                    compared += want.len();
                }
                cast += changed.iter().step_by(13).count();
            }
        }
        // (enough of them within an image to mean something)
        assert!(seen > 20_000 && seen < compared / 2, "{seen} of {compared}");
        assert!(cast > 1000, "{cast}");
    }
}
