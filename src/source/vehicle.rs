//! The vehicle's own body as a LiDAR sees it: the returns a rig reader drops before anything
//! uses the scan (depth labels, the depth-guided stitch, the objects' LiDAR check).
//!
//! A roof LiDAR hits the car it is mounted on (its roof, bonnet and boot): such returns lie
//! 0.2-2 m from the sensor and would read as the nearest surface of every ray that passes
//! them. Each dataset's own tools drop them with a rule of their own, in the sensor's frame:
//! nuScenes' devkit (`LidarPointCloud.remove_close(1.0)`) drops points with |x| and |y| both
//! under 1 m; KITTI-360's scripts (`accumuLaser`, `CropVelodyneData(.., 3, 80)`) keep points
//! 3 to 80 m from the Velodyne.

use nalgebra::Vector3;
use serde::Serialize;

/// A region of the LiDAR's own frame whose returns are the vehicle's body.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum VehicleBox {
    /// Nothing is dropped.
    None,
    /// An axis-aligned box, metres.
    Box {
        /// Its least corner.
        min: [f64; 3],
        /// Its greatest corner.
        max: [f64; 3],
    },
    /// Points nearer to the sensor than this, metres.
    Range(f64),
}

impl VehicleBox {
    /// nuScenes' LIDAR_TOP (x right, y forward, z up, 1.84 m above the ground): the devkit's
    /// square (|x|, |y| < 1 m) lengthened to the Renault Zoe's bonnet and boot (its body spans
    /// 2.5 m ahead of the sensor and 1.6 m behind it), from 0.34 m above the road (the road's
    /// own returns stay) to 0.3 m above the sensor.
    pub const NUSCENES: VehicleBox = VehicleBox::Box {
        min: [-1.0, -2.0, -1.5],
        max: [1.0, 2.7, 0.3],
    };
    /// KITTI-360's Velodyne: the scripts' 3 m.
    pub const KITTI360: VehicleBox = VehicleBox::Range(3.0);

    /// Whether sensor-frame point `p` is the vehicle's return.
    pub fn holds(&self, p: &Vector3<f64>) -> bool {
        match self {
            VehicleBox::None => false,
            VehicleBox::Box { min, max } => (0..3).all(|a| p[a] >= min[a] && p[a] <= max[a]),
            VehicleBox::Range(r) => p.norm() < *r,
        }
    }

    /// `none`, a range `R` (metres), or a box `X0,Y0,Z0,X1,Y1,Z1` (its two corners, metres).
    pub fn parse(s: &str) -> Result<Self, String> {
        if s == "none" {
            return Ok(VehicleBox::None);
        }
        let values: Vec<f64> = s
            .split(',')
            .map(|v| v.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("{s:?}: expected none, R or X0,Y0,Z0,X1,Y1,Z1 (metres)"))?;
        match values[..] {
            [r] if r.is_finite() && r > 0.0 => Ok(VehicleBox::Range(r)),
            [x0, y0, z0, x1, y1, z1]
                if values.iter().all(|v| v.is_finite()) && x0 < x1 && y0 < y1 && z0 < z1 =>
            {
                Ok(VehicleBox::Box {
                    min: [x0, y0, z0],
                    max: [x1, y1, z1],
                })
            }
            _ => Err(format!(
                "{s:?}: expected none, a positive range R, or X0,Y0,Z0,X1,Y1,Z1 with each \
                 first corner's value below the second's (metres)"
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boxes_ranges_and_none_hold_what_they_say() {
        let p = |x, y, z| Vector3::new(x, y, z);
        let nus = VehicleBox::NUSCENES;
        assert!(nus.holds(&p(0.5, 2.5, -1.0)) && nus.holds(&p(-0.9, -1.9, 0.2)));
        assert!(!nus.holds(&p(1.1, 0.0, 0.0)) && !nus.holds(&p(0.0, 3.0, -1.8)));
        assert!(VehicleBox::KITTI360.holds(&p(2.9, 0.0, 0.0)));
        assert!(!VehicleBox::KITTI360.holds(&p(3.0, 0.1, 0.0)));
        assert!(!VehicleBox::None.holds(&p(0.0, 0.0, 0.0)));
        assert_eq!(VehicleBox::parse("none"), Ok(VehicleBox::None));
        assert_eq!(VehicleBox::parse("2.5"), Ok(VehicleBox::Range(2.5)));
        assert_eq!(
            VehicleBox::parse("-1,-2,-3,1,2,3"),
            Ok(VehicleBox::Box {
                min: [-1.0, -2.0, -3.0],
                max: [1.0, 2.0, 3.0]
            })
        );
        for bad in ["", "x", "0", "-1", "1,2", "1,0,0,0,1,1", "nan"] {
            assert!(VehicleBox::parse(bad).is_err(), "{bad}");
        }
    }
}
