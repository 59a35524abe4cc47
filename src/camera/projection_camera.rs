//! The camera of a linear projection, [`Projection::camera`]: apart from `projection.rs`
//! because each mapping (`equirect.rs`, ...) names its own `Projection`, and this constructor
//! names every mapping; in one file the two would import each other.

use super::cylindrical::Cylindrical;
use super::equirect::Equirect;
use super::perspective::Perspective;
use super::projection::Projection;
use super::{ImageSize, Intrinsics, LinearCamera};

impl Projection {
    /// The camera of this projection with intrinsics `k` and image `size`.
    pub fn camera(self, k: Intrinsics, size: ImageSize) -> Box<dyn LinearCamera> {
        match self {
            Projection::Perspective => Box::new(Perspective::new(k, size)),
            Projection::Equirect => Box::new(Equirect::new(k, size)),
            Projection::Cylindrical => Box::new(Cylindrical::new(k, size)),
        }
    }
}
