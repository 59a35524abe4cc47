//! The synthetic drive: where the vehicle is at each frame, what stands around it, and the
//! bridge between KITTI-360's world (z up) and the analytic scene of `tools/synth.rs` (a
//! camera-like frame, y down, ground at [`GROUND_Y`]).
//!
//! world = [`WORLD_FROM_SCENE`] · scene + [`WORLD_ORIGIN`]: scene x is world x (east), scene z
//! is world y (north), scene y (down) is world −z.

use crate::tools::synth::{Scene, SceneBox, GROUND_Y};
use nalgebra::{Matrix3, Matrix4, Rotation3, Vector3};
use std::f64::consts::FRAC_PI_2;

/// world_from_scene's rotation (scene x → world x, scene y → world −z, scene z → world y).
pub const WORLD_FROM_SCENE: [f64; 9] = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0];
/// The scene origin in the world, metres (a UTM-like offset, as KITTI-360's world has).
pub const WORLD_ORIGIN: [f64; 3] = [1043.25, 3816.5, 115.75];
/// Height of the vehicle's pose frame (its IMU) above the ground: puts image_00 1.55 m up.
const POSE_HEIGHT: f64 = 0.90;
/// The first frame number of a synthetic sequence.
pub const FIRST_FRAME: u32 = 250;

/// world_from_scene's rotation.
pub fn world_from_scene() -> Matrix3<f64> {
    Matrix3::from_row_slice(&WORLD_FROM_SCENE)
}

/// A scene point in the world.
pub fn scene_to_world(p: &Vector3<f64>) -> Vector3<f64> {
    world_from_scene() * p + Vector3::from(WORLD_ORIGIN)
}

/// A world point in the scene.
pub fn world_to_scene(p: &Vector3<f64>) -> Vector3<f64> {
    world_from_scene().transpose() * (p - Vector3::from(WORLD_ORIGIN))
}

/// world_from_pose of the vehicle at the `i`-th frame of the drive: it starts at the scene
/// origin heading north (scene +z) and turns right by 3° a frame at 1.2 m a frame, pitched
/// 0.6° and rolled −0.4° (so that the level frame differs from the vehicle's). The pose
/// frame's axes are KITTI-360's: x forward, y right, z down.
pub fn world_from_pose(i: u32) -> Matrix4<f64> {
    let heading = |j: u32| (90.0 - 3.0 * j as f64).to_radians();
    let mut p = scene_to_world(&Vector3::new(0.0, GROUND_Y, 0.0)) + Vector3::z() * POSE_HEIGHT;
    for j in 0..i {
        p += 1.2 * Vector3::new(heading(j).cos(), heading(j).sin(), 0.0);
    }
    let turn = Rotation3::from_axis_angle(&Vector3::z_axis(), heading(i))
        * Rotation3::from_axis_angle(&Vector3::y_axis(), 0.6f64.to_radians())
        * Rotation3::from_axis_angle(&Vector3::x_axis(), (-0.4f64).to_radians());
    // x forward, y right, z down: a half turn about x from the z-up vehicle axes
    let flip = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
    let mut m = Matrix4::identity();
    m.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(turn.into_inner() * flip));
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(&p);
    m
}

/// How an object moves.
#[derive(Debug, Clone, Copy)]
pub enum Motion {
    /// Standing at a scene (x, z), present from `start` to `end` (frame numbers).
    Static {
        /// Scene x, z of the bottom centre.
        at: [f64; 2],
        /// First and last frame of the object.
        frames: [u32; 2],
    },
    /// At `from` (scene x, z) on the first frame, moving by `step` each frame.
    Moving {
        /// Scene x, z on the first frame.
        from: [f64; 2],
        /// Scene x, z moved each frame.
        step: [f64; 2],
    },
}

/// An object of the synthetic drive.
#[derive(Debug, Clone)]
pub struct Object {
    /// KITTI-360 kittiId (`<semanticId>`).
    pub kitti_id: i64,
    /// `<instanceId>`.
    pub instance_id: i64,
    /// The `<label>` text (KITTI-360 writes `pedestrian` for its class person).
    pub label: &'static str,
    /// height, width, length, metres.
    pub dimensions: [f64; 3],
    /// Yaw about the scene's y axis (KITTI's rotation_y in the scene frame), radians.
    pub rotation_y: f64,
    /// Base colour.
    pub colour: [f64; 3],
    /// Where it is.
    pub motion: Motion,
    /// Lean from upright about the box's length axis (roll), radians, about its bottom centre.
    pub lean: f64,
}

impl Object {
    /// The scene box at frame `frame`, or None when the object is not there.
    pub fn at(&self, frame: u32) -> Option<SceneBox> {
        let [x, z] = match self.motion {
            Motion::Static { at, frames } => {
                if frame < frames[0] || frame > frames[1] {
                    return None;
                }
                at
            }
            Motion::Moving { from, step } => {
                let n = frame.checked_sub(FIRST_FRAME)? as f64;
                [from[0] + n * step[0], from[1] + n * step[1]]
            }
        };
        Some(SceneBox {
            kind: self.label,
            dimensions: self.dimensions,
            location: Vector3::new(x, GROUND_Y, z),
            rotation_y: self.rotation_y,
            colour: self.colour,
            tilt: (self.lean != 0.0)
                .then(|| Rotation3::from_axis_angle(&Vector3::x_axis(), self.lean).into_inner()),
        })
    }

    /// Whether the object is dynamic (one XML entry per frame).
    pub fn is_dynamic(&self) -> bool {
        matches!(self.motion, Motion::Moving { .. })
    }
}

/// world_from_box of a scene box as KITTI-360 writes it: the unit cube's axes X (length),
/// Y (width), Z (up), scaled by the box's size, rotated and placed at its centre.
pub fn world_transform(b: &SceneBox) -> Matrix4<f64> {
    let [h, w, l] = b.dimensions;
    let (s, c) = b.rotation_y.sin_cos();
    let yaw = Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c);
    // KITTI-360 box axes in the scene's box axes (x length, y down, z width): X→x, Y→z, Z→−y
    let axes = Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0);
    let tilt = b.tilt.unwrap_or_else(Matrix3::identity);
    let r = world_from_scene() * yaw * tilt * axes * Matrix3::from_diagonal(&Vector3::new(l, w, h));
    let centre = scene_to_world(&(b.location + yaw * tilt * Vector3::new(0.0, -h / 2.0, 0.0)));
    let mut m = Matrix4::identity();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(&centre);
    m
}

/// An object that stands in the scene for the whole drive: (kittiId, instanceId, label,
/// dimensions h w l, rotation_y, colour, scene x z of its bottom centre, lean in degrees).
type Standing = (
    i64,
    i64,
    &'static str,
    [f64; 3],
    f64,
    [f64; 3],
    [f64; 2],
    f64,
);

const CAR: [f64; 3] = [1.52, 1.65, 3.9];

/// The objects standing all around the rig: vehicles, a pedestrian, a bicycle leaning 12° on
/// its stand (a box that is not upright) and a building (a class KITTI has no type for).
#[rustfmt::skip]
const STANDING: [Standing; 8] = [
    (13, 1, "car", CAR, -FRAC_PI_2, [170.0, 60.0, 60.0], [2.0, 11.0], 0.0),
    (13, 2, "car", CAR, -FRAC_PI_2, [60.0, 70.0, 170.0], [-1.6, -11.0], 0.0),
    (13, 3, "car", CAR, -1.45, [200.0, 200.0, 80.0], [-4.2, 3.5], 0.0),
    (16, 1, "caravan", [2.4, 2.1, 5.5], -1.65, [150.0, 90.0, 40.0], [4.6, -1.5], 0.0),
    (19, 1, "pedestrian", [1.75, 0.6, 0.8], 0.4, [90.0, 140.0, 90.0], [3.4, 6.0], 0.0),
    (18, 1, "bicycle", [1.1, 0.6, 1.7], -1.5, [120.0, 50.0, 140.0], [-3.3, -4.5], 12.0),
    (14, 1, "truck", [3.2, 2.5, 8.0], -1.6, [70.0, 90.0, 160.0], [-7.0, 22.0], 0.0),
    (11, 1, "building", [6.0, 8.0, 12.0], 0.0, [130.0, 120.0, 110.0], [14.0, 8.0], 0.0),
];

/// The objects of the synthetic drive: those standing all around the rig, a parked car that
/// is annotated for the first two frames only, and one car driving towards the rig.
pub fn objects() -> Vec<Object> {
    let standing = STANDING.iter().map(
        |&(kitti_id, instance_id, label, dimensions, rotation_y, colour, at, lean)| Object {
            kitti_id,
            instance_id,
            label,
            dimensions,
            rotation_y,
            colour,
            motion: Motion::Static {
                at,
                frames: [0, 100_000],
            },
            lean: lean.to_radians(),
        },
    );
    let car = |instance_id, rotation_y, colour, motion| Object {
        kitti_id: 13,
        instance_id,
        label: "car",
        dimensions: CAR,
        rotation_y,
        colour,
        motion,
        lean: 0.0,
    };
    let parked = Motion::Static {
        at: [5.0, 16.0],
        frames: [FIRST_FRAME - 50, FIRST_FRAME + 1],
    };
    let driving = Motion::Moving {
        from: [-1.8, 18.0],
        step: [0.0, -1.5],
    };
    standing
        .chain([
            car(4, -1.5, [60.0, 150.0, 60.0], parked),
            car(5, FRAC_PI_2, [180.0, 180.0, 190.0], driving),
        ])
        .collect()
}

/// The scene at `frame`.
pub fn scene_at(frame: u32) -> Scene {
    Scene {
        boxes: objects().iter().filter_map(|o| o.at(frame)).collect(),
    }
}
