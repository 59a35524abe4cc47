//! KITTI velodyne scans (`velodyne/NNNNNN.bin`): little-endian float32 x, y, z, reflectance per
//! point, in the LiDAR frame (x forward, y left, z up), metres.

use crate::error::{Error, Result};
use nalgebra::Vector3;
use std::path::Path;

const POINT_BYTES: usize = 16;

/// A Velodyne scan (`velodyne/NNNNNN.bin`: float32 x, y, z, reflectance per point).
#[derive(Debug, Clone, Default)]
pub struct Scan {
    /// Points in the Velodyne frame (x forward, y left, z up), metres.
    pub points: Vec<Vector3<f64>>,
    /// Each point's reflectance, 0 to 1.
    pub reflectance: Vec<f32>,
    /// Points with a NaN or infinite coordinate, dropped and counted.
    pub dropped_non_finite: usize,
}

/// What is wrong with a scan of `len` bytes by its length alone (not a whole number of
/// points), or None: what [`parse`] refuses, and what `panoconv inspect` reports.
pub fn length_problem(len: u64) -> Option<String> {
    (!len.is_multiple_of(POINT_BYTES as u64)).then(|| {
        format!(
            "{len} bytes is not a whole number of 16-byte points (x, y, z, reflectance as float32): truncated or not a velodyne scan"
        )
    })
}

/// Parses a scan; a size that is not a whole number of points is a broken file.
pub fn parse(bytes: &[u8], path: &Path) -> Result<Scan> {
    if let Some(problem) = length_problem(bytes.len() as u64) {
        return Err(Error::file(path, problem));
    }
    let mut scan = Scan::default();
    scan.points.reserve(bytes.len() / POINT_BYTES);
    for chunk in bytes.chunks_exact(POINT_BYTES) {
        let f = |i: usize| f32::from_le_bytes([chunk[i], chunk[i + 1], chunk[i + 2], chunk[i + 3]]);
        let (x, y, z, r) = (f(0), f(4), f(8), f(12));
        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
            scan.dropped_non_finite += 1;
            continue;
        }
        scan.points.push(Vector3::new(x as f64, y as f64, z as f64));
        scan.reflectance.push(r);
    }
    Ok(scan)
}

/// Reads and parses a scan file.
pub fn read(path: &Path) -> Result<Scan> {
    parse(&crate::fs::read_file(path)?, path)
}

/// Encodes points (for synthetic scans and tests).
pub fn encode(points: &[(Vector3<f64>, f32)]) -> Vec<u8> {
    let mut out = Vec::with_capacity(points.len() * POINT_BYTES);
    for (p, r) in points {
        for v in [p.x as f32, p.y as f32, p.z as f32, *r] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

/// LiDAR points (LiDAR frame) to rect: X = R0_rect · Tr_velo_to_cam · p.
pub fn rect_from_velo(
    points: &[Vector3<f64>],
    r0_rect: &nalgebra::Matrix3<f64>,
    tr_velo_to_cam: &nalgebra::Matrix3x4<f64>,
) -> Vec<Vector3<f64>> {
    points
        .iter()
        .map(rect_from_velo_map(r0_rect, tr_velo_to_cam))
        .collect()
}

/// [`rect_from_velo`] of one point at a time.
pub fn rect_from_velo_map(
    r0_rect: &nalgebra::Matrix3<f64>,
    tr_velo_to_cam: &nalgebra::Matrix3x4<f64>,
) -> impl Fn(&Vector3<f64>) -> Vector3<f64> {
    let r0_rect = *r0_rect;
    let r = tr_velo_to_cam.fixed_view::<3, 3>(0, 0).into_owned();
    let t = tr_velo_to_cam.column(3).into_owned();
    move |p| r0_rect * (r * p + t)
}
