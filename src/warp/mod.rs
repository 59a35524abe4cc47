//! Image reprojection: a remap table built once per (source camera, output camera) and applied
//! to every frame that shares them.

mod footprint;
mod kernel;
mod mapping;
pub mod mask;
mod reach;
pub mod stitch;
mod stream;
mod table;

pub use footprint::Footprint;
#[doc(hidden)]
pub use kernel::Kernel;
pub use mapping::{ImageMapping, NO_SOURCE};
pub use mask::EgoMask;
pub use stitch::{
    grid_applies, GridBox, GridScene, GroundHit, Stitch, StitchCamera, StitchDepth, StitchFigures,
    StitchOptions, Stitched, FALLBACK_SOURCE, FAR_SOURCE,
};
pub use stream::{warp_encode, PngSource};
pub use table::{
    narrow_u8, pyramid, RemapTable, Wrap, LENS_TAPS_BELOW, MAX_SUPERSAMPLE, TAPS_BELOW,
};

/// ⌊x⌋, exactly, without a libm call for 0 ≤ x < 2^52 (truncation there): a pixel or cell
/// index on a per-tap path.
#[inline]
pub(crate) fn floor(x: f64) -> f64 {
    if (0.0..4_503_599_627_370_496.0).contains(&x) {
        (x as u64) as f64
    } else {
        x.floor()
    }
}
