//! KITTI-360's published calibration (the values of its `calibration/` folder), optionally
//! scaled to smaller images and with the four camera centres moved to one point, and the text
//! of each calibration file as the official release lays it out.
//!
//! Numbers are written in Rust's shortest round-trip notation (never exponent notation, which
//! PyYAML's YAML 1.1 resolver would read as a string), so a reader gets back exactly the value
//! the renderer used.

use crate::camera::{ImageSize, Intrinsics, Lens, MeiDistortion, Perspective, Unified};
use crate::error::{Error, Result};
use nalgebra::{Matrix3, Matrix4};

/// `calib_cam_to_pose.txt`: pose_from_camera of image_00..03 (3x4, row-major).
pub const CAM_TO_POSE: [[f64; 12]; 4] = [
    [
        0.0371783278,
        -0.0986182135,
        0.9944306009,
        1.5752681039,
        0.9992675562,
        -0.0053553387,
        -0.0378902567,
        0.0043914093,
        0.0090621821,
        0.9951109327,
        0.0983468786,
        -0.6500000000,
    ],
    [
        0.0194000864,
        -0.1051529641,
        0.9942668106,
        1.5977241400,
        0.9997374956,
        -0.0100836652,
        -0.0205732716,
        0.5981494900,
        0.0121891942,
        0.9944049345,
        0.1049297370,
        -0.6488433108,
    ],
    [
        0.9995185086,
        0.0041276589,
        -0.0307524527,
        0.7264036936,
        -0.0307926666,
        0.0100608424,
        -0.9994751579,
        -0.1499658517,
        -0.0038160970,
        0.9999408692,
        0.0101830998,
        -1.0686400091,
    ],
    [
        -0.9996821702,
        0.0005703407,
        -0.0252038325,
        0.7016842127,
        -0.0252033830,
        0.0007820814,
        0.9996820384,
        0.7463650950,
        0.0005898709,
        0.9999995315,
        -0.0007674583,
        -1.0751978255,
    ],
];

/// `perspective.txt`: R_rect_00 and R_rect_01 (row-major; six digits as published).
pub const R_RECT: [[f64; 9]; 2] = [
    [
        0.999974, -0.007141, -0.000089, 0.007141, 0.999969, -0.003247, 0.000112, 0.003247, 0.999995,
    ],
    [
        0.999778, -0.012115, 0.017222, 0.012059, 0.999922, 0.003351, -0.017261, -0.003143, 0.999846,
    ],
];

/// `perspective.txt`: P_rect_00 (f, cu, cv; its fourth column is zero).
pub const P_RECT_00: [f64; 3] = [552.554261, 682.049453, 238.769549];
/// `perspective.txt`: P_rect_01's fourth column, −f·b (the stereo baseline, in pixels).
pub const P_RECT_01_TX: f64 = -328.318735;
/// `perspective.txt`: S_rect_00/01, the rectified image size.
pub const S_RECT: [u32; 2] = [1408, 376];

/// `calib_cam_to_velo.txt`: velo_from_camera of image_00 (3x4, row-major).
pub const CAM_TO_VELO: [f64; 12] = [
    0.04307104361,
    -0.08829286498,
    0.995162929,
    0.8043914418,
    -0.999004371,
    0.007784614041,
    0.04392796942,
    0.2993489574,
    -0.01162548558,
    -0.9960641394,
    -0.08786966659,
    -0.1770225824,
];

/// A fisheye's YAML values: xi, k1, k2, p1, p2, gamma1, gamma2, u0, v0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeiValues {
    /// Mirror parameter ξ.
    pub xi: f64,
    /// Radial and tangential distortion k1, k2, p1, p2.
    pub distortion: [f64; 4],
    /// gamma1, gamma2, u0, v0 (pixels).
    pub projection: [f64; 4],
}

/// `image_02.yaml` and `image_03.yaml` (1400x1400).
// The YAML's seventeen digits as published: they parse to the same doubles.
#[allow(clippy::excessive_precision)]
pub const FISHEYE: [MeiValues; 2] = [
    MeiValues {
        xi: 2.2134047507854890,
        distortion: [
            1.6798235660113681e-02,
            1.6548773243373522,
            4.2223943394772046e-04,
            4.2462134260997584e-04,
        ],
        projection: [
            1.3363220825849971e+03,
            1.3357883350012958e+03,
            7.1694323510126321e+02,
            7.0576498308221585e+02,
        ],
    },
    MeiValues {
        xi: 2.5535139132482758,
        distortion: [
            4.9370396274089505e-02,
            4.5068455478645308,
            1.3477698472982495e-03,
            -7.0340482615055284e-04,
        ],
        projection: [
            1.4854388981875156e+03,
            1.4849477411748708e+03,
            6.9888316784030962e+02,
            6.9814541887723055e+02,
        ],
    },
];
/// The fisheyes' published image size.
pub const FISHEYE_SIZE: u32 = 1400;
/// The lens circle the synthetic fisheye images show, degrees (the reader's default).
pub const FISHEYE_FOV_DEG: f64 = 185.0;

/// The rig a synthetic sequence is rendered with and its calibration files are written from.
#[derive(Debug, Clone)]
pub struct Rig {
    /// pose_from_camera, image_00..03 (unrectified axes for 00/01).
    pub cam_to_pose: [Matrix4<f64>; 4],
    /// R_rect_00, R_rect_01.
    pub r_rect: [Matrix3<f64>; 2],
    /// The rectified pinhole of image_00/01 (they share it).
    pub rect_k: Intrinsics,
    /// The rectified image size.
    pub rect_size: ImageSize,
    /// P_rect_01's fourth column (−f·b, scaled; 0 for a zero baseline).
    pub p_rect_01_tx: f64,
    /// The fisheyes' values (scaled).
    pub fisheye: [MeiValues; 2],
    /// The fisheyes' image size.
    pub fisheye_size: ImageSize,
    /// velo_from_camera of image_00.
    pub cam_to_velo: Matrix4<f64>,
}

fn matrix_3x4(v: &[f64; 12]) -> Matrix4<f64> {
    let mut m = Matrix4::identity();
    for i in 0..12 {
        m[(i / 4, i % 4)] = v[i];
    }
    m
}

/// An image dimension scaled by `s`, at least one pixel.
fn scaled(n: u32, s: f64) -> u32 {
    ((n as f64 * s).round() as u32).max(1)
}

/// A principal point scaled with its image (pixel centres at integers).
fn scaled_centre(c: f64, s: f64) -> f64 {
    (c + 0.5) * s - 0.5
}

impl Rig {
    /// The published rig with images scaled by `scale` (intrinsics follow, pixel centres at
    /// integers); with `zero_baseline` every camera's centre is image_00's and P_rect_01's
    /// baseline is zero.
    pub fn new(scale: f64, zero_baseline: bool) -> Result<Self> {
        if !(scale > 0.0 && scale <= 4.0) {
            return Err(Error::Setup(format!(
                "--scale must be in (0, 4], not {scale}"
            )));
        }
        let mut cam_to_pose = CAM_TO_POSE.map(|v| matrix_3x4(&v));
        if zero_baseline {
            let centre = cam_to_pose[0].fixed_view::<3, 1>(0, 3).into_owned();
            for m in cam_to_pose.iter_mut().skip(1) {
                m.fixed_view_mut::<3, 1>(0, 3).copy_from(&centre);
            }
        }
        let [f, cu, cv] = P_RECT_00;
        let fisheye = FISHEYE.map(|m| MeiValues {
            projection: [
                m.projection[0] * scale,
                m.projection[1] * scale,
                scaled_centre(m.projection[2], scale),
                scaled_centre(m.projection[3], scale),
            ],
            ..m
        });
        Ok(Self {
            cam_to_pose,
            r_rect: R_RECT.map(|r| Matrix3::from_row_slice(&r)),
            rect_k: Intrinsics::new(
                f * scale,
                f * scale,
                scaled_centre(cu, scale),
                scaled_centre(cv, scale),
            ),
            rect_size: ImageSize::new(scaled(S_RECT[0], scale), scaled(S_RECT[1], scale)),
            p_rect_01_tx: if zero_baseline {
                0.0
            } else {
                P_RECT_01_TX * scale
            },
            fisheye,
            fisheye_size: ImageSize::new(scaled(FISHEYE_SIZE, scale), scaled(FISHEYE_SIZE, scale)),
            cam_to_velo: matrix_3x4(&CAM_TO_VELO),
        })
    }

    /// pose_from_image for camera k, as kitti360Scripts composes it: cam_to_pose · R_rect⁻¹
    /// for the rectified cameras, cam_to_pose for the fisheyes.
    pub fn pose_from_image(&self, k: usize) -> Matrix4<f64> {
        if k < 2 {
            let mut r = Matrix4::identity();
            let inv = self.r_rect[k].try_inverse().expect("R_rect is invertible");
            r.fixed_view_mut::<3, 3>(0, 0).copy_from(&inv);
            self.cam_to_pose[k] * r
        } else {
            self.cam_to_pose[k]
        }
    }

    /// pose_from_velo: `cam_to_pose[0] · cam_to_velo⁻¹`.
    pub fn pose_from_velo(&self) -> Matrix4<f64> {
        self.cam_to_pose[0] * self.cam_to_velo.try_inverse().expect("invertible")
    }

    /// The rectified pinhole.
    pub fn perspective(&self) -> Perspective {
        Perspective::new(self.rect_k, self.rect_size)
    }

    /// Fisheye `i` (0: image_02, 1: image_03) seeing [`FISHEYE_FOV_DEG`].
    pub fn fisheye_lens(&self, i: usize) -> Result<Lens> {
        let m = &self.fisheye[i];
        let [k1, k2, p1, p2] = m.distortion;
        let [g1, g2, u0, v0] = m.projection;
        Unified::new(
            m.xi,
            MeiDistortion { k1, k2, p1, p2 },
            Intrinsics::new(g1, g2, u0, v0),
            0.0,
            self.fisheye_size,
            FISHEYE_FOV_DEG.to_radians() / 2.0,
        )
        .map(Lens::erased)
        .map_err(|e| Error::Setup(format!("synthetic fisheye: {e}")))
    }

    /// `calib_cam_to_pose.txt`.
    pub fn cam_to_pose_text(&self) -> String {
        (0..4)
            .map(|k| format!("image_0{k}: {}\n", row_3x4(&self.cam_to_pose[k])))
            .collect()
    }

    /// `perspective.txt` (the rectified lines that readers use).
    pub fn perspective_text(&self) -> String {
        let k = self.rect_k;
        let mut out = String::new();
        for cam in 0..2 {
            let tx = if cam == 0 { 0.0 } else { self.p_rect_01_tx };
            let p = [
                k.fu, 0.0, k.cu, tx, 0.0, k.fv, k.cv, 0.0, 0.0, 0.0, 1.0, 0.0,
            ];
            out.push_str(&format!(
                "S_rect_0{cam}: {} {}\nR_rect_0{cam}: {}\nP_rect_0{cam}: {}\n",
                self.rect_size.width,
                self.rect_size.height,
                join(self.r_rect[cam].transpose().as_slice()),
                join(&p)
            ));
        }
        out
    }

    /// `image_02.yaml` or `image_03.yaml` (`i` = 0 or 1), in the release's OpenCV YAML.
    pub fn fisheye_yaml(&self, i: usize) -> String {
        let m = &self.fisheye[i];
        let [k1, k2, p1, p2] = m.distortion;
        let [g1, g2, u0, v0] = m.projection;
        format!(
            "%YAML:1.0\n---\nmodel_type: MEI\ncamera_name: image_0{}\nimage_width: {}\n\
             image_height: {}\nmirror_parameters:\n   xi: {}\ndistortion_parameters:\n   \
             k1: {k1}\n   k2: {k2}\n   p1: {p1}\n   p2: {p2}\nprojection_parameters:\n   \
             gamma1: {g1}\n   gamma2: {g2}\n   u0: {u0}\n   v0: {v0}\n",
            i + 2,
            self.fisheye_size.width,
            self.fisheye_size.height,
            m.xi,
        )
    }

    /// `calib_cam_to_velo.txt`.
    pub fn cam_to_velo_text(&self) -> String {
        format!("{}\n", row_3x4(&self.cam_to_velo))
    }
}

/// Numbers joined by single spaces (kitti360Scripts splits on one space).
pub fn join(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The first three rows of a 4x4 matrix, row-major, joined.
pub fn row_3x4(m: &Matrix4<f64>) -> String {
    let v: Vec<f64> = (0..12).map(|i| m[(i / 4, i % 4)]).collect();
    join(&v)
}
