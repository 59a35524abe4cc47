//! Which objects of a frame its labels hold, and why the others are left out.
//!
//! An object of the frame is written when, in order: 0. its class is asked for (else `class`);
//! 1. its centre lies within `max_distance` of the output centre C2 (else `distance`);
//! 2. at least `min_points` LiDAR points of the frame lie inside its box, not counting the
//!    lowest [`GROUND_MARGIN`] of it, where the ground under the object is hit (else `unseen`;
//!    `min_points` 0 turns this off);
//! 3. its exact 2D box meets the output image (else `outside`);
//! 4. some chosen camera sees a pixel of that box (`coverage.rs`; else `uncovered`: with a
//!    subset of `--cameras`, the part of the image no camera gives holds no object);
//! 5. the visibility rule accepts the covered part of that box ([`Visibility`], the part not
//!    covered counted as outside the image; else `barely_visible`, and the box is written as
//!    a DontCare region). The written box is the object's whole exact 2D box.
//!
//! Each object's outcome (its class, instance, distance, LiDAR points, tilt, and the reason it
//! was dropped) is kept for the frame's `objects/` record.

use super::coverage::Coverage;
use crate::camera::CameraModel;
use crate::reproject::source_box::source_box_in_image;
use crate::reproject::visibility::Visibility;
use crate::source::{LidarPoint, SourceBox};
use nalgebra::Vector3;
use serde::Serialize;

/// The lowest part of a box (metres above its bottom face) whose LiDAR points are not counted:
/// the ground under the object.
pub const GROUND_MARGIN: f64 = 0.1;

/// A box leaning more than this from upright (radians) is counted as tilted.
pub const TILT_TOLERANCE: f64 = 1e-3;

/// The object rule's two parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ObjectRule {
    /// Objects whose centre is farther from the output centre are dropped, metres.
    pub max_distance: f64,
    /// LiDAR points an object's box must hold (0: no LiDAR check).
    pub min_points: usize,
    /// Which boxes in the image are objects (the others are written as DontCare regions).
    #[serde(skip_serializing_if = "Visibility::is_implied")]
    pub visibility: Visibility,
}

/// Why an object is not in the labels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DropReason {
    /// A class that was not asked for (the reader's class table).
    Class,
    /// Farther than `max_distance`.
    Distance,
    /// Fewer LiDAR points inside than `min_points`.
    Unseen,
    /// Its 2D box misses the output image.
    Outside,
    /// No chosen camera sees any pixel of its 2D box.
    Uncovered,
    /// Its 2D box fails the visibility rule: written as a DontCare region.
    BarelyVisible,
}

/// What became of one object of a frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ObjectOutcome {
    /// The class written (a KITTI type), or the dataset's class for a dropped class.
    pub class: String,
    /// The dataset's own class name.
    pub dataset_class: String,
    /// The dataset's instance id.
    pub instance: Option<u64>,
    /// Distance of the box centre from the output centre, metres (to the millimetre).
    pub distance: f64,
    /// LiDAR points inside the box (None when not counted).
    pub lidar_points: Option<usize>,
    /// Lean from upright, milliradians (to the microradian).
    pub tilt_mrad: f64,
    /// The exact box in the reference frame: its geometric centre (metres), ...
    pub centre: [f64; 3],
    /// ... its length, height and width (metres), ...
    pub size: [f64; 3],
    /// ... and its full rotation reference_from_box (row-major; box axes x length, y down,
    /// z width), which KITTI's one angle cannot hold for a tilted box.
    pub rotation: [f64; 9],
    /// Why it was left out; None for a written object.
    pub dropped: Option<DropReason>,
}

impl ObjectOutcome {
    /// The outcome of `b`, seen from `centre`, before any check.
    pub fn of(b: &SourceBox, centre: &Vector3<f64>) -> Self {
        Self {
            class: b.class.clone(),
            dataset_class: b.dataset_class.clone(),
            instance: b.instance,
            distance: ((b.centre - centre).norm() * 1000.0).round() / 1000.0,
            lidar_points: None,
            tilt_mrad: (b.tilt() * 1e6).round() / 1000.0,
            centre: [b.centre.x, b.centre.y, b.centre.z],
            size: [b.size.x, b.size.y, b.size.z],
            rotation: std::array::from_fn(|i| b.rotation[(i / 3, i % 3)]),
            dropped: None,
        }
    }

    /// Whether the box leans more than [`TILT_TOLERANCE`].
    pub fn is_tilted(&self) -> bool {
        self.tilt_mrad > TILT_TOLERANCE * 1000.0
    }
}

/// LiDAR points inside `b`, its lowest [`GROUND_MARGIN`] aside.
pub fn points_inside(b: &SourceBox, lidar: &[LidarPoint]) -> usize {
    let box_from_reference = b.rotation.transpose();
    let half = b.size / 2.0;
    lidar
        .iter()
        .filter(|p| {
            let l = box_from_reference * (p.position - b.centre);
            // local +y points down: the bottom face is at +h/2
            l.x.abs() <= half.x
                && l.z.abs() <= half.z
                && l.y >= -half.y
                && l.y <= half.y - GROUND_MARGIN
        })
        .count()
}

/// A written object placed in an output camera: which of the frame's objects, its exact 2D
/// box, truncation and occlusion. The dataset's writer formats it (`kitti::rig_output`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlacedObject {
    /// Its index in the frame's `objects`.
    pub index: usize,
    /// The exact 2D box in the output image: left, top, right, bottom, pixels.
    pub bounds: [f64; 4],
    /// The part of the box outside the image, 0 to 1.
    pub truncation: f64,
    /// The dataset's occlusion level (0 when it has none).
    pub occlusion: u8,
    /// It failed the visibility rule: written as a DontCare region, not as an object.
    pub dont_care: bool,
}

/// The written objects of `objects` placed in `camera` (centre `centre`, the reference
/// frame's axes) and every object's outcome, in the objects' order; classes that
/// `keep_class` refuses are dropped first, and what no camera of `coverage` sees.
pub(super) fn label_objects(
    objects: &[SourceBox],
    lidar: &[LidarPoint],
    (centre, camera): (&Vector3<f64>, &dyn CameraModel),
    coverage: &Coverage,
    rule: &ObjectRule,
    keep_class: &(dyn Fn(&SourceBox) -> Option<DropReason> + Sync),
) -> (Vec<PlacedObject>, Vec<ObjectOutcome>) {
    let mut placed = Vec::new();
    let mut outcomes = Vec::with_capacity(objects.len());
    for (index, b) in objects.iter().enumerate() {
        let mut outcome = ObjectOutcome::of(b, centre);
        if let Some(reason) = keep_class(b) {
            outcome.dropped = Some(reason);
        } else if !((b.centre - centre).norm() <= rule.max_distance) {
            outcome.dropped = Some(DropReason::Distance);
        } else {
            if rule.min_points > 0 {
                let n = points_inside(b, lidar);
                outcome.lidar_points = Some(n);
                if n < rule.min_points {
                    outcome.dropped = Some(DropReason::Unseen);
                }
            }
            if outcome.dropped.is_none() {
                let image = source_box_in_image(b, centre, camera);
                match image.map(|i| (i, coverage.covered(b, centre, camera, &i))) {
                    Some((_, None)) => outcome.dropped = Some(DropReason::Uncovered),
                    Some((image, Some(covered))) => {
                        let dont_care = !rule.visibility.sees(&covered);
                        if dont_care {
                            outcome.dropped = Some(DropReason::BarelyVisible);
                        }
                        placed.push(PlacedObject {
                            index,
                            bounds: image.bounds,
                            truncation: image.truncation,
                            occlusion: b.occlusion.unwrap_or(0),
                            dont_care,
                        })
                    }
                    None => outcome.dropped = Some(DropReason::Outside),
                }
            }
        }
        outcomes.push(outcome);
    }
    (placed, outcomes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{ImageSize, Intrinsics, Perspective};

    fn point(x: f64, y: f64, z: f64) -> LidarPoint {
        LidarPoint {
            position: Vector3::new(x, y, z),
            intensity: 0.0,
        }
    }

    const ORIGIN: Vector3<f64> = Vector3::new(0.0, 0.0, 0.0);

    fn at_origin(camera: &Perspective) -> (&Vector3<f64>, &dyn CameraModel) {
        (&ORIGIN, camera)
    }

    /// The output camera itself as the one chosen camera: every pixel covered.
    fn all(camera: &Perspective) -> Coverage<'_> {
        Coverage::single(camera)
    }

    /// The KITTI label lines of the placed objects.
    fn lines(objects: &[SourceBox], placed: &[PlacedObject]) -> Vec<String> {
        placed
            .iter()
            .map(|p| {
                if p.dont_care {
                    return crate::kitti::rig_output::dont_care_line(p.bounds);
                }
                let b = &objects[p.index];
                crate::kitti::rig_output::label_line(b, p.bounds, p.truncation, p.occlusion)
            })
            .collect()
    }

    #[test]
    fn the_rule_drops_far_unseen_and_outside_objects_and_says_why() {
        let camera = Perspective::new(
            Intrinsics::new(500.0, 500.0, 320.0, 120.0),
            ImageSize::new(640, 240),
        );
        let car = |x: f64, z: f64| {
            SourceBox::from_kitti("Car", [1.5, 1.6, 4.0], Vector3::new(x, 1.7, z), 0.0)
        };
        // seen (two points on its side, one on the ground under it that does not count)
        let seen = car(0.0, 10.0);
        let lidar = vec![
            point(0.0, 1.0, 9.3),
            point(0.3, 0.5, 9.3),
            point(0.0, 1.65, 10.0),
        ];
        assert_eq!(points_inside(&seen, &lidar), 2);
        let far = car(0.0, 95.0);
        let unseen = car(3.0, 20.0);
        let behind = car(0.0, -10.0);
        let rule = ObjectRule {
            max_distance: 80.0,
            min_points: 2,
            visibility: Visibility::OFF,
        };
        let objects = [seen, far, unseen, behind.clone()];
        let (placed, outcomes) = label_objects(
            &objects,
            &lidar,
            at_origin(&camera),
            &all(&camera),
            &rule,
            &|_| None,
        );
        assert_eq!(placed.len(), 1);
        assert_eq!((placed[0].index, placed[0].truncation), (0, 0.0));
        assert!(lines(&objects, &placed)[0].starts_with("Car 0.00 0 "));
        let reasons: Vec<_> = outcomes.iter().map(|o| o.dropped).collect();
        assert_eq!(
            reasons,
            [
                None,
                Some(DropReason::Distance),
                Some(DropReason::Unseen),
                Some(DropReason::Unseen)
            ]
        );
        // without the LiDAR check the box behind the camera is outside its image
        let (_, outcomes) = label_objects(
            &[behind],
            &[],
            at_origin(&camera),
            &all(&camera),
            &ObjectRule {
                min_points: 0,
                ..rule
            },
            &|b: &SourceBox| (b.class != "Car").then_some(DropReason::Class),
        );
        assert_eq!(outcomes[0].dropped, Some(DropReason::Outside));
        assert!(outcomes[0].lidar_points.is_none() && !outcomes[0].is_tilted());
    }

    #[test]
    fn a_tilted_box_is_written_with_its_heading_and_counted() {
        let camera = Perspective::new(
            Intrinsics::new(500.0, 500.0, 320.0, 120.0),
            ImageSize::new(640, 240),
        );
        let upright =
            SourceBox::from_kitti("Car", [1.5, 1.6, 4.0], Vector3::new(0.0, 1.7, 10.0), 0.3);
        let pitch = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), 0.05).into_inner();
        let tilted = SourceBox {
            rotation: upright.rotation * pitch,
            ..upright.clone()
        };
        let rule = ObjectRule {
            max_distance: 80.0,
            min_points: 0,
            visibility: Visibility::OFF,
        };
        let objects = [upright, tilted.clone()];
        let (placed, outcomes) = label_objects(
            &objects,
            &[],
            at_origin(&camera),
            &all(&camera),
            &rule,
            &|_| None,
        );
        let lines = lines(&objects, &placed);
        assert_eq!(lines.len(), 2);
        assert!(!outcomes[0].is_tilted() && outcomes[1].is_tilted());
        assert_eq!(outcomes[1].tilt_mrad, 50.0);
        // its heading is the upright box's, its exact rotation is in the outcome
        let ry: Vec<&str> = lines
            .iter()
            .map(|l| l.rsplit(' ').next().unwrap())
            .collect();
        assert_eq!(ry, ["0.30", "0.30"]);
        let r = outcomes[1].rotation;
        assert!((0..9).all(|i| r[i] == tilted.rotation[(i / 3, i % 3)]));
        let counts = super::super::job::ObjectCounts::of(&outcomes);
        assert_eq!((counts.written, counts.tilted), (2, 1));
    }
}
