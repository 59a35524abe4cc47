//! The affine part shared by the linear cameras: K = [[fu, 0, cu], [0, fv, cv], [0, 0, 1]].

use serde::{Deserialize, Serialize};

/// An image's size in pixels; displayed as `WIDTHxHEIGHT`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ImageSize {
    /// Columns, in pixels.
    pub width: u32,
    /// Rows, in pixels.
    pub height: u32,
}

impl ImageSize {
    /// A size of `width` × `height` pixels.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height }
    }
}

impl std::fmt::Display for ImageSize {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

/// Focal lengths (pixels per unit of the projection coordinate: per radian for angles) and the
/// principal point, with pixel centres at integers.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Horizontal focal length: pixels per unit of `a` (`K[0][0]`).
    pub fu: f64,
    /// Vertical focal length: pixels per unit of `b` (`K[1][1]`).
    pub fv: f64,
    /// Column of the principal point, in pixels (`K[0][2]`).
    pub cu: f64,
    /// Row of the principal point, in pixels (`K[1][2]`).
    pub cv: f64,
}

impl Intrinsics {
    /// K from its four entries: focal lengths `fu`, `fv` and principal point (`cu`, `cv`).
    pub fn new(fu: f64, fv: f64, cu: f64, cv: f64) -> Self {
        Self { fu, fv, cu, cv }
    }

    /// Pixel (u, v) of projection coordinates (a, b): K · (a, b, 1).
    #[inline]
    pub fn to_pixel(&self, a: f64, b: f64) -> (f64, f64) {
        (self.fu * a + self.cu, self.fv * b + self.cv)
    }

    /// Projection coordinates (a, b) of pixel (u, v): the inverse of [`Intrinsics::to_pixel`].
    #[inline]
    pub fn from_pixel(&self, u: f64, v: f64) -> (f64, f64) {
        (self.a_of_column(u), self.b_of_row(v))
    }

    /// Projection coordinate `a` of pixel column position `u` (K's first row inverted).
    #[inline]
    pub fn a_of_column(&self, u: f64) -> f64 {
        (u - self.cu) / self.fu
    }

    /// Projection coordinate `b` of pixel row position `v` (K's second row inverted).
    #[inline]
    pub fn b_of_row(&self, v: f64) -> f64 {
        (v - self.cv) / self.fv
    }

    /// Row-major 3x3 matrix.
    pub fn matrix(&self) -> [f64; 9] {
        [self.fu, 0.0, self.cu, 0.0, self.fv, self.cv, 0.0, 0.0, 1.0]
    }

    /// Bit pattern, for use as a cache key.
    pub fn key(&self) -> [u64; 4] {
        [
            self.fu.to_bits(),
            self.fv.to_bits(),
            self.cu.to_bits(),
            self.cv.to_bits(),
        ]
    }
}
