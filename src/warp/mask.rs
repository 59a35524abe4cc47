//! A source camera's ego mask: the pixels where the vehicle's own body fills the image (a
//! fisheye looking down the car's side sees its doors and mirror). A stitch gives a masked
//! camera weight 0 wherever its sample would touch the mask (`Stitch::build_masked`), so the
//! body never appears in the output: the other cameras fill those pixels, or they stay black.

use crate::camera::ImageSize;
use crate::error::{Error, Result};
use crate::image::RgbImage;
use nalgebra::Point2;
use std::path::Path;

/// Which pixels of a camera's image are the vehicle's body.
#[derive(Debug, Clone, PartialEq)]
pub struct EgoMask {
    size: ImageSize,
    masked: Vec<bool>,
}

impl EgoMask {
    /// A mask of `size` from its pixels, row-major (true = body); None when the count is not
    /// width × height.
    pub fn new(size: ImageSize, masked: Vec<bool>) -> Option<Self> {
        (masked.len() == size.width as usize * size.height as usize)
            .then_some(Self { size, masked })
    }

    /// Reads a mask image (PNG or any format `codec` reads: grey, RGB or with alpha; a pixel
    /// whose colour channels are not all 0 is the body). Its size must be `size`, the camera's
    /// image size: another size is an error naming the file.
    pub fn read(path: &Path, size: ImageSize) -> Result<Self> {
        let bytes = crate::fs::read_file(path)?;
        Self::from_image(&crate::codec::decode_rgb8(&bytes, path)?, path, size)
    }

    /// [`Self::read`] of a mask image already decoded from `path` (a caller that also hashes
    /// the file's bytes decodes them once).
    pub fn from_image(image: &RgbImage, path: &Path, size: ImageSize) -> Result<Self> {
        if image.width() != size.width || image.height() != size.height {
            return Err(Error::file(
                path,
                format!(
                    "an ego mask of {}x{} pixels for a camera of {}x{}: a mask must be the \
                     camera's image size",
                    image.width(),
                    image.height(),
                    size.width,
                    size.height
                ),
            ));
        }
        let masked = image
            .as_raw()
            .chunks_exact(3)
            .map(|px| px.iter().any(|&c| c != 0))
            .collect();
        Ok(Self { size, masked })
    }

    /// The mask's size (its camera's image size).
    pub fn size(&self) -> ImageSize {
        self.size
    }

    /// Whether pixel (x, y) is the body (false outside the image).
    pub fn is_masked(&self, x: i64, y: i64) -> bool {
        x >= 0
            && y >= 0
            && (x as u64) < self.size.width as u64
            && (y as u64) < self.size.height as u64
            && self.masked[y as usize * self.size.width as usize + x as usize]
    }

    /// The number of masked pixels.
    pub fn count(&self) -> usize {
        self.masked.iter().filter(|m| **m).count()
    }

    /// Whether a masked pixel centre lies within `half` pixels of `p` in x and in y (pixel
    /// centres at integers): with `half` ≥ 1 this holds whenever a bilinear tap at `p` is
    /// masked.
    pub fn touches(&self, p: &Point2<f64>, half: f64) -> bool {
        if !(p.x.is_finite() && p.y.is_finite() && half.is_finite()) {
            return false;
        }
        let (w, h) = (self.size.width as f64, self.size.height as f64);
        let x0 = (p.x - half).ceil().max(0.0);
        let x1 = (p.x + half).floor().min(w - 1.0);
        let y0 = (p.y - half).ceil().max(0.0);
        let y1 = (p.y + half).floor().min(h - 1.0);
        if x0 > x1 || y0 > y1 {
            return false;
        }
        let width = self.size.width as usize;
        (y0 as usize..=y1 as usize).any(|y| {
            self.masked[y * width + x0 as usize..=y * width + x1 as usize]
                .iter()
                .any(|m| *m)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mask_touches_the_taps_around_a_point() {
        let size = ImageSize::new(4, 3);
        let mut pixels = vec![false; 12];
        pixels[2 * 4 + 3] = true; // (3, 2)
        let mask = EgoMask::new(size, pixels).unwrap();
        assert!(EgoMask::new(size, vec![false; 11]).is_none());
        assert_eq!(mask.count(), 1);
        assert!(mask.is_masked(3, 2) && !mask.is_masked(2, 2) && !mask.is_masked(4, 2));
        // bilinear taps of (2.5, 1.5) are (2..=3, 1..=2): one is masked
        assert!(mask.touches(&Point2::new(2.5, 1.5), 1.0));
        // (1.9, 1.0) reaches x 2 at most
        assert!(!mask.touches(&Point2::new(1.9, 1.0), 1.0));
        assert!(mask.touches(&Point2::new(1.9, 1.0), 1.2));
        assert!(!mask.touches(&Point2::new(-9.0, -9.0), 1.0));
        assert!(!mask.touches(&Point2::new(f64::NAN, 1.0), 1.0));
    }
}
