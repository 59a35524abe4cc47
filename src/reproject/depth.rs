//! Sparse LiDAR depth in the output projection, with occlusion correction.
//!
//! Points go to rect with R0_rect·Tr_velo_to_cam, then into the output camera about its centre
//! C; the depth of a pixel is the projection's own distance (z, range or rho) of its nearest
//! point. Only points the source camera could see (inside its image) are kept.
//!
//! Occlusion: the LiDAR sits ~8 cm above and ~27 cm behind the camera and sees surfaces the
//! camera cannot; seen from the camera they fall *between* the scan lines of the nearer surface
//! that hides them. Following Kumar et al., points are split into depth layers and each layer is
//! dilated; a point is dropped when a layer more than `min_gap` nearer covers its pixel. Made
//! right for the target projection: the dilation window is the LiDAR's angular sampling (beam
//! and azimuth spacing, times a margin) converted to output pixels with the camera's local
//! pixels-per-radian at that pixel, so it is the same angular size in every projection and at
//! every place in the image.

use crate::camera::{pinhole_point_lanes, CameraModel, Intrinsics};
use nalgebra::{Point2, Vector3};

/// Parameters of the occlusion filter (defaults for a Velodyne HDL-64E, as KITTI).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct OcclusionFilter {
    /// Angle between LiDAR beams (vertical), radians.
    pub beam_spacing: f64,
    /// Angle between successive firings of a beam (horizontal), radians.
    pub azimuth_spacing: f64,
    /// The window covers this many spacings each side of a point.
    pub margin: f64,
    /// A nearer layer hides a point only if it is nearer by this fraction of the point's depth.
    pub min_gap: f64,
    /// Relative thickness of a depth layer.
    pub layer_ratio: f64,
}

impl Default for OcclusionFilter {
    fn default() -> Self {
        Self {
            beam_spacing: 0.4f64.to_radians(),
            azimuth_spacing: 0.09f64.to_radians(),
            margin: 1.5,
            min_gap: 0.1,
            layer_ratio: 0.05,
        }
    }
}

/// A depth map: `values[v * width + u]` in metres, 0 where there is no point.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthMap {
    /// Width of the map, pixels (the output camera's).
    pub width: u32,
    /// Height of the map, pixels.
    pub height: u32,
    /// Per pixel, row-major: the projection's own distance (z, range or rho) of its nearest
    /// point, metres; 0 where there is none.
    pub values: Vec<f64>,
}

impl DepthMap {
    /// The 16-bit KITTI encoding: round(d·256), 0 = none. A distance past what 16 bits hold
    /// (255.998 m, a long-range LiDAR's returns) is written as none: clamped, it would read as
    /// a false 255.996 m.
    pub fn to_u16(&self) -> Vec<u16> {
        self.values.iter().map(|&d| encode(d)).collect()
    }

    /// Number of pixels whose depth is written ([`DepthMap::to_u16`] not 0).
    pub fn valid(&self) -> usize {
        self.values.iter().filter(|&&d| encode(d) != 0).count()
    }
}

/// round(d·256) where it fits 16 bits, else 0 (none).
fn encode(d: f64) -> u16 {
    let v = (d * 256.0).round();
    if v > 0.0 && v <= f64::from(u16::MAX) {
        v as u16
    } else {
        0
    }
}

/// A point as the output camera sees it.
#[derive(Debug, Clone, Copy)]
struct Projected {
    u: u32,
    v: u32,
    depth: f64,
}

/// Projects LiDAR points (`rect`, already in the rect frame) into `output` (centre `centre`),
/// keeping points the `source` camera (same centre and axes) sees inside its image; nearest
/// point per pixel; optional occlusion filter. Returns the map and how many points the filter
/// dropped.
pub fn depth_map(
    rect: impl IntoIterator<Item = Vector3<f64>>,
    centre: &Vector3<f64>,
    output: &dyn CameraModel,
    source: &dyn CameraModel,
    filter: Option<&OcclusionFilter>,
) -> (DepthMap, usize) {
    let mut points = DepthPoints::new(centre, output, source);
    for p in rect {
        points.push(p);
    }
    points.finish(filter)
}

/// [`depth_map`] a point at a time, for points read as a stream (a scan file's chunks): `push`
/// each point (or `push_columns` many), then `finish`.
pub struct DepthPoints<'a> {
    centre: Vector3<f64>,
    output: &'a dyn CameraModel,
    source: &'a dyn CameraModel,
    /// The source's intrinsics where it is a pinhole: its test then takes [`LANES`] points
    /// at once.
    pinhole: Option<Intrinsics>,
    front: Option<Vector3<f64>>,
    /// With `pinhole`: points pushed one by one (x, y, z in rect) waiting for their test.
    pending: [Vec<f64>; 3],
    /// With `pinhole`: scratch, the source pixels (u, v) of the columns under test.
    pixels: [Vec<f64>; 2],
    projected: Vec<Projected>,
}

impl<'a> DepthPoints<'a> {
    /// Points about `centre` into `output`, those `source` sees.
    pub fn new(
        centre: &Vector3<f64>,
        output: &'a dyn CameraModel,
        source: &'a dyn CameraModel,
    ) -> Self {
        Self {
            centre: *centre,
            output,
            source,
            pinhole: source.pinhole(),
            front: source.front_halfspace(),
            pending: Default::default(),
            pixels: Default::default(),
            projected: Vec::new(),
        }
    }

    /// One point, in rect.
    #[inline]
    pub fn push(&mut self, p: Vector3<f64>) {
        // the source first: a scan all around meets a camera's image with a fraction of its
        // points, and a pinhole source's test is a division where a panorama's is trigonometry
        if self.pinhole.is_some() {
            for (column, v) in self.pending.iter_mut().zip([p.x, p.y, p.z]) {
                column.push(v);
            }
            if self.pending[0].len() == PENDING {
                self.flush();
            }
            return;
        }
        let rel = p - self.centre;
        // half of a scan all around lies behind a front-only source: a dot product says so
        // before the projection does
        if self.front.is_some_and(|n| behind(&n, &rel)) {
            return;
        }
        if matches!(self.source.project_point(&rel), Ok(px) if self.source.contains(&px)) {
            self.land(&rel);
        }
    }

    /// Points in rect as columns (x, y, z), in order: [`DepthPoints::push`] of each, a pinhole
    /// source's test taken over the whole columns in lanes.
    pub fn push_columns(&mut self, [x, y, z]: [&[f64]; 3]) {
        let n = x.len().min(y.len()).min(z.len());
        let Some(k) = self.pinhole else {
            for i in 0..n {
                self.push(Vector3::new(x[i], y[i], z[i]));
            }
            return;
        };
        // (the points pushed one by one come first)
        self.flush();
        self.seen_by_pinhole(&k, [&x[..n], &y[..n], &z[..n]]);
    }

    /// The pending points through the pinhole source's test.
    fn flush(&mut self) {
        let Some(k) = self.pinhole else {
            return;
        };
        let mut pending = std::mem::take(&mut self.pending);
        let [x, y, z] = &pending;
        self.seen_by_pinhole(&k, [x, y, z]);
        pending.iter_mut().for_each(Vec::clear);
        self.pending = pending;
    }

    /// Lands each of the points (columns, rect) that the pinhole source of intrinsics `k` sees.
    fn seen_by_pinhole(&mut self, k: &Intrinsics, [x, y, z]: [&[f64]; 3]) {
        let mut pixels = std::mem::take(&mut self.pixels);
        pinhole_columns(k, &self.centre, [x, y, z], &mut pixels);
        let [u, v] = &pixels;
        for i in 0..x.len() {
            if !u[i].is_nan() && self.source.contains(&Point2::new(u[i], v[i])) {
                self.land(&(Vector3::new(x[i], y[i], z[i]) - self.centre));
            }
        }
        self.pixels = pixels;
    }

    /// Keeps a point the source sees where it lands on the output.
    fn land(&mut self, rel: &Vector3<f64>) {
        let size = self.output.size();
        let Ok(px) = self.output.project_point(rel) else {
            return;
        };
        let (u, v) = (px.x.round(), px.y.round());
        if u < 0.0 || v < 0.0 || u >= size.width as f64 || v >= size.height as f64 {
            return;
        }
        let depth = self.output.distance(rel);
        if depth > 0.0 && depth.is_finite() {
            self.projected.push(Projected {
                u: u as u32,
                v: v as u32,
                depth,
            });
        }
    }

    /// The map, and how many points the occlusion filter dropped.
    pub fn finish(mut self, filter: Option<&OcclusionFilter>) -> (DepthMap, usize) {
        self.flush();
        let (output, mut projected) = (self.output, self.projected);
        let size = output.size();
        let mut dropped = 0;
        if let Some(f) = filter {
            let keep = occlusion_mask(&projected, output, f);
            dropped = keep.iter().filter(|k| !**k).count();
            projected = projected
                .into_iter()
                .zip(keep)
                .filter(|(_, k)| *k)
                .map(|(p, _)| p)
                .collect();
        }
        let mut values = vec![0.0; size.width as usize * size.height as usize];
        for p in &projected {
            let slot = &mut values[(p.v * size.width + p.u) as usize];
            if *slot == 0.0 || p.depth < *slot {
                *slot = p.depth;
            }
        }
        (
            DepthMap {
                width: size.width,
                height: size.height,
                values,
            },
            dropped,
        )
    }
}

/// Points a pinhole source tests at once ([`pinhole_point_lanes`]): the lanes overlap the
/// latency of a square root and three divisions a point.
const LANES: usize = 8;

/// Points pushed one by one that wait for a pinhole source's test.
const PENDING: usize = 1024;

/// The source pixels (u, v) into `out` of points (x, y, z columns, rect) about the centre
/// `centre` of a pinhole source of intrinsics `k`, [`LANES`] at a time: `project_point` of
/// `p - centre` ([`pinhole_point_lanes`]), NaN u where it rejects.
fn pinhole_columns(
    k: &Intrinsics,
    centre: &Vector3<f64>,
    columns: [&[f64]; 3],
    out: &mut [Vec<f64>; 2],
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the processor has AVX2 (checked just above).
        return unsafe { pinhole_columns_avx2(k, centre, columns, out) };
    }
    pinhole_columns_any(k, centre, columns, out)
}

/// [`pinhole_columns`] for AVX2.
///
/// # Safety
///
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn pinhole_columns_avx2(
    k: &Intrinsics,
    centre: &Vector3<f64>,
    columns: [&[f64]; 3],
    out: &mut [Vec<f64>; 2],
) {
    pinhole_columns_any(k, centre, columns, out)
}

#[inline(always)]
fn pinhole_columns_any(
    k: &Intrinsics,
    centre: &Vector3<f64>,
    columns: [&[f64]; 3],
    out: &mut [Vec<f64>; 2],
) {
    let n = columns[0].len();
    for o in out.iter_mut() {
        o.clear();
        o.resize(n.next_multiple_of(LANES), f64::NAN);
    }
    let c = [centre.x, centre.y, centre.z];
    for first in (0..n).step_by(LANES) {
        let m = LANES.min(n - first);
        // (lanes past the columns' end: the origin, rejected)
        let lane = |a: usize| -> [f64; LANES] {
            std::array::from_fn(|i| {
                if i < m {
                    columns[a][first + i] - c[a]
                } else {
                    0.0
                }
            })
        };
        let [u, v] = pinhole_point_lanes(k, [lane(0), lane(1), lane(2)]);
        out[0][first..first + LANES].copy_from_slice(&u);
        out[1][first..first + LANES].copy_from_slice(&v);
    }
}

/// Whether `p` lies more than [`BEHIND`] radians behind the plane of the unit normal `n` of a
/// camera's [`CameraModel::front_halfspace`]: no pixel, whatever the model's rounding at its
/// domain's edge (a lens seeing exactly 90° keeps bearings up to 1e-12 relative past it).
#[inline(always)]
fn behind(n: &Vector3<f64>, p: &Vector3<f64>) -> bool {
    let dot = n.dot(p);
    dot < 0.0 && dot * dot > BEHIND * BEHIND * p.norm_squared()
}

/// See [`behind`]: far beyond every model's rounding, far below a LiDAR's angular spacing.
const BEHIND: f64 = 1e-9;

/// Pixels per radian of `camera` around pixel (u, v), horizontally and vertically.
fn pixels_per_radian(camera: &dyn CameraModel, u: f64, v: f64) -> (f64, f64) {
    let angle = |a: Point2<f64>, b: Point2<f64>| -> Option<f64> {
        let (da, db) = (camera.unproject(&a).ok()?, camera.unproject(&b).ok()?);
        Some(da.cross(&db).norm().atan2(da.dot(&db)))
    };
    let h = angle(Point2::new(u - 0.5, v), Point2::new(u + 0.5, v)).unwrap_or(0.0);
    let w = angle(Point2::new(u, v - 0.5), Point2::new(u, v + 0.5)).unwrap_or(0.0);
    (
        if h > 0.0 { 1.0 / h } else { 0.0 },
        if w > 0.0 { 1.0 / w } else { 0.0 },
    )
}

/// Which points survive the layered occlusion test.
fn occlusion_mask(
    points: &[Projected],
    camera: &dyn CameraModel,
    f: &OcclusionFilter,
) -> Vec<bool> {
    let size = camera.size();
    let (w, h) = (size.width as usize, size.height as usize);
    // Layer index by log-depth: thin layers, so a surface is never compared with itself.
    let layer = |d: f64| (d.max(0.1).ln() / (1.0 + f.layer_ratio).ln()).floor() as i64;
    // The nearest depth per pixel of each point's own layer is enough: for every pixel keep the
    // nearest point depth, then dilate that image with a per-pixel window (a nearer layer's
    // dilation is a min-filter over depths from nearer layers).
    let mut nearest = vec![f64::INFINITY; w * h];
    for p in points {
        let i = p.v as usize * w + p.u as usize;
        nearest[i] = nearest[i].min(p.depth);
    }
    // Window half-sizes in pixels, evaluated on a coarse grid (they vary slowly).
    const CELL: usize = 16;
    let (gw, gh) = (w.div_ceil(CELL), h.div_ceil(CELL));
    let mut radius = vec![(0i64, 0i64); gw * gh];
    for gy in 0..gh {
        for gx in 0..gw {
            let (u, v) = (
                (gx * CELL + CELL / 2).min(w - 1),
                (gy * CELL + CELL / 2).min(h - 1),
            );
            let (ppr_u, ppr_v) = pixels_per_radian(camera, u as f64, v as f64);
            radius[gy * gw + gx] = (
                (f.margin * f.azimuth_spacing * ppr_u).ceil() as i64,
                (f.margin * f.beam_spacing * ppr_v).ceil() as i64,
            );
        }
    }
    points
        .iter()
        .map(|p| {
            let (rx, ry) = radius[(p.v as usize / CELL) * gw + p.u as usize / CELL];
            let limit = p.depth * (1.0 - f.min_gap);
            let rows =
                (p.v as i64 - ry).max(0) as usize..=(p.v as i64 + ry).min(h as i64 - 1) as usize;
            let columns =
                (p.u as i64 - rx).max(0) as usize..=(p.u as i64 + rx).min(w as i64 - 1) as usize;
            let window = || rows.clone().map(|y| &nearest[y * w..][columns.clone()]);
            // the window's nearest first, without a branch a pixel: most points have no nearer
            // return beside them, and then none hides them
            let least = window().fold(f64::INFINITY, |m, row| row.iter().fold(m, |m, &d| m.min(d)));
            if !(least < limit) {
                return true;
            }
            // (a logarithm each, taken only for a point a nearer one may hide)
            let own = layer(p.depth);
            !window().flatten().any(|&d| d < limit && layer(d) < own)
        })
        .collect()
}

#[cfg(test)]
mod encoding_tests {
    use super::*;

    #[test]
    fn distances_past_16_bits_are_written_as_none_not_clamped() {
        let map = DepthMap {
            width: 6,
            height: 1,
            values: vec![0.0, 1.0, 255.99, 255.998, 256.5, 306.0],
        };
        assert_eq!(map.to_u16(), vec![0, 256, 65533, 65535, 0, 0]);
        assert_eq!(map.valid(), 3);
    }
}

#[cfg(test)]
mod source_tests {
    use super::*;
    use crate::camera::{
        rotation_ypr, Fisheye, ImageSize, Intrinsics, MeiDistortion, Perspective, RadialModel,
        Rotated, Unified,
    };
    use std::f64::consts::FRAC_PI_2;

    /// The front-only sources: a pinhole, a turned one, lenses seeing exactly 90°.
    fn sources() -> Vec<Box<dyn CameraModel>> {
        let size = ImageSize::new(800, 600);
        let k = Intrinsics::new(250.0, 240.0, 399.5, 299.5);
        let mei = MeiDistortion {
            k1: -0.1,
            k2: 0.02,
            p1: 1e-3,
            p2: -1e-3,
        };
        vec![
            Box::new(Perspective::new(k, size)),
            Box::new(Rotated::new(
                Perspective::new(k, size),
                rotation_ypr(0.7, -0.3, 0.2),
            )),
            Box::new(Fisheye::new(RadialModel::Equidistant, k, size, FRAC_PI_2).unwrap()),
            Box::new(Unified::new(0.9, mei, k, 0.0, size, FRAC_PI_2).unwrap()),
        ]
    }

    /// Draws in [-1, 1) (xorshift from `seed`).
    fn uniform(mut s: u64) -> impl FnMut() -> f64 {
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    #[test]
    fn a_point_behind_a_front_only_source_has_no_pixel() {
        let mut r = uniform(5);
        for source in sources() {
            let n = source.front_halfspace().expect("front-only");
            let (mut skipped, mut near_plane) = (0, 0);
            for _ in 0..20_000 {
                let p = Vector3::new(r(), r(), r()) * 40.0;
                // points near the plane too: 2e-9 and 1e-12 radians behind it
                let on_plane = (p - n * n.dot(&p)).normalize() * p.norm();
                for q in [
                    p,
                    on_plane - n * 2e-9 * p.norm(),
                    on_plane - n * 1e-12 * p.norm(),
                ] {
                    if behind(&n, &q) {
                        skipped += 1;
                        assert!(source.project_point(&q).is_err(), "{source:?} {q:?}");
                    } else if n.dot(&q) < 0.0 {
                        near_plane += 1;
                    }
                }
            }
            // the rule skips about half the points and leaves those within 1e-9 rad
            assert!(skipped > 25_000, "{source:?}: {skipped}");
            assert!(near_plane >= 19_000, "{source:?}: {near_plane}");
        }
    }

    /// A camera that hides it is a pinhole: the depth map takes its per-point path.
    #[derive(Debug)]
    struct Opaque<'a>(&'a dyn CameraModel);

    impl CameraModel for Opaque<'_> {
        fn project(
            &self,
            d: &Vector3<f64>,
        ) -> Result<Point2<f64>, crate::camera::ProjectionReject> {
            self.0.project(d)
        }
        fn unproject(
            &self,
            px: &Point2<f64>,
        ) -> Result<Vector3<f64>, crate::camera::ProjectionReject> {
            self.0.unproject(px)
        }
        fn distance(&self, p: &Vector3<f64>) -> f64 {
            self.0.distance(p)
        }
        fn size(&self) -> ImageSize {
            self.0.size()
        }
        fn front_halfspace(&self) -> Option<Vector3<f64>> {
            self.0.front_halfspace()
        }
    }

    #[test]
    fn a_pinhole_sources_points_in_lanes_give_the_per_point_map() {
        use crate::camera::{Equirect, Fisheye};
        let k = Intrinsics::new(707.05, 707.05, 604.08, 180.51);
        let source = Perspective::new(k, ImageSize::new(1224, 370));
        let out_k = Intrinsics::new(200.0, 200.0, 319.5, 239.5);
        let outputs: Vec<Box<dyn CameraModel>> = vec![
            Box::new(Equirect::new(out_k, ImageSize::new(640, 480))),
            Box::new(
                Fisheye::new(
                    RadialModel::Equidistant,
                    out_k,
                    ImageSize::new(640, 480),
                    1.2,
                )
                .unwrap(),
            ),
        ];
        let mut r = uniform(9);
        // a scan all around (and points at the centre, off to infinity, not finite), 8k + 5
        let centre = Vector3::new(-0.06, 0.0018, -0.005);
        let mut points: Vec<Vector3<f64>> = (0..40_000)
            .map(|_| Vector3::new(r() * 60.0, r() * 3.0, r() * 60.0))
            .collect();
        points.extend([centre, centre + Vector3::new(0.0, 0.0, 1e-13)]);
        points.extend([
            Vector3::new(f64::NAN, 0.0, 5.0),
            Vector3::new(0.0, 0.0, 1e300),
        ]);
        points.push(Vector3::new(1.0, 0.5, 10.0));
        assert_eq!(points.len() % LANES, 5);
        for output in &outputs {
            for filter in [None, Some(OcclusionFilter::default())] {
                let lanes = depth_map(
                    points.clone(),
                    &centre,
                    output.as_ref(),
                    &source,
                    filter.as_ref(),
                );
                let one = depth_map(
                    points.clone(),
                    &centre,
                    output.as_ref(),
                    &Opaque(&source),
                    filter.as_ref(),
                );
                assert_eq!(lanes, one, "{output:?}");
                // columns after a few points pushed one by one (those go first)
                let mut columns = DepthPoints::new(&centre, output.as_ref(), &source);
                for p in &points[..3] {
                    columns.push(*p);
                }
                let [x, y, z] =
                    [0, 1, 2].map(|c| points[3..].iter().map(|p| p[c]).collect::<Vec<_>>());
                columns.push_columns([&x, &y, &z]);
                assert_eq!(columns.finish(filter.as_ref()), lanes, "{output:?}");
                assert!(lanes.0.valid() > 500, "{output:?}: {}", lanes.0.valid());
            }
        }
    }
}
