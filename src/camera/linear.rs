//! The cameras whose pixels are an affine map K of projection coordinates (a, b):
//! pixel = K · (a, b, 1). Everything K-related lives here once; each projection file only says
//! how a bearing becomes (a, b) and back ([`Mapping`]).

use super::separable::{Separable, Share};
use super::{
    CameraModel, ImageSize, Intrinsics, LinearCamera, OutputCamera, OutputProjection, Projection,
    ProjectionReject,
};
use nalgebra::{Point2, Vector3};
use std::marker::PhantomData;

/// A projection's coordinates (a, b) of a bearing, and the distance it pairs with.
pub trait Mapping: Send + Sync + std::fmt::Debug + 'static {
    /// The projection this mapping implements.
    const PROJECTION: Projection;
    /// `a` is an angle about the y axis, so u is periodic with 2π·fu (360° images wrap).
    const PERIODIC: bool;
    /// Only bearings with z > 0 have an image.
    const FRONT_ONLY: bool;
    /// Every bearing with z >= 1e-6·|d| has an image (see [`CameraModel::sees_whole_front`]);
    /// only meaningful with `FRONT_ONLY`.
    const WHOLE_FRONT: bool = false;
    /// Projection coordinates (a, b) of a bearing (any non-zero length); angles in radians.
    fn bearing_to_ab(d: &Vector3<f64>) -> Result<(f64, f64), ProjectionReject>;
    /// `a` of [`Mapping::bearing_to_ab`] alone: the same value and rejection, overridden where
    /// `a` costs less than both.
    #[inline]
    fn bearing_to_a(d: &Vector3<f64>) -> Result<f64, ProjectionReject> {
        Self::bearing_to_ab(d).map(|ab| ab.0)
    }
    /// `b` of [`Mapping::bearing_to_ab`] alone, as [`Mapping::bearing_to_a`].
    #[inline]
    fn bearing_to_b(d: &Vector3<f64>) -> Result<f64, ProjectionReject> {
        Self::bearing_to_ab(d).map(|ab| ab.1)
    }
    /// Unit bearing of projection coordinates (a, b): made of the shares of `a` and `b`, so
    /// that a grid of pixels (a [`Separable`] camera) gives each pixel the same bits.
    #[inline]
    fn ab_to_bearing(a: f64, b: f64) -> Result<Vector3<f64>, ProjectionReject> {
        Self::join(Self::split_a(a), Self::split_b(b))
    }
    /// What `a` alone contributes to a bearing (NaN where `a` has no bearing).
    fn split_a(a: f64) -> [f64; 2];
    /// What `b` alone contributes to a bearing (NaN where `b` has no bearing).
    fn split_b(b: f64) -> [f64; 2];
    /// Unit bearing of the shares of `a` and `b`.
    fn join(a: [f64; 2], b: [f64; 2]) -> Result<Vector3<f64>, ProjectionReject>;
    /// [`Mapping::join`] of each column share of `columns` with the row share `row`, written
    /// coordinate by coordinate into `x`, `y`, `z` (as long as `columns`), NaN x where `join`
    /// rejects. Overridden by a loop without branches (it vectorises) giving the same values.
    #[inline]
    fn join_lanes(columns: &[Share], row: [f64; 2], [x, y, z]: [&mut [f64]; 3]) {
        for (i, c) in columns.iter().enumerate() {
            let d = Self::join(c.0, row).unwrap_or(Vector3::repeat(f64::NAN));
            (x[i], y[i], z[i]) = (d.x, d.y, d.z);
        }
    }
    /// The distance this projection pairs with, for a point relative to the centre.
    fn distance(p: &Vector3<f64>) -> f64;
}

/// A linear camera of projection `M` with intrinsics `k` and image `size`.
#[derive(Debug, PartialEq)]
pub struct Linear<M> {
    /// The affine map from projection coordinates (a, b) to pixels.
    pub k: Intrinsics,
    /// Image size in pixels.
    pub size: ImageSize,
    mapping: PhantomData<M>,
}

impl<M> Clone for Linear<M> {
    fn clone(&self) -> Self {
        Self::new(self.k, self.size)
    }
}

impl<M> Linear<M> {
    /// A camera of projection `M` with intrinsics `k` and an image of `size` pixels.
    pub fn new(k: Intrinsics, size: ImageSize) -> Self {
        Self {
            k,
            size,
            mapping: PhantomData,
        }
    }
}

impl<M: Mapping> CameraModel for Linear<M> {
    #[inline]
    fn project(&self, bearing: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        let (a, b) = M::bearing_to_ab(bearing)?;
        let (u, v) = self.k.to_pixel(a, b);
        Ok(Point2::new(u, v))
    }

    fn unproject(&self, pixel: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        let (a, b) = self.k.from_pixel(pixel.x, pixel.y);
        M::ab_to_bearing(a, b)
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        M::distance(p)
    }

    fn size(&self) -> ImageSize {
        self.size
    }

    fn front_halfspace(&self) -> Option<Vector3<f64>> {
        M::FRONT_ONLY.then(Vector3::z)
    }

    fn horizontal_period(&self) -> Option<f64> {
        M::PERIODIC.then_some(2.0 * std::f64::consts::PI * self.k.fu)
    }

    fn project_point_coordinate(
        &self,
        p: &Vector3<f64>,
        axis: usize,
    ) -> Result<f64, ProjectionReject> {
        // project_point's steps, then to_pixel's line of the one coordinate
        let n = p.norm();
        if !(n > 1e-12) {
            return Err(ProjectionReject::Singular);
        }
        let d = p / n;
        if axis == 0 {
            M::bearing_to_a(&d).map(|a| self.k.fu * a + self.k.cu)
        } else {
            M::bearing_to_b(&d).map(|b| self.k.fv * b + self.k.cv)
        }
    }

    fn sees_whole_front(&self) -> bool {
        M::FRONT_ONLY && M::WHOLE_FRONT
    }

    fn exact_key(&self, key: &mut super::ExactKey) -> bool {
        let Linear { k, size, mapping } = self;
        key.name(std::any::type_name_of_val(mapping));
        key.intrinsics(k, *size);
        true
    }

    fn project_all(&self, bearings: &[Option<Vector3<f64>>], out: &mut Vec<Option<Point2<f64>>>) {
        // the same `project`, inlined here rather than called through the trait object
        out.extend(bearings.iter().map(|d| self.project(d.as_ref()?).ok()));
    }

    fn separable(&self) -> Option<&dyn Separable> {
        Some(self)
    }

    fn pinhole(&self) -> Option<Intrinsics> {
        (M::PROJECTION == Projection::Perspective).then_some(self.k)
    }
}

impl<M: Mapping> Separable for Linear<M> {
    fn column(&self, u: f64) -> Share {
        Share(M::split_a(self.k.a_of_column(u)))
    }

    fn row(&self, v: f64) -> Share {
        Share(M::split_b(self.k.b_of_row(v)))
    }

    fn bearings(&self, columns: &[Share], row: Share, out: &mut Vec<Option<Vector3<f64>>>) {
        out.extend(columns.iter().map(|c| M::join(c.0, row.0).ok()));
    }

    fn bearing_lanes(&self, columns: &[Share], row: Share, out: [&mut [f64]; 3]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2 (checked just above).
            return unsafe { join_lanes_avx2::<M>(columns, row.0, out) };
        }
        M::join_lanes(columns, row.0, out);
    }
}

/// [`Mapping::join_lanes`] compiled for AVX2 (four lanes of f64 an instruction; the same IEEE
/// operations, so the same bits).
///
/// # Safety
///
/// The processor must have AVX2 (`is_x86_feature_detected!("avx2")`): the function is compiled
/// with its instructions, which fault on a processor without them. It reads and writes only
/// through safe slices.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn join_lanes_avx2<M: Mapping>(columns: &[Share], row: [f64; 2], out: [&mut [f64]; 3]) {
    M::join_lanes(columns, row, out);
}

impl<M: Mapping> OutputCamera for Linear<M> {
    fn projection(&self) -> OutputProjection {
        OutputProjection::Linear(M::PROJECTION)
    }

    fn intrinsics(&self) -> Intrinsics {
        self.k
    }

    fn with_intrinsics(
        &self,
        k: Intrinsics,
        size: ImageSize,
    ) -> Result<Box<dyn OutputCamera>, String> {
        Ok(Box::new(Self::new(k, size)))
    }

    fn boxed_output(&self) -> Box<dyn OutputCamera> {
        Box::new(self.clone())
    }
}

impl<M: Mapping> LinearCamera for Linear<M> {
    fn bearing_to_ab(&self, d: &Vector3<f64>) -> Result<(f64, f64), ProjectionReject> {
        M::bearing_to_ab(d)
    }

    fn ab_to_bearing(&self, a: f64, b: f64) -> Result<Vector3<f64>, ProjectionReject> {
        M::ab_to_bearing(a, b)
    }

    fn boxed_clone(&self) -> Box<dyn LinearCamera> {
        Box::new(self.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Cylindrical, Equirect, Perspective, Rotated};
    use super::*;

    fn cameras() -> Vec<Box<dyn CameraModel>> {
        let k = Intrinsics::new(160.0, 150.0, 503.5, 180.5);
        let size = ImageSize::new(1008, 362);
        vec![
            Box::new(Equirect::new(k, size)),
            Box::new(Cylindrical::new(k, size)),
            Box::new(Perspective::new(k, size)),
            Box::new(Rotated::new(
                Perspective::new(k, size),
                super::super::rotation_ypr(0.4, -0.2, 0.1),
            )),
        ]
    }

    /// Points of every kind: ordinary, on the axes, tiny, huge, zero and not finite.
    fn points() -> Vec<Vector3<f64>> {
        let mut out = vec![
            Vector3::zeros(),
            Vector3::new(1e-13, 0.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
            Vector3::new(0.0, -3.0, 0.0),
            Vector3::new(0.0, 0.0, -1.0),
            Vector3::new(-0.0, 0.0, -1.0),
            Vector3::new(1e200, 1e200, 1e200),
            Vector3::new(1e300, 0.0, 1.0),
            Vector3::new(f64::INFINITY, 0.0, 1.0),
            Vector3::new(f64::NAN, 0.0, 1.0),
            Vector3::new(1.0, 1e-12, 1e-9),
        ];
        let mut s = 11u64;
        for _ in 0..3000 {
            let mut r = || {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 11) as f64 / (1u64 << 53) as f64 * 80.0 - 40.0
            };
            out.push(Vector3::new(r(), r(), r()));
        }
        out
    }

    #[test]
    fn one_coordinate_is_that_of_the_whole_projection_bit_for_bit() {
        for camera in cameras() {
            for p in points() {
                let whole = camera.project_point(&p);
                for axis in 0..2 {
                    let one = camera.project_point_coordinate(&p, axis);
                    match (whole, one) {
                        (Ok(px), Ok(c)) => {
                            assert_eq!(px[axis].to_bits(), c.to_bits(), "{camera:?} {p:?}")
                        }
                        (Err(a), Err(b)) => assert_eq!(a, b, "{camera:?} {p:?}"),
                        _ => panic!("{camera:?} {p:?} axis {axis}: {whole:?} vs {one:?}"),
                    }
                }
            }
        }
    }

    #[test]
    fn a_camera_that_sees_its_whole_front_projects_every_bearing_in_front() {
        let mut checked = 0;
        for camera in cameras() {
            let Some(n) = camera
                .front_halfspace()
                .filter(|_| camera.sees_whole_front())
            else {
                // equirect and cylindrical have no front half-space: they promise nothing
                assert!(!camera.sees_whole_front(), "{camera:?}");
                continue;
            };
            for p in points() {
                // the bearings just inside the promise: p pushed to n·d = 1e-6·|d|
                let along = p - n * n.dot(&p);
                if !(along.norm() > 0.0 && along.norm().is_finite()) {
                    continue;
                }
                let d = along.normalize() + n * 1.000_001e-6;
                assert!(camera.project_point(&d).is_ok(), "{camera:?} {d:?}");
                checked += 1;
            }
        }
        assert!(checked > 5000, "{checked}");
    }

    #[test]
    fn lanes_are_the_per_pixel_bearings_and_pixels_bit_for_bit() {
        let bits = |d: Option<Vector3<f64>>| d.map(|d| [d.x, d.y, d.z].map(f64::to_bits));
        let k = Intrinsics::new(160.0, 150.0, 503.5, 180.5);
        let size = ImageSize::new(1008, 362);
        let separable: Vec<Box<dyn CameraModel>> = vec![
            Box::new(Equirect::new(k, size)),
            Box::new(Cylindrical::new(k, size)),
            Box::new(Perspective::new(k, size)),
            // rows beyond the poles, a column without an azimuth: rejected pixels
            Box::new(Equirect::new(Intrinsics::new(1e-310, 40.0, 0.5, 1.5), size)),
            Box::new(Cylindrical::new(
                Intrinsics::new(1e-310, 0.0, 0.5, 1.5),
                size,
            )),
        ];
        let (mut some, mut none) = (0, 0);
        for camera in &separable {
            let sep = camera.separable().expect("a linear camera separates");
            let columns: Vec<Share> = (-3..1012).map(|u| sep.column(u as f64 * 0.999)).collect();
            for v in [-400.0, -5.0, 0.0, 77.25, 180.5, 361.0, 900.0] {
                let row = sep.row(v);
                let mut want = Vec::new();
                sep.bearings(&columns, row, &mut want);
                let mut got = [(); 3].map(|_| vec![0.0; columns.len()]);
                let [x, y, z] = &mut got;
                sep.bearing_lanes(&columns, row, [x, y, z]);
                for (i, want) in want.into_iter().enumerate() {
                    let lane = Vector3::new(got[0][i], got[1][i], got[2][i]);
                    if want.is_some() {
                        assert_eq!(bits(Some(lane)), bits(want), "{camera:?} {v} {i}");
                        some += 1;
                    } else {
                        assert!(lane.x.is_nan(), "{camera:?} {v} {i}: {lane}");
                        none += 1;
                    }
                }
            }
        }
        assert!(some > 10000 && none > 1000, "{some} {none}");
        // a pinhole's pixels of bearings in every direction, in lanes of 4
        let pinhole = Perspective::new(k, size);
        let bearings: Vec<Vector3<f64>> = points()
            .iter()
            .map(|p| p.normalize())
            .chain([Vector3::new(0.3, 0.2, 1e-12), Vector3::new(0.3, 0.2, 1e-8)])
            .collect();
        let (mut projected, mut rejected) = (0, 0);
        for four in bearings.chunks_exact(4) {
            let lanes = [0, 1, 2].map(|c| std::array::from_fn::<f64, 4, _>(|l| four[l][c]));
            let [u, v] = crate::camera::pinhole_lanes(&k, lanes);
            for (l, d) in four.iter().enumerate() {
                match pinhole.project(d) {
                    Ok(p) => {
                        assert_eq!([u[l], v[l]].map(f64::to_bits), [p.x, p.y].map(f64::to_bits));
                        projected += 1;
                    }
                    Err(_) => {
                        assert!(u[l].is_nan(), "{d:?}");
                        rejected += 1;
                    }
                }
            }
        }
        assert!(
            projected > 1000 && rejected > 1000,
            "{projected} {rejected}"
        );
    }

    #[test]
    fn a_pinholes_points_in_lanes_are_its_project_point_bit_for_bit() {
        let k = Intrinsics::new(707.05, 707.05, 604.08, 180.51);
        let pinhole = Perspective::new(k, ImageSize::new(1224, 370));
        let points: Vec<Vector3<f64>> = points()
            .into_iter()
            .chain([
                Vector3::new(1e-13, 1e-13, 1e-13),
                Vector3::new(0.0, 0.0, 2e-12),
            ])
            .collect();
        let (mut projected, mut rejected) = (0, 0);
        for eight in points.chunks_exact(8) {
            let lanes = [0, 1, 2].map(|c| std::array::from_fn::<f64, 8, _>(|l| eight[l][c]));
            let [u, v] = crate::camera::pinhole_point_lanes(&k, lanes);
            for (l, p) in eight.iter().enumerate() {
                match pinhole.project_point(p) {
                    Ok(q) => {
                        assert_eq!([u[l], v[l]].map(f64::to_bits), [q.x, q.y].map(f64::to_bits));
                        projected += 1;
                    }
                    Err(_) => {
                        assert!(u[l].is_nan(), "{p:?}");
                        rejected += 1;
                    }
                }
            }
        }
        assert!(
            projected > 1000 && rejected > 1000,
            "{projected} {rejected}"
        );
    }
}
