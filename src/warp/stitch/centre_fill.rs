//! The depth-guided stitch's centre fill: never black where a camera's image holds a pixel's
//! centre.
//!
//! A table gives a pixel nothing unless its whole footprint lies inside the image, and across a
//! depth edge the footprint's taps lie at their own distances. On the far fill's rim a pixel
//! keeps the scene's distance while its neighbour is stitched at the proxy distance: its
//! footprint straddles both, and the taps on the far side, at the proxy distance, fall outside
//! the image that holds its centre (that point lies in no image at the scene's distance, which
//! is why it was far-filled). Every camera's weight is then 0 and the pixel would be black, in
//! thin lines inside the cameras' coverage (650-810 px a frame on the real PandaSet frames);
//! the same where a pixel's centre lies within an image's outermost pixel but its footprint
//! does not. Such a pixel takes the camera whose image holds its centre at its stitched
//! distance (one that sees the point first, then the one whose border lies farthest), the
//! bilinear sample of that camera's image at the centre, its gain applied. Its source index is
//! the camera's, + [`super::FALLBACK_SOURCE`] where the camera does not see the point (the
//! fallback rule), + [`super::FAR_SOURCE`] where the far fill took the pixel.

use super::proxy::Proxy;
use super::StitchDepth;
use crate::camera::ImageSize;
use crate::image::RgbImage;
use crate::warp::mask::EgoMask;
use crate::warp::reach::Reach;
use crate::warp::table::RemapTable;
use nalgebra::Point2;
use rayon::prelude::*;

/// Source pixels around a centre sample's position within which a camera's ego mask must be
/// clear: the bilinear taps' reach.
const TAPS_REACH: f64 = 1.0;

/// A pixel the centre fill took: its index (row-major), its camera and the position of its
/// centre in that camera's image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct CentreSample {
    pub(super) at: usize,
    pub(super) camera: u8,
    pub(super) x: f64,
    pub(super) y: f64,
}

/// What the centre fill asks: the output's bearings, each pixel's stitched distance (the far
/// fill's applied), the cameras' tables, their proxies through the stitch's scene and their ego
/// masks (at most 64 cameras).
pub(super) struct CentreFill<'a> {
    pub(super) reach: &'a Reach,
    pub(super) tables: &'a [RemapTable],
    pub(super) size: ImageSize,
    pub(super) distances: &'a [f64],
    pub(super) proxies: &'a [Proxy<'a>],
    pub(super) masks: &'a [Option<&'a EgoMask>],
    pub(super) depth: &'a dyn StitchDepth,
}

impl CentreFill<'_> {
    /// The centre samples of the pixels no camera weighs (`weights` resolved, see
    /// [`super::fallback::resolve`]) whose centre some camera's image holds, in pixel order;
    /// `fallback` marks those whose camera does not see the point.
    pub(super) fn samples(&self, weights: &[Vec<f32>], fallback: &mut [bool]) -> Vec<CentreSample> {
        let w = self.size.width as usize;
        let rows: Vec<Vec<(CentreSample, bool)>> = (0..self.size.height as usize)
            .into_par_iter()
            .map_init(Vec::new, |reached, v| {
                // per pixel of the row, the cameras whose tables sample their images there
                // (a centre an image holds has a tap in it): most of the row has none
                reached.clear();
                reached.resize(w, 0u64);
                for (i, table) in self.tables.iter().enumerate() {
                    for span in table.stored_spans(v) {
                        reached[span].iter_mut().for_each(|r| *r |= 1 << i);
                    }
                }
                (0..w)
                    .filter(|&u| reached[u] != 0 && weights.iter().all(|wk| !(wk[v * w + u] > 0.0)))
                    .filter_map(|u| self.sample(u, v, reached[u]))
                    .collect()
            })
            .collect();
        let samples = rows.into_iter().flatten();
        samples
            .map(|(s, seen)| {
                fallback[s.at] |= !seen;
                s
            })
            .collect()
    }

    /// Pixel (u, v)'s centre sample, where some camera's image holds its centre, and whether
    /// its camera sees the point ([`StitchDepth::sees`]).
    fn sample(&self, u: usize, v: usize, cameras: u64) -> Option<(CentreSample, bool)> {
        let w = self.size.width as usize;
        let at = v * w + u;
        let d = self.reach.bearing(u, v)?;
        let (t, n) = (self.distances[at], d.normalize());
        if !(t > 0.0) {
            return None;
        }
        // (seen, border distance, camera, position): the best so far
        let mut best: Option<(bool, f64, usize, Point2<f64>)> = None;
        for (i, proxy) in self.proxies.iter().enumerate() {
            if cameras >> i & 1 == 0 {
                continue;
            }
            let q = proxy.local_at(&n, t);
            if !proxy.holds(&q, 0.0) {
                continue;
            }
            let Ok(p) = proxy.camera.model.project_point(&q) else {
                continue;
            };
            let mask = self.masks.get(i).copied().flatten();
            if mask.is_some_and(|m| m.touches(&p, TAPS_REACH)) {
                continue;
            }
            let size = proxy.camera.model.size();
            let border = (p.x + 0.5)
                .min(size.width as f64 - 0.5 - p.x)
                .min(p.y + 0.5)
                .min(size.height as f64 - 0.5 - p.y);
            let seen = self.depth.sees(i, &proxy.point_at(&n, t));
            if best.is_none_or(|(s, b, _, _)| (seen, border) > (s, b)) {
                best = Some((seen, border, i, p));
            }
        }
        let (seen, _, camera, p) = best?;
        let sample = CentreSample {
            at,
            camera: camera as u8,
            x: p.x,
            y: p.y,
        };
        Some((sample, seen))
    }
}

/// The bilinear sample of `image` at position (x, y) (pixel centres at integers), the edge's
/// pixels repeated beyond it.
pub(super) fn bilinear(image: &RgbImage, x: f64, y: f64) -> [f64; 3] {
    let (w, h) = (image.width() as usize, image.height() as usize);
    let x = x.clamp(0.0, (w - 1) as f64);
    let y = y.clamp(0.0, (h - 1) as f64);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (x - x0 as f64, y - y0 as f64);
    let raw = image.as_raw();
    let px = |x: usize, y: usize, c: usize| raw[(y * w + x) * 3 + c] as f64;
    std::array::from_fn(|c| {
        let top = px(x0, y0, c) * (1.0 - fx) + px(x1, y0, c) * fx;
        let bottom = px(x0, y1, c) * (1.0 - fx) + px(x1, y1, c) * fx;
        top * (1.0 - fy) + bottom * fy
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{CameraModel, Equirect, Intrinsics, Perspective};
    use crate::warp::stitch::{Stitch, StitchCamera, StitchOptions};
    use crate::warp::NO_SOURCE;
    use nalgebra::{Matrix3, Vector3};

    /// A camera's own near surface: 0.3 m from the output centre above a line of bearings (the
    /// forward camera stands 0.5 m ahead, so it lies behind it: no camera holds it), a wall at
    /// 5 m below.
    #[derive(Debug)]
    struct NearBand;

    impl StitchDepth for NearBand {
        fn distance(&self, d: &Vector3<f64>) -> f64 {
            if d.y < -0.2 * d.norm() {
                0.3
            } else {
                5.0
            }
        }
        fn sees(&self, _: usize, _: &Vector3<f64>) -> bool {
            true
        }
        fn nearest(&self) -> f64 {
            0.3
        }
    }

    #[test]
    fn the_far_fills_rim_is_not_left_black_where_an_image_holds_the_pixels_centre() {
        // a 60° pinhole 0.5 m ahead of the output centre, 3.6 of its pixels an output pixel:
        // the band above the line is far-filled (at 10 m the camera holds it), and the wall's
        // pixels along its rim have footprints whose upper taps lie on the band, behind the
        // camera: the table gives them nothing
        let model = Perspective::new(
            Intrinsics::new(207.8, 207.8, 119.5, 79.5),
            ImageSize::new(240, 160),
        );
        let camera = StitchCamera {
            model: &model,
            rotation: Matrix3::identity(),
            translation: Vector3::new(0.0, 0.0, -0.5),
            max_theta: None,
        };
        let f = 180.0 / std::f64::consts::PI;
        let output = Equirect::new(Intrinsics::new(f, f, 179.5, 89.5), ImageSize::new(360, 180));
        let options = StitchOptions::default();
        let stitch = Stitch::build_guided(
            &output,
            &Vector3::zeros(),
            &[camera],
            &[],
            options,
            &NearBand,
        )
        .unwrap();
        let image = RgbImage::from_raw(240, 160, vec![100; 240 * 160 * 3]).unwrap();
        let stitched = stitch.apply(&[&image]);
        let distances = stitch.distances().unwrap();
        let (mut held, mut rim_unweighed, mut black) = (0, 0, 0);
        for v in 0..180u32 {
            for u in 0..360u32 {
                let i = (v * 360 + u) as usize;
                let Ok(d) = output.unproject(&nalgebra::Point2::new(u as f64, v as f64)) else {
                    continue;
                };
                // the point at the pixel's stitched distance, in the camera's image by 0.05 px
                let q = d.normalize() * distances[i] + camera.translation;
                let inside = q.z > 0.0
                    && model.project_point(&q).is_ok_and(|p| {
                        p.x >= -0.45 && p.x <= 239.45 && p.y >= -0.45 && p.y <= 159.45
                    });
                if !inside {
                    continue;
                }
                held += 1;
                // the far fill's rim: a neighbour far-filled
                let rim = (v.saturating_sub(1)..(v + 2).min(180)).any(|y| {
                    (u.saturating_sub(1)..(u + 2).min(360)).any(|x| stitch.filled_far(x, y))
                });
                if stitch.weight(0, u, v) == 0.0 {
                    rim_unweighed += rim as usize;
                    let px = &stitched.image.as_raw()[i * 3..i * 3 + 3];
                    if stitched.source[i] != NO_SOURCE {
                        assert_eq!(px, [100; 3], "pixel ({u}, {v})");
                    }
                }
                black += (stitched.source[i] == NO_SOURCE) as usize;
            }
        }
        eprintln!(
            "{held} held pixels, {rim_unweighed} on the far fill's rim weighed 0, {black} black"
        );
        assert!(held > 1_500, "{held} pixels held");
        assert!(
            rim_unweighed > 40,
            "{rim_unweighed} held pixels on the far fill's rim the table gives nothing"
        );
        assert_eq!(black, 0, "{black} of {held} held pixels black");
    }
}
