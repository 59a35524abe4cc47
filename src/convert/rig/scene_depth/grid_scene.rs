//! A frame's scene for the grid-guided stitch ([`GridScene`]): the scan without its lone
//! returns (`noise.rs`: one return is noise, not a surface), without the returns in a box
//! (its faces are exact) or swept by a moving one, the boxes with each camera's move to its
//! time (`motion.rs`), and the ground fitted locally (`ground.rs`) where the scan has no
//! return; the returns within [`GROUND_BAND`] of it marked as the ground's.

use super::{ByX, LocalGround, Motion, Noise, Solid};
use crate::convert::rig::ground::GROUND_BAND;
use crate::source::Frame;
use crate::warp::{GridBox, GridScene, GroundHit};
use nalgebra::Vector3;

/// The scene of `frame` seen from `centre`, for cameras at `eyes`.
pub(super) fn grid_scene(frame: &Frame, centre: &Vector3<f64>, eyes: &[Vector3<f64>]) -> GridScene {
    let points: Vec<Vector3<f64>> = frame.lidar.iter().map(|p| p.position).collect();
    let solids: Vec<Solid> = frame.objects.iter().map(Solid::new).collect();
    let motion = Motion::new(frame, eyes);
    let by_x = ByX::new(&solids);
    let in_box: Vec<bool> = points.iter().map(|p| by_x.in_a_box(p)).collect();
    let ground = LocalGround::fit(&points, centre, |i| !in_box[i]);
    let noise = Noise::measure(centre, &points);
    // a box's returns are its faces' (ray-cast exactly): kept, a gap between a box's return
    // and the ground's beyond it would be closed as one surface
    let points: Vec<Vector3<f64>> = (points.into_iter().zip(in_box))
        .filter(|(p, in_box)| !in_box && !motion.swept(&solids, p))
        .map(|(p, _)| p)
        .collect();
    let points = noise.without_lone_returns(centre, points);
    let boxes = frame
        .objects
        .iter()
        .enumerate()
        .map(|(k, b)| GridBox {
            centre: b.centre,
            half: b.size / 2.0,
            rotation: b.rotation,
            moved: (0..eyes.len()).map(|i| motion.shift(i, k)).collect(),
        })
        .collect();
    let on_ground = match &ground {
        Some(g) => points
            .iter()
            .map(|p| g.height(p).abs() < GROUND_BAND)
            .collect(),
        None => vec![false; points.len()],
    };
    let origin = *centre;
    GridScene {
        points,
        ring_spacing: noise.spacing,
        on_ground,
        ground_normal: ground.as_ref().map(|g| g.plane.normal),
        boxes,
        ground: ground.map(|g| Box::new(move |d: &Vector3<f64>| g.hit(&origin, d)) as GroundHit),
    }
}
