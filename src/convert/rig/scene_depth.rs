//! A frame's scene as a depth-guided stitch sees it ([`crate::warp::StitchDepth`]): the surfaces
//! a driving scene is made of, each from the frame's own data, in the reference frame.
//!
//! - the 3D boxes (every class, not only those written): exact ray–box intersections, so a
//!   labelled object's pixels are stitched at its faces' distance;
//! - the ground, fitted locally (`ground.rs`): a plane fitted to the scan's lowest dense layer,
//!   raised per knot of a polar grid around the centre to the scan's own ground returns there
//!   (a crest, a dip, a camber), the knots nearer than the scan's first ground returns (near
//!   the vehicle) continuing the grade of the first ones;
//! - the rest of the scan (points neither on the ground nor in a box, [`BOX_MARGIN`]), without
//!   its lone returns (`noise.rs`: one return is noise, not an occluder): each point splatted
//!   as a disc of [`SPLAT_DEG`] into a spherical depth buffer per viewpoint (the output centre
//!   and each camera), the nearest point per cell; the disc closes the gaps between a sweep's
//!   beams and azimuth steps; in the centre's buffer a surface's edge against the sky is
//!   carried out by the cameras' parallax ([`EDGE_DEG`] at most);
//! - beyond all of them (the sky), [`FAR`].
//!
//! The distance along a ray is the nearest of these; a camera sees a point when none of them
//! lies nearer on its own ray (within [`SURFACE_TOLERANCE`] for the exact surfaces; for the
//! splats [`SCAN_TOLERANCE`] plus a share of the distance that grows with the scan's ring
//! spacing, measured from the scan), and its sample of the point is clean when no
//! other box lies 5 % nearer on the rim of its footprint ([`RING_RAYS`] rays).
//!
//! Time: the scan is the reader's, motion-compensated to the frame's time (docs/kitti360.md,
//! "The Velodyne sweep"), and the boxes are at that time too; a camera that fired at another
//! time sees each moving box where it was then (`motion.rs`).

#[cfg(test)]
mod faults;
mod grid;
mod grid_scene;
mod motion;
mod noise;
mod occlusion;
mod solid;
mod splats;

use super::ground::{Ground, LocalGround, GROUND_FIT};
use crate::camera::CameraModel;
use crate::error::Result;
use crate::reproject::depth::DepthMap;
use crate::source::Frame;
use crate::warp::{
    grid_applies, EgoMask, GridScene, Stitch, StitchCamera, StitchDepth, StitchOptions,
};
use grid::BoxGrid;
use motion::Motion;
use nalgebra::Vector3;
use noise::Noise;
use serde::Serialize;
use solid::{Solid, Solids};
use splats::{angles, Splats};
use std::sync::OnceLock;

/// The distance of a ray that meets nothing (the sky), metres: 1 m of baseline is 0.1 mrad of
/// parallax there.
pub const FAR: f64 = 10_000.0;
/// Points within this of a box (metres, in every axis) belong to the box.
pub const BOX_MARGIN: f64 = 0.1;
/// Angular radius of a residual point's splat, degrees.
pub const SPLAT_DEG: f64 = 0.5;
/// The longest gap between splats that is closed ([`splats`]), degrees: wider than the ring
/// spacing of the scanners read (1.33° for nuScenes' HDL-32E, up to 1° for PandaSet's
/// Pandar64), narrower than the sky above a roof.
pub const GAP_DEG: f64 = 3.0;
/// Two splats across a gap agree (it lies on one surface) within this share of the farther's
/// range.
pub const GAP_AGREE: f64 = 0.1;
/// The widest angle by which a surface's edge against the sky is carried out for the cameras'
/// parallax ([`splats`]), degrees.
pub const EDGE_DEG: f64 = 5.0;
/// Cells per degree of the residual points' spherical depth buffers.
const CELLS_PER_DEG: f64 = 4.0;
/// An exact surface (box, ground) nearer than the point by more than this hides it, metres.
pub const SURFACE_TOLERANCE: f64 = 1e-3;
/// A residual splat nearer than the point by more than this (metres, plus 5 % of the
/// distance) hides it.
pub const SCAN_TOLERANCE: f64 = 0.1;
/// Rays on the rim of a camera sample's footprint that [`StitchDepth::hidden_near`] casts.
const RING_RAYS: usize = 8;

/// How a rig frame's cameras are stitched.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum StitchMode {
    /// Each output pixel at its own distance ([`SceneDepth`]) when the frame has a scan, else
    /// at the proxy distance.
    #[default]
    Depth,
    /// Every output pixel at the proxy distance.
    Fixed,
}

/// A frame's stitch of `cameras` (the chosen rig cameras, centres `eyes`) into `output` from
/// `centre`: depth-guided by the frame's scene when `mode` asks for it, the frame has a scan
/// and there are two cameras or more, else through the proxy sphere. Returns the stitch and
/// the mode it was built with.
pub fn frame_stitch(
    frame: &Frame,
    output: &dyn CameraModel,
    centre: &Vector3<f64>,
    (cameras, eyes): (&[StitchCamera], Vec<Vector3<f64>>),
    masks: &[Option<&EgoMask>],
    options: StitchOptions,
    mode: StitchMode,
) -> Result<(Stitch, StitchMode)> {
    let scene = FrameScene::default();
    frame_stitch_in(
        (frame, &scene),
        output,
        centre,
        (cameras, eyes),
        masks,
        options,
        mode,
    )
}

/// Whether a frame's stitch is at the proxy distance whatever `mode` asks: without a scan, or
/// of one camera, there is no scene to guide it.
pub(super) fn at_proxy(frame: &Frame, cameras: usize, mode: StitchMode) -> bool {
    mode == StitchMode::Fixed || frame.lidar.is_empty() || cameras < 2
}

/// A frame's scene as its depth-guided stitch reads it, built on first use: the grid's for a
/// rig of pinholes, else the per-ray one. The views of one frame (same centre, same eyes)
/// share it.
#[derive(Default)]
pub(super) struct FrameScene {
    rays: OnceLock<SceneDepth>,
    grid: OnceLock<GridScene>,
}

/// [`frame_stitch`] with the frame's scene built on first use into `scene`.
pub(super) fn frame_stitch_in(
    (frame, scene): (&Frame, &FrameScene),
    output: &dyn CameraModel,
    centre: &Vector3<f64>,
    (cameras, eyes): (&[StitchCamera], Vec<Vector3<f64>>),
    masks: &[Option<&EgoMask>],
    options: StitchOptions,
    mode: StitchMode,
) -> Result<(Stitch, StitchMode)> {
    if at_proxy(frame, cameras.len(), mode) {
        let stitch = Stitch::build_masked(output, centre, cameras, masks, options)?;
        return Ok((stitch, StitchMode::Fixed));
    }
    if grid_applies(cameras) {
        let scene = (scene.grid).get_or_init(|| grid_scene::grid_scene(frame, centre, &eyes));
        let stitch = Stitch::build_grid(output, centre, cameras, masks, options, scene)?;
        return Ok((stitch, StitchMode::Depth));
    }
    let scene = (scene.rays).get_or_init(|| SceneDepth::new(frame, *centre, eyes));
    let stitch = Stitch::build_guided(output, centre, cameras, masks, options, scene)?;
    Ok((stitch, StitchMode::Depth))
}

/// A depth-guided stitch's distances as a depth map (`--stitch-depth`): metres from C2 along
/// each pixel's ray, 0 where the output has no bearing and for the sky ([`FAR`]).
pub fn distance_map(stitch: &Stitch) -> Option<DepthMap> {
    let size = stitch.size();
    let values = stitch
        .distances()?
        .iter()
        .map(|&d| if d >= FAR { 0.0 } else { d })
        .collect();
    Some(DepthMap {
        width: size.width,
        height: size.height,
        values,
    })
}

/// A frame's scene for a depth-guided stitch from `centre`, its cameras at `eyes`.
#[derive(Debug, Clone)]
pub struct SceneDepth {
    centre: Vector3<f64>,
    eyes: Vec<Vector3<f64>>,
    solids: Vec<Solid>,
    /// The boxes seen from the centre, nearest first.
    from_centre: Solids,
    ground: Option<LocalGround>,
    /// The scan's noise: the occlusion test's margin.
    noise: Noise,
    /// The residual points' buffers seen from the centre, then from each eye (empty: none).
    splats: Vec<Splats>,
    /// The boxes' grids seen from the centre, then from each eye.
    grids: Vec<BoxGrid>,
    nearest: f64,
    /// The moving boxes and the cameras' times.
    motion: Motion,
    /// Per eye, the boxes where it saw them (empty: every box is still).
    moved: Vec<Vec<Solid>>,
}

impl SceneDepth {
    /// The scene of `frame` (its boxes and scan) seen from `centre`, for cameras at `eyes`.
    pub fn new(frame: &Frame, centre: Vector3<f64>, eyes: Vec<Vector3<f64>>) -> Self {
        let points: Vec<Vector3<f64>> = frame.lidar.iter().map(|p| p.position).collect();
        let solids: Vec<Solid> = frame.objects.iter().map(Solid::new).collect();
        let motion = Motion::new(frame, &eyes);
        // per point, whether it lies in a box (the ground fit and the residual both ask)
        let by_x = ByX::new(&solids);
        let in_box: Vec<bool> = points.iter().map(|p| by_x.in_a_box(p)).collect();
        let ground = LocalGround::fit(&points, &centre, |i| !in_box[i]);
        let noise = Noise::measure(&centre, &points);
        let residual: Vec<Vector3<f64>> = (points.into_iter().zip(in_box))
            .filter(|(p, in_box)| {
                !in_box
                    && ground
                        .as_ref()
                        .is_none_or(|g| g.height(p) > GROUND_FIT * 2.0)
            })
            .map(|(p, _)| p)
            .filter(|p| !motion.swept(&solids, p))
            .collect();
        let residual = noise.without_lone_returns(&centre, residual);
        let splats = residual_splats(&centre, &eyes, &residual);
        let (moved, grids) = motion::views(&motion, &solids, &centre, &eyes);
        let mut nearest = FAR;
        for s in &solids {
            nearest = nearest.min((s.centre - centre).norm() - s.radius);
        }
        if let Some(g) = &ground {
            nearest = nearest.min(g.nearest(&centre));
        }
        for p in &residual {
            nearest = nearest.min((p - centre).norm());
        }
        SceneDepth {
            from_centre: Solids::new(&solids, &centre),
            centre,
            eyes,
            solids,
            ground,
            noise,
            splats,
            grids,
            nearest: nearest.max(0.0),
            motion,
            moved,
        }
    }

    /// The fitted ground plane, if the scan held one (the plane the local ground is measured
    /// from).
    pub fn ground(&self) -> Option<Ground> {
        self.ground.as_ref().map(|g| g.plane)
    }

    /// The nearest exact surface (box or ground) along unit ray (o, d) or `nearer`, whichever
    /// is nearer (infinite for none): `view` the index of o's grid (0 the centre, 1 + i eye i).
    fn exact_hit(&self, view: usize, o: &Vector3<f64>, d: &Vector3<f64>, nearer: f64) -> f64 {
        self.exact_hit_listed(view, o, d, nearer).0
    }

    /// [`SceneDepth::exact_hit`], and whether o's grid lists a box at `d`.
    fn exact_hit_listed(
        &self,
        view: usize,
        o: &Vector3<f64>,
        d: &Vector3<f64>,
        nearer: f64,
    ) -> (f64, bool) {
        let ground = self.ground.as_ref().and_then(|g| g.hit(o, d));
        let mut t = ground.map_or(nearer, |g| g.min(nearer));
        let solids = self.solids_of(view);
        let mut listed = false;
        self.grids[view].any(d, solids.len(), |k| {
            listed = true;
            // (an entry point lies in the bounding sphere: not before along − radius)
            let s = &solids[k];
            if (s.centre - o).dot(d) - s.radius < t {
                if let Some(h) = s.hit(o, d) {
                    t = t.min(h);
                }
            }
            false
        });
        (t, listed)
    }
}

/// The boxes in order of their centres' x, for [`ByX::in_a_box`].
struct ByX<'a> {
    solids: Vec<&'a Solid>,
    /// The largest reach of a box's sphere from its centre ([`ByX::in_a_box`]).
    widest: f64,
}

impl<'a> ByX<'a> {
    fn new(solids: &'a [Solid]) -> Self {
        let mut by_x: Vec<&Solid> = solids.iter().collect();
        by_x.sort_by(|a, b| a.centre.x.total_cmp(&b.centre.x));
        let widest = (solids.iter())
            .map(|s| (s.radius + BOX_MARGIN) * (1.0 + 1e-12))
            .fold(0.0, f64::max);
        ByX {
            solids: by_x,
            widest,
        }
    }

    /// Whether `p` lies in one of the boxes ([`BOX_MARGIN`]): the boxes whose bounding sphere
    /// one of p's offsets alone leaves (with room for its rounding) are passed over untested,
    /// those whose centre's x lies beyond twice the widest reach from p's without a look.
    fn in_a_box(&self, p: &Vector3<f64>) -> bool {
        let first = (self.solids).partition_point(|s| s.centre.x < p.x - self.widest * 2.0);
        self.solids[first..]
            .iter()
            .take_while(|s| s.centre.x <= p.x + self.widest * 2.0)
            .any(|s| {
                let reach = (s.radius + BOX_MARGIN) * (1.0 + 1e-12);
                let v = p - s.centre;
                !(v.x.abs() > reach || v.y.abs() > reach || v.z.abs() > reach)
                    && s.contains(p, BOX_MARGIN)
            })
    }
}

/// The residual points' buffers seen from `centre` (its surfaces' edges against the sky
/// carried out by the farthest eye's parallax, [`Splats::extend_edges`]), then from each of
/// `eyes` (empty: no point).
fn residual_splats(
    centre: &Vector3<f64>,
    eyes: &[Vector3<f64>],
    residual: &[Vector3<f64>],
) -> Vec<Splats> {
    if residual.is_empty() {
        return Vec::new();
    }
    let baseline = eyes.iter().map(|e| (e - centre).norm()).fold(0.0, f64::max);
    std::iter::once(centre)
        .chain(eyes)
        .enumerate()
        .map(|(view, o)| {
            if view > 0 {
                // (an eye's buffer is looked up only where its camera sees)
                return Splats::lazy(*o, residual);
            }
            let mut s = Splats::new(*o, residual);
            s.extend_edges(baseline);
            s
        })
        .collect()
}

impl StitchDepth for SceneDepth {
    fn distance(&self, d: &Vector3<f64>) -> f64 {
        // the splats first: a box beyond them is not tested
        let splat = self.splats.first().map_or(f64::INFINITY, |s| {
            let (lon, lat) = angles(d);
            s.range(lon, lat)
        });
        self.exact_hit(0, &self.centre, d, splat).min(FAR)
    }

    fn distance_and_may_interpolate(&self, d: &Vector3<f64>, radius: f64) -> (f64, bool) {
        let splat = self.splats.first().map_or(f64::INFINITY, |s| {
            let (lon, lat) = angles(d);
            s.range(lon, lat)
        });
        // (as `may_interpolate`: the grid lists every box within its reach of d)
        let (t, listed) = self.exact_hit_listed(0, &self.centre, d, splat);
        (t.min(FAR), radius <= grid::REACH && !listed)
    }

    fn sees(&self, camera: usize, x: &Vector3<f64>) -> bool {
        self.eye_ray(camera, x)
            .is_some_and(|ray| self.sees_along(camera, &ray))
    }

    fn hidden_near(&self, camera: usize, x: &Vector3<f64>, radius: f64) -> bool {
        self.eye_ray(camera, x)
            .is_some_and(|ray| self.hidden_along(camera, x, &ray, radius))
    }

    fn sees_clean(&self, camera: usize, x: &Vector3<f64>, radius: f64) -> bool {
        self.eye_ray(camera, x)
            .is_some_and(|ray| self.clean_along(camera, x, &ray, radius))
    }
    fn nearest(&self) -> f64 {
        self.nearest
    }

    fn may_interpolate(&self, d: &Vector3<f64>, radius: f64) -> bool {
        // the grid lists every box within its reach of d
        radius <= grid::REACH && !self.grids[0].any(d, self.solids.len(), |_| true)
    }

    fn seen_at(&self, camera: usize, x: &Vector3<f64>) -> Vector3<f64> {
        self.moved_point(camera, x)
    }

    fn motion_bound(&self, camera: usize) -> f64 {
        self.motion_reach(camera)
    }

    fn nearest_within(&self, d: &Vector3<f64>, radius: f64) -> f64 {
        let mut t = self
            .ground
            .as_ref()
            .map_or(f64::INFINITY, |g| g.nearest_within(&self.centre, d, radius));
        if let Some(s) = self.splats.first() {
            t = t.min(s.nearest_within(d, radius));
        }
        // (the boxes last: one farther than the bound so far cannot lower it, untested)
        self.from_centre.lower_within(d, radius, t).min(FAR)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::{LidarPoint, SourceBox};
    use std::f64::consts::TAU;

    /// A frame of `points` (a scan in the reference frame) and `objects`, nothing else: the
    /// scene tests' input (`faults.rs` and `occlusion.rs` take it too).
    pub(super) fn frame(points: Vec<Vector3<f64>>, objects: Vec<SourceBox>) -> Frame {
        Frame {
            id: "0".into(),
            provenance: Vec::new(),
            rig: Vec::new(),
            objects,
            regions: Vec::new(),
            lidar: points
                .into_iter()
                .map(|position| LidarPoint {
                    position,
                    intensity: 0.0,
                })
                .collect(),
            world_from_reference: None,
            reference_from_lidar: None,
            lidar_from_imu: None,
            input_hashes: Vec::new(),
        }
    }

    /// A scan of the ground 1.6 m below the origin, slightly sloped, on a grid.
    fn ground_points() -> Vec<Vector3<f64>> {
        let mut p = Vec::new();
        for i in -30..=30 {
            for j in -30..=30 {
                let (x, z) = (i as f64, j as f64);
                p.push(Vector3::new(x, 1.6 + 0.01 * x - 0.02 * z, z));
            }
        }
        p
    }

    #[test]
    fn the_ground_boxes_and_residual_points_give_exact_distances_and_occlusion() {
        let car = SourceBox::from_kitti("Car", [1.5, 1.8, 4.0], Vector3::new(0.0, 1.6, 10.0), 0.3);
        // a wall of points 20 m to the left, 4 m high, not in any box
        let mut points = ground_points();
        for i in 0..200 {
            for j in 0..40 {
                points.push(Vector3::new(
                    -20.0,
                    1.5 - j as f64 * 0.1,
                    i as f64 * 0.1 - 10.0,
                ));
            }
        }
        let f = frame(points, vec![car.clone()]);
        let eyes = vec![Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.0, 0.0, 16.0)];
        let scene = SceneDepth::new(&f, Vector3::zeros(), eyes);
        let g = scene.ground().expect("a ground plane");
        // the plane y = 1.6 + 0.01x − 0.02z, to a millimetre (the wall's lowest returns lie
        // within the fit's band, up to 5 cm off the plane)
        for (x, z) in [(0.0, 0.0), (5.0, -7.0)] {
            let y = 1.6 + 0.01 * x - 0.02 * z;
            let h = g.height(&Vector3::new(x, y, z));
            assert!(h.abs() < 1e-3, "{h}");
        }
        assert!(g.height(&Vector3::zeros()) > 1.5);
        // straight down: the ground at 1.6 m
        let down = scene.distance(&Vector3::new(0.0, 1.0, 0.0));
        assert!((down - 1.6).abs() < 1e-3, "{down}");
        // straight ahead: the car's rear face (the ray meets its rotated box)
        let towards = Vector3::new(0.0, 0.085, 1.0).normalize();
        let ahead = scene.distance(&towards);
        let exact = Solid::new(&car).hit(&Vector3::zeros(), &towards).unwrap();
        assert!(ahead == exact && ahead > car.centre.z - 2.5 && ahead < car.centre.z - 0.9);
        // up: nothing but the sky
        assert_eq!(scene.distance(&Vector3::new(0.0, -1.0, 0.0)), FAR);
        // left, level: the wall's splats, within the splat's angular error
        let left = scene.distance(&Vector3::new(-1.0, 0.0, 0.0));
        assert!((left - 20.0).abs() < 0.1, "{left}");
        // the car's far side: the centre does not see it, the eye ahead of the car does
        let beside = car.centre + car.rotation * Vector3::new(0.0, 0.0, 0.9);
        assert!(!scene.sees(0, &beside) && scene.sees(1, &beside));
        // a point on the ground behind the car is hidden from the first eye
        assert!(!scene.sees(0, &Vector3::new(0.0, 1.6 - 0.02 * 20.0, 20.0)));
        // the wall hides what lies behind it, and not itself
        assert!(!scene.sees(0, &Vector3::new(-30.0, 0.0, 0.0)));
        assert!(scene.sees(0, &Vector3::new(-20.0, 0.0, 0.0)));
        assert!(scene.nearest() > 1.0 && scene.nearest() < 1.6);
    }

    #[test]
    fn the_nearest_distance_within_a_cone_bounds_every_bearing_in_it() {
        let car = SourceBox::from_kitti("Car", [1.5, 1.8, 4.0], Vector3::new(2.0, 1.6, 8.0), 0.3);
        let mut points = ground_points();
        // a post 6 m to the left (residual splats) and a wall behind
        for j in 0..30 {
            points.push(Vector3::new(-6.0, 1.5 - j as f64 * 0.1, 1.0));
            for i in 0..60 {
                points.push(Vector3::new(
                    i as f64 * 0.2 - 6.0,
                    1.5 - j as f64 * 0.1,
                    -15.0,
                ));
            }
        }
        let f = frame(points, vec![car]);
        let scene = SceneDepth::new(&f, Vector3::zeros(), vec![Vector3::zeros()]);
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut useful, mut tested) = (0, 0);
        for k in 0..3000 {
            let radius = [0.002, 0.02, 0.2][k % 3];
            let d = Vector3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            let bound = scene.nearest_within(&d, radius);
            // two axes across d (a random d is never along the helper)
            let a = d.cross(&Vector3::new(0.36, 0.48, 0.8)).normalize();
            let b = d.cross(&a);
            for _ in 0..20 {
                // a bearing within `radius` of d
                let (angle, turn) = (radius * next().sqrt(), next() * TAU);
                let e =
                    (d * angle.cos() + (a * turn.cos() + b * turn.sin()) * angle.sin()).normalize();
                let t = scene.distance(&e);
                assert!(t >= bound, "{t} < {bound} at {e} (cone {d}, {radius})");
                tested += 1;
            }
            useful += usize::from(bound > 2.0 * scene.nearest());
        }
        assert!(tested == 60_000 && useful > 1000, "{useful}");
    }

    #[test]
    fn a_nearer_box_within_a_samples_footprint_hides_it_and_the_points_own_box_does_not() {
        // a car across the view 10 m ahead (1.8 m deep: its faces at 9.1 and 10.9 m, its roof
        // at 0.1 m below the eye)
        let car = SourceBox::from_kitti("Car", [1.5, 1.8, 4.0], Vector3::new(0.0, 1.6, 10.0), 0.0);
        // the eye 0.5 m beside the output centre, and the eye at the centre (no parallax)
        let f = frame(ground_points(), vec![car]);
        let scene = SceneDepth::new(&f, Vector3::new(0.5, 0.0, 0.0), vec![Vector3::zeros()]);
        let centred = SceneDepth::new(&f, Vector3::zeros(), vec![Vector3::zeros()]);
        let top = 1.6 - 1.5;
        // the eye sees the roof: its outline is the far edge; a point 30 m away 1 mrad above it
        let edge = (top / 10.9f64).atan();
        let above = |mrad: f64| {
            let e = edge - mrad * 1e-3;
            Vector3::new(0.0, e.tan(), 1.0).normalize() * 30.0
        };
        assert!(scene.sees(0, &above(1.0)));
        // the footprint of 2 mrad reaches the roof, one of 0.5 mrad does not
        assert!(scene.hidden_near(0, &above(1.0), 2e-3));
        assert!(!scene.hidden_near(0, &above(1.0), 0.5e-3));
        // without parallax the blur mixes the roof in as the centre sees it
        assert!(!centred.hidden_near(0, &above(1.0), 2e-3));
        // a point of the car's own rear face beside its edge is not hidden by the car
        let on_car = Vector3::new(0.0, top + 0.01, 9.1);
        assert!(scene.sees(0, &on_car) && !scene.hidden_near(0, &on_car, 2e-3));
        // a camera that is not in the scene hides nothing
        assert!(!scene.hidden_near(3, &above(1.0), 2e-3));
    }

    #[test]
    fn without_a_scan_there_is_no_ground_and_the_sky_everywhere() {
        let scene = SceneDepth::new(&frame(Vec::new(), Vec::new()), Vector3::zeros(), vec![]);
        assert!(scene.ground().is_none());
        assert_eq!(scene.distance(&Vector3::new(0.0, 1.0, 0.0)), FAR);
        assert!(!scene.sees(0, &Vector3::z()));
    }
}
