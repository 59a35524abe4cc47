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
    /// Projection coordinates (a, b) of a bearing (any non-zero length); angles in radians.
    fn bearing_to_ab(d: &Vector3<f64>) -> Result<(f64, f64), ProjectionReject>;
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

    fn project_all(&self, bearings: &[Option<Vector3<f64>>], out: &mut Vec<Option<Point2<f64>>>) {
        // the same `project`, inlined here rather than called through the trait object
        out.extend(bearings.iter().map(|d| self.project(d.as_ref()?).ok()));
    }

    fn separable(&self) -> Option<&dyn Separable> {
        Some(self)
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
