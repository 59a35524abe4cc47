//! The depth-guided stitch's far fill: never black where the fixed stitch has a sample.
//!
//! Near the car, between two cameras, a pixel's point at the scene's distance can lie in no
//! camera's image although its point at the proxy distance lies in one: the cameras' baselines
//! open a gap there that the fixed stitch's sphere closes (nuScenes' back and back-left cameras
//! over the near road, PandaSet's side cameras below the horizon and beside the nearest parked
//! cars: 4-9 % of what the cameras cover on the real frames). Such a pixel is stitched at the
//! proxy distance, as the fixed stitch stitches it, every camera's weight a fallback's (no
//! camera is shown to see that point: its colour is a parallax copy), and its source index
//! carries [`FAR_SOURCE`].

use super::proxy::Proxy;
use super::StitchDepth;
use crate::camera::{CameraModel, ImageSize};
use crate::warp::reach::Reach;
use nalgebra::Vector3;
use rayon::prelude::*;

/// Added to a pixel's source index (the camera of largest weight) when the far fill took it:
/// its colour is a camera's sample at the proxy distance, where no camera's image holds the
/// point at the scene's distance.
pub const FAR_SOURCE: u8 = 64;

/// Source pixels within which of an image's border a point counts as not held at the scene's
/// distance: a table gives a pixel nothing unless its whole footprint lies inside the image,
/// so a centre this near the border may still be left black.
const RIM: f64 = 1.5;

/// Per output pixel (row-major), whether the far fill takes it: its point at the scene's
/// distance (`distances`, as [`super::guided::pixel_distances`] gives them) lies in no camera's
/// image, and its point at `far`, farther, in one (`proxies`: the cameras' proxies).
pub(super) fn far_pixels(
    reach: &Reach,
    size: ImageSize,
    distances: &[f64],
    proxies: &[Proxy],
    far: f64,
) -> Vec<bool> {
    let w = size.width as usize;
    let mut out = vec![false; distances.len()];
    out.par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(v, row)| {
            // per distance, the camera that held the row's last pixel is asked first (the
            // answer is whether any holds: the same in any order); the scene's distance is
            // asked first after a pixel held there (a lens's wide image holds most of a row)
            let mut first = [0usize; 2];
            let mut scene_first = false;
            for (u, flag) in row.iter_mut().enumerate() {
                let t = distances[v * w + u];
                let Some(d) = reach.bearing(u, v).filter(|_| t < far) else {
                    continue;
                };
                let n = d.normalize();
                // only the cameras whose bound may reach the pixel: the bound holds every
                // point at the scene's distance or farther (its cone widened for the tile's
                // nearest), so the others hold neither point
                let held = |t: f64, rim: f64, first: &mut usize| {
                    let count = proxies.len();
                    let found = (0..count).map(|k| (*first + k) % count).find(|&i| {
                        let p = &proxies[i];
                        reach.may_reach_pixel(i, u, v) && p.holds(&p.local_at(&n, t), rim)
                    });
                    *first = found.unwrap_or(*first);
                    found.is_some()
                };
                let [at_far, at_scene] = &mut first;
                // (else the far test first: most pixels of a row beyond every image are held
                // at neither distance)
                if scene_first && held(t, RIM, at_scene) {
                    continue;
                }
                // (where the scene's distance was asked above, it was not held there)
                let held_far = held(far, 0.0, at_far);
                let held_scene = held_far && !scene_first && held(t, RIM, at_scene);
                *flag = held_far && !held_scene;
                scene_first = held_scene;
            }
        });
    out
}

/// The scene of a depth-guided stitch with its far pixels at the proxy distance, seen by no
/// camera; `inner` everywhere else. Its lower bounds are `inner`'s: a far pixel's distance
/// only grows.
#[derive(Debug)]
pub(super) struct FarScene<'a> {
    pub(super) inner: &'a dyn StitchDepth,
    pub(super) output: &'a dyn CameraModel,
    pub(super) centre: Vector3<f64>,
    /// [`far_pixels`]' answer.
    pub(super) far: &'a [bool],
    pub(super) distance: f64,
}

impl FarScene<'_> {
    /// Whether unit bearing `d`'s nearest output pixel is a far one.
    fn is_far(&self, d: &Vector3<f64>) -> bool {
        let Ok(p) = self.output.project(d) else {
            return false;
        };
        let size = self.output.size();
        let (w, h) = (size.width as i64, size.height as i64);
        let (u, v) = (p.x.round() as i64, p.y.round() as i64);
        (0..h).contains(&v) && self.far[(v * w + u.rem_euclid(w.max(1))) as usize]
    }
}

impl StitchDepth for FarScene<'_> {
    fn distance(&self, d: &Vector3<f64>) -> f64 {
        if self.is_far(d) {
            self.distance
        } else {
            self.inner.distance(d)
        }
    }

    fn sees(&self, camera: usize, x: &Vector3<f64>) -> bool {
        !self.is_far(&(x - self.centre).normalize()) && self.inner.sees(camera, x)
    }

    fn hidden_near(&self, camera: usize, x: &Vector3<f64>, radius: f64) -> bool {
        self.inner.hidden_near(camera, x, radius)
    }

    fn sees_clean(&self, camera: usize, x: &Vector3<f64>, radius: f64) -> bool {
        !self.is_far(&(x - self.centre).normalize()) && self.inner.sees_clean(camera, x, radius)
    }

    fn nearest(&self) -> f64 {
        self.inner.nearest()
    }

    fn may_interpolate(&self, d: &Vector3<f64>, radius: f64) -> bool {
        self.inner.may_interpolate(d, radius)
    }

    fn seen_at(&self, camera: usize, x: &Vector3<f64>) -> Vector3<f64> {
        if self.is_far(&(x - self.centre).normalize()) {
            *x // a point of no object
        } else {
            self.inner.seen_at(camera, x)
        }
    }

    fn motion_bound(&self, camera: usize) -> f64 {
        self.inner.motion_bound(camera)
    }

    fn nearest_within(&self, d: &Vector3<f64>, radius: f64) -> f64 {
        self.inner.nearest_within(d, radius)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Equirect, Intrinsics, Perspective};
    use crate::warp::stitch::proxy::tests::Sphere;
    use crate::warp::stitch::{Stitch, StitchCamera, StitchOptions};
    use crate::warp::NO_SOURCE;
    use nalgebra::Rotation3;

    /// A 60° pinhole of 120x80 px.
    fn pinhole() -> Perspective {
        Perspective::new(
            Intrinsics::new(69.3, 69.3, 59.5, 39.5),
            ImageSize::new(120, 80),
        )
    }

    /// `model` twice, 1 m apart along x, each turned 33° outwards.
    fn outward_pair(model: &Perspective) -> [StitchCamera<'_>; 2] {
        let camera = |x: f64, yaw: f64| {
            let rotation = *Rotation3::from_euler_angles(0.0, yaw, 0.0).matrix();
            StitchCamera {
                model,
                rotation,
                translation: -(rotation * Vector3::new(x, 0.0, 0.0)),
                max_theta: None,
            }
        };
        [
            camera(-0.5, 33f64.to_radians()),
            camera(0.5, -33f64.to_radians()),
        ]
    }

    /// A 180x90 px equirect of the whole sphere.
    fn equirect_180() -> Equirect {
        Equirect::new(
            Intrinsics::new(
                90.0 / std::f64::consts::PI,
                90.0 / std::f64::consts::PI,
                89.5,
                44.5,
            ),
            ImageSize::new(180, 90),
        )
    }

    #[test]
    fn a_near_scene_between_two_cameras_is_stitched_at_the_proxy_distance_not_left_black() {
        // two 60° pinholes 1 m apart, turned 33° outwards: their fields of view meet 4.6 m out,
        // so a scene at 1.5 m leaves a wedge between them that the 10 m sphere closes
        let model = pinhole();
        let cameras = outward_pair(&model);
        let output = equirect_180();
        let centre = Vector3::zeros();
        let options = StitchOptions::default();
        let images: Vec<crate::image::RgbImage> = (0..2)
            .map(|k| {
                let level = 60 + 100 * k as u8;
                crate::image::RgbImage::from_raw(120, 80, vec![level; 120 * 80 * 3]).unwrap()
            })
            .collect();
        let refs: Vec<_> = images.iter().collect();
        let fixed = Stitch::build_masked(&output, &centre, &cameras, &[], options)
            .unwrap()
            .apply(&refs)
            .source;
        let guided =
            Stitch::build_guided(&output, &centre, &cameras, &[], options, &Sphere(1.5)).unwrap();
        let source = guided.apply(&refs).source;
        let far = (0..90u32)
            .flat_map(|v| (0..180u32).map(move |u| (u, v)))
            .filter(|&(u, v)| guided.filled_far(u, v))
            .count();
        // every pixel the fixed stitch gives, the guided one gives (within a pixel of the rim,
        // where a table asks the whole footprint inside the image)
        let lost = (0..fixed.len())
            .filter(|&i| fixed[i] != NO_SOURCE && source[i] == NO_SOURCE)
            .count();
        let marked = (0..source.len())
            .filter(|&i| source[i] != NO_SOURCE && source[i] & FAR_SOURCE != 0)
            .inspect(|&i| assert!(guided.filled_far((i % 180) as u32, (i / 180) as u32)))
            .count();
        assert!(
            marked > 100 && marked <= far,
            "{marked} marked of {far} far pixels"
        );
        assert!(lost <= 20, "{lost} pixels the fixed stitch gives are black");
        // and none where a camera's image holds the scene's point
        assert!(!guided.filled_far(45, 45) && !guided.filled_far(135, 45));
    }

    #[test]
    fn far_pixels_are_those_held_at_the_proxy_distance_and_not_at_the_scenes() {
        // two 60° pinholes 1 m apart, turned 33° outwards, over drawn runs of distances (near,
        // mid, beyond the proxy, none): each pixel's flag is the rule's, asked of every camera
        // at both distances, whatever order the rows ask them in
        let model = pinhole();
        let cameras = outward_pair(&model);
        let (w, h) = (180usize, 90usize);
        let output = equirect_180();
        let all = |d: &Vector3<f64>| *d;
        let cone = || crate::warp::reach::Cone {
            local: &all,
            half_angle: None,
            parallax: None,
            baseline: None,
            frustum: None,
        };
        let reach = Reach::new(&output, &[cone(), cone()], None);
        let (centre, far) = (Vector3::new(0.0, 0.1, 0.0), 10.0);
        let proxies: Vec<Proxy> = (cameras.iter().enumerate())
            .map(|(i, c)| Proxy::guided((i, *c), centre, far, Some(&Sphere(1.5))))
            .collect();
        let distances: Vec<f64> = (0..w * h)
            .map(|i| match (i / 7 + i / w) % 5 {
                0 => 1.5,
                1 => 1.2 + 0.01 * (i % 7) as f64,
                2 => 4.0,
                3 => 20.0,
                _ => 0.0,
            })
            .collect();
        let flags = far_pixels(&reach, output.size(), &distances, &proxies, far);
        let held = |n: &Vector3<f64>, t: f64, rim: f64| {
            (proxies.iter()).any(|p| p.holds(&p.local_at(n, t), rim))
        };
        let mut kinds = [0usize; 3];
        for v in 0..h {
            for u in 0..w {
                let t = distances[v * w + u];
                let want = reach.bearing(u, v).filter(|_| t < far).is_some_and(|d| {
                    let n = d.normalize();
                    let (at_far, at_scene) = (held(&n, far, 0.0), held(&n, t, RIM));
                    kinds[at_far as usize + at_scene as usize] += 1;
                    at_far && !at_scene
                });
                assert_eq!(flags[v * w + u], want, "({u}, {v})");
            }
        }
        // (pixels held at neither distance, at one and at both)
        assert!(kinds.iter().all(|k| *k > 200), "{kinds:?}");
    }
}
