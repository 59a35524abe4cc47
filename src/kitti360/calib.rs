//! KITTI-360's calibration folder: `calib_cam_to_pose.txt` (each camera's mounting on the
//! vehicle's pose frame), `perspective.txt` (the rectified perspective cameras `image_00` and
//! `image_01`: `P_rect_0k`, `R_rect_0k`, `S_rect_0k`), `image_02.yaml` / `image_03.yaml` (the
//! MEI fisheyes, read by `camera/`'s KITTI-360 reader) and `calib_cam_to_velo.txt` (image_00 to
//! the Velodyne).
//!
//! What trips readers, and how it is handled here:
//! - `P_rect_01`'s fourth column is the stereo baseline (−f·b). `calib_cam_to_pose.txt` holds
//!   image_01's position already, so the column is not used: adding it would move the camera
//!   twice.
//! - The rectified cameras' axes are `cam_to_pose[k] · R_rect_k⁻¹` (kitti360Scripts'
//!   `helpers/project.py`); `R_rect_k` is published with six digits, so the exact inverse is
//!   taken, as there.
//! - The fisheye YAML states no field of view and the MEI model with ξ > 1 folds back only
//!   beyond acos(−1/ξ) (about 117° and 113° from the axis here), far outside the lens circle
//!   of the real images: each fisheye's valid region is a field of view given per camera
//!   (default [`DEFAULT_FISHEYE_FOV_DEG`]), not the model's.

use super::text::{keyed_lines, matrix_3x4, numbers, required};
use crate::camera::description::CameraDescription;
use crate::camera::{ImageSize, Intrinsics, Lens, Perspective};
use crate::error::{Error, Result};
use crate::fs::read_lines;
use crate::source::Pose;
use nalgebra::Matrix3;
use std::path::{Path, PathBuf};

/// The field of view (degrees) of KITTI-360's fisheye lenses, used when none is given: the
/// real images are black outside a circle of about 185°.
pub const DEFAULT_FISHEYE_FOV_DEG: f64 = 185.0;

/// The four cameras' names, in calib_cam_to_pose.txt's order.
pub const CAMERAS: [&str; 4] = ["image_00", "image_01", "image_02", "image_03"];

/// A rectified perspective camera (`image_00`, `image_01`).
#[derive(Debug, Clone)]
pub struct RectCamera {
    /// The pinhole of `P_rect_0k`'s first three columns and `S_rect_0k`.
    pub model: Perspective,
    /// `P_rect_0k` as published, row-major 3x4 (its fourth column is not used; see the module).
    pub p_rect: [f64; 12],
    /// `R_rect_0k`: unrectified camera axes to rectified ones (rect = R_rect · camera).
    pub r_rect: Matrix3<f64>,
}

/// The calibration folder of a KITTI-360 release.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// pose_from_camera for image_00 to image_03 (unrectified camera axes for 00/01).
    pub cam_to_pose: [Pose; 4],
    /// image_00 and image_01.
    pub perspective: [RectCamera; 2],
    /// image_02 and image_03, each seeing up to its field of view.
    pub fisheye: [Lens; 2],
    /// velo_from_camera of image_00 (unrectified).
    pub cam_to_velo: Pose,
    /// The files read, for provenance.
    pub files: Vec<PathBuf>,
}

impl Calibration {
    /// Reads `dir` (`ROOT/calibration`); `fisheye_fov_deg` is the field of view of image_02
    /// and image_03 (degrees).
    pub fn read(dir: &Path, fisheye_fov_deg: [f64; 2]) -> Result<Self> {
        let cam_to_pose_path = dir.join("calib_cam_to_pose.txt");
        let perspective_path = dir.join("perspective.txt");
        let velo_path = dir.join("calib_cam_to_velo.txt");
        let yaml = [dir.join("image_02.yaml"), dir.join("image_03.yaml")];
        let cam_to_pose = read_cam_to_pose(&cam_to_pose_path)?;
        let perspective = read_perspective(&perspective_path)?;
        let fisheye = [
            read_fisheye(&yaml[0], fisheye_fov_deg[0])?,
            read_fisheye(&yaml[1], fisheye_fov_deg[1])?,
        ];
        let cam_to_velo = read_cam_to_velo(&velo_path)?;
        Ok(Self {
            cam_to_pose,
            perspective,
            fisheye,
            cam_to_velo,
            files: vec![
                cam_to_pose_path,
                perspective_path,
                yaml[0].clone(),
                yaml[1].clone(),
                velo_path,
            ],
        })
    }

    /// pose_from_camera for camera `k` (0 to 3) in the axes its images are in: the rectified
    /// axes for image_00/01 (`cam_to_pose[k] · R_rect_k⁻¹`), the fisheye's own for 02/03.
    pub fn pose_from_image(&self, k: usize) -> Pose {
        match k {
            0 | 1 => {
                let r = &self.perspective[k].r_rect;
                // R_rect is rounded to six digits: its exact inverse, as kitti360Scripts.
                let inv = r.try_inverse().unwrap_or_else(|| r.transpose());
                self.cam_to_pose[k].compose(&Pose::new(inv, nalgebra::Vector3::zeros()))
            }
            _ => self.cam_to_pose[k],
        }
    }

    /// pose_from_velo: `cam_to_pose[image_00] · cam_to_velo⁻¹`.
    pub fn pose_from_velo(&self) -> Pose {
        // cam_to_velo was checked invertible when read
        self.cam_to_pose[0].compose(&self.cam_to_velo.inverse().unwrap_or(Pose::identity()))
    }
}

/// A rigid transform from 12 numbers, refusing a singular linear part.
fn pose_3x4(v: &[f64], path: &Path, line: usize, field: &str) -> Result<Pose> {
    let pose = Pose::from_matrix4(&matrix_3x4(v));
    if pose.inverse().is_none() || !(pose.rotation.determinant() > 0.5) {
        return Err(Error::parse(
            path,
            line,
            field,
            "the 3x3 part is not a rotation (determinant far from 1)",
        ));
    }
    Ok(pose)
}

/// `calib_cam_to_pose.txt`: `image_0k: 12 numbers` (3x4, pose_from_camera) for k = 0..3.
pub fn read_cam_to_pose(path: &Path) -> Result<[Pose; 4]> {
    let lines = keyed_lines(&read_lines(path)?, path)?;
    let mut out = [Pose::identity(); 4];
    for (k, name) in CAMERAS.iter().enumerate() {
        let v = required(&lines, name, 12, path)?;
        let line = lines.iter().find(|l| l.key == *name).map_or(1, |l| l.line);
        out[k] = pose_3x4(&v, path, line, name)?;
    }
    Ok(out)
}

/// `perspective.txt`: `P_rect_0k` (12), `R_rect_0k` (9) and `S_rect_0k` (width height) for
/// k = 0, 1; other lines (the unrectified K, D, R, T, S) are not needed and not read.
pub fn read_perspective(path: &Path) -> Result<[RectCamera; 2]> {
    let lines = keyed_lines(&read_lines(path)?, path)?;
    let line_of = |key: &str| lines.iter().find(|l| l.key == key).map_or(1, |l| l.line);
    let camera = |k: usize| -> Result<RectCamera> {
        let (p_key, r_key, s_key) = (
            format!("P_rect_0{k}"),
            format!("R_rect_0{k}"),
            format!("S_rect_0{k}"),
        );
        let p = required(&lines, &p_key, 12, path)?;
        let r = required(&lines, &r_key, 9, path)?;
        let s = required(&lines, &s_key, 2, path)?;
        let pinhole = p[1] == 0.0 && p[4] == 0.0 && p[8] == 0.0 && p[9] == 0.0 && p[10] == 1.0;
        if !(pinhole && p[0] > 0.0 && p[5] > 0.0) {
            return Err(Error::parse(
                path,
                line_of(&p_key),
                &p_key,
                "expected [[f, 0, cu, tx], [0, f, cv, ty], [0, 0, 1, tz]] with f > 0",
            ));
        }
        let r_rect = Matrix3::from_row_slice(&r);
        if !((r_rect.determinant() - 1.0).abs() < 1e-3) {
            return Err(Error::parse(
                path,
                line_of(&r_key),
                &r_key,
                format!("not a rotation (determinant {:.6})", r_rect.determinant()),
            ));
        }
        let whole = |v: f64| v >= 1.0 && v.fract() == 0.0 && v <= u32::MAX as f64;
        if !(whole(s[0]) && whole(s[1])) {
            return Err(Error::parse(
                path,
                line_of(&s_key),
                &s_key,
                format!(
                    "expected a width and height in whole pixels, found {} {}",
                    s[0], s[1]
                ),
            ));
        }
        let k_rect = Intrinsics::new(p[0], p[5], p[2], p[6]);
        Ok(RectCamera {
            model: Perspective::new(k_rect, ImageSize::new(s[0] as u32, s[1] as u32)),
            p_rect: std::array::from_fn(|i| p[i]),
            r_rect,
        })
    };
    Ok([camera(0)?, camera(1)?])
}

/// `image_0k.yaml` (MEI) through `camera/`'s reader, seeing up to `fov_deg` degrees.
pub fn read_fisheye(path: &Path, fov_deg: f64) -> Result<Lens> {
    let lens = CameraDescription::read(path)?.camera;
    let Some(mei) = lens.downcast::<crate::camera::MeiModel>() else {
        return Err(Error::file(path, "not a MEI calibration (model_type: MEI)"));
    };
    let half = fov_deg.to_radians() / 2.0;
    // The reader narrows the lens to its image's corners; the field of view may be wider.
    let widest = crate::camera::Unified::fov_limit(mei.model.xi, &mei.model.distortion).0;
    if !(half > 0.0 && half <= widest) {
        return Err(Error::file(
            path,
            format!(
                "a field of view of {fov_deg}° is outside what this MEI calibration can represent \
                 (0° to {:.1}°)",
                2.0 * widest.to_degrees()
            ),
        ));
    }
    lens.with_max_theta(half)
        .map_err(|e| Error::file(path, e.to_string()))
}

/// `calib_cam_to_velo.txt`: one row of 12 numbers (3x4, velo_from_camera of image_00).
pub fn read_cam_to_velo(path: &Path) -> Result<Pose> {
    let lines = read_lines(path)?;
    let rows: Vec<(usize, &String)> = lines
        .iter()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .collect();
    let Some(&(i, text)) = rows.first() else {
        return Err(Error::file(path, "empty: expected one row of 12 numbers"));
    };
    if rows.len() > 1 {
        return Err(Error::parse(
            path,
            rows[1].0 + 1,
            "cam_to_velo",
            "expected one row of 12 numbers, found a second line",
        ));
    }
    let values: Vec<String> = text.split_whitespace().map(str::to_owned).collect();
    let v = numbers(&values, 12, path, i + 1, "cam_to_velo")?;
    pose_3x4(&v, path, i + 1, "cam_to_velo")
}
