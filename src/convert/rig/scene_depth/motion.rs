//! Moving objects at each camera's time.
//!
//! A frame's cameras fire at their own times ([`crate::source::RigCamera::time`]) and each box
//! holds at its own ([`crate::source::SourceBox::time`]: a rotating LiDAR measures an object as
//! its sweep passes it; by default the frame's time). A box with a velocity v
//! ([`crate::source::SourceBox::velocity`]) held at t_b lies, at camera i's time tᵢ, moved by
//! v·(tᵢ − t_b):
//! - camera i's occlusion tests meet the boxes where they were at tᵢ;
//! - a point of the scene on or in a moving box (where the output centre sees it, the box as
//!   given) is sampled by camera i at x + v·(tᵢ − t_b) ([`Motion::holds`]);
//! - the scan's returns on a moving box were measured at their own times within the sweep, so
//!   a return belongs to the box (it leaves the residual points, the box's exact faces stand
//!   for it) when it lies within [`BOX_MARGIN`] of the box anywhere on its path within
//!   [`SWEEP`] of the box's time ([`Motion::swept`]).
//!
//! A box without a velocity and a camera at the box's time are still: a frame whose cameras
//! fire with the scan (KITTI-360) or whose boxes are still is stitched as before, to the bit.

use super::grid::BoxGrid;
use super::{SceneDepth, Solid, BOX_MARGIN};
use crate::source::Frame;
use nalgebra::Vector3;

/// How far from a box's time a return of the sweep on it may have been measured, seconds: a
/// 10 Hz scanner's whole turn (a 20 Hz one's is half).
pub const SWEEP: f64 = 0.1;

/// The boxes' velocities and the cameras' times of a frame's scene.
#[derive(Debug, Clone, Default)]
pub(super) struct Motion {
    /// Per camera of the stitch: its time after the frame's, seconds.
    times: Vec<f64>,
    /// Per box: its velocity in the reference frame, m/s (zero: still or unknown).
    velocities: Vec<Vector3<f64>>,
    /// Per box: when it holds, seconds after the frame's time.
    box_times: Vec<f64>,
    /// The boxes whose velocity is not zero.
    moving: Vec<usize>,
}

impl Motion {
    /// The motion of `frame`'s boxes for the cameras at `eyes`. Camera i's time is that of
    /// the frame's rig camera whose centre is eyes[i]; where several share that centre with
    /// different times, or none has one, camera i is taken at the frame's time.
    pub(super) fn new(frame: &Frame, eyes: &[Vector3<f64>]) -> Self {
        let times = eyes
            .iter()
            .map(|eye| {
                let mut at = frame.rig.iter().filter(|c| c.centre() == *eye);
                let first = at.next().and_then(|c| c.time).unwrap_or(0.0);
                let agree = at.all(|c| c.time.unwrap_or(0.0) == first);
                if agree && first.is_finite() {
                    first
                } else {
                    0.0
                }
            })
            .collect();
        let velocities: Vec<Vector3<f64>> = frame
            .objects
            .iter()
            .map(|b| {
                b.velocity
                    .filter(|v| v.iter().all(|x| x.is_finite()))
                    .unwrap_or_else(Vector3::zeros)
            })
            .collect();
        let box_times = frame
            .objects
            .iter()
            .map(|b| b.time.filter(|t| t.is_finite()).unwrap_or(0.0))
            .collect();
        let moving = (0..velocities.len())
            .filter(|&k| velocities[k] != Vector3::zeros())
            .collect();
        Motion {
            times,
            velocities,
            box_times,
            moving,
        }
    }

    /// Whether no box moves between its time and any camera's.
    pub(super) fn is_still(&self) -> bool {
        let at = |k: usize| self.box_times[k];
        self.moving
            .iter()
            .all(|&k| self.times.iter().all(|t| *t == at(k)))
    }

    /// Box `k`'s displacement from its time to camera `camera`'s, metres.
    pub(super) fn shift(&self, camera: usize, k: usize) -> Vector3<f64> {
        let t = self.times.get(camera).copied().unwrap_or(0.0);
        match (self.velocities.get(k), self.box_times.get(k)) {
            (Some(v), Some(at)) if t != *at => v * (t - at),
            _ => Vector3::zeros(),
        }
    }

    /// `solids` (the frame's boxes at its time) where camera `camera` saw them.
    pub(super) fn solids_at(&self, camera: usize, solids: &[Solid]) -> Vec<Solid> {
        let mut out = solids.to_vec();
        for &k in &self.moving {
            out[k].centre += self.shift(camera, k);
        }
        out
    }

    /// The largest displacement of any box at camera `camera`'s time, metres.
    pub(super) fn bound(&self, camera: usize) -> f64 {
        self.moving
            .iter()
            .map(|&k| self.shift(camera, k).norm())
            .fold(0.0, f64::max)
    }

    /// Whether box `k` moves and holds scene point `x` (the boxes as given; within
    /// [`super::SURFACE_TOLERANCE`], its faces included): camera i saw `x` at
    /// x + [`Motion::shift`] of the first such box.
    pub(super) fn holds(&self, solids: &[Solid], k: usize, x: &Vector3<f64>) -> bool {
        let moves = self
            .velocities
            .get(k)
            .is_some_and(|v| *v != Vector3::zeros());
        moves
            && solids
                .get(k)
                .is_some_and(|s| s.contains(x, super::SURFACE_TOLERANCE))
    }

    /// Whether return `p` lies within [`BOX_MARGIN`] of a moving box anywhere on its path
    /// within [`SWEEP`] of the box's time: the segment p − v·s, s in ±[`SWEEP`], meets the
    /// box grown by the margin.
    pub(super) fn swept(&self, solids: &[Solid], p: &Vector3<f64>) -> bool {
        self.moving.iter().any(|&k| {
            let s = &solids[k];
            let reach = self.velocities[k].norm() * SWEEP;
            if (p - s.centre).norm() > s.radius + BOX_MARGIN + reach {
                return false;
            }
            // in the box's axes: the point at path time s is a − w·s
            let a = s.box_from_reference * (p - s.centre);
            let w = s.box_from_reference * self.velocities[k];
            let (mut lo, mut hi) = (-SWEEP, SWEEP);
            for i in 0..3 {
                let half = s.half[i] + BOX_MARGIN;
                if w[i] == 0.0 {
                    if a[i].abs() > half {
                        return false;
                    }
                    continue;
                }
                // |a − w·s| ≤ half  ⇔  s in [(a − half)/w, (a + half)/w] (ordered)
                let (s0, s1) = ((a[i] - half) / w[i], (a[i] + half) / w[i]);
                lo = lo.max(s0.min(s1));
                hi = hi.min(s0.max(s1));
            }
            lo <= hi
        })
    }
}

/// Per eye, the boxes where it saw them (empty: every box is still), and the boxes' grids
/// seen from `centre`, then from each eye, each with the boxes where that view saw them.
pub(super) fn views(
    motion: &Motion,
    solids: &[Solid],
    centre: &Vector3<f64>,
    eyes: &[Vector3<f64>],
) -> (Vec<Vec<Solid>>, Vec<BoxGrid>) {
    let moved: Vec<Vec<Solid>> = match motion.is_still() {
        true => Vec::new(),
        false => (0..eyes.len())
            .map(|i| motion.solids_at(i, solids))
            .collect(),
    };
    let grids = std::iter::once(centre)
        .chain(eyes)
        .enumerate()
        .map(|(view, o)| {
            let at = view.checked_sub(1).and_then(|i| moved.get(i));
            let spheres: Vec<_> = at
                .map_or(solids, Vec::as_slice)
                .iter()
                .map(|s| (s.centre, s.radius))
                .collect();
            BoxGrid::new(o, &spheres)
        })
        .collect();
    (moved, grids)
}

impl SceneDepth {
    /// The boxes as `view` (0 the centre, 1 + i eye i) saw them.
    pub(super) fn solids_of(&self, view: usize) -> &[Solid] {
        match view.checked_sub(1).and_then(|i| self.moved.get(i)) {
            Some(moved) => moved,
            None => &self.solids,
        }
    }

    /// [`crate::warp::StitchDepth::seen_at`]: `x` moved with the first moving box that holds
    /// it, found among those the centre's ray through `x` may meet.
    pub(super) fn moved_point(&self, camera: usize, x: &Vector3<f64>) -> Vector3<f64> {
        if self.moved.is_empty() {
            return *x;
        }
        let mut holder = None;
        self.grids[0].any(&(x - self.centre), self.solids.len(), |k| {
            let holds = self.motion.holds(&self.solids, k, x);
            holder = holder.or(holds.then_some(k));
            holds
        });
        holder.map_or(*x, |k| x + self.motion.shift(camera, k))
    }

    /// [`crate::warp::StitchDepth::motion_bound`].
    pub(super) fn motion_reach(&self, camera: usize) -> f64 {
        match self.moved.is_empty() {
            true => 0.0,
            false => self.motion.bound(camera),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{frame_stitch, StitchMode};
    use super::*;
    use crate::camera::{CameraModel, ImageSize, Intrinsics, Perspective};
    use crate::image::RgbImage;
    use crate::source::{LidarPoint, Pose, RigCamera, SourceBox};
    use crate::warp::{StitchCamera, StitchOptions};
    use nalgebra::{Matrix3, Point2};
    use std::sync::Arc;

    fn frame(cameras: &[(Vector3<f64>, Option<f64>)], boxes: Vec<SourceBox>) -> Frame {
        let model = Arc::new(Perspective::new(
            Intrinsics::new(100.0, 100.0, 50.0, 50.0),
            ImageSize::new(100, 100),
        ));
        Frame {
            id: "0".into(),
            provenance: Vec::new(),
            rig: cameras
                .iter()
                .map(|(c, time)| RigCamera {
                    name: "c".into(),
                    model: model.clone(),
                    reference_from_camera: Pose::new(Matrix3::identity(), *c),
                    image: "c.png".into(),
                    time: *time,
                })
                .collect(),
            objects: boxes,
            regions: Vec::new(),
            lidar: Vec::new(),
            world_from_reference: None,
            reference_from_lidar: None,
            lidar_from_imu: None,
            input_hashes: Vec::new(),
        }
    }

    /// Where camera `camera` saw `x`: moved with the first moving box that holds it.
    fn seen_at(m: &Motion, solids: &[Solid], camera: usize, x: &Vector3<f64>) -> Vector3<f64> {
        match (0..solids.len()).find(|&k| m.holds(solids, k, x)) {
            Some(k) => x + m.shift(camera, k),
            None => *x,
        }
    }

    fn car(velocity: Option<Vector3<f64>>) -> SourceBox {
        SourceBox {
            velocity,
            ..SourceBox::from_kitti("Car", [1.5, 1.8, 4.0], Vector3::new(0.0, 1.6, 10.0), 0.0)
        }
    }

    #[test]
    fn a_moving_box_is_shifted_by_its_velocity_times_each_cameras_time() {
        let eyes = [Vector3::new(-0.5, 0.0, 0.0), Vector3::new(0.5, 0.0, 0.0)];
        let f = frame(
            &[(eyes[0], Some(-0.04)), (eyes[1], Some(0.01))],
            vec![car(Some(Vector3::new(10.0, 0.0, 0.0))), car(None)],
        );
        let m = Motion::new(&f, &eyes);
        assert!(!m.is_still());
        assert_eq!(m.shift(0, 0), Vector3::new(-0.4, 0.0, 0.0));
        assert_eq!(m.shift(1, 0), Vector3::new(0.1, 0.0, 0.0));
        assert_eq!(m.shift(0, 1), Vector3::zeros());
        assert_eq!(m.bound(0), 0.4);
        let solids: Vec<Solid> = f.objects.iter().map(Solid::new).collect();
        // the moving car's rear face moves with it; the still car's does not
        let rear = Vector3::new(0.3, 1.0, 10.0 - 0.9);
        assert_eq!(
            seen_at(&m, &solids, 0, &rear),
            rear + Vector3::new(-0.4, 0.0, 0.0)
        );
        // a box held at camera 0's time is where camera 0 saw it, and 0.5 m on for camera 1
        let mut held = car(Some(Vector3::new(10.0, 0.0, 0.0)));
        held.time = Some(-0.04);
        let h = Motion::new(
            &frame(&[(eyes[0], Some(-0.04)), (eyes[1], Some(0.01))], vec![held]),
            &eyes,
        );
        assert_eq!(h.shift(0, 0), Vector3::zeros());
        assert!((h.shift(1, 0) - Vector3::new(0.5, 0.0, 0.0)).norm() < 1e-12);
        let still = Motion::new(&frame(&[(eyes[0], Some(-0.04))], vec![car(None)]), &eyes);
        assert!(still.is_still());
        assert_eq!(seen_at(&still, &solids, 0, &rear), rear);
        // a point beside the box (not on it) stays
        let beside = Vector3::new(3.0, 1.0, 10.0);
        assert_eq!(seen_at(&m, &solids, 0, &beside), beside);
    }

    #[test]
    fn a_return_on_the_boxs_path_within_the_sweep_belongs_to_it() {
        // the car (length 4 m along x) moves at 10 m/s along x: its path within ±0.1 s spans
        // x in [−3 − 0.1, 3 + 0.1] with the margin
        let f = frame(&[], vec![car(Some(Vector3::new(10.0, 0.0, 0.0)))]);
        let m = Motion::new(&f, &[]);
        let solids: Vec<Solid> = f.objects.iter().map(Solid::new).collect();
        let at = |x: f64| Vector3::new(x, 1.6, 10.0);
        assert!(m.swept(&solids, &at(3.05)) && m.swept(&solids, &at(-3.05)));
        assert!(!m.swept(&solids, &at(3.15)) && !m.swept(&solids, &at(-3.15)));
        // across the path only the margin
        assert!(m.swept(&solids, &Vector3::new(0.0, 1.6, 10.95)));
        assert!(!m.swept(&solids, &Vector3::new(0.0, 1.6, 11.05)));
        // a still box has no path
        let still = Motion::new(&frame(&[], vec![car(None)]), &[]);
        assert!(!still.swept(&solids, &at(2.5)));
    }

    /// The code of a point of the car: red 60 levels per metre along its length (0 at its
    /// back end), green along its height, blue 200; the ground and the sky a flat grey.
    fn code(solid: &Solid, x: &Vector3<f64>) -> [u8; 3] {
        let l = solid.box_from_reference * (x - solid.centre);
        let r = ((l.x + solid.half.x) * 60.0).round().clamp(0.0, 255.0) as u8;
        let g = ((l.y + solid.half.y) * 60.0).round().clamp(0.0, 255.0) as u8;
        [r, g, 200]
    }

    /// Camera `camera`'s image (identity rotation, centre `eye`) of the car moved by `shift`:
    /// each pixel centre's ray against the box, exactly.
    fn render(
        model: &Perspective,
        eye: &Vector3<f64>,
        car: &Solid,
        shift: Vector3<f64>,
    ) -> RgbImage {
        let moved = Solid {
            centre: car.centre + shift,
            ..car.clone()
        };
        let size = model.size();
        let mut img = RgbImage::new(size.width, size.height);
        for v in 0..size.height {
            for u in 0..size.width {
                let d = model
                    .unproject(&Point2::new(u as f64, v as f64))
                    .unwrap()
                    .normalize();
                let px = match moved.hit(eye, &d) {
                    Some(t) => code(&moved, &(eye + d * t)),
                    None => [90, 90, 90],
                };
                img.put_pixel(u, v, px);
            }
        }
        img
    }

    /// A car crossing at 15 m/s 12 m ahead, seen by two cameras 1 m apart that fire 80 ms
    /// apart (−40 and +40 ms from the scan): each camera's image shows it 0.6 m from where the
    /// boxes put it. Over the car's pixels (2 px in from its outline) each camera's remapped
    /// sample must show the car point the output centre sees: within 5 cm (3 levels of the
    /// code; rounding the blend of two equal weights loses under 1). Without the motion each
    /// camera samples the car 0.6 m off.
    #[test]
    fn a_moving_car_is_sampled_by_each_camera_where_it_was_at_the_cameras_time() {
        let velocity = Vector3::new(15.0, 0.0, 0.0);
        let times = [-0.04, 0.04];
        let eyes = [Vector3::new(-0.5, 0.0, 0.0), Vector3::new(0.5, 0.0, 0.0)];
        let mut f = frame(
            &[(eyes[0], Some(times[0])), (eyes[1], Some(times[1]))],
            vec![SourceBox {
                velocity: Some(velocity),
                ..SourceBox::from_kitti("Car", [1.5, 1.8, 4.0], Vector3::new(0.0, 1.6, 12.0), 0.0)
            }],
        );
        // a scan of the ground (1.6 m below) so that the stitch is depth-guided
        for i in -30..=30 {
            for j in 0..=40 {
                f.lidar.push(LidarPoint {
                    position: Vector3::new(i as f64, 1.6, j as f64),
                    intensity: 0.0,
                });
            }
        }
        let car = Solid::new(&f.objects[0]);
        let model = Perspective::new(
            Intrinsics::new(150.0, 150.0, 99.5, 74.5),
            ImageSize::new(200, 150),
        );
        let images: Vec<RgbImage> = (0..2)
            .map(|i| render(&model, &eyes[i], &car, velocity * times[i]))
            .collect();
        let output = Perspective::new(
            Intrinsics::new(300.0, 300.0, 79.5, 59.5),
            ImageSize::new(160, 120),
        );
        let cameras: Vec<StitchCamera> = eyes
            .iter()
            .map(|e| StitchCamera {
                model: &model,
                rotation: Matrix3::identity(),
                translation: -e,
                max_theta: None,
            })
            .collect();
        let options = StitchOptions {
            even_exposure: false,
            ..StitchOptions::default()
        };
        let (stitch, mode) = frame_stitch(
            &f,
            &output,
            &Vector3::zeros(),
            (&cameras, eyes.to_vec()),
            &[None, None],
            options,
            StitchMode::Depth,
        )
        .unwrap();
        assert_eq!(mode, StitchMode::Depth);
        let black = RgbImage::new(200, 150);
        let alone = |i: usize| {
            let mut list = [&black, &black];
            list[i] = &images[i];
            stitch.apply(&list).image
        };
        let each = [alone(0), alone(1)];
        // the car's pixels 2 px in from its outline as the output centre sees it
        let hit = |u: i64, v: i64| {
            let d = output
                .unproject(&Point2::new(u as f64, v as f64))
                .unwrap()
                .normalize();
            car.hit(&Vector3::zeros(), &d).map(|t| d * t)
        };
        let (mut worst, mut count) = (0.0f64, 0);
        for v in 0..120i64 {
            for u in 0..160i64 {
                let Some(x) = hit(u, v) else { continue };
                if !(-2..=2).all(|dv| (-2..=2).all(|du| hit(u + du, v + dv).is_some())) {
                    continue;
                }
                let want = code(&car, &x);
                let (pu, pv) = (u as u32, v as u32);
                let w = [stitch.weight(0, pu, pv), stitch.weight(1, pu, pv)];
                let total = (w[0] + w[1]) as f64;
                for i in 0..2 {
                    // a camera that gives the pixel nothing is as far off as the car moved
                    let off = match w[i] > 0.0 {
                        true => {
                            let got = each[i].pixel(pu, pv)[0] as f64 * total / w[i] as f64;
                            (got - want[0] as f64).abs() / 60.0
                        }
                        false => (velocity * times[i]).norm(),
                    };
                    worst = worst.max(off);
                }
                count += 1;
            }
        }
        assert!(count > 1000, "{count} car pixels");
        assert!(
            worst < 0.05,
            "misregistration on the car {worst} m over {count} pixels"
        );
    }
}
