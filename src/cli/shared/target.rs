//! What `--to`, `--pano-width` and `--px-per-deg` name: the output projection and its scale,
//! for the dataset commands.

use anyhow::Result;
use clap::ValueEnum;
use panoconv::camera::{OutputProjection, Projection};
use panoconv::geometry::Scale;

#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum To {
    Equirect,
    Cylindrical,
    Perspective,
    /// A real fisheye camera, described by --camera FILE.
    Fisheye,
}

/// What `--to` names: a linear projection or a fisheye camera.
pub(crate) fn projection_of(to: To) -> OutputProjection {
    match to {
        To::Equirect => Projection::Equirect.into(),
        To::Cylindrical => Projection::Cylindrical.into(),
        To::Perspective => Projection::Perspective.into(),
        To::Fisheye => OutputProjection::Fisheye,
    }
}

/// The output scale `--pano-width` or `--px-per-deg` asks for (default: the source's own).
pub(crate) fn scale_of(pano_width: Option<u32>, px_per_deg: Option<f64>) -> Result<Scale> {
    Ok(Scale::from_flags(pano_width, px_per_deg)?)
}
