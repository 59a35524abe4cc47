//! `data_3d_raw/SEQ/velodyne_points/data/%010d.bin`: little-endian float32 x, y, z,
//! reflectance per point, in the Velodyne frame (x forward, y left, z up), metres: the layout
//! of KITTI's scans. KITTI-360's scans are not motion-compensated (a sweep takes 0.1 s):
//! [`SweepMotion`] is the model that compensates them.

use crate::error::{Error, Result};
use crate::source::Pose;
use nalgebra::{Rotation3, Vector3};
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

/// The motion of the Velodyne during one sweep, as kitti360Scripts' `curlVelodyneData` models
/// it: the sensor spins clockwise seen from above (azimuth decreasing), facing backwards
/// (azimuth ±180°) half a frame before the frame's time, left (+90°) a quarter frame before,
/// forwards (0°) at the frame's time and right (−90°) a quarter frame after. A point measured
/// at azimuth a = atan2(y, x) of its own coordinates was taken at the fraction s = a / 2π of a
/// frame *before* the frame's time (s in (−½, ½]), in the Velodyne frame of that instant; the
/// Velodyne frame at the frame's time sees it at `R(s·r)·p + s·t`, where (r, t) is the motion
/// over one frame: r the axis-angle vector of velo_now_from_velo_previous's rotation, t its
/// translation. The rotation is scaled along its axis and the translation linearly, exactly as
/// `curlVelodyneData` does (not a screw motion), and the motion is taken as constant over the
/// sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepMotion {
    /// Axis-angle vector r of the motion over one frame, radians.
    pub rotation: Vector3<f64>,
    /// Translation t of the motion over one frame, metres.
    pub translation: Vector3<f64>,
}

impl SweepMotion {
    /// The model of a sweep from the Velodyne's motion over one frame, `velo_later_from_velo_earlier`
    /// (between a frame and the one before it, or the one after it and the frame): its rotation
    /// is taken as the nearest rotation of its linear part.
    pub fn from_frame_motion(velo_later_from_velo_earlier: &Pose) -> Self {
        let r = Rotation3::from_matrix_eps(
            &velo_later_from_velo_earlier.rotation,
            1e-15,
            100,
            Rotation3::identity(),
        );
        Self {
            rotation: r.scaled_axis(),
            translation: velo_later_from_velo_earlier.translation,
        }
    }

    /// The fraction of a frame before the frame's time at which the Velodyne faces the point `p`
    /// (its own coordinates): atan2(y, x) / 2π.
    pub fn fraction(p: &Vector3<f64>) -> f64 {
        p.y.atan2(p.x) / std::f64::consts::TAU
    }

    /// velo_at_frame_time_from_velo_at_measurement for a point measured at fraction `s`.
    pub fn frame_from_measured(&self, s: f64) -> Pose {
        Pose::new(
            Rotation3::from_scaled_axis(self.rotation * s).into_inner(),
            self.translation * s,
        )
    }

    /// A measured point `p` in the Velodyne frame at the frame's time.
    pub fn compensate(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.frame_from_measured(Self::fraction(p)).apply(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sweep_model_is_curl_velodyne_data() {
        // a turn of 0.05 rad about z and 1.2 m forward per frame
        let pose = Pose::new(
            Rotation3::from_axis_angle(&Vector3::z_axis(), 0.05).into_inner(),
            Vector3::new(1.2, 0.1, 0.0),
        );
        let m = SweepMotion::from_frame_motion(&pose);
        assert!((m.rotation - Vector3::new(0.0, 0.0, 0.05)).norm() < 1e-15);
        // forwards: the frame's time, no change
        let ahead = Vector3::new(10.0, 0.0, -1.0);
        assert_eq!(m.compensate(&ahead), ahead);
        // left: a quarter frame earlier
        let left = Vector3::new(0.0, 8.0, 0.5);
        let want = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.0125) * left
            + Vector3::new(0.3, 0.025, 0.0);
        assert!((m.compensate(&left) - want).norm() < 1e-14);
        // behind on the right: nearly half a frame later
        let back = Vector3::new(-5.0, -1e-9, 0.0);
        let s = SweepMotion::fraction(&back);
        assert!((s + 0.5).abs() < 1e-9, "{s}");
        let want = Rotation3::from_axis_angle(&Vector3::z_axis(), -0.025) * back
            + Vector3::new(-0.6, -0.05, 0.0);
        assert!((m.compensate(&back) - want).norm() < 1e-8);
    }

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
