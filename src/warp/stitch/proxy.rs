//! The proxy: an output bearing's point at the proxy distance, seen by one source camera
//! (steps 1 and 2 of the stitch's model), as a camera model a remap table is built through.

use super::fixed_proxy::FixedPinhole;
pub(super) use super::guided_lanes::Centres;
use super::guided_lanes::{Alone, GuidedLanes, GuidedPinhole, PinholeLanes};
use super::guided_lens::LensLanes;
use super::{StitchCamera, StitchDepth};
use crate::camera::{CameraModel, ImageSize, Intrinsics, MeiModel, ProjectionReject, Separable};
use crate::warp::table::{column_inside, row_inside, Surfaces};
use cells::{between, Cells};
use nalgebra::{Point2, Vector3};
use std::ops::Range;

/// The mapping from output bearings to one camera's pixels through the proxy point, as a
/// camera model for [`RemapTable`] (which asks the source model for `project` only).
#[derive(Debug, Clone, Copy)]
pub(super) struct Proxy<'a> {
    pub(super) camera: StitchCamera<'a>,
    /// The camera's index in the stitch (a depth's cameras are asked by it).
    index: usize,
    /// Whether the depth moves points for this camera ([`StitchDepth::seen_at`]).
    moves: bool,
    centre: Vector3<f64>,
    distance: f64,
    /// The scene's distance per output bearing, in place of the proxy distance (a
    /// depth-guided stitch).
    depth: Option<&'a dyn StitchDepth>,
    /// cos of the field of view's half-angle less and plus [`FOV_SLACK`]: a point whose
    /// cosine from the axis lies outside that interval is decided without `atan2` (None:
    /// no lens bound, or one too near 0 or π for the shortcut).
    fov_cos: Option<(f64, f64)>,
    /// The scene's distances at the output's pixel centres, computed once for the distance
    /// map: a table's centres take them instead of casting their rays again, and its taps
    /// between centres on one surface interpolate them ([`Proxy::between_centres`]).
    centres: Option<Centres<'a>>,
    /// The distance from the output centre to the camera's, metres (infinite: unknown).
    baseline: f64,
    /// With a depth, the camera's intrinsics where it is a pinhole: its camera points are
    /// projected directly (x/z, y/z), not through the model's unit bearing (a depth-guided
    /// table projects every tap's point; the fixed stitch keeps the model's path).
    pinhole: Option<Intrinsics>,
    /// With a depth, the camera's projection in lanes where it is a unified (MEI) lens with a
    /// field-of-view bound: a depth-guided table projects its rows of centres so.
    lens: Option<LensLanes>,
}

/// A window of output pixels: its top-left and bottom-right pixels.
type Window = ((usize, usize), (usize, usize));

/// A tap between output pixel centres takes their distances interpolated (in inverse distance)
/// where the four around it lie on one surface: moving the tap's point from one of their
/// distances to another moves it in the camera by at most this share of an output pixel (the
/// baseline times the spread of their inverse distances, against the pixel's angle); beyond
/// it (a depth edge, a splat's step) the tap casts its own ray.
pub(super) const TAP_AGREE: f64 = 1.0;

/// Radians between the half field of view and the angles the shortcut of [`Proxy::within`]
/// decides: far beyond the rounding of a cosine, so its answer is `atan2`'s.
pub(super) const FOV_SLACK: f64 = 1e-6;

impl<'a> Proxy<'a> {
    #[cfg(test)]
    pub(super) fn new(camera: StitchCamera<'a>, centre: Vector3<f64>, distance: f64) -> Self {
        Self::guided((0, camera), centre, distance, None)
    }

    /// [`Proxy::new`] of the stitch's camera `index`, whose point lies at the scene's distance
    /// along each bearing (`depth`), where the camera saw it, or at the proxy distance without
    /// one.
    pub(super) fn guided(
        (index, camera): (usize, StitchCamera<'a>),
        centre: Vector3<f64>,
        distance: f64,
        depth: Option<&'a dyn StitchDepth>,
    ) -> Self {
        let fov_cos = camera
            .max_theta
            .filter(|t| *t > 1e-3 && *t < 3.0)
            .map(|t| ((t - FOV_SLACK).cos(), (t + FOV_SLACK).cos()));
        let baseline = camera.rotation.try_inverse().map_or(f64::INFINITY, |r| {
            (-(r * camera.translation) - centre).norm()
        });
        Self {
            camera,
            index,
            moves: depth.is_some_and(|d| d.motion_bound(index) > 0.0),
            centre,
            distance,
            depth,
            fov_cos,
            centres: None,
            baseline: if baseline.is_finite() {
                baseline
            } else {
                f64::INFINITY
            },
            pinhole: depth.and(camera.model.pinhole()),
            lens: (depth.and_then(|_| camera.model.lens()?.downcast::<MeiModel>()))
                .zip(fov_cos)
                .and_then(|(lens, fov_cos)| LensLanes::of(&lens, fov_cos)),
        }
    }

    /// This proxy, taking the distances of the output's pixel centres from `centres`.
    pub(super) fn with_centres(mut self, centres: Centres<'a>) -> Self {
        self.centres = Some(centres);
        self
    }

    /// The distance map's entries for bearings `ds` when they are the centres of one output
    /// row, columns -1..=width, as the output's bound gave them (a table's row of centres),
    /// per bearing: None for another bearing. The row is the one the output projects the
    /// first bearing to, and each bearing must equal the bound's to the bit: its distance is
    /// then the same call's result.
    fn centre_distances<'c>(
        &'c self,
        ds: &'c [Option<Vector3<f64>>],
    ) -> Option<impl Iterator<Item = Option<f64>> + 'c> {
        let (c, v) = self.centre_row(ds)?;
        let w = c.output.size().width as usize;
        let same = |a: &Vector3<f64>, b: &Vector3<f64>| {
            a.iter().zip(b).all(|(a, b)| a.to_bits() == b.to_bits())
        };
        Some(ds.iter().enumerate().map(move |(k, d)| {
            let u = k.checked_sub(1).filter(|u| *u < w)?;
            let stored = c.reach.bearing(u, v)?;
            same(d.as_ref()?, &stored).then(|| c.distances[v * w + u])
        }))
    }

    /// The output row of bearings `ds` when they are a table's row of centres, as
    /// [`Proxy::centre_distances`] reads them: the row the output projects the first
    /// bearing to, with the centres' distances.
    fn centre_row(&self, ds: &[Option<Vector3<f64>>]) -> Option<(Centres<'a>, usize)> {
        let c = self.centres?;
        let size = c.output.size();
        let w = size.width as usize;
        if ds.len() != w + 2 {
            return None;
        }
        let first = ds[1..=w].iter().flatten().next()?;
        let y = c.output.project(first).ok()?.y.round();
        if !(y >= 0.0 && y < size.height as f64) {
            return None;
        }
        Some((c, y as usize))
    }

    /// With a depth and the centres' distances, for a pinhole camera without a field-of-view
    /// bound, what its projection of a row of centres in lanes reads ([`GuidedPinhole`]).
    pub(super) fn guided_pinhole(&self) -> Option<GuidedPinhole<'a>> {
        let size = self.size();
        Some(self.guided_lanes(PinholeLanes {
            k: self.pinhole.filter(|_| self.camera.max_theta.is_none())?,
            size: (size.width as f64, size.height as f64),
        }))
    }

    /// With a depth and the centres' distances, for a unified (MEI) lens with a field-of-view
    /// bound, what its projection of a row of centres in lanes reads (`guided_lens.rs`).
    pub(super) fn guided_lens(&self) -> Option<GuidedLanes<'a, LensLanes>> {
        Some(self.guided_lanes(self.lens?))
    }

    /// What a projection of a row of centres in lanes through `camera` reads.
    fn guided_lanes<C>(&self, camera: C) -> GuidedLanes<'a, C> {
        GuidedLanes {
            rotation: self.camera.rotation,
            translation: self.camera.translation,
            centre: self.centre,
            moved: self.depth.filter(|_| self.moves).map(|d| (d, self.index)),
            camera,
        }
    }

    /// The scene's distance along unit bearing `n` (a table's tap) from the distances of the
    /// four output pixel centres around it, bilinear in inverse distance, where they lie on one
    /// surface ([`TAP_AGREE`]); None where they do not, or a centre has no distance.
    fn between_centres(&self, n: &Vector3<f64>) -> Option<f64> {
        let c = self.centres?;
        self.between_centres_at(&c.output.project(n).ok()?)
    }

    /// Whether the distances of the window of output pixels from `(u0, v0)` to `(u1, v1)`,
    /// nearest and farthest `(near, far)`, lie on one surface ([`SURFACE_AGREE`]).
    fn agree(&self, ((u0, v0), (u1, v1)): Window, (near, far): (f64, f64)) -> bool {
        let Some(c) = self.centres else { return false };
        // (the inverses' extremes: a division rounds monotonically)
        let (lo, hi) = (1.0 / far, 1.0 / near);
        // an output pixel's angle: the chord across the neighbourhood's diagonal over its steps
        let (Some(a), Some(b)) = (c.reach.bearing(u0, v0), c.reach.bearing(u1, v1)) else {
            return false;
        };
        let steps = (((u1 - u0).pow(2) + (v1 - v0).pow(2)) as f64).sqrt();
        let pixel = (a.normalize() - b.normalize()).norm() / steps;
        (hi - lo) * self.baseline <= SURFACE_AGREE * pixel
    }

    /// [`CameraModel::project`] of bearing `d`, a table's tap: at the distance interpolated
    /// between the centres around it where they lie on one surface, else at its own cast.
    fn project_tap(&self, d: &Vector3<f64>) -> std::result::Result<Point2<f64>, ProjectionReject> {
        match self.between_centres(&d.normalize()) {
            Some(t) => self.project_at(d, t),
            None => self.project(d),
        }
    }

    /// [`CameraModel::project`] of bearing `d` through the scene's point at `distance`.
    pub(super) fn project_at(
        &self,
        d: &Vector3<f64>,
        distance: f64,
    ) -> std::result::Result<Point2<f64>, ProjectionReject> {
        let q = self.local_at(&d.normalize(), distance);
        if !self.within(&q) {
            return Err(ProjectionReject::OutsideDomain);
        }
        self.pixel(&q)
    }

    /// The camera's pixel of camera point `q` ([`CameraModel::project_point`]; a pinhole's
    /// directly, with its front test).
    #[inline]
    fn pixel(&self, q: &Vector3<f64>) -> std::result::Result<Point2<f64>, ProjectionReject> {
        let Some(k) = &self.pinhole else {
            return self.camera.model.project_point(q);
        };
        // the pinhole's test of the unit bearing (z > 1e-9 of its norm), on the point, squared
        if !(q.z > 0.0 && q.z * q.z > 1e-18 * q.norm_squared()) {
            return Err(ProjectionReject::BehindCamera);
        }
        let z = 1.0 / q.z;
        let (u, v) = k.to_pixel(q.x * z, q.y * z);
        Ok(Point2::new(u, v))
    }

    /// The camera point of output bearing `d`: its proxy point, or with a depth the scene's
    /// point along it.
    pub(super) fn local(&self, d: &Vector3<f64>) -> Vector3<f64> {
        match self.depth {
            None => {
                let x = self.centre + d.normalize() * self.distance;
                self.camera.rotation * x + self.camera.translation
            }
            Some(depth) => {
                let n = d.normalize();
                self.local_at(&n, depth.distance(&n))
            }
        }
    }

    /// The reference point at `distance` along unit bearing `n` from the output centre, where
    /// the camera saw it ([`StitchDepth::seen_at`]).
    #[inline]
    pub(super) fn point_at(&self, n: &Vector3<f64>, distance: f64) -> Vector3<f64> {
        let x = self.centre + n * distance;
        match self.depth.filter(|_| self.moves) {
            Some(depth) => depth.seen_at(self.index, &x),
            None => x,
        }
    }

    /// How far the depth moves a point for this camera at most, metres (0: no depth).
    pub(super) fn motion_bound(&self) -> f64 {
        self.depth.map_or(0.0, |d| d.motion_bound(self.index))
    }

    /// The camera point of the reference point at `distance` along unit bearing `n`.
    #[inline]
    pub(super) fn local_at(&self, n: &Vector3<f64>, distance: f64) -> Vector3<f64> {
        self.camera.rotation * self.point_at(n, distance) + self.camera.translation
    }

    /// Without a depth, for a pinhole camera without a field-of-view bound, what its
    /// projection in lanes reads ([`FixedPinhole`]).
    fn fixed_pinhole(&self) -> Option<FixedPinhole> {
        let fixed = self.depth.is_none() && self.camera.max_theta.is_none();
        Some(FixedPinhole {
            rotation: self.camera.rotation,
            translation: self.camera.translation,
            centre: self.centre,
            distance: self.distance,
            k: self.camera.model.pinhole().filter(|_| fixed)?,
        })
    }

    /// [`CameraModel::project_all`] without the image bound.
    fn project_each(&self, bearings: &[Option<Vector3<f64>>], out: &mut Vec<Option<Point2<f64>>>) {
        match self.centre_distances(bearings) {
            Some(known) => out.extend(bearings.iter().zip(known).map(|(d, t)| {
                let d = d.as_ref()?;
                match t {
                    Some(t) => self.project_at(d, t),
                    None => self.project(d),
                }
                .ok()
            })),
            None => out.extend(bearings.iter().map(|d| self.project_tap(d.as_ref()?).ok())),
        }
    }

    /// [`CameraModel::project_all`] centre by centre: [`Proxy::project_each`], then with a
    /// depth the image bound.
    pub(super) fn project_all_each(
        &self,
        bearings: &[Option<Vector3<f64>>],
        out: &mut Vec<Option<Point2<f64>>>,
    ) {
        let start = out.len();
        self.project_each(bearings, out);
        if self.depth.is_some() {
            let (w, h) = (self.size().width as f64, self.size().height as f64);
            for p in &mut out[start..] {
                *p = p.filter(|p| in_image(p, w, h));
            }
        }
    }

    /// Whether camera point `q` lies within the camera's image as a depth-guided table's
    /// pixel centre must ([`Proxy::within`], then [`in_image`]), at least `rim` source
    /// pixels inside its border.
    #[inline]
    pub(super) fn holds(&self, q: &Vector3<f64>, rim: f64) -> bool {
        let size = self.camera.model.size();
        let (w, h) = (
            size.width as f64 - 2.0 * rim,
            size.height as f64 - 2.0 * rim,
        );
        self.within(q)
            && (self.pixel(q)).is_ok_and(|p| in_image(&Point2::new(p.x - rim, p.y - rim), w, h))
    }

    /// Whether camera point `q` lies within the lens's field of view: θ(q) ≤ θ_max, θ the
    /// angle from the optical axis (`atan2` only within [`FOV_SLACK`] of the edge).
    #[inline]
    pub(super) fn within(&self, q: &Vector3<f64>) -> bool {
        let Some(t) = self.camera.max_theta else {
            return true;
        };
        if let Some((inner, outer)) = self.fov_cos.filter(|_| q.iter().all(|x| x.is_finite())) {
            let n = q.norm();
            if q.z >= inner * n && n > 0.0 {
                return true;
            }
            if q.z < outer * n {
                return false;
            }
        }
        !(q.x.hypot(q.y).atan2(q.z) > t)
    }
}

/// Whether source position `p` lies within a `w`×`h` image as a remap table's taps do: the
/// positions a table can sample.
fn in_image(p: &Point2<f64>, w: f64, h: f64) -> bool {
    column_inside(p.x, w) && row_inside(p.y, h)
}

/// Output pixels from a depth-guided table's pixel within which the scene must lie on one
/// surface for it to sample the pyramid: a level's bilinear tap reaches up to 2 output pixels
/// from the centre. Against the exact render of the KITTI-360 offset rig at 360×180
/// (`tests/kitti360_stitch/depth_guided.rs`, the taps everywhere 49.08 dB, the pyramid
/// everywhere 43.87) 1 gave 48.84 dB (image_01's region 1.85 dB below the taps'), 2 gave 48.97.
pub(super) const SURFACE_REACH: usize = 2;

/// The largest spread of those pixels' inverse distances, times the baseline, in output
/// pixels' angles (the parallax it makes in the camera): half [`TAP_AGREE`]. With
/// [`SURFACE_REACH`] 2 the offset rig above reads 49.04 dB, every camera's region within 0.2
/// dB of the taps' (at 1, 48.97 dB).
pub(super) const SURFACE_AGREE: f64 = 0.5 * TAP_AGREE;

/// The footprint rule of a depth-guided table ([`RemapTable::build_pyramid_guided`]): a pixel
/// samples the pyramid only where the scene's distances within [`SURFACE_REACH`] of it lie on
/// one surface ([`SURFACE_AGREE`]: moving the point across their spread of inverse distances
/// moves it in the camera by at most that share of an output pixel); a depth edge, a splat's
/// step or a neighbour without a distance keeps the taps. Without the centres' distances
/// every pixel keeps them.
///
/// [`RemapTable::build_pyramid_guided`]: crate::warp::table::RemapTable::build_pyramid_guided
impl Surfaces for Proxy<'_> {
    fn one_surface(&self, u: usize, v: usize) -> bool {
        let Some(c) = self.centres else {
            return false;
        };
        let size = c.output.size();
        let (w, h) = (size.width as usize, size.height as usize);
        let r = SURFACE_REACH;
        let (u0, u1) = (u.saturating_sub(r), (u + r).min(w - 1));
        let (v0, v1) = (v.saturating_sub(r), (v + r).min(h - 1));
        // the nearest and farthest distances (their inverses are the inverses' extremes)
        let (mut near, mut far) = (f64::INFINITY, 0.0f64);
        for row in c.distances[v0 * w..(v1 + 1) * w].chunks_exact(w) {
            for t in &row[u0..=u1] {
                if !(*t > 0.0 && t.is_finite()) {
                    return false;
                }
                (near, far) = (near.min(*t), far.max(*t));
            }
        }
        self.agree(((u0, v0), (u1, v1)), (near, far))
    }

    /// The rows' spans of distances by column, then a sliding window along the row: the same
    /// extremes as [`Proxy::one_surface`]'s, a fifth of the reads.
    fn one_surface_row(&self, v: usize, columns: Range<usize>, out: &mut Vec<bool>) {
        out.clear();
        let Some(c) = self.centres.filter(|_| !columns.is_empty()) else {
            out.resize(columns.len(), false);
            return;
        };
        let (w, h) = (
            c.output.size().width as usize,
            c.output.size().height as usize,
        );
        let r = SURFACE_REACH;
        let (v0, v1) = (v.saturating_sub(r), (v + r).min(h - 1));
        let (c0, c1) = (
            columns.start.saturating_sub(r),
            (columns.end - 1 + r).min(w - 1),
        );
        // each column's nearest and farthest distance over rows v0..=v1; None: one has none
        let spans: Vec<Option<(f64, f64)>> = (c0..=c1)
            .map(|x| {
                (v0..=v1).try_fold((f64::INFINITY, 0.0f64), |(near, far), y| {
                    let t = c.distances[y * w + x];
                    (t > 0.0 && t.is_finite()).then(|| (near.min(t), far.max(t)))
                })
            })
            .collect();
        out.extend(columns.map(|u| {
            let (u0, u1) = (u.saturating_sub(r), (u + r).min(w - 1));
            let window = (spans[u0 - c0..=u1 - c0].iter())
                .try_fold((f64::INFINITY, 0.0f64), |(near, far), s| {
                    s.map(|(n, f)| (near.min(n), far.max(f)))
                });
            window.is_some_and(|nf| self.agree(((u0, v0), (u1, v1)), nf))
        }));
    }

    /// Each tap at the distance interpolated between the centres around its output position
    /// where they lie on one surface ([`Proxy::between_centres`]), else at its own cast.
    fn project_taps(
        &self,
        at: &[Point2<f64>],
        ds: &[Option<Vector3<f64>>],
        out: &mut Vec<Option<Point2<f64>>>,
    ) {
        if self.centres.is_none() || self.depth.is_none() {
            return self.project_all(ds, out);
        }
        let (w, h) = (self.size().width as f64, self.size().height as f64);
        // a pixel's taps lie in a few cells of centres: each cell's distances read once
        let mut cells = Cells::default();
        out.extend(at.iter().zip(ds).map(|(p, d)| {
            let d = d.as_ref()?;
            let (x, y) = (crate::warp::floor(p.x), crate::warp::floor(p.y));
            let s = cells.get((x, y), || self.cell_inverses(x, y));
            match s.map(|s| between(s, p.x - x, p.y - y)) {
                Some(t) => self.project_at(d, t),
                None => self.project(d),
            }
            .ok()
            .filter(|p| in_image(p, w, h))
        }));
    }

    /// The output's own: a stitch's table is built from it gated by this camera's reach
    /// ([`crate::warp::reach::Gated`]), whose `unproject` gives a tap of a pixel it keeps
    /// the output's bearing (the tap's nearest pixel is its own).
    fn tap_output(&self) -> Option<&dyn Separable> {
        self.centres?.output.separable()
    }
}

impl CameraModel for Proxy<'_> {
    fn project(&self, d: &Vector3<f64>) -> std::result::Result<Point2<f64>, ProjectionReject> {
        let q = self.local(d);
        if !self.within(&q) {
            return Err(ProjectionReject::OutsideDomain);
        }
        self.pixel(&q)
    }

    /// With a depth, only positions within the camera's image (its edges at -0.5 and
    /// size - 0.5): a pixel whose centre lands outside has no position, so a table spends no
    /// taps on it (a camera gives a stitch nothing where its image does not cover a pixel's
    /// whole footprint).
    fn project_all(&self, bearings: &[Option<Vector3<f64>>], out: &mut Vec<Option<Point2<f64>>>) {
        if let Some(fixed) = self.fixed_pinhole() {
            // the same positions, a group of lanes at a time (`fixed_proxy.rs`)
            return fixed.project_all(bearings, out);
        }
        // with the centres' distances, the same positions a group of lanes at a time
        // (`guided_lanes.rs`), a bearing not stored for its pixel cast alone
        let (pinhole, lens) = (self.guided_pinhole(), self.guided_lens());
        let row = (pinhole.is_some() || lens.is_some())
            .then(|| self.centre_row(bearings))
            .flatten();
        let Some(row) = row else {
            return self.project_all_each(bearings, out);
        };
        let (w, h) = (self.size().width as f64, self.size().height as f64);
        let cast = |d: &Vector3<f64>| self.project(d).ok().filter(|p| in_image(p, w, h));
        let at = |d: &Vector3<f64>, t| self.project_at(d, t).ok().filter(|p| in_image(p, w, h));
        let alone = Alone {
            cast: &cast,
            at: &at,
        };
        match (pinhole, lens) {
            (Some(lanes), _) => lanes.project_row(bearings, row, out, alone),
            (_, Some(lanes)) => lanes.project_row(bearings, row, out, alone),
            _ => self.project_all_each(bearings, out),
        }
    }

    /// A row of output pixel centres takes the distances computed for them (see
    /// [`Proxy::with_centres`]): only a whole row is projected so.
    fn projects_bearing_by_bearing(&self) -> bool {
        self.centres.is_none()
    }

    /// The output bearing whose proxy point the pixel sees: the camera's ray met with the
    /// sphere of radius s around the output centre.
    fn unproject(&self, p: &Point2<f64>) -> std::result::Result<Vector3<f64>, ProjectionReject> {
        let b = self.camera.model.unproject(p)?;
        let inv = self
            .camera
            .rotation
            .try_inverse()
            .ok_or(ProjectionReject::Singular)?;
        let origin = -(inv * self.camera.translation) - self.centre;
        let dir = (inv * b).normalize();
        // |origin + λ·dir| = s, λ > 0
        let half_b = origin.dot(&dir);
        let c = origin.norm_squared() - self.distance * self.distance;
        let disc = half_b * half_b - c;
        if !(disc >= 0.0) {
            return Err(ProjectionReject::OutsideDomain);
        }
        let lambda = -half_b + disc.sqrt();
        if !(lambda > 0.0) {
            return Err(ProjectionReject::OutsideDomain);
        }
        Ok((origin + dir * lambda).normalize())
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        p.norm()
    }

    fn size(&self) -> ImageSize {
        self.camera.model.size()
    }
}

mod cells;
#[cfg(test)]
pub(super) mod tests;
