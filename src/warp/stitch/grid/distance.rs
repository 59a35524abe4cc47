//! The scene's distance from the output centre at every output pixel centre, built in the
//! output's own grid once a frame: each return of the scan in its nearest pixel (nearest
//! wins; a return of the ground at the pixel centre's distance along the ground's plane),
//! the gaps along a column between two returns closed where they lie on one surface
//! (linearly in inverse distance; else each side's distance to the gap's middle, or the
//! ground's between two of the ground's returns: a road at a grazing angle), short gaps
//! along rows, the boxes ray-cast exactly (nearest wins), a wall's top return carried up where
//! the scan's top ring ends on it, then the ground where the ray meets it, and the far
//! distance elsewhere. A scan's rings are degrees apart (1.33° for nuScenes' HDL-32E, 7.6 px
//! at 2048 px): a pixel between two rings is interpolated, never left at the far distance, or
//! a camera would sample a far point through a near facade.

use super::{Bearings, GridBox, GridScene};
use crate::camera::CameraModel;
use nalgebra::Vector3;

/// Where a pixel's distance came from.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[repr(u8)]
pub(super) enum Origin {
    /// Nothing yet (after the build: the output has no bearing there).
    Empty,
    /// A return of the scan in this pixel.
    Return,
    /// Interpolated between returns of one surface (column) or beside them (row).
    Fill,
    /// Carried up from the column's top return (a wall above the top ring).
    Up,
    /// The ground.
    Ground,
    /// Nothing known: the far distance.
    Far,
    /// A box's face.
    Box,
}

/// No box at the pixel.
pub(super) const NO_BOX: u16 = u16::MAX;

/// The distance of a ray that meets nothing the scan shows (the sky), metres: 1 m of baseline
/// is 0.1 mrad of parallax there.
pub(super) const FAR_DISTANCE: f32 = 10_000.0;
/// Longest column gap (output rows) the ring fill closes: 7° at 2048 px, past the widest ring
/// spacing of the scanners read (the Pandar64's 6° at its bottom).
const MAX_COLUMN_GAP_RAD: f64 = 7.0 * std::f64::consts::PI / 180.0;
/// Longest row gap (output columns) the row fill closes: the scan's azimuth step is about one
/// output pixel at 2048 px.
const MAX_ROW_GAP: usize = 3;
/// Returns nearer than this to the output centre are not splatted (the vehicle's own body,
/// which the readers' vehicle box removes where it is given), metres.
const MIN_RANGE: f64 = 0.3;
/// The farthest ground distance taken, metres.
const GROUND_LIMIT: f64 = 100.0;
/// Side of the cells whose corners the ground is cast at, output pixels.
const GROUND_CELL: usize = 4;

/// The grid, row-major, the output's size.
pub(super) struct DistanceGrid {
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) d: Vec<f32>,
    pub(super) origin: Vec<Origin>,
    /// The box whose face gives the pixel's distance (its index in the scene's boxes), or
    /// [`NO_BOX`].
    pub(super) box_id: Vec<u16>,
    /// Whether the pixel's return is the ground's.
    ground_return: Vec<bool>,
}

impl DistanceGrid {
    /// The grid of `scene` seen from `centre` through `output` (`step`: the output's angular
    /// pixel size at its middle row, radians).
    pub(super) fn build(
        output: &dyn CameraModel,
        bearing: Bearings,
        centre: &Vector3<f64>,
        scene: &GridScene,
        step: f64,
    ) -> Self {
        let size = output.size();
        let (width, height) = (size.width as usize, size.height as usize);
        let mut g = Self {
            width,
            height,
            d: vec![0.0; width * height],
            origin: vec![Origin::Empty; width * height],
            box_id: vec![NO_BOX; width * height],
            ground_return: vec![false; width * height],
        };
        // a full turn's columns wrap (u and u ± width are one direction); a crop of a turn
        // lies within the ±180° its projection gives (a crop past them is refused)
        let wraps = output.horizontal_period() == Some(width as f64);
        g.splat(output, (bearing, centre), scene, wraps);
        let column_gap = ((MAX_COLUMN_GAP_RAD / step.max(1e-6)) as usize).max(1);
        g.fill_columns(column_gap);
        g.fill_rows();
        // the boxes before the carry: a tall box's top return is not a wall's (its faces end
        // where the box does)
        for (k, b) in scene.boxes.iter().enumerate() {
            g.raster_box(output, bearing, centre, b, k as u16, wraps);
        }
        g.carry_up(bearing);
        g.ground_and_far(bearing, scene);
        g
    }

    /// Each return into its nearest pixel, nearest distance winning.
    fn splat(
        &mut self,
        output: &dyn CameraModel,
        (bearing, centre): (Bearings, &Vector3<f64>),
        scene: &GridScene,
        wraps: bool,
    ) {
        let (w, h) = (self.width as i64, self.height as i64);
        for (k, p) in scene.points.iter().enumerate() {
            let r = p - centre;
            let dist = r.norm();
            if !(dist >= MIN_RANGE) {
                continue;
            }
            let Ok(px) = output.project(&(r / dist)) else {
                continue;
            };
            let (u, v) = (px.x.round() as i64, px.y.round() as i64);
            let u = if wraps { u.rem_euclid(w) } else { u };
            if !(0..h).contains(&v) || !(0..w).contains(&u) {
                continue;
            }
            let i = (v * w + u) as usize;
            let on_ground = scene.on_ground.get(k).copied().unwrap_or(false);
            let d = match scene.ground_normal.filter(|_| on_ground) {
                // on the plane through the return parallel to the ground's, n·X = n·r: the
                // pixel centre's bearing b meets it at t = n·r / n·b
                Some(n) => {
                    let t = n.dot(&r) / n.dot(&bearing.at(u as isize, v as isize));
                    if t.is_finite() && t > 0.0 && (t / dist - 1.0).abs() < 0.5 {
                        t
                    } else {
                        dist
                    }
                }
                None => dist,
            } as f32;
            if self.origin[i] == Origin::Empty || d < self.d[i] {
                self.d[i] = d;
                self.origin[i] = Origin::Return;
                self.ground_return[i] = on_ground;
            }
        }
    }

    /// Closes each column's gaps of at most `max_gap` rows between two returns: in inverse
    /// distance, linearly, where the two lie on one surface (their relative difference under a
    /// bound growing with the gap), else each side's distance to the gap's middle; but a gap
    /// between two returns of the ground that are not one surface by that bound (rings on a
    /// road seen at a grazing angle) is left to the ground model.
    fn fill_columns(&mut self, max_gap: usize) {
        let (w, h) = (self.width, self.height);
        for u in 0..w {
            let mut last: Option<usize> = None;
            for v in 0..h {
                let i = v * w + u;
                if self.origin[i] != Origin::Return {
                    continue;
                }
                if let Some(l) = last {
                    let gap = v - l - 1;
                    if gap > 0 && gap <= max_gap {
                        self.fill_column_gap(u, l, v);
                    }
                }
                last = Some(v);
            }
        }
    }

    /// Fills rows l+1..v of column u between the returns at rows l and v.
    fn fill_column_gap(&mut self, u: usize, l: usize, v: usize) {
        let w = self.width;
        let gap = v - l - 1;
        let (s0, s1) = (1.0 / self.d[l * w + u], 1.0 / self.d[v * w + u]);
        let rel = (s0 - s1).abs() / s0.max(s1);
        // the bound grows with the gap: a surface seen at a grazing angle (the road) changes
        // its distance along the column
        let one_surface = rel < 0.03 + 0.02 * gap as f32;
        if !one_surface && self.ground_return[l * w + u] && self.ground_return[v * w + u] {
            return;
        }
        for k in 1..=gap {
            let t = k as f32 / (gap + 1) as f32;
            let s = match (one_surface, t < 0.5) {
                (true, _) => s0 + t * (s1 - s0),
                (false, true) => s0,
                (false, false) => s1,
            };
            let j = (l + k) * w + u;
            self.d[j] = 1.0 / s;
            self.origin[j] = Origin::Fill;
        }
    }

    /// Closes short gaps along rows (columns the scan's azimuth step missed): the farther
    /// side's distance where the sides differ (a near surface is not widened), their inverse-
    /// distance mean where they agree.
    fn fill_rows(&mut self) {
        let (w, h) = (self.width, self.height);
        for v in 0..h {
            let row = v * w;
            let mut last: Option<usize> = None;
            for u in 0..w {
                if self.origin[row + u] == Origin::Empty {
                    continue;
                }
                if let Some(l) = last {
                    let gap = u - l - 1;
                    if gap > 0 && gap <= MAX_ROW_GAP {
                        let (d0, d1) = (self.d[row + l], self.d[row + u]);
                        let agree = (d0 - d1).abs() < 0.05 * d0.min(d1);
                        let d = if agree {
                            2.0 / (1.0 / d0 + 1.0 / d1)
                        } else {
                            d0.max(d1)
                        };
                        for k in l + 1..u {
                            self.d[row + k] = d;
                            self.origin[row + k] = Origin::Fill;
                        }
                    }
                }
                last = Some(u);
            }
        }
    }

    /// Above a column's top return, where that return lies on the scan's top ring (a surface
    /// taller than the ring reaches) above the horizon and not on a box: its distance carried
    /// up to the top. (A top return at or below the horizon is the ground's or a low
    /// object's: the sky above it stays the sky.)
    fn carry_up(&mut self, bearing: Bearings) {
        let (w, h) = (self.width, self.height);
        // the top ring's highest row: the first row holding returns in 2 % of the columns
        // (lone high returns aside); the frame's pitch moves a ring by a few rows
        let Some(top_ring) = (0..h).find(|&v| {
            (0..w)
                .filter(|&u| self.origin[v * w + u] == Origin::Return)
                .count()
                > w / 50
        }) else {
            return;
        };
        for u in 0..w {
            let Some(v) = (0..h).find(|&v| self.origin[v * w + u] != Origin::Empty) else {
                continue;
            };
            let on_box = (v..(v + 4).min(h)).any(|y| self.origin[y * w + u] == Origin::Box);
            // (the reference frame's y points down)
            let above_horizon = bearing.at(u as isize, v as isize).y < 0.0;
            if v <= top_ring + 8 && above_horizon && !on_box {
                let d = self.d[v * w + u];
                for k in 0..v {
                    self.d[k * w + u] = d;
                    self.origin[k * w + u] = Origin::Up;
                }
            }
        }
    }

    /// What is still empty: the ground where the ray meets it (under [`GROUND_LIMIT`]), else
    /// the far distance; a pixel without a bearing stays empty. The ground is cast at the
    /// corners of cells of [`GROUND_CELL`] pixels; a cell whose four corners all meet it takes
    /// 1/t interpolated bilinearly between them (the ground's 1/t is nearly linear across a
    /// cell: a plane's is linear in the bearing), the others cast every pixel.
    fn ground_and_far(&mut self, bearing: Bearings, scene: &GridScene) {
        let (w, h) = (self.width, self.height);
        let cast = |u: usize, v: usize| -> Option<f64> {
            let b = bearing.at(u as isize, v as isize);
            let ground = scene.ground.as_ref()?;
            (b.x.is_finite())
                .then(|| ground(&b))
                .flatten()
                .filter(|t| *t > 0.0 && *t < GROUND_LIMIT)
        };
        let (cw, ch) = (w.div_ceil(GROUND_CELL), h.div_ceil(GROUND_CELL));
        // the corners' casts, made on first use (positions up to the width and height: the
        // output's bearings reach one pixel beyond)
        let mut corners: Vec<Option<Option<f64>>> = vec![None; (cw + 1) * (ch + 1)];
        let mut corner = |i: usize, j: usize| {
            *corners[j * (cw + 1) + i]
                .get_or_insert_with(|| cast((i * GROUND_CELL).min(w), (j * GROUND_CELL).min(h)))
        };
        for cv in 0..ch {
            let rows = cv * GROUND_CELL..((cv + 1) * GROUND_CELL).min(h);
            for cu in 0..cw {
                let columns = cu * GROUND_CELL..((cu + 1) * GROUND_CELL).min(w);
                let empty = rows
                    .clone()
                    .any(|v| self.origin[v * w..][columns.clone()].contains(&Origin::Empty));
                if !empty {
                    continue;
                }
                let at = [
                    corner(cu, cv),
                    corner(cu + 1, cv),
                    corner(cu, cv + 1),
                    corner(cu + 1, cv + 1),
                ];
                let inverse = match at {
                    [Some(a), Some(b), Some(c), Some(d)] => {
                        Some([1.0 / a, 1.0 / b, 1.0 / c, 1.0 / d])
                    }
                    _ => None,
                };
                let (u0, v0) = (cu * GROUND_CELL, cv * GROUND_CELL);
                let (du, dv) = (
                    ((u0 + GROUND_CELL).min(w) - u0) as f64,
                    ((v0 + GROUND_CELL).min(h) - v0) as f64,
                );
                for v in rows.clone() {
                    for u in columns.clone() {
                        let i = v * w + u;
                        if self.origin[i] != Origin::Empty
                            || !bearing.at(u as isize, v as isize).x.is_finite()
                        {
                            continue;
                        }
                        let ground = match inverse {
                            Some([a, b, c, d]) => {
                                let (fx, fy) = ((u - u0) as f64 / du, (v - v0) as f64 / dv);
                                let top = a + (b - a) * fx;
                                let bottom = c + (d - c) * fx;
                                Some(1.0 / (top + (bottom - top) * fy))
                            }
                            None => cast(u, v),
                        };
                        (self.d[i], self.origin[i]) = match ground {
                            Some(t) => (t as f32, Origin::Ground),
                            None => (FAR_DISTANCE, Origin::Far),
                        };
                    }
                }
            }
        }
    }

    /// The box's faces, ray-cast exactly over its corners' bounding rectangle in the output;
    /// nearest wins. A box holding the centre, or one a corner of which the output cannot
    /// show, is left to the scan.
    fn raster_box(
        &mut self,
        output: &dyn CameraModel,
        bearing: Bearings,
        centre: &Vector3<f64>,
        b: &GridBox,
        id: u16,
        wraps: bool,
    ) {
        let (w, h) = (self.width as i64, self.height as i64);
        let rt = b.rotation.transpose();
        let o = rt * (centre - b.centre);
        if o.x.abs() < b.half.x && o.y.abs() < b.half.y && o.z.abs() < b.half.z {
            return;
        }
        let mut us = Vec::with_capacity(8);
        let (mut v0, mut v1) = (h, -1i64);
        for corner in b.corners() {
            let Ok(px) = output.project(&(corner - centre).normalize()) else {
                return;
            };
            us.push(px.x);
            v0 = v0.min(px.y.floor() as i64 - 1);
            v1 = v1.max(px.y.ceil() as i64 + 1);
        }
        if wraps {
            // a box across the turn's seam: its columns taken on one side of it
            let (lo, hi) = min_max(&us);
            if hi - lo > w as f64 / 2.0 {
                for u in us.iter_mut().filter(|u| **u < w as f64 / 2.0) {
                    *u += w as f64;
                }
            }
        }
        let (lo, hi) = min_max(&us);
        let (u0, u1) = (lo.floor() as i64 - 1, hi.ceil() as i64 + 1);
        let (u0, u1) = if wraps {
            (u0, u1.min(u0 + w - 1))
        } else {
            (u0.max(0), u1.min(w - 1))
        };
        for v in v0.max(0)..=v1.min(h - 1) {
            for uu in u0..=u1 {
                let u = uu.rem_euclid(w) as usize;
                let i = v as usize * self.width + u;
                let dir = bearing.at(u as isize, v as isize);
                if !dir.x.is_finite() {
                    continue;
                }
                if let Some(t) = slab(&o, &(rt * dir), &b.half) {
                    if self.origin[i] == Origin::Empty || (t as f32) < self.d[i] {
                        self.d[i] = t as f32;
                        self.origin[i] = Origin::Box;
                        self.box_id[i] = id;
                    }
                }
            }
        }
    }
}

fn min_max(values: &[f64]) -> (f64, f64) {
    values
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, c), &u| (a.min(u), c.max(u)))
}

/// The entry distance of the ray o + t·dir into the box |x| ≤ half (o outside it), if any.
pub(super) fn slab(o: &Vector3<f64>, dir: &Vector3<f64>, half: &Vector3<f64>) -> Option<f64> {
    let (mut t0, mut t1) = (0.0f64, f64::MAX);
    for k in 0..3 {
        if dir[k].abs() < 1e-12 {
            if o[k].abs() > half[k] {
                return None;
            }
            continue;
        }
        let (a, b) = ((-half[k] - o[k]) / dir[k], (half[k] - o[k]) / dir[k]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t0 <= t1 && t0 > 0.0).then_some(t0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Equirect, ImageSize, Intrinsics};
    use crate::warp::reach::OutputGrid;
    use nalgebra::Point2;
    use std::sync::Arc;

    /// A whole-sphere panorama of 1° pixels and its bearings.
    fn one_degree_panorama() -> (Equirect, Arc<OutputGrid>) {
        let f = 360.0 / (2.0 * std::f64::consts::PI);
        let output = Equirect::new(Intrinsics::new(f, f, 179.5, 89.5), ImageSize::new(360, 180));
        let grid = OutputGrid::of(&output);
        (output, grid)
    }

    /// The distance to a road 1.5 m under the centre along unit bearing `b` (y down).
    fn road(b: &Vector3<f64>) -> Option<f64> {
        (b.y > 1e-3).then(|| 1.5 / b.y)
    }

    /// A road 1.5 m under the centre seen at a grazing angle: two returns on it in one
    /// column, rows apart and far from one surface by the column fill's bound (1/t differs by
    /// more than half). Where they are the ground's, the pixels between take the ground's
    /// distance; as any other returns, each side's distance (the step the ground's returns
    /// made before: the cameras then sampled the road at a wrong distance).
    #[test]
    fn a_ring_gap_on_the_road_takes_the_ground_between_its_returns() {
        let (output, out_grid) = one_degree_panorama();
        let bearing = Bearings { grid: &out_grid };
        // (the reference frame's y points down: rows below the horizon, 2° and 7° down)
        let (u, rows) = (100usize, [91usize, 96]);
        let point = |v: usize| {
            let b = output
                .unproject(&Point2::new(u as f64, v as f64))
                .unwrap()
                .normalize();
            b * road(&b).unwrap()
        };
        let build = |on_ground: bool| {
            let scene = GridScene {
                points: rows.iter().map(|&v| point(v)).collect(),
                on_ground: vec![on_ground; 2],
                ground_normal: None,
                ring_spacing: 0.01,
                boxes: Vec::new(),
                ground: Some(Box::new(road)),
            };
            DistanceGrid::build(&output, bearing, &Vector3::zeros(), &scene, out_grid.step)
        };
        let (ground, other) = (build(true), build(false));
        for v in rows[0] + 1..rows[1] {
            let i = v * 360 + u;
            let b = bearing.at(u as isize, v as isize);
            let want = road(&b).unwrap() as f32;
            assert_eq!(ground.origin[i], Origin::Ground, "row {v}");
            assert!(
                (ground.d[i] - want).abs() < 0.01 * want,
                "row {v}: {} vs {want}",
                ground.d[i]
            );
            assert_eq!(other.origin[i], Origin::Fill, "row {v}");
            assert!(
                (other.d[i] - want).abs() > 0.1 * want,
                "row {v}: {} vs {want}",
                other.d[i]
            );
        }
        for v in rows {
            assert_eq!(ground.origin[v * 360 + u], Origin::Return);
        }
    }

    /// A return of the road 0.4 px below its pixel's centre, 2.5° under the horizon: the
    /// pixel takes the road's distance at its centre (the plane's grade moves it by 16 %
    /// there), where a return of anything else keeps its own.
    #[test]
    fn a_return_of_the_ground_gives_its_pixel_the_ground_at_the_centre() {
        let (output, out_grid) = one_degree_panorama();
        let bearing = Bearings { grid: &out_grid };
        let (u, v) = (100usize, 92usize);
        let off = output
            .unproject(&Point2::new(u as f64, v as f64 + 0.4))
            .unwrap()
            .normalize();
        let build = |on_ground: bool| {
            let scene = GridScene {
                points: vec![off * road(&off).unwrap()],
                on_ground: vec![on_ground],
                ground_normal: Some(-Vector3::y()),
                ring_spacing: 0.01,
                boxes: Vec::new(),
                ground: Some(Box::new(road)),
            };
            DistanceGrid::build(&output, bearing, &Vector3::zeros(), &scene, out_grid.step)
        };
        let i = v * 360 + u;
        let centre = road(&bearing.at(u as isize, v as isize)).unwrap();
        let own = road(&off).unwrap();
        assert!((centre / own - 1.0).abs() > 0.1, "{centre} {own}");
        let (ground, other) = (build(true), build(false));
        assert_eq!(ground.origin[i], Origin::Return);
        assert!(
            (ground.d[i] as f64 / centre - 1.0).abs() < 1e-6,
            "{}",
            ground.d[i]
        );
        assert!(
            (other.d[i] as f64 / own - 1.0).abs() < 1e-6,
            "{}",
            other.d[i]
        );
    }

    #[test]
    fn the_slab_test_meets_a_box_at_its_near_face() {
        let half = Vector3::new(1.0, 2.0, 3.0);
        let o = Vector3::new(0.0, 0.0, -10.0);
        let t = slab(&o, &Vector3::z(), &half).expect("a hit");
        assert!((t - 7.0).abs() < 1e-12, "{t}");
        assert!(slab(&o, &-Vector3::z(), &half).is_none());
        assert!(slab(&o, &Vector3::new(0.5, 0.0, 1.0).normalize(), &half).is_none());
    }
}
