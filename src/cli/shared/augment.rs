//! `--augment` and its options, shared by `kitti` and the rig commands.

use super::parse::{parse_range, parse_size};
use clap::Args;
use panoconv::camera::ImageSize;
use panoconv::geometry::augment::Augment;
use panoconv::reproject::visibility::Visibility;

/// `--augment` and its options, and the labels' visibility rule, for `kitti` and `kitti360`.
#[derive(Args)]
pub(crate) struct AugmentArgs {
    /// Write N random scale-and-crop views of each frame's output (ids frame×N+k) instead of
    /// the frame.
    #[arg(long, value_name = "N", conflicts_with_all = ["crop", "resize"], requires = "crop_size")]
    augment: Option<u32>,
    /// Seed of --augment (same seed, same views, whatever --jobs).
    #[arg(long, default_value_t = 0, requires = "augment")]
    seed: u64,
    /// Range of the --augment scale factor, drawn uniformly.
    #[arg(long, value_name = "MIN,MAX", default_value = "1,1", value_parser = parse_range, requires = "augment")]
    scale_range: (f64, f64),
    /// Size of every --augment view.
    #[arg(long, value_name = "WxH", value_parser = parse_size, requires = "augment")]
    crop_size: Option<ImageSize>,
    /// Redraw an --augment view (up to 16 times) until it holds at least N objects (DontCare
    /// regions do not count); the summary says how many views still hold fewer.
    #[arg(long, value_name = "N", requires = "augment")]
    min_objects: Option<u32>,
    /// Write an object as an object only when its 2D box is at least PX pixels on each side
    /// and at least SHARE of its full projected box is in the image; the others become DontCare
    /// regions [default: 2,0.1 with --augment, else 0,0: every object the source labels]
    #[arg(long, value_name = "PX,SHARE", value_parser = Visibility::parse)]
    min_visible: Option<Visibility>,
}

impl AugmentArgs {
    /// The visibility rule of `--min-visible`.
    pub(crate) fn visibility(&self) -> Visibility {
        self.min_visible.unwrap_or(if self.augment.is_some() {
            Visibility::default()
        } else {
            Visibility::OFF
        })
    }

    /// The views `--augment` asks for, if given.
    pub(crate) fn views(&self) -> Option<Augment> {
        self.augment.map(|count| Augment {
            count,
            seed: self.seed,
            scale_range: self.scale_range,
            crop_size: self
                .crop_size
                .expect("clap requires --crop-size with --augment"),
            min_objects: self.min_objects.unwrap_or(0),
        })
    }
}
