//! [`CanvasFlags`]: the flags that shape a linear output camera's scale and canvas, one
//! definition for every command that has them (`kitti`'s [`super::kitti::KittiOptions`], the
//! rig commands' [`super::rig::rig_output_spec`]).

use crate::camera::{ImageSize, Projection};
use crate::error::Result;
use crate::geometry::{Canvas, Crop, OutputSpec, Scale};

/// The scale and canvas flags of a conversion, as given.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CanvasFlags {
    /// `--pano-width`.
    pub pano_width: Option<u32>,
    /// `--px-per-deg`.
    pub px_per_deg: Option<f64>,
    /// `--full-360`.
    pub full_360: bool,
    /// `--size`.
    pub size: Option<ImageSize>,
    /// `--crop`.
    pub crop: Option<Crop>,
    /// `--resize`.
    pub resize: Option<ImageSize>,
}

impl CanvasFlags {
    /// The first given flag of those a fisheye target refuses (its camera file has its own
    /// size and scale; `--crop` and `--resize` still apply), in the order of `--help`.
    pub fn sized_flag(&self) -> Option<&'static str> {
        [
            (self.pano_width.is_some(), "--pano-width"),
            (self.px_per_deg.is_some(), "--px-per-deg"),
            (self.full_360, "--full-360"),
            (self.size.is_some(), "--size"),
        ]
        .into_iter()
        .find_map(|(given, flag)| given.then_some(flag))
    }

    /// The scale the flags give ([`Scale::SourceFocal`] without one).
    pub fn scale(&self) -> Result<Scale> {
        Scale::from_flags(self.pano_width, self.px_per_deg)
    }

    /// The output of `projection` as one camera is converted: the source's tight field of view
    /// unless `--full-360` or `--size` says otherwise.
    pub fn single_camera_spec(&self, projection: Projection) -> Result<OutputSpec> {
        Ok(OutputSpec {
            projection,
            scale: self.scale()?,
            canvas: match (self.full_360, self.size) {
                (true, _) => Canvas::Full360,
                (false, Some(s)) => Canvas::Size(s),
                (false, None) => Canvas::Tight,
            },
            crop: self.crop,
            resize: self.resize,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_sized_flag_is_named_in_help_order() {
        assert_eq!(CanvasFlags::default().sized_flag(), None);
        let flags = CanvasFlags {
            size: Some(ImageSize::new(10, 10)),
            px_per_deg: Some(3.0),
            crop: Some(Crop {
                x: 0,
                y: 0,
                width: 5,
                height: 5,
            }),
            ..Default::default()
        };
        assert_eq!(flags.sized_flag(), Some("--px-per-deg"));
        let crop_only = CanvasFlags {
            crop: flags.crop,
            resize: Some(ImageSize::new(4, 4)),
            ..Default::default()
        };
        assert_eq!(crop_only.sized_flag(), None, "--crop and --resize apply");
    }
}
