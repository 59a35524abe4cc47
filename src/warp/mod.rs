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
pub use stitch::{Stitch, StitchCamera, StitchDepth, StitchOptions, Stitched};
pub use stream::{warp_encode, PngSource};
pub use table::{RemapTable, Wrap, MAX_SUPERSAMPLE};
