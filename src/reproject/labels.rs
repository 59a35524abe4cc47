//! Boxes under a reprojection: 2D boxes recomputed from the exact projection of a 3D box's
//! corners ([`box_bounds`]) or from the outline of a source-pixel rectangle ([`rect_bounds`]).
//! The neutral annotations of a frame go through them in `source_box`.
//!
//! Straight 3D edges become curves in a panoramic image, so a box's extremes can lie inside an
//! edge rather than at a corner: every face edge is sampled and each extreme refined by a
//! golden-section search. Inside a face an extreme only occurs where the face meets the camera's
//! vertical axis (a box above or below the camera); that case is tested exactly. Geometry
//! behind a one-sided camera is clipped at a near plane first.

use crate::camera::{CameraModel, ProjectionReject};
use nalgebra::{Point2, Vector3};

/// Near plane (metres along the camera's front normal) for one-sided cameras.
const NEAR: f64 = 0.05;
const EDGE_SAMPLES: usize = 32;
const REFINE_STEPS: usize = 28;
/// Bisection steps for where an edge leaves the camera's domain (2^-40 of the edge).
const BOUNDARY_STEPS: usize = 40;
/// Grid of a face whose inside leaves the camera's domain: a coarse one to find out, then a
/// fine one along whose lines the domain's edge is bisected (the edge's image is the rim of
/// a fisheye's circle: 64 steps keep the rim's chords within ~0.1 px of it).
const FACE_PROBE: usize = 16;
const FACE_GRID: usize = 64;

/// Pixel bounds [left, top, right, bottom]; may extend beyond the image or be infinite.
pub type Bounds = [f64; 4];

struct Accumulator<'a> {
    camera: &'a dyn CameraModel,
    /// The camera's horizontal period, asked once.
    period: Option<f64>,
    /// Horizontal reference for unwrapping a periodic horizontal coordinate.
    reference_u: Option<f64>,
    bounds: Bounds,
}

impl<'a> Accumulator<'a> {
    fn new(camera: &'a dyn CameraModel) -> Self {
        Self {
            camera,
            period: camera.horizontal_period(),
            reference_u: None,
            bounds: [
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
            ],
        }
    }

    /// Pixel of a point, unwrapped next to the reference so a seam-crossing box stays whole.
    fn pixel(&self, p: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        let mut px = self.camera.project_point(p)?;
        px.x = self.unwrap(px.x);
        Ok(px)
    }

    fn unwrap(&self, u: f64) -> f64 {
        match (self.period, self.reference_u) {
            (Some(period), Some(r)) => r + rem_euclid(u - r + period / 2.0, period) - period / 2.0,
            _ => u,
        }
    }

    /// Objective `k` (0: −u, 1: −v, 2: u, 3: v) of a point: the coordinate of `pixel` that it
    /// compares, computed alone.
    fn objective(&self, k: usize, p: &Vector3<f64>) -> Option<f64> {
        let axis = k % 2;
        let c = self.camera.project_point_coordinate(p, axis).ok()?;
        let c = if axis == 0 { self.unwrap(c) } else { c };
        Some(if k < 2 { -c } else { c })
    }

    fn add(&mut self, px: Point2<f64>) {
        let b = &mut self.bounds;
        b[0] = b[0].min(px.x);
        b[1] = b[1].min(px.y);
        b[2] = b[2].max(px.x);
        b[3] = b[3].max(px.y);
    }

    /// Adds the projection of the segment p→q, with each coordinate's extremes refined.
    fn add_segment(&mut self, p: &Vector3<f64>, q: &Vector3<f64>) {
        let at = |t: f64| p + (q - p) * t;
        let samples: [Option<Point2<f64>>; EDGE_SAMPLES + 1] =
            std::array::from_fn(|i| self.pixel(&at(i as f64 / EDGE_SAMPLES as f64)).ok());
        for s in samples.iter().flatten() {
            self.add(*s);
        }
        // Where the segment leaves the camera's domain between two samples (a fisheye's field
        // of view), its image ends at the domain's edge: bisect for the last point with an image.
        for (i, pair) in samples.windows(2).enumerate() {
            if pair[0].is_some() == pair[1].is_some() {
                continue;
            }
            let (mut inside, mut outside) = (i as f64, (i + 1) as f64);
            if pair[0].is_none() {
                std::mem::swap(&mut inside, &mut outside);
            }
            let (mut inside, mut outside) =
                (inside / EDGE_SAMPLES as f64, outside / EDGE_SAMPLES as f64);
            for _ in 0..BOUNDARY_STEPS {
                let mid = 0.5 * (inside + outside);
                if self.pixel(&at(mid)).is_ok() {
                    inside = mid;
                } else {
                    outside = mid;
                }
            }
            if let Ok(px) = self.pixel(&at(inside)) {
                self.add(px);
            }
        }
        // objective k: 0 → -u, 1 → -v, 2 → u, 3 → v (maximised)
        for k in 0..4 {
            let value = |px: &Point2<f64>| match k {
                0 => -px.x,
                1 => -px.y,
                2 => px.x,
                _ => px.y,
            };
            let best = samples
                .iter()
                .enumerate()
                .filter_map(|(i, s)| s.map(|s| (i, value(&s))))
                .max_by(|a, b| a.1.total_cmp(&b.1));
            let Some((i, _)) = best else { continue };
            let lo = i.saturating_sub(1) as f64 / EDGE_SAMPLES as f64;
            let hi = (i + 1).min(EDGE_SAMPLES) as f64 / EDGE_SAMPLES as f64;
            let f = |t: f64| self.objective(k, &at(t));
            if let Some(t) = golden_max(&f, lo, hi) {
                if let Ok(px) = self.pixel(&at(t)) {
                    self.add(px);
                }
            }
        }
    }
}

impl Accumulator<'_> {
    /// Adds the points where the face (a parallelogram p0 p1 p2 p3) leaves the camera's
    /// domain, bisected along the lines of a grid over it; only points in front of the near
    /// plane count.
    fn add_domain_edge(&mut self, face: &[Vector3<f64>; 4], front: Option<Vector3<f64>>) {
        let [p0, p1, _, p3] = *face;
        let at = |s: f64, t: f64| p0 + (p1 - p0) * s + (p3 - p0) * t;
        let usable = |p: &Vector3<f64>| front.is_none_or(|n| n.dot(p) >= NEAR);
        // None: behind the near plane; Some(ok): whether the point has a pixel.
        let probe = |s: f64, t: f64| {
            let p = at(s, t);
            usable(&p).then(|| self.pixel(&p).is_ok())
        };
        let grid = |n: usize| -> Vec<Vec<Option<bool>>> {
            (0..=n)
                .map(|j| {
                    (0..=n)
                        .map(|i| probe(i as f64 / n as f64, j as f64 / n as f64))
                        .collect()
                })
                .collect()
        };
        let coarse = grid(FACE_PROBE);
        if !coarse.iter().flatten().any(|p| *p == Some(false)) {
            return;
        }
        let n = FACE_GRID;
        let fine = grid(n);
        let coords = |i: usize, j: usize| (i as f64 / n as f64, j as f64 / n as f64);
        let mut found = Vec::new();
        for j in 0..=n {
            for i in 0..n {
                // along s (row j) and along t (column j)
                for (a, b) in [((i, j), (i + 1, j)), ((j, i), (j, i + 1))] {
                    let (pa, pb) = (fine[a.1][a.0], fine[b.1][b.0]);
                    let (mut inside, mut outside) = match (pa, pb) {
                        (Some(true), Some(false)) => (coords(a.0, a.1), coords(b.0, b.1)),
                        (Some(false), Some(true)) => (coords(b.0, b.1), coords(a.0, a.1)),
                        _ => continue,
                    };
                    for _ in 0..BOUNDARY_STEPS {
                        let mid = ((inside.0 + outside.0) / 2.0, (inside.1 + outside.1) / 2.0);
                        if probe(mid.0, mid.1) == Some(true) {
                            inside = mid;
                        } else {
                            outside = mid;
                        }
                    }
                    found.push(at(inside.0, inside.1));
                }
            }
        }
        for p in found {
            if let Ok(px) = self.pixel(&p) {
                self.add(px);
            }
        }
    }
}

/// `x.rem_euclid(period)` without `fmod` where its result is known exactly: x itself on
/// [0, period), x − period on [period, 2·period) (exact there), x + period on (−period, 0)
/// (`rem_euclid` adds period to fmod's x there).
#[inline]
fn rem_euclid(x: f64, period: f64) -> f64 {
    if !(period > 0.0) {
        x.rem_euclid(period)
    } else if (0.0..period).contains(&x) {
        x
    } else if x >= period && x < 2.0 * period {
        x - period
    } else if x < 0.0 && x > -period {
        x + period
    } else {
        x.rem_euclid(period)
    }
}

/// Maximises f on [lo, hi] (assumed unimodal there); None if f is undefined at the probes.
fn golden_max(f: &impl Fn(f64) -> Option<f64>, mut lo: f64, mut hi: f64) -> Option<f64> {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let mut x1 = hi - g * (hi - lo);
    let mut x2 = lo + g * (hi - lo);
    let (mut f1, mut f2) = (f(x1)?, f(x2)?);
    for _ in 0..REFINE_STEPS {
        if f1 < f2 {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = f(x2)?;
        } else {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = f(x1)?;
        }
    }
    Some((lo + hi) / 2.0)
}

/// Clips a convex polygon to n·p >= d (Sutherland–Hodgman against one plane).
fn clip_polygon(poly: &[Vector3<f64>], n: &Vector3<f64>, d: f64) -> Vec<Vector3<f64>> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let (da, db) = (n.dot(&a) - d, n.dot(&b) - d);
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

const FACES: [[usize; 4]; 6] = [
    [0, 1, 2, 3],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [3, 0, 4, 7],
];

/// Where the camera's vertical axis (through the centre, along y) meets a convex planar
/// polygon, if it does.
fn vertical_axis_hit(poly: &[Vector3<f64>]) -> Option<Vector3<f64>> {
    // Work in the x-z plane: the axis is the point (0, 0); test containment, then find y on the plane.
    let n = (poly[1] - poly[0]).cross(&(poly[2] - poly[0]));
    if n.y.abs() < 1e-12 * n.norm() {
        return None;
    }
    let mut sign = 0.0;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let cross = (b.x - a.x) * (-a.z) - (b.z - a.z) * (-a.x);
        if cross.abs() < 1e-15 {
            continue;
        }
        if sign == 0.0 {
            sign = cross.signum();
        } else if cross.signum() != sign {
            return None;
        }
    }
    // plane: n·(p - poly[0]) = 0 with p = (0, y, 0)
    let y = n.dot(&poly[0]) / n.y;
    Some(Vector3::new(0.0, y, 0.0))
}

/// Unclipped pixel bounds of a 3D box (corners relative to the camera centre, camera axes).
pub fn box_bounds(corners: &[Vector3<f64>; 8], camera: &dyn CameraModel) -> Option<Bounds> {
    let mut acc = Accumulator::new(camera);
    let centroid = corners.iter().sum::<Vector3<f64>>() / 8.0;
    acc.reference_u = camera
        .project_point(&centroid)
        .ok()
        .or_else(|| corners.iter().find_map(|c| camera.project_point(c).ok()))
        .map(|p| p.x);
    let front = camera.front_halfspace();
    // Each edge of a box borders two faces: collected first so that it is projected once.
    let mut edges = Vec::with_capacity(24);
    for face in FACES {
        let quad: Vec<Vector3<f64>> = face.iter().map(|&i| corners[i]).collect();
        let poly = match front {
            Some(n) => clip_polygon(&quad, &n, NEAR),
            None => quad,
        };
        if poly.len() < 3 {
            continue;
        }
        for i in 0..poly.len() {
            edges.push(Edge::new(poly[i], poly[(i + 1) % poly.len()]));
        }
        // A panorama (u an angle about the vertical axis) sees a face crossing that axis at
        // every azimuth; a fisheye has no such axis.
        if camera.horizontal_period().is_some() {
            if let Some(hit) = vertical_axis_hit(&poly) {
                // The box spans every azimuth around the camera's vertical axis.
                acc.bounds[0] = f64::NEG_INFINITY;
                acc.bounds[2] = f64::INFINITY;
                match camera.project_point(&hit) {
                    Ok(px) => acc.add(px),
                    Err(_) if hit.y < 0.0 => acc.bounds[1] = f64::NEG_INFINITY,
                    Err(_) => acc.bounds[3] = f64::INFINITY,
                }
            }
        }
    }
    edges.sort_by(Edge::order);
    edges.dedup();
    for e in &edges {
        acc.add_segment(&e.0, &e.1);
    }
    // A fisheye's field of view can cut a face inside: that part of its outline is the rim of
    // the fisheye's circle, which the edges never reach. A camera that sees its whole front
    // half-space has no such rim, and is not probed: within 5 km, a point with n·p >= NEAR has
    // n·p >= 1e-5·|p|, ten times what the camera promises to see.
    let sees_every_face_point = front.is_some()
        && camera.sees_whole_front()
        && corners.iter().all(|c| c.norm() <= NEAR * 1e5);
    if camera.horizontal_period().is_none() && !sees_every_face_point {
        for face in FACES {
            acc.add_domain_edge(&face.map(|i| corners[i]), front);
        }
    }
    let b = acc.bounds;
    (b[0] <= b[2] && b[1] <= b[3]).then_some(b)
}

/// A segment with its ends in a fixed order, so that the two faces sharing an edge give the
/// same value (and the bounds do not depend on the direction an edge is walked).
#[derive(PartialEq)]
struct Edge(Vector3<f64>, Vector3<f64>);

impl Edge {
    fn new(p: Vector3<f64>, q: Vector3<f64>) -> Self {
        if Self::point_order(&p, &q).is_le() {
            Self(p, q)
        } else {
            Self(q, p)
        }
    }

    fn point_order(p: &Vector3<f64>, q: &Vector3<f64>) -> std::cmp::Ordering {
        p.iter()
            .zip(q.iter())
            .map(|(a, b)| a.total_cmp(b))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
    }

    fn order(a: &Self, b: &Self) -> std::cmp::Ordering {
        Self::point_order(&a.0, &b.0).then_with(|| Self::point_order(&a.1, &b.1))
    }
}

/// Unclipped bounds of the image of a source-pixel rectangle, mapped through `map` (source
/// pixel → output pixel), by its boundary.
pub fn rect_bounds(
    rect: [f64; 4],
    map: &dyn Fn(Point2<f64>) -> Option<Point2<f64>>,
    period: Option<f64>,
) -> Option<Bounds> {
    let [l, t, r, b] = rect;
    let n = 64;
    let mut pts = Vec::with_capacity(4 * (n + 1));
    for i in 0..=n {
        let s = i as f64 / n as f64;
        pts.push(Point2::new(l + (r - l) * s, t));
        pts.push(Point2::new(l + (r - l) * s, b));
        pts.push(Point2::new(l, t + (b - t) * s));
        pts.push(Point2::new(r, t + (b - t) * s));
    }
    let centre = map(Point2::new((l + r) / 2.0, (t + b) / 2.0)).map(|p| p.x);
    let mut out = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for p in pts {
        if let Some(mut q) = map(p) {
            if let (Some(period), Some(c)) = (period, centre) {
                q.x = c + rem_euclid(q.x - c + period / 2.0, period) - period / 2.0;
            }
            out[0] = out[0].min(q.x);
            out[1] = out[1].min(q.y);
            out[2] = out[2].max(q.x);
            out[3] = out[3].max(q.y);
        }
    }
    (out[0] <= out[2]).then_some(out)
}

/// Clips bounds to KITTI's box range [0, w-1] × [0, h-1]; None when nothing is left.
pub fn clip(b: Bounds, width: u32, height: u32) -> Option<Bounds> {
    let (wm, hm) = ((width - 1) as f64, (height - 1) as f64);
    let c = [b[0].max(0.0), b[1].max(0.0), b[2].min(wm), b[3].min(hm)];
    (b[0] <= wm && b[2] >= 0.0 && b[1] <= hm && b[3] >= 0.0 && c[0] <= c[2] && c[1] <= c[3])
        .then_some(c)
}

/// Fraction of the unclipped box's area that clipping removed.
pub fn clipped_fraction(unclipped: Bounds, clipped: Bounds) -> f64 {
    let area = |b: Bounds| (b[2] - b[0]).max(0.0) * (b[3] - b[1]).max(0.0);
    let full = area(unclipped);
    if !full.is_finite() {
        return 1.0;
    }
    if full <= 0.0 {
        return 0.0;
    }
    (1.0 - area(clipped) / full).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{
        rotation_ypr, Cylindrical, Equirect, FisheyeCamera, ImageSize, Intrinsics, Lens,
        Perspective, Rotated,
    };
    use nalgebra::{Matrix3, Rotation3};

    /// A camera's projection alone: the trait's defaults for everything else, so `box_bounds`
    /// probes every face and projects both coordinates at each probe, as the search is defined.
    #[derive(Debug)]
    struct Plain<'a>(&'a dyn CameraModel);

    impl CameraModel for Plain<'_> {
        fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
            self.0.project(d)
        }
        fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
            self.0.unproject(p)
        }
        fn distance(&self, p: &Vector3<f64>) -> f64 {
            self.0.distance(p)
        }
        fn size(&self) -> crate::camera::ImageSize {
            self.0.size()
        }
        fn front_halfspace(&self) -> Option<Vector3<f64>> {
            self.0.front_halfspace()
        }
        fn horizontal_period(&self) -> Option<f64> {
            self.0.horizontal_period()
        }
    }

    /// xorshift64: uniform in [0, 1).
    fn uniform(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Boxes ahead, anywhere, around the camera, above or below it and behind it, upright or
    /// turned about every axis.
    fn random_boxes(n: usize) -> Vec<[Vector3<f64>; 8]> {
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        let mut r = |a: f64, b: f64| a + (b - a) * uniform(&mut s);
        (0..n)
            .map(|i| {
                let centre = match i % 5 {
                    0 => Vector3::new(r(-10.0, 10.0), r(-1.0, 3.0), r(2.0, 60.0)),
                    1 => Vector3::new(r(-30.0, 30.0), r(-5.0, 5.0), r(-30.0, 30.0)),
                    2 => Vector3::new(r(-2.0, 2.0), r(-2.0, 2.0), r(-2.0, 2.0)),
                    3 => Vector3::new(r(-1.0, 1.0), r(-8.0, 8.0), r(-1.0, 1.0)),
                    _ => Vector3::new(r(-10.0, 10.0), r(-2.0, 2.0), r(-40.0, -1.0)),
                };
                let half = Vector3::new(r(0.15, 2.5), r(0.15, 1.5), r(0.15, 2.5));
                let rotation = if i % 3 == 0 {
                    Rotation3::from_euler_angles(r(-3.2, 3.2), r(-3.2, 3.2), r(-3.2, 3.2))
                } else {
                    Rotation3::from_axis_angle(&Vector3::y_axis(), r(-3.2, 3.2))
                };
                let (xs, zs) = ([1.0, 1.0, -1.0, -1.0], [1.0, -1.0, -1.0, 1.0]);
                std::array::from_fn(|j| {
                    let y = if j < 4 { 1.0 } else { -1.0 };
                    let local = Vector3::new(xs[j % 4], y, zs[j % 4]).component_mul(&half);
                    centre + rotation * local
                })
            })
            .collect()
    }

    #[test]
    fn the_bounds_are_bit_for_bit_those_of_the_full_search() {
        let k = Intrinsics::new(160.0, 160.0, 503.5, 180.5);
        let size = ImageSize::new(1008, 362);
        let kitti = Intrinsics::new(721.5, 721.5, 609.6, 172.9);
        let kitti_size = ImageSize::new(1242, 375);
        let lens = Lens::from_parameters(
            "kannala_brandt",
            Intrinsics::new(300.0, 300.0, 639.5, 482.5),
            &[0.01, -0.002, 0.0005, -0.0001],
            ImageSize::new(1280, 966),
            80f64.to_radians(),
        )
        .unwrap();
        let cameras: Vec<Box<dyn CameraModel>> = vec![
            Box::new(Equirect::new(k, size)),
            Box::new(Cylindrical::new(k, size)),
            Box::new(Perspective::new(kitti, kitti_size)),
            Box::new(Rotated::new(
                Perspective::new(kitti, kitti_size),
                rotation_ypr(-0.5, 0.1, 0.2),
            )),
            Box::new(FisheyeCamera {
                lens,
                rect_from_camera: Matrix3::identity(),
            }),
        ];
        let boxes = random_boxes(600);
        for camera in &cameras {
            let mut seen = 0;
            for corners in &boxes {
                let got = box_bounds(corners, camera.as_ref());
                let want = box_bounds(corners, &Plain(camera.as_ref()));
                let bits = |b: Option<Bounds>| b.map(|b| b.map(f64::to_bits));
                assert_eq!(bits(got), bits(want), "{camera:?} {corners:?}");
                seen += usize::from(got.is_some());
            }
            // most boxes have an image: the comparison is not of Nones
            assert!(seen > boxes.len() / 2, "{camera:?}: {seen}");
        }
    }

    #[test]
    fn rem_euclid_is_the_standard_one_bit_for_bit() {
        let mut s = 7u64;
        for period in [
            2.0 * std::f64::consts::PI * 160.0,
            1.0,
            1e-3,
            3e9,
            -5.0,
            0.0,
        ] {
            let edges = [
                0.0,
                -0.0,
                period,
                -period,
                2.0 * period,
                -2.0 * period,
                period / 2.0,
                1e300,
                -1e300,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NAN,
                f64::MIN_POSITIVE,
            ];
            let near = edges.iter().flat_map(|&x| [x, x.next_up(), x.next_down()]);
            let random = (0..2000).map(|_| (uniform(&mut s) * 6.0 - 3.0) * period);
            for x in near.chain(random) {
                let (got, want) = (rem_euclid(x, period), x.rem_euclid(period));
                assert!(
                    got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                    "{x} mod {period}: {got} vs {want}"
                );
            }
        }
    }
}
