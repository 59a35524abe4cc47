//! Fixed-distance stitches kept across a run's frames: a rig whose geometry repeats exactly
//! from frame to frame (a rigid rig whose poses in the level frame do not move: a source
//! without odometry, a parked vehicle, a dataset that gives the rig in its vehicle frame)
//! builds its tables and weights once and applies them to every frame.
//!
//! The key is the exact geometry the build reads, as the bit patterns of its floats
//! ([`ExactKey`]): every field of the output camera and of each source camera (each model feeds
//! its own, [`CameraModel::exact_key`]; a camera that cannot is never kept), the output centre,
//! each camera's rotation, translation and field of view, every stitch option, and which ego
//! mask each camera has (the run's masks, by address). Equal keys give the same build, so a
//! reused stitch writes the same bytes as a fresh one; no printed form is compared, so two
//! geometries that print alike (a rounded float, a field a `Debug` leaves out) stay apart.
//! Where the geometry moves, even by one bit (nuScenes, PandaSet and KITTI-360 place the rig in
//! a level frame that follows the vehicle's pitch and roll, and nuScenes' cameras each at their
//! own time), every frame misses and builds as without the cache.
//!
//! The depth-guided stitch is not kept: its tables and weights follow the frame's scan.
//! `PANOCONV_STITCH_CACHE=off` in the environment turns the cache off (the tests compare).

use crate::camera::{CameraModel, ExactKey};
use crate::error::Result;
use crate::warp::{EgoMask, Stitch, StitchCamera, StitchOptions};
use nalgebra::Vector3;
use std::sync::{Arc, Mutex};

/// Builds without a single reuse after which a run stops keeping stitches: its geometry
/// moves, and a kept stitch (hundreds of MB at 2048 px over six cameras) would only hold
/// memory between frames.
const GIVE_UP: usize = 3;

/// The environment variable that turns the cache off (`off`).
pub(super) const CACHE_ENV: &str = "PANOCONV_STITCH_CACHE";

/// A run's latest fixed stitch by its exact geometry.
#[derive(Debug, Default)]
pub(super) struct StitchCache {
    state: Mutex<Kept>,
}

#[derive(Debug, Default)]
struct Kept {
    /// The latest build and its key.
    latest: Option<(ExactKey, Arc<Stitch>)>,
    builds: usize,
    reuses: usize,
}

impl StitchCache {
    /// The run's cache, None where the environment turns it off.
    pub(super) fn from_env() -> Option<Arc<StitchCache>> {
        let off = std::env::var(CACHE_ENV).is_ok_and(|v| v == "off");
        (!off).then(|| Arc::new(StitchCache::default()))
    }

    /// [`Stitch::build_masked`] of these arguments, built once per geometry.
    pub(super) fn fixed(
        &self,
        output: &dyn CameraModel,
        centre: &Vector3<f64>,
        cameras: &[StitchCamera],
        masks: &[Option<&EgoMask>],
        options: StitchOptions,
    ) -> Result<Arc<Stitch>> {
        let Some(key) = geometry_key(output, centre, cameras, masks, options) else {
            // a camera that cannot say its geometry exactly: built for this frame alone
            return Ok(Arc::new(Stitch::build_masked(
                output, centre, cameras, masks, options,
            )?));
        };
        {
            let mut kept = self.lock();
            if let Some((_, found)) = kept.latest.as_ref().filter(|(k, _)| *k == key) {
                let found = found.clone();
                kept.reuses += 1;
                return Ok(found);
            }
            // another geometry: let its tables go before these are built, so that a moving
            // rig's run never holds two stitches at once
            kept.latest = None;
        }
        // built outside the lock: frames of other geometries build beside it
        let stitch = Arc::new(Stitch::build_masked(
            output, centre, cameras, masks, options,
        )?);
        let mut kept = self.lock();
        kept.builds += 1;
        kept.latest = (kept.reuses > 0 || kept.builds < GIVE_UP).then(|| (key, stitch.clone()));
        Ok(stitch)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Kept> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Everything a fixed stitch's build reads, exactly; None where a camera cannot say its own.
/// The options and cameras are taken apart field by field, so that a field added to either
/// does not compile until it is keyed here.
fn geometry_key(
    output: &dyn CameraModel,
    centre: &Vector3<f64>,
    cameras: &[StitchCamera],
    masks: &[Option<&EgoMask>],
    options: StitchOptions,
) -> Option<ExactKey> {
    let mut key = ExactKey::new();
    if !output.exact_key(&mut key) {
        return None;
    }
    key.floats(centre.as_slice());
    let StitchOptions {
        distance,
        blend_width,
        even_exposure,
    } = options;
    key.floats(&[distance, blend_width]);
    key.count(even_exposure as usize);
    key.count(cameras.len());
    for (i, camera) in cameras.iter().enumerate() {
        let StitchCamera {
            model,
            rotation,
            translation,
            max_theta,
        } = camera;
        if !model.exact_key(&mut key) {
            return None;
        }
        key.matrix(rotation);
        key.floats(translation.as_slice());
        key.floats(max_theta.as_slice());
        let mask = masks.get(i).copied().flatten();
        key.count(mask.map_or(0, |m| m as *const EgoMask as usize));
    }
    Some(key)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Equirect, ImageSize, Intrinsics, Perspective};
    use crate::image::RgbImage;

    fn scene() -> (Equirect, Perspective) {
        let output = Equirect::new(
            Intrinsics::new(30.0, 30.0, 94.0, 47.0),
            ImageSize::new(188, 94),
        );
        let pinhole = Perspective::new(
            Intrinsics::new(60.0, 60.0, 59.5, 39.5),
            ImageSize::new(120, 80),
        );
        (output, pinhole)
    }

    fn rig(model: &Perspective, nudge: f64) -> Vec<StitchCamera<'_>> {
        let turn = |deg: f64| *nalgebra::Rotation3::from_euler_angles(0.0, deg, 0.0).matrix();
        (0..3)
            .map(|k| StitchCamera {
                model,
                rotation: turn(k as f64 * 2.1),
                translation: Vector3::new(0.1 * k as f64 + nudge, 0.0, 0.05),
                max_theta: None,
            })
            .collect()
    }

    #[test]
    fn a_repeated_geometry_reuses_its_stitch_and_a_moved_one_does_not() {
        let (output, pinhole) = scene();
        let cache = StitchCache::default();
        let centre = Vector3::new(0.1, 0.0, 0.0);
        let options = StitchOptions::default();
        let build = |nudge: f64| {
            let cameras = rig(&pinhole, nudge);
            cache
                .fixed(&output, &centre, &cameras, &[], options)
                .unwrap()
        };
        let (a, b) = (build(0.0), build(0.0));
        assert!(Arc::ptr_eq(&a, &b), "the same geometry builds once");
        // one bit of one translation is another geometry
        let moved = build(f64::from_bits(1));
        assert!(!Arc::ptr_eq(&a, &moved));
        // what the kept stitch gives is what a fresh build gives
        let fresh = Stitch::build(&output, &centre, &rig(&pinhole, 0.0), options);
        let mut image = RgbImage::new(120, 80);
        for (i, px) in image.as_raw_mut().iter_mut().enumerate() {
            *px = (i * 7 % 251) as u8;
        }
        let images = [&image, &image, &image];
        let (kept, new) = (a.apply(&images), fresh.apply(&images));
        assert_eq!(kept.image.as_raw(), new.image.as_raw());
        assert_eq!(kept.source, new.source);
        assert!(kept.source.iter().any(|&s| s != 255), "a camera is seen");
    }

    #[test]
    fn a_moving_geometry_stops_being_kept() {
        let (output, pinhole) = scene();
        let cache = StitchCache::default();
        let options = StitchOptions::default();
        for k in 0..GIVE_UP {
            let cameras = rig(&pinhole, k as f64 * 0.01);
            cache
                .fixed(&output, &Vector3::zeros(), &cameras, &[], options)
                .unwrap();
            assert_eq!(cache.lock().latest.is_some(), k + 1 < GIVE_UP, "build {k}");
        }
    }

    /// A pinhole whose `Debug` prints its focal length to 0.01 px, as a printed key would
    /// have compared it; it says nothing of its exact geometry.
    struct Rounded(Perspective);

    impl std::fmt::Debug for Rounded {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "Rounded({:.2})", self.0.k.fu)
        }
    }

    impl CameraModel for Rounded {
        fn project(
            &self,
            d: &Vector3<f64>,
        ) -> std::result::Result<nalgebra::Point2<f64>, crate::camera::ProjectionReject> {
            self.0.project(d)
        }
        fn unproject(
            &self,
            p: &nalgebra::Point2<f64>,
        ) -> std::result::Result<Vector3<f64>, crate::camera::ProjectionReject> {
            self.0.unproject(p)
        }
        fn distance(&self, p: &Vector3<f64>) -> f64 {
            self.0.distance(p)
        }
        fn size(&self) -> ImageSize {
            self.0.size
        }
    }

    #[test]
    fn cameras_that_print_alike_do_not_share_a_stitch() {
        let (output, _) = scene();
        let pinhole = |fu: f64| {
            Rounded(Perspective::new(
                Intrinsics::new(fu, 60.0, 59.5, 39.5),
                ImageSize::new(120, 80),
            ))
        };
        let (a, b) = (pinhole(60.0), pinhole(60.001));
        assert_eq!(
            format!("{a:?}"),
            format!("{b:?}"),
            "their Debug texts agree"
        );
        let cache = StitchCache::default();
        let build = |model: &Rounded| {
            let camera = StitchCamera {
                model,
                rotation: nalgebra::Matrix3::identity(),
                translation: Vector3::zeros(),
                max_theta: None,
            };
            let options = StitchOptions::default();
            cache
                .fixed(&output, &Vector3::zeros(), &[camera], &[], options)
                .unwrap()
        };
        let (first, second) = (build(&a), build(&b));
        assert!(!Arc::ptr_eq(&first, &second), "60.001 px built its own");
        // and the stitch is 60.001's: a fresh build of it writes the same weights
        let fresh = Stitch::build(
            &output,
            &Vector3::zeros(),
            &[StitchCamera {
                model: &b.0,
                rotation: nalgebra::Matrix3::identity(),
                translation: Vector3::zeros(),
                max_theta: None,
            }],
            StitchOptions::default(),
        );
        let mut image = RgbImage::new(120, 80);
        for (i, px) in image.as_raw_mut().iter_mut().enumerate() {
            *px = (i * 13 % 251) as u8;
        }
        let (kept, new) = (second.apply(&[&image]), fresh.apply(&[&image]));
        assert_eq!(kept.image.as_raw(), new.image.as_raw());
    }

    #[test]
    fn one_ulp_of_a_rotation_a_translation_or_a_lens_is_another_key() {
        let (output, pinhole) = scene();
        let o = StitchOptions::default();
        let key = |cameras: &[StitchCamera]| {
            geometry_key(&output, &Vector3::zeros(), cameras, &[], o).expect("exact cameras")
        };
        let base = rig(&pinhole, 0.0);
        let ulp = |v: f64| f64::from_bits(v.to_bits() + 1);
        let mut turned = rig(&pinhole, 0.0);
        turned[1].rotation[(0, 2)] = ulp(turned[1].rotation[(0, 2)]);
        let mut moved = rig(&pinhole, 0.0);
        moved[2].translation.z = ulp(moved[2].translation.z);
        assert_eq!(key(&base), key(&rig(&pinhole, 0.0)));
        assert_ne!(key(&base), key(&turned));
        assert_ne!(key(&base), key(&moved));
        // a fisheye lens: one ULP of one parameter, and its field of view
        let lens = |xi: f64, fov: f64| {
            crate::camera::Lens::with_model(
                crate::camera::MeiModel {
                    xi,
                    distortion: crate::camera::MeiDistortion::NONE,
                    skew: 0.0,
                },
                Intrinsics::new(300.0, 300.0, 59.5, 39.5),
                ImageSize::new(120, 80),
                fov,
            )
            .unwrap()
        };
        let one = |l: &crate::camera::Unified| {
            key(&[StitchCamera {
                model: l,
                rotation: nalgebra::Matrix3::identity(),
                translation: Vector3::zeros(),
                max_theta: Some(1.2),
            }])
        };
        let (a, b, c) = (lens(0.9, 1.5), lens(ulp(0.9), 1.5), lens(0.9, ulp(1.5)));
        assert_eq!(one(&a), one(&lens(0.9, 1.5)));
        assert_ne!(one(&a), one(&b));
        assert_ne!(one(&a), one(&c));
    }

    #[test]
    fn the_key_tells_masks_options_and_models_apart() {
        let (output, pinhole) = scene();
        // the next float above 39.5
        let up = f64::from_bits(39.5f64.to_bits() + 1);
        let other = Perspective::new(
            Intrinsics::new(60.0, 60.0, 59.5, up),
            ImageSize::new(120, 80),
        );
        let centre = Vector3::zeros();
        let o = StitchOptions::default();
        let key = |model: &Perspective, masks: &[Option<&EgoMask>], o: StitchOptions| {
            geometry_key(&output, &centre, &rig(model, 0.0), masks, o).unwrap()
        };
        let base = key(&pinhole, &[], o);
        assert_eq!(base, key(&pinhole, &[None, None], o));
        let masked = (0..120 * 80).map(|i| i / 120 > 70).collect();
        let mask = EgoMask::new(ImageSize::new(120, 80), masked).unwrap();
        assert_ne!(base, key(&pinhole, &[Some(&mask)], o));
        let nearer = StitchOptions { distance: 9.0, ..o };
        assert_ne!(base, key(&pinhole, &[], nearer));
        // one bit of a model's parameter
        assert_ne!(base, key(&other, &[], o));
        let wider = Perspective::new(
            Intrinsics::new(60.0, 60.0, 59.5, 39.5),
            ImageSize::new(121, 80),
        );
        assert_ne!(base, key(&wider, &[], o));
    }
}
