//! Where a stitch's source camera can reach in its output: a conservative per-pixel bound that
//! lets the stitch build skip the table entries and weights of the output pixels a camera
//! cannot see (most of them: a fisheye sees about half the sphere, a forward camera a few
//! percent), without changing a byte of the result.
//!
//! Camera i samples output position x at the proxy point q_i(x), which has an image only
//! within the cone of half-angle c_i about the camera's optical axis: its field of view, or,
//! for a camera without one, the widest angle of its image border (one pixel out) plus a
//! margin. The bearings of the output pixel centres (and of the ring one pixel outside) are
//! computed once per output camera, and kept across frames ([`grid`]). Between adjacent centres the output bearing turns by at most A, and seen
//! from camera i the proxy point turns by at most A·s/(s − b_i) (s the proxy distance, b_i the
//! camera's distance from the output centre). A tap lies within half a pixel of its pixel's
//! centre, so a pixel with a tap in the image has θ(q_i) ≤ c_i + δ_i at its centre, with
//! δ_i = 2·A·s/(s − b_i): those centres are the candidates, and a centre without a bearing is
//! one too. Widened by two pixels (a pixel's scale estimate reads its neighbours' centres),
//! they are the pixels the table maps; the others take nothing from the camera. The test runs
//! per tile of [`TILE`]×[`TILE`] positions at its middle position: a tile whose middle lies
//! beyond the limit (or within it) by more than the tile's turn k·A·s/(s − b_i) (k the most
//! positions from the middle) is decided whole, the others position by position (with one
//! limit, a block of [`BLOCK`]×[`BLOCK`] tiles is tried whole first, the same way); the set
//! is the per-position one. A pinhole camera's cone circumscribes its image border; the four
//! planes through that border bound it further, by the same angle (`reach/frustum.rs`). The
//! set is a bit a position (`reach/set.rs`); a table built through [`Gated`] reads the stored
//! bearings of a row's reachable centres, across the row's span of the set alone
//! ([`CameraModel::stored_centre_span`]).
//!
//! A depth-guided stitch samples the scene's point at distance t along the bearing instead,
//! which camera i sees at most asin(b_i / t) from the bearing's direction: the cone is widened
//! by that angle per tile of [`TILE`]×[`TILE`] positions, t a lower bound of the scene's
//! distance over every bearing within the tile's angular radius (plus two turns A for the
//! taps) of its middle position's bearing; a pinhole's border planes are widened by the same
//! angle (a point's signed angle from a plane through the camera moves by at most the angle
//! its direction turns).

use crate::camera::{CameraModel, ImageSize, ProjectionReject};
use nalgebra::{Point2, Vector3};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::Arc;

mod frustum;
mod grid;
mod set;
pub(super) use frustum::Frustum;
use frustum::Slack;
pub(in crate::warp) use grid::OutputGrid;
use set::PositionSet;

/// Pixels the candidates are widened by.
const WIDEN: usize = 2;
/// Radians added to a cone measured on an image border.
const BORDER_SLACK: f64 = 1e-3;
/// Positions per side of a tile of the depth-guided bound.
const TILE: usize = 8;
/// Tiles per side of a block, decided whole at once where it can be.
const BLOCK: usize = 8;

/// A lower bound of a scene's distance (metres) over the unit bearings within an angle
/// (radians) of a unit bearing.
pub(super) type NearBound<'a> = &'a (dyn Fn(&Vector3<f64>, f64) -> f64 + Sync);

/// The bearings of an output's pixel centres and, per camera, the pixels it may reach.
#[derive(Debug)]
pub(super) struct Reach {
    size: ImageSize,
    /// The output's positions -1..=width × -1..=height and their bearings.
    grid: Arc<OutputGrid>,
    /// Per camera, over the same positions: those the camera may reach (None: all).
    reach: Vec<Option<PositionSet>>,
    /// Per camera with a bound, per row of positions: the first and the end of those it may
    /// reach (equal where none).
    spans: Vec<Option<Vec<(u32, u32)>>>,
}

/// One camera as the bound sees it.
pub(super) struct Cone<'a> {
    /// The proxy point of an output bearing, in the camera's coordinates.
    pub local: &'a (dyn Fn(&Vector3<f64>) -> Vector3<f64> + Sync),
    /// Half-angle c_i of the cone holding every point with an image (None: unbounded).
    pub half_angle: Option<f64>,
    /// s/(s − b_i), None where the camera lies on or beyond the proxy sphere.
    pub parallax: Option<f64>,
    /// With a depth-guided stitch, b_i: the cone is widened per tile by asin(b_i / t) (no
    /// bound in a tile where t ≤ b_i).
    pub baseline: Option<f64>,
    /// A pinhole camera's image border planes, which bound it within its cone (widened per
    /// tile as the cone is with a baseline; see `reach/frustum.rs`).
    pub frustum: Option<Frustum>,
}

/// The widest angle from the optical axis of `model`'s image border, one pixel out, plus a
/// slack; None where part of the border has no bearing. For a pinhole camera every point with
/// an image lies within it (the angle grows with the distance from the principal point, whose
/// largest value over a rectangle is on its border).
pub(super) fn border_cone(model: &dyn CameraModel) -> Option<f64> {
    let size = model.size();
    let (x0, y0) = (-1.5, -1.5);
    let (x1, y1) = (size.width as f64 + 0.5, size.height as f64 + 0.5);
    let mut widest: f64 = 0.0;
    let mut edge = |a: Point2<f64>, b: Point2<f64>| -> Option<()> {
        let steps = ((b - a).norm() * 2.0).ceil().max(1.0) as usize;
        for k in 0..=steps {
            let p = a + (b - a) * (k as f64 / steps as f64);
            let d = model.unproject(&p).ok()?;
            let theta = d.x.hypot(d.y).atan2(d.z);
            if !theta.is_finite() {
                return None;
            }
            widest = widest.max(theta);
        }
        Some(())
    };
    let c = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)].map(|(x, y)| Point2::new(x, y));
    for i in 0..4 {
        edge(c[i], c[(i + 1) % 4])?;
    }
    Some(widest + BORDER_SLACK)
}

impl Reach {
    /// The bound of `cameras` in `output`; `near` bounds the scene's distance for the cones
    /// with a baseline (a cone with one is unbounded without it).
    pub(super) fn new(
        output: &dyn CameraModel,
        cameras: &[Cone],
        near: Option<NearBound>,
    ) -> Reach {
        let size = output.size();
        let output_grid = OutputGrid::of(output);
        let tiles = near.map(|near| tile_nearest(&output_grid, near));
        let grid = Grid {
            output: &output_grid,
            tiles: tiles.as_deref(),
        };
        let reach: Vec<_> = cameras.iter().map(|cone| cone_reach(cone, &grid)).collect();
        let gh = output_grid.gh;
        let spans = (reach.iter())
            .map(|r| r.as_ref().map(|r| (0..gh).map(|j| r.span(j)).collect()))
            .collect();
        Reach {
            size,
            grid: output_grid,
            reach,
            spans,
        }
    }

    /// The output's bearing of pixel (u, v), as its `unproject` gave it (None where it gave
    /// none).
    pub(super) fn bearing(&self, u: usize, v: usize) -> Option<Vector3<f64>> {
        let d = self.grid.bearings[(v + 1) * (self.size.width as usize + 2) + u + 1];
        d.x.is_finite().then_some(d)
    }

    /// The stored bearing of output position `p` when it is a pixel centre the bound covers
    /// (Some(None) where the output's `unproject` gave none), None for another position.
    #[inline]
    pub(super) fn stored_bearing(&self, p: &Point2<f64>) -> Option<Option<Vector3<f64>>> {
        let (x, y) = (p.x + 1.0, p.y + 1.0);
        let (gw, gh) = (self.size.width as usize + 2, self.size.height as usize + 2);
        // (an integer below 2^52 converts exactly)
        if !(x >= 0.0 && y >= 0.0 && x < gw as f64 && y < gh as f64)
            || (x as u64) as f64 != x
            || (y as u64) as f64 != y
        {
            return None;
        }
        let d = self.grid.bearings[y as usize * gw + x as usize];
        Some(d.x.is_finite().then_some(d))
    }

    /// Whether camera `i` may reach the pixel nearest to output position `p` (true beyond the
    /// positions the bound covers).
    pub(super) fn may_reach(&self, i: usize, p: &Point2<f64>) -> bool {
        let Some(reach) = &self.reach[i] else {
            return true;
        };
        let gw = self.size.width as usize + 2;
        let (x, y) = (super::floor(p.x + 0.5) + 1.0, super::floor(p.y + 0.5) + 1.0);
        if !(x >= 0.0 && y >= 0.0 && x < gw as f64 && y < (self.size.height + 2) as f64) {
            return true;
        }
        reach.contains(x as usize, y as usize)
    }

    /// Appends the stored bearings of row `v`'s positions -1..=width to `out`, None where
    /// the output gave none or camera `i` cannot reach: what [`Gated`]'s `unproject` gives
    /// at those centres; false, `out` unchanged, for a row beyond the bound's.
    fn gated_row(&self, i: usize, v: isize, out: &mut Vec<Option<Vector3<f64>>>) -> bool {
        let gw = self.size.width as usize + 2;
        self.gated_span(i, v, 0..gw, out).is_some()
    }

    /// [`Reach::gated_row`] of the positions from the first to the last camera `i` may reach
    /// (see [`CameraModel::stored_centre_span`]).
    fn gated_reached(
        &self,
        i: usize,
        v: isize,
        out: &mut Vec<Option<Vector3<f64>>>,
    ) -> Option<Range<usize>> {
        let gw = self.size.width as usize + 2;
        let span = match (&self.spans[i], usize::try_from(v + 1)) {
            (Some(spans), Ok(j)) if j < spans.len() => spans[j].0 as usize..spans[j].1 as usize,
            _ => 0..gw,
        };
        self.gated_span(i, v, span, out)
    }

    /// [`Reach::gated_row`] of the positions `span` of row `v` alone; gives `span`.
    fn gated_span(
        &self,
        i: usize,
        v: isize,
        span: Range<usize>,
        out: &mut Vec<Option<Vector3<f64>>>,
    ) -> Option<Range<usize>> {
        let (gw, gh) = (self.size.width as usize + 2, self.size.height as usize + 2);
        let j = usize::try_from(v + 1).ok().filter(|j| *j < gh)?;
        let row = &self.grid.bearings[j * gw..(j + 1) * gw];
        let stored = |d: &Vector3<f64>| d.x.is_finite().then_some(*d);
        let (first, end) = (span.start, span.end);
        match &self.reach[i] {
            None => out.extend(row[first..end].iter().map(stored)),
            Some(reach) => {
                // by runs: most of a row lies beyond a camera's reach
                let mut i = first;
                while i < end {
                    let on = reach.contains(i, j);
                    let run = reach.run_end(j, i, end, on);
                    if on {
                        out.extend(row[i..run].iter().map(stored));
                    } else {
                        out.resize(out.len() + run - i, None);
                    }
                    i = run;
                }
            }
        }
        Some(span)
    }

    /// A: the largest turn between adjacent output centres, radians.
    pub(super) fn step(&self) -> f64 {
        self.grid.step
    }

    /// Whether camera `i` may reach an output pixel of columns `us` in rows `vs` (false only
    /// where it reaches none: by the rows' spans, without a look at each pixel).
    pub(super) fn may_reach_block(&self, i: usize, us: Range<usize>, vs: Range<usize>) -> bool {
        let Some(spans) = &self.spans[i] else {
            return true;
        };
        // (grid positions are pixels + 1)
        vs.map(|v| spans[v + 1])
            .any(|(a, b)| (a as usize) < us.end + 1 && us.start + 1 < b as usize)
    }

    /// Whether camera `i` may reach output pixel (u, v).
    pub(super) fn may_reach_pixel(&self, i: usize, u: usize, v: usize) -> bool {
        self.reach[i]
            .as_ref()
            .is_none_or(|r| r.contains(u + 1, v + 1))
    }
}

/// The output's grid as a cone's bound reads it.
struct Grid<'a> {
    /// The output's bearings, largest turn and complete tiles.
    output: &'a OutputGrid,
    /// The nearest scene distance per tile, when bounded.
    tiles: Option<&'a [f64]>,
}

/// The positions of the grid where `cone`'s camera may give a sample (widened by one), None
/// for every position.
fn cone_reach(cone: &Cone, grid: &Grid) -> Option<PositionSet> {
    cone_reach_by(cone, grid, true)
}

/// [`cone_reach`], deciding the tiles it settles whole (`whole_tiles`) or every position
/// alone (the tests' reference).
fn cone_reach_by(cone: &Cone, grid: &Grid, whole_tiles: bool) -> Option<PositionSet> {
    let Grid { output, tiles } = *grid;
    let (bearings, gw, gh, step) = (&output.bearings, output.gw, output.gh, output.step);
    let tiles_across = output.tiles_across();
    let (Some(c), Some(k)) = (cone.half_angle, cone.parallax) else {
        return None;
    };
    let limit = c + 2.0 * step * k + 1e-9;
    // one limit for every position, or with a baseline one per tile (and the tile's
    // parallax angle asin(b / t), which widens the planes as it widens the cone)
    let (limits, widening): (Vec<f64>, Vec<f64>) = match (cone.baseline, &tiles) {
        (None, _) => (vec![limit], vec![0.0]),
        (Some(b), Some(tiles)) => tiles
            .iter()
            .map(|&t| {
                if b.is_finite() && b < t {
                    let parallax = (b / t).asin();
                    (limit + parallax, parallax)
                } else {
                    (f64::INFINITY, f64::INFINITY)
                }
            })
            .unzip(),
        (Some(_), None) => return None,
    };
    if !limits.iter().any(|l| *l < std::f64::consts::PI) {
        return None;
    }
    // θ(q) > limit + 1e-6 as cos θ < cos(limit + 1e-6): no atan2 per position, and
    // the few positions within 1e-6 rad beyond the limit stay candidates (a larger
    // set changes no value); near π a cosine no longer resolves the angle
    let cos_limits: Vec<Option<f64>> = limits
        .iter()
        .map(|&limit| (limit < 3.0).then(|| (limit + 1e-6).cos()))
        .collect();
    // a pinhole's image border planes at the same angle beyond as the cone's limit (and the
    // border cone's slack), per tile with a baseline (none where the tile has no bound)
    let planes = |tile: usize| -> Option<Slack> {
        let widening = widening[tile];
        (cone.frustum)
            .filter(|_| widening.is_finite())
            .map(|f| f.within(2.0 * step * k + 1e-9 + BORDER_SLACK + widening))
    };
    let position = |d: &Vector3<f64>, tile: usize, planes: Option<&Slack>| -> bool {
        let limit = limits[tile];
        if !d.x.is_finite() || !(limit < std::f64::consts::PI) {
            return true;
        }
        let q = (cone.local)(d);
        // NaN compares false: such a point is a candidate too
        let within = match cos_limits[tile] {
            Some(c) => !(q.z < c * q.norm()),
            None => !(q.x.hypot(q.y).atan2(q.z) > limit),
        };
        within && planes.is_none_or(|p| p.holds(&q))
    };
    let single = (limits.len() == 1).then(|| planes(0)).flatten();
    let mut candidate = PositionSet::new(gw, gh);
    let words = candidate.words();
    let tiles_down = gh.div_ceil(TILE);
    candidate
        .bits_mut()
        .par_chunks_mut(words * TILE * BLOCK)
        .enumerate()
        .for_each(|(bj, rows)| {
            let jb = bj * TILE * BLOCK;
            let fill = |rows: &mut [u64], (i0, i1), (j0, j1), whole: Option<bool>, tile| {
                let tile_planes = match limits.len() {
                    1 => single,
                    _ => whole.is_none().then(|| planes(tile)).flatten(),
                };
                for j in j0..j1 {
                    let row = &mut rows[(j - jb) * words..][..words];
                    match whole {
                        Some(true) => set::set_range(row, i0, i1),
                        Some(false) => {}
                        None => {
                            for i in i0..i1 {
                                if position(&bearings[j * gw + i], tile, tile_planes.as_ref()) {
                                    set::set(row, i);
                                }
                            }
                        }
                    }
                }
            };
            let tjs = bj * BLOCK..((bj + 1) * BLOCK).min(tiles_down);
            for bi in 0..tiles_across.div_ceil(BLOCK) {
                let tis = bi * BLOCK..((bi + 1) * BLOCK).min(tiles_across);
                // with one limit, a block of tiles decided whole at once (most of the
                // output lies far beyond a camera's cone)
                let complete = || {
                    tjs.clone().all(|tj| {
                        tis.clone()
                            .all(|ti| output.complete[tj * tiles_across + ti])
                    })
                };
                let (i0, i1) = (tis.start * TILE, (tis.end * TILE).min(gw));
                let (j0, j1) = (tjs.start * TILE, (tjs.end * TILE).min(gh));
                if whole_tiles && limits.len() == 1 && complete() {
                    let at = ((i0, i1), (j0, j1));
                    let whole = whole_tile(cone, single.as_ref(), k, output, limits[0], at);
                    if whole.is_some() {
                        fill(rows, (i0, i1), (j0, j1), whole, 0);
                        continue;
                    }
                } else if whole_tiles && complete() {
                    // per tile limits: a block beyond its tiles' widest limit (and planes)
                    // lies beyond each tile's
                    let tiles = || {
                        (tjs.clone())
                            .flat_map(|tj| tis.clone().map(move |ti| tj * tiles_across + ti))
                    };
                    let widest = tiles().map(|t| limits[t]).fold(0.0, f64::max);
                    let widening = tiles().map(|t| widening[t]).fold(0.0, f64::max);
                    if widest < std::f64::consts::PI {
                        let planes = (cone.frustum)
                            .map(|f| f.within(2.0 * step * k + 1e-9 + BORDER_SLACK + widening));
                        let at = ((i0, i1), (j0, j1));
                        let whole = whole_tile(cone, planes.as_ref(), k, output, widest, at);
                        if whole == Some(false) {
                            continue;
                        }
                    }
                }
                for tj in tjs.clone() {
                    for ti in tis.clone() {
                        let tile = if limits.len() == 1 {
                            0
                        } else {
                            tj * tiles_across + ti
                        };
                        let (i0, i1) = (ti * TILE, (ti * TILE + TILE).min(gw));
                        let (j0, j1) = (tj * TILE, (tj * TILE + TILE).min(gh));
                        let complete = output.complete[tj * tiles_across + ti];
                        let whole = (whole_tiles && complete)
                            .then(|| {
                                let at = ((i0, i1), (j0, j1));
                                let planes = match limits.len() {
                                    1 => single,
                                    _ => planes(tile),
                                };
                                whole_tile(cone, planes.as_ref(), k, output, limits[tile], at)
                            })
                            .flatten();
                        fill(rows, (i0, i1), (j0, j1), whole, tile);
                    }
                }
            }
        });
    Some(candidate.widened(WIDEN))
}

/// Radians a tile's decision keeps clear of the cone's limit (and of the 1e-6 rad the
/// per-position test adds to it): far beyond the rounding of the angles compared.
const TILE_CLEARANCE: f64 = 1e-7;

/// The per-position decision of every position of the tile `is` × `js` at once, where the
/// cone test at its middle position's bearing settles them all: every position lies within
/// k·A of the middle (k the most positions between them, A the largest turn between adjacent
/// ones), so its camera point within k·A·`parallax` of the middle's; None where it does not
/// settle them. Every position of the tile has a bearing (the caller reads
/// [`OutputGrid::complete`]).
fn whole_tile(
    cone: &Cone,
    planes: Option<&Slack>,
    parallax: f64,
    grid: &OutputGrid,
    limit: f64,
    ((i0, i1), (j0, j1)): ((usize, usize), (usize, usize)),
) -> Option<bool> {
    if !(limit < std::f64::consts::PI) {
        return Some(true);
    }
    let gw = grid.gw;
    let (mi, mj) = ((i0 + i1 - 1) / 2, (j0 + j1 - 1) / 2);
    let k = (mi - i0).max(i1 - 1 - mi).max(mj - j0).max(j1 - 1 - mj);
    let radius = k as f64 * grid.step * parallax + 1e-9;
    let q = (cone.local)(&grid.bearings[mj * gw + mi]);
    let theta = q.x.hypot(q.y).atan2(q.z);
    if !(theta.is_finite() && radius.is_finite()) {
        return None;
    }
    let within = if theta - radius > limit + 1e-6 + TILE_CLEARANCE {
        Some(false)
    } else if theta + radius < limit - TILE_CLEARANCE {
        Some(true)
    } else {
        None
    };
    // every position also within the planes, or one of them beyond
    match (within, planes.map_or(Some(true), |p| p.whole(&q, radius))) {
        (Some(false), _) | (_, Some(false)) => Some(false),
        (Some(true), Some(true)) => Some(true),
        _ => None,
    }
}

/// Per tile of [`TILE`]×[`TILE`] positions (row-major), a lower bound of the scene's distance
/// over the bearings of its positions' taps: `near` at the middle position's bearing within
/// (k + 2)·`step`, k the most positions from the middle to another of the tile (every path of
/// k steps turns by at most k·`step`, a tap lies within two turns of its centre); 0 where a
/// position has no bearing.
fn tile_nearest(grid: &OutputGrid, near: NearBound) -> Vec<f64> {
    let (bearings, gw, gh, step) = (&grid.bearings, grid.gw, grid.gh, grid.step);
    let across = grid.tiles_across();
    (0..grid.complete.len())
        .into_par_iter()
        .map(|tile| {
            let (i0, j0) = (tile % across * TILE, tile / across * TILE);
            let (i1, j1) = ((i0 + TILE).min(gw), (j0 + TILE).min(gh));
            if !grid.complete[tile] {
                return 0.0;
            }
            let (mi, mj) = ((i0 + i1 - 1) / 2, (j0 + j1 - 1) / 2);
            let k = (mi - i0).max(i1 - 1 - mi).max(mj - j0).max(j1 - 1 - mj);
            let radius = (k as f64 + 2.0) * step + 1e-9;
            let t = near(&bearings[mj * gw + mi].normalize(), radius);
            if t.is_finite() {
                t
            } else {
                0.0
            }
        })
        .collect()
}

/// An output camera whose `unproject` refuses the positions one camera cannot reach: a remap
/// table built from it maps only the pixels the bound keeps (the others take nothing).
#[derive(Debug)]
pub(super) struct Gated<'a> {
    /// The output camera.
    pub output: &'a dyn CameraModel,
    /// The bound.
    pub reach: &'a Reach,
    /// The camera whose reach gates it.
    pub camera: usize,
}

impl CameraModel for Gated<'_> {
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        self.output.project(d)
    }

    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        if !self.reach.may_reach(self.camera, p) {
            return Err(ProjectionReject::OutsideDomain);
        }
        // a pixel centre's bearing is the one the bound computed (the same call's result)
        if let Some(d) = self.reach.stored_bearing(p) {
            return d.ok_or(ProjectionReject::OutsideDomain);
        }
        self.output.unproject(p)
    }

    fn stored_centres(&self, v: isize, out: &mut Vec<Option<Vector3<f64>>>) -> bool {
        self.reach.gated_row(self.camera, v, out)
    }

    fn stored_centre_span(
        &self,
        v: isize,
        out: &mut Vec<Option<Vector3<f64>>>,
    ) -> Option<Range<usize>> {
        self.reach.gated_reached(self.camera, v, out)
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.output.distance(p)
    }

    fn size(&self) -> ImageSize {
        self.output.size()
    }
}

#[cfg(test)]
mod tests;
