//! The fixed stitch's proxy of a pinhole camera without a field-of-view bound, a group of
//! lanes at a time: each output bearing's proxy point (its unit bearing at the proxy distance
//! from the output centre, in the camera's axes) projected with the very operations of
//! `Proxy::project` (nalgebra's `normalize`, its products and sums in its order,
//! [`CameraModel::project_point`]'s norm and division, then the pinhole's `project`): the same
//! positions, bit for bit, in loops without branches that vectorise (with AVX2 where the
//! processor has it). A fixed stitch's tables project every reached pixel centre so.
//!
//! [`CameraModel::project_point`]: crate::camera::CameraModel::project_point

use crate::camera::Intrinsics;
use nalgebra::{Matrix3, Point2, Vector3};

/// Bearings a group takes.
const LANES: usize = 8;
/// One coordinate of a group, a lane each.
type Lanes = [f64; LANES];

/// `project_point`'s bound on a point's norm (below it: no pixel).
const MIN_NORM: f64 = 1e-12;
/// The pinhole's front test: z above this share of the unit bearing's norm.
const MIN_FORWARD: f64 = 1e-9;

/// What the fixed proxy of a pinhole camera reads.
#[derive(Debug, Clone, Copy)]
pub(super) struct FixedPinhole {
    /// camera_from_reference.
    pub(super) rotation: Matrix3<f64>,
    pub(super) translation: Vector3<f64>,
    /// The output centre and the proxy distance.
    pub(super) centre: Vector3<f64>,
    pub(super) distance: f64,
    /// The camera's intrinsics.
    pub(super) k: Intrinsics,
}

impl FixedPinhole {
    /// Appends to `out` the camera pixel of each output bearing of `bearings` (None for None
    /// and where `project` rejects): `Proxy::project`'s positions.
    pub(super) fn project_all(
        &self,
        bearings: &[Option<Vector3<f64>>],
        out: &mut Vec<Option<Point2<f64>>>,
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2 (checked just above).
            return unsafe { self.project_all_avx2(bearings, out) };
        }
        self.project_all_any(bearings, out)
    }

    /// [`FixedPinhole::project_all`] compiled for AVX2 (the same IEEE operations, the same
    /// bits).
    ///
    /// # Safety
    ///
    /// The processor must have AVX2 (`is_x86_feature_detected!("avx2")`). It reads and writes
    /// only through safe slices.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn project_all_avx2(
        &self,
        bearings: &[Option<Vector3<f64>>],
        out: &mut Vec<Option<Point2<f64>>>,
    ) {
        self.project_all_any(bearings, out)
    }

    #[inline(always)]
    fn project_all_any(
        &self,
        bearings: &[Option<Vector3<f64>>],
        out: &mut Vec<Option<Point2<f64>>>,
    ) {
        out.reserve(bearings.len());
        for group in bearings.chunks(LANES) {
            if group.iter().all(Option::is_none) {
                // (most of a row: beyond the camera's reach)
                out.extend(std::iter::repeat_n(None, group.len()));
                continue;
            }
            let mut d = [[0.0; LANES]; 3];
            let mut some = [false; LANES];
            for (l, b) in group.iter().enumerate() {
                if let Some(b) = b {
                    (d[0][l], d[1][l], d[2][l]) = (b.x, b.y, b.z);
                    some[l] = true;
                }
            }
            let (ok, [u, v]) = self.lanes(d);
            out.extend(
                (0..group.len()).map(|l| (some[l] && ok[l]).then(|| Point2::new(u[l], v[l]))),
            );
        }
    }

    /// The pixels of a group's bearings `d` (x, y, z lanes) and whether each has one.
    #[inline(always)]
    fn lanes(&self, d: [Lanes; 3]) -> ([bool; LANES], [Lanes; 2]) {
        let (r, t, c, s, k) = (
            &self.rotation,
            &self.translation,
            &self.centre,
            self.distance,
            &self.k,
        );
        let mut ok = [false; LANES];
        let mut px = [[0.0; LANES]; 2];
        for l in 0..LANES {
            // `centre + d.normalize() * distance`: nalgebra's norm sums the squares in order
            let n = (d[0][l] * d[0][l] + d[1][l] * d[1][l] + d[2][l] * d[2][l]).sqrt();
            let x = [0, 1, 2].map(|i| c[i] + d[i][l] / n * s);
            // `rotation * x + translation`: nalgebra's product is (r0·x + r1·y) + r2·z
            let q =
                [0, 1, 2].map(|i| r[(i, 0)] * x[0] + r[(i, 1)] * x[1] + r[(i, 2)] * x[2] + t[i]);
            // `project_point`: the point's norm, then its unit bearing
            let m = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
            let e = q.map(|q| q / m);
            // the pinhole's `project` of the unit bearing: its own norm, the front test, K
            let norm = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
            ok[l] = m > MIN_NORM && e[2] > MIN_FORWARD * norm;
            let (u, v) = k.to_pixel(e[0] / e[2], e[1] / e[2]);
            (px[0][l], px[1][l]) = (u, v);
        }
        (ok, px)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{CameraModel, ImageSize, Perspective};
    use crate::warp::stitch::proxy::Proxy;
    use crate::warp::stitch::StitchCamera;

    #[test]
    fn the_lanes_give_the_proxys_positions_bit_for_bit() {
        let k = Intrinsics::new(1270.3, 1268.9, 961.7, 543.2);
        let model = Perspective::new(k, ImageSize::new(1920, 1080));
        let rotation = *nalgebra::Rotation3::from_euler_angles(0.31, -1.27, 0.05).matrix();
        let f = FixedPinhole {
            rotation,
            translation: Vector3::new(0.43, -1.61, 0.27),
            centre: Vector3::new(0.02, -0.3, 0.11),
            distance: 10.0,
            k,
        };
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        // every direction, some None, a zero bearing and one along the image plane's horizon
        let mut bearings: Vec<Option<Vector3<f64>>> = (0..4000)
            .map(|i| (i % 7 != 3).then(|| Vector3::new(next(), next(), next())))
            .collect();
        bearings.push(Some(Vector3::zeros()));
        bearings.push(Some(rotation.transpose() * Vector3::new(1.0, 0.0, 0.0)));
        let mut got = Vec::new();
        f.project_all(&bearings, &mut got);
        // the proxy's own projection, bearing by bearing
        let camera = StitchCamera {
            model: &model,
            rotation,
            translation: f.translation,
            max_theta: None,
        };
        let proxy = Proxy::new(camera, f.centre, f.distance);
        let want: Vec<_> = (bearings.iter())
            .map(|d| proxy.project(d.as_ref()?).ok())
            .collect();
        let bits = |p: &Option<Point2<f64>>| p.map(|p| (p.x.to_bits(), p.y.to_bits()));
        assert_eq!(got.len(), want.len());
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert_eq!(bits(g), bits(w), "bearing {i}: {:?}", bearings[i]);
        }
        let seen = want.iter().flatten().count();
        assert!(seen > 500 && seen < 3000, "{seen} bearings with a pixel");
    }
}
