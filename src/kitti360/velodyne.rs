//! `data_3d_raw/SEQ/velodyne_points/data/%010d.bin`: little-endian float32 x, y, z,
//! reflectance per point, in the Velodyne frame (x forward, y left, z up), metres: the layout
//! of KITTI's scans. KITTI-360's scans are not motion-compensated (a sweep takes 0.1 s).

use crate::error::{Error, Result};
use nalgebra::Vector3;
use std::path::Path;

const POINT_BYTES: usize = 16;

/// The finite points of a scan and their reflectance; a size that is not a whole number of
/// points is an error.
pub fn parse_scan(bytes: &[u8], path: &Path) -> Result<Vec<(Vector3<f64>, f32)>> {
    if !bytes.len().is_multiple_of(POINT_BYTES) {
        return Err(Error::file(
            path,
            format!(
                "{} bytes is not a whole number of 16-byte points (x, y, z, reflectance as \
                 float32): truncated or not a Velodyne scan",
                bytes.len()
            ),
        ));
    }
    Ok(bytes
        .chunks_exact(POINT_BYTES)
        .filter_map(|c| {
            let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
            let (x, y, z) = (f(0), f(4), f(8));
            (x.is_finite() && y.is_finite() && z.is_finite())
                .then(|| (Vector3::new(x as f64, y as f64, z as f64), f(12)))
        })
        .collect())
}

/// The scan's file bytes of points (for synthetic scans and tests).
pub fn encode_scan(points: &[(Vector3<f64>, f32)]) -> Vec<u8> {
    let mut out = Vec::with_capacity(points.len() * POINT_BYTES);
    for (p, r) in points {
        for v in [p.x as f32, p.y as f32, p.z as f32, *r] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scans_round_trip_and_broken_ones_are_refused() {
        let points = vec![
            (Vector3::new(1.5, -2.25, 0.5), 0.25f32),
            (Vector3::new(f64::NAN, 0.0, 0.0), 0.0),
            (Vector3::new(-30.0, 4.0, -1.75), 1.0),
        ];
        let bytes = encode_scan(&points);
        assert_eq!(bytes.len(), 48);
        let back = parse_scan(&bytes, Path::new("s.bin")).unwrap();
        assert_eq!(back, vec![points[0], points[2]]);
        let e = parse_scan(&bytes[..47], Path::new("s.bin")).unwrap_err();
        assert!(e.to_string().starts_with("s.bin: 47 bytes"), "{e}");
    }
}
