//! Which placed objects are written as objects: the visibility rule.
//!
//! A crop or a projection edge can leave of an object a sliver (a 21.6 × 0.04 px box) or a
//! corner of a box that is mostly outside the image. Trained on as an object, such a box teaches
//! a detector to find what cannot be seen; left out, the detections there are penalised as false
//! positives. So an object is written as an object only when its written (clipped) 2D box is at
//! least [`Visibility::min_side_px`] on each side and at least [`Visibility::min_share`] of its
//! own full projected box lies in the image; the others are written as DontCare regions (their
//! box, so detections there are not penalised) and do not count as objects (`--min-objects`).
//! `kitti`, `kitti360` and the exports apply the same rule.

use super::source_box::BoxInImage;
use serde::Serialize;

/// The visibility rule's two thresholds (`--min-visible PX,SHARE`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Visibility {
    /// The written box's width and height must each be at least this, pixels.
    pub min_side_px: f64,
    /// The share of the object's full projected box inside the image must be at least this
    /// (0 to 1): 1 − the clipped fraction (KITTI's truncation of the clipping alone).
    pub min_share: f64,
}

impl Default for Visibility {
    /// 2 px on each side, a tenth of the box: a sliver or a corner is not an object, a car
    /// half out of the frame still is.
    fn default() -> Self {
        Self {
            min_side_px: 2.0,
            min_share: 0.1,
        }
    }
}

impl Visibility {
    /// No threshold: every placed object is an object (`--min-visible 0,0`).
    pub const OFF: Visibility = Visibility {
        min_side_px: 0.0,
        min_share: 0.0,
    };

    /// Whether the defaults apply.
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// Whether the rule is one the other options imply (the default of `--augment`, or none
    /// without it): the manifest records the rule only otherwise, so that runs without the
    /// flag keep their manifests.
    pub fn is_implied(&self) -> bool {
        self.is_default() || *self == Self::OFF
    }

    /// Whether a box `bounds` ([left, top, right, bottom], clipped) of which `truncation`
    /// (the clipped fraction of the full box) lies outside the image is an object.
    pub fn accepts(&self, bounds: [f64; 4], truncation: f64) -> bool {
        let (w, h) = (bounds[2] - bounds[0], bounds[3] - bounds[1]);
        // (1e-9: a written truncation of 0.90 is a tenth visible, though 1 − 0.9 < 0.1 in f64)
        w >= self.min_side_px && h >= self.min_side_px && 1.0 - truncation >= self.min_share - 1e-9
    }

    /// [`Visibility::accepts`] of a placed box.
    pub fn sees(&self, placed: &BoxInImage) -> bool {
        self.accepts(placed.bounds, placed.truncation)
    }

    /// Parses `PX,SHARE` (`2,0.1`).
    pub fn parse(s: &str) -> Result<Self, String> {
        let (px, share) = s
            .split_once(',')
            .ok_or_else(|| format!("{s:?}: expected PX,SHARE (for example 2,0.1)"))?;
        let px: f64 = px
            .trim()
            .parse()
            .map_err(|_| format!("{px:?}: not a number of pixels"))?;
        let share: f64 = share
            .trim()
            .parse()
            .map_err(|_| format!("{share:?}: not a share"))?;
        if !(px >= 0.0 && px.is_finite() && (0.0..=1.0).contains(&share)) {
            return Err(format!(
                "{s:?}: PX must be at least 0 and SHARE from 0 to 1"
            ));
        }
        Ok(Self {
            min_side_px: px,
            min_share: share,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slivers_and_corners_are_not_objects() {
        let rule = Visibility::default();
        // The sliver of the real frames: 21.6 x 0.04 px.
        assert!(!rule.accepts([425.40, 126.96, 447.00, 127.00], 0.0));
        assert!(!rule.accepts([0.0, 0.0, 1.9, 50.0], 0.0));
        assert!(rule.accepts([0.0, 0.0, 2.0, 2.0], 0.0));
        assert!(rule.accepts([0.0, 0.0, 40.0, 30.0], 0.9));
        assert!(!rule.accepts([0.0, 0.0, 40.0, 30.0], 0.91));
        assert!(Visibility::OFF.accepts([1.0, 1.0, 1.0, 1.0], 1.0));
    }

    #[test]
    fn the_flag_parses_and_refuses_what_has_no_meaning() {
        assert_eq!(
            Visibility::parse("3,0.25").unwrap(),
            Visibility {
                min_side_px: 3.0,
                min_share: 0.25
            }
        );
        assert_eq!(Visibility::parse("0,0").unwrap(), Visibility::OFF);
        for bad in ["3", "a,0.1", "2,1.5", "-1,0.1", "2,x"] {
            assert!(Visibility::parse(bad).is_err(), "{bad}");
        }
    }
}
