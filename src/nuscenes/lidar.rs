//! nuScenes' LiDAR files (`samples/LIDAR_TOP/*.pcd.bin`): little-endian float32 records of five
//! values, x y z (metres, the sensor's frame), intensity (0 to 255) and the ring index.

use crate::error::{Error, Result};
use nalgebra::Vector3;
use std::path::Path;

/// Bytes per point.
pub const POINT_BYTES: usize = 20;

/// The points of a scan: position in the sensor frame and intensity.
pub fn parse_points(bytes: &[u8], path: &Path) -> Result<Vec<(Vector3<f64>, f32)>> {
    if !bytes.len().is_multiple_of(POINT_BYTES) {
        return Err(Error::file(
            path,
            format!(
                "{} bytes is not a whole number of 5-float points ({POINT_BYTES} bytes each)",
                bytes.len()
            ),
        ));
    }
    let mut out = Vec::with_capacity(bytes.len() / POINT_BYTES);
    for (i, p) in bytes.chunks_exact(POINT_BYTES).enumerate() {
        let f = |k: usize| f32::from_le_bytes(p[4 * k..4 * k + 4].try_into().expect("4 bytes"));
        let (x, y, z, intensity) = (f(0), f(1), f(2), f(3));
        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
            return Err(Error::file(
                path,
                format!("point {i}: not a finite position ({x}, {y}, {z})"),
            ));
        }
        out.push((Vector3::new(x as f64, y as f64, z as f64), intensity));
    }
    Ok(out)
}

/// The file of `points` (ring index `ring` each, the beam of the point).
pub fn encode_points(points: &[(Vector3<f64>, f32, u8)]) -> Vec<u8> {
    let mut out = Vec::with_capacity(points.len() * POINT_BYTES);
    for (p, intensity, ring) in points {
        for v in [p.x as f32, p.y as f32, p.z as f32, *intensity, *ring as f32] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}
