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

use crate::camera::CameraModel;
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
    let size = output.size();
    let mut projected = Vec::new();
    for p in rect {
        let rel = p - centre;
        // the source first: a scan all around meets a camera's image with a fraction of its
        // points, and a pinhole source's test is a division where a panorama's is trigonometry
        let Ok(src_px) = source.project_point(&rel) else {
            continue;
        };
        if !source.contains(&src_px) {
            continue;
        }
        let Ok(px) = output.project_point(&rel) else {
            continue;
        };
        let (u, v) = (px.x.round(), px.y.round());
        if u < 0.0 || v < 0.0 || u >= size.width as f64 || v >= size.height as f64 {
            continue;
        }
        let depth = output.distance(&rel);
        if depth > 0.0 && depth.is_finite() {
            projected.push(Projected {
                u: u as u32,
                v: v as u32,
                depth,
            });
        }
    }
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
            let own = layer(p.depth);
            for y in (p.v as i64 - ry).max(0)..=(p.v as i64 + ry).min(h as i64 - 1) {
                for x in (p.u as i64 - rx).max(0)..=(p.u as i64 + rx).min(w as i64 - 1) {
                    let d = nearest[y as usize * w + x as usize];
                    if d < limit && layer(d) < own {
                        return false;
                    }
                }
            }
            true
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
