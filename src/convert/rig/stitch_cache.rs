//! Fixed-distance stitches kept across a run's frames: a rig whose geometry repeats exactly
//! from frame to frame (a rigid rig whose poses in the level frame do not move: a source
//! without odometry, a parked vehicle, a dataset that gives the rig in its vehicle frame)
//! builds its tables and weights once and applies them to every frame.
//!
//! The key is the exact geometry the build reads: the output camera's and each source
//! camera's parameters (their `Debug` text, whose floats print round-trip exact), the bit
//! patterns of the output centre, of each camera's rotation, translation and field of view and
//! of the stitch options, and which ego mask each camera has (the run's masks, by address).
//! Equal keys give the same build, so a reused stitch writes the same bytes as a fresh one.
//! Where the geometry moves, even by one bit (nuScenes, PandaSet and KITTI-360 place the rig in
//! a level frame that follows the vehicle's pitch and roll, and nuScenes' cameras each at their
//! own time), every frame misses and builds as without the cache.
//!
//! The depth-guided stitch is not kept: its tables and weights follow the frame's scan.
//! `PANOCONV_STITCH_CACHE=off` in the environment turns the cache off (the tests compare).

use crate::camera::CameraModel;
use crate::error::Result;
use crate::warp::{EgoMask, Stitch, StitchCamera, StitchOptions};
use nalgebra::Vector3;
use std::fmt::Write;
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
    latest: Option<(String, Arc<Stitch>)>,
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
        let key = geometry_key(output, centre, cameras, masks, options);
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

/// Everything a fixed stitch's build reads, exactly.
fn geometry_key(
    output: &dyn CameraModel,
    centre: &Vector3<f64>,
    cameras: &[StitchCamera],
    masks: &[Option<&EgoMask>],
    options: StitchOptions,
) -> String {
    let mut key = String::new();
    let bits = |key: &mut String, values: &[f64]| {
        for v in values {
            let _ = write!(key, "{:x},", v.to_bits());
        }
    };
    let _ = write!(key, "{output:?};");
    bits(&mut key, centre.as_slice());
    let o = options;
    bits(&mut key, &[o.distance, o.blend_width]);
    let _ = write!(key, "{};", o.even_exposure);
    for (i, c) in cameras.iter().enumerate() {
        let _ = write!(key, "|{:?};", c.model);
        bits(&mut key, c.rotation.as_slice());
        bits(&mut key, c.translation.as_slice());
        bits(&mut key, &[c.max_theta.map_or(f64::NAN, |t| t)]);
        let _ = write!(key, "{};", c.max_theta.is_some());
        let mask = masks.get(i).copied().flatten();
        let _ = write!(key, "{:?}", mask.map(|m| m as *const EgoMask));
    }
    key
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
            geometry_key(&output, &centre, &rig(model, 0.0), masks, o)
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
