//! A box's motion: its velocity as nuScenes' devkit gives it (`NuScenes.box_velocity`): the
//! difference of the object's centres in its previous and next annotations (or this one where
//! it has no previous or next) over their samples' time, unknown when it has neither or the
//! two lie more than [`MAX_TIME_DIFF`] apart (twice that for a centred difference); and the
//! time it holds at ([`sweep_time`]).

use super::json::Fields;
use super::listed::read_listed;
use super::tables::{raw, Annotation};
use super::token::Token;
use crate::error::{Error, Result};
use crate::source::{Pose, RigCamera};
use nalgebra::Vector3;
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// The devkit's `max_time_diff`, seconds.
pub const MAX_TIME_DIFF: f64 = 1.5;

/// Where a neighbouring annotation puts its object, and when.
#[derive(Debug, Clone)]
pub(super) struct Neighbour {
    translation: Vector3<f64>,
    sample: Token,
}

/// The annotations next to the selected ones, and every sample's time: what velocities need.
#[derive(Debug, Default)]
pub(super) struct Tracks {
    /// Microseconds, every sample of the version.
    pub(super) sample_times: HashMap<Token, u64>,
    neighbours: HashMap<Token, Neighbour>,
}

impl Tracks {
    /// Reads from `path` (`sample_annotation.json`) the previous and next annotations of
    /// `annotations`.
    pub(super) fn read<'a>(
        path: &Path,
        annotations: impl Iterator<Item = &'a Annotation>,
        sample_times: HashMap<Token, u64>,
    ) -> Result<Self> {
        let wanted: HashSet<Token> = annotations
            .flat_map(|a| a.prev.iter().chain(&a.next).cloned())
            .collect();
        let neighbours = if wanted.is_empty() {
            HashMap::new()
        } else {
            read_listed(path, &wanted, read_neighbour)?
        };
        Ok(Tracks {
            sample_times,
            neighbours,
        })
    }

    /// The global-frame velocity (m/s) of annotation `a` of sample `sample`, None where the
    /// devkit gives NaN. `path` names the annotation table in errors.
    pub(super) fn velocity(
        &self,
        path: &Path,
        a: &Annotation,
        sample: &Token,
    ) -> Result<Option<Vector3<f64>>> {
        if a.prev.is_none() && a.next.is_none() {
            return Ok(None);
        }
        let here = (
            a.global_from_box.translation,
            self.time(path, sample, &a.token)?,
        );
        let end = |link: &Option<Token>, field: &str| -> Result<(Vector3<f64>, f64)> {
            let Some(t) = link else { return Ok(here) };
            let n = self.neighbours.get(t).ok_or_else(|| {
                Error::file(
                    path,
                    format!("record {}: {field}: no sample_annotation {t}", a.token),
                )
            })?;
            Ok((n.translation, self.time(path, &n.sample, t)?))
        };
        let (first, last) = (end(&a.prev, "prev")?, end(&a.next, "next")?);
        let dt = last.1 - first.1;
        let centred = a.prev.is_some() && a.next.is_some();
        let max = if centred {
            MAX_TIME_DIFF * 2.0
        } else {
            MAX_TIME_DIFF
        };
        let v = (last.0 - first.0) / dt;
        Ok((dt <= max && v.iter().all(|x| x.is_finite())).then_some(v))
    }

    /// Seconds of sample `sample` as the devkit computes them (1e-6 · microseconds), for
    /// annotation `record`.
    fn time(&self, path: &Path, sample: &Token, record: &Token) -> Result<f64> {
        match self.sample_times.get(sample) {
            Some(t) => Ok(1e-6 * *t as f64),
            None => Err(Error::file(
                path,
                format!("record {record}: sample_token: no sample {sample}"),
            )),
        }
    }
}

/// A raw annotation's token, centre and sample.
fn read_neighbour(path: &Path, index: usize, r: &raw::Annotation) -> Result<(Token, Neighbour)> {
    let (f, token) = Fields::new(path, index, &r.token)?;
    let translation = Vector3::from(f.numbers::<3>("translation", &r.translation)?);
    let sample = f.token("sample_token", &r.sample_token)?;
    Ok((
        token,
        Neighbour {
            translation,
            sample,
        },
    ))
}

/// When the sweep measured an object centred at `centre` (reference frame), seconds after the
/// keyframe: nuScenes triggers each camera as the LiDAR sweeps across the middle of its view,
/// so the object was measured about when the camera whose optical axis lies nearest it in
/// azimuth (about the LiDAR's z axis) fired. None without a camera time.
pub(super) fn sweep_time(
    rig: &[RigCamera],
    reference_from_lidar: &Pose,
    centre: &Vector3<f64>,
) -> Option<f64> {
    let lidar_from_reference = reference_from_lidar.inverse()?;
    let azimuth = |v: Vector3<f64>| v.y.atan2(v.x);
    let at = azimuth(lidar_from_reference.apply(centre));
    let apart = |a: f64| {
        let d = (a - at).rem_euclid(std::f64::consts::TAU);
        d.min(std::f64::consts::TAU - d)
    };
    rig.iter()
        .filter_map(|c| {
            let axis = lidar_from_reference.apply_vector(&c.optical_axis());
            Some((apart(azimuth(axis)), c.time?))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, t)| t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{ImageSize, Intrinsics, Perspective};
    use nalgebra::{Matrix3, Rotation3};
    use std::sync::Arc;

    #[test]
    fn an_object_is_timed_by_the_camera_facing_it() {
        // the LiDAR's axes: x forward, y left, z up; cameras (x right, y down, z forward)
        // looking forward, left and back, firing at −30, −10 and −45 ms
        let model = Arc::new(Perspective::new(
            Intrinsics::new(100.0, 100.0, 50.0, 50.0),
            ImageSize::new(100, 100),
        ));
        let forward = Matrix3::from_columns(&[-Vector3::y(), -Vector3::z(), Vector3::x()]);
        let camera = |yaw: f64, time: f64| RigCamera {
            name: "c".into(),
            model: model.clone(),
            reference_from_camera: Pose::new(
                Rotation3::from_axis_angle(&Vector3::z_axis(), yaw).into_inner() * forward,
                Vector3::zeros(),
            ),
            image: "c.png".into(),
            time: Some(time),
        };
        let pi = std::f64::consts::PI;
        let rig = [
            camera(0.0, -0.03),
            camera(pi / 2.0, -0.01),
            camera(pi, -0.045),
        ];
        // the reference frame is the LiDAR's here
        let lidar = Pose::new(Matrix3::identity(), Vector3::zeros());
        let at = |x: f64, y: f64| sweep_time(&rig, &lidar, &Vector3::new(x, y, 0.0));
        assert_eq!(at(10.0, 1.0), Some(-0.03));
        assert_eq!(at(1.0, 10.0), Some(-0.01));
        assert_eq!(at(-10.0, -1.0), Some(-0.045));
        assert_eq!(at(-10.0, 9.0), Some(-0.045));
        let untimed: Vec<RigCamera> = rig
            .iter()
            .map(|c| RigCamera {
                time: None,
                ..c.clone()
            })
            .collect();
        assert_eq!(sweep_time(&untimed, &lidar, &Vector3::x()), None);
    }
}
