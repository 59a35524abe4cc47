//! The affine part shared by the linear cameras: K = [[fu, 0, cu], [0, fv, cv], [0, 0, 1]].

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ImageSize {
    pub width: u32,
    pub height: u32,
}

impl ImageSize {
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
    pub fu: f64,
    pub fv: f64,
    pub cu: f64,
    pub cv: f64,
}

impl Intrinsics {
    pub fn new(fu: f64, fv: f64, cu: f64, cv: f64) -> Self {
        Self { fu, fv, cu, cv }
    }

    #[inline]
    pub fn to_pixel(&self, a: f64, b: f64) -> (f64, f64) {
        (self.fu * a + self.cu, self.fv * b + self.cv)
    }

    #[inline]
    pub fn from_pixel(&self, u: f64, v: f64) -> (f64, f64) {
        ((u - self.cu) / self.fu, (v - self.cv) / self.fv)
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
