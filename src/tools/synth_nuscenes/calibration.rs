//! nuScenes' published calibration (the `calibrated_sensor` records of v1.0-mini's scene-0061):
//! the six cameras' mountings and pinhole matrices and LIDAR_TOP's mounting, ego_from_sensor
//! with quaternions [w, x, y, z] as the tables write them; and the cameras' firing times
//! relative to the LiDAR keyframe in that scene's first sample (each camera fires as the LiDAR
//! sweeps past it).

use nalgebra::{Matrix4, Quaternion, UnitQuaternion, Vector3};

/// A sensor's published calibration.
#[derive(Debug, Clone, Copy)]
pub struct Mounting {
    /// The channel.
    pub channel: &'static str,
    /// ego_from_sensor translation, metres.
    pub translation: [f64; 3],
    /// ego_from_sensor rotation, [w, x, y, z] (as published: unit to about 1e-8).
    pub rotation: [f64; 4],
}

/// A camera's calibration: its mounting, [fx, fy, cx, cy] at 1600x900, and its firing time
/// relative to the LiDAR keyframe, microseconds.
#[derive(Debug, Clone, Copy)]
pub struct CameraCalibration {
    /// Mounting.
    pub mounting: Mounting,
    /// fx, fy, cx, cy (pixel centres at integers, as OpenCV and the devkit's `view_points`).
    pub intrinsics: [f64; 4],
    /// Firing time minus the LiDAR keyframe's, microseconds.
    pub offset_us: i64,
}

/// The official image size.
pub const IMAGE_SIZE: [u32; 2] = [1600, 900];

/// The six cameras, clockwise from the front.
pub const CAMERAS: [CameraCalibration; 6] = [
    CameraCalibration {
        mounting: Mounting {
            channel: "CAM_FRONT",
            translation: [1.70079118954, 0.0159456324149, 1.51095763913],
            rotation: [
                0.4998015430569128,
                -0.5030316162024876,
                0.4997798114386805,
                -0.49737083824542755,
            ],
        },
        intrinsics: [
            1266.417203046554,
            1266.417203046554,
            816.2670197447984,
            491.50706579294757,
        ],
        offset_us: -35491,
    },
    CameraCalibration {
        mounting: Mounting {
            channel: "CAM_FRONT_RIGHT",
            translation: [1.5508477543, -0.493404796419, 1.49574800619],
            rotation: [
                0.2060347966337182,
                -0.2026940577919598,
                0.6824507824531167,
                -0.6713610884174485,
            ],
        },
        intrinsics: [
            1260.8474446004698,
            1260.8474446004698,
            807.968244525554,
            495.3344268742088,
        ],
        offset_us: -27612,
    },
    CameraCalibration {
        mounting: Mounting {
            channel: "CAM_BACK_RIGHT",
            translation: [1.0148780988, -0.480568219723, 1.56239545128],
            rotation: [
                0.12280980120078765,
                -0.132400842670559,
                -0.7004305821388234,
                0.690496031265798,
            ],
        },
        intrinsics: [
            1259.5137405846733,
            1259.5137405846733,
            807.2529053838625,
            501.19579884916527,
        ],
        offset_us: -20058,
    },
    CameraCalibration {
        mounting: Mounting {
            channel: "CAM_BACK",
            translation: [0.0283260309358, 0.00345136761476, 1.57910346144],
            rotation: [
                0.5037872666382278,
                -0.49740249788611096,
                -0.4941850223835201,
                0.5045496097725578,
            ],
        },
        intrinsics: [
            809.2209905677063,
            809.2209905677063,
            829.2196003259838,
            481.77842384512485,
        ],
        offset_us: -10426,
    },
    CameraCalibration {
        mounting: Mounting {
            channel: "CAM_BACK_LEFT",
            translation: [1.03569100218, 0.484795032713, 1.59097014818],
            rotation: [
                0.6924185592174665,
                -0.7031619420114925,
                -0.11648342771943819,
                0.11203317912370753,
            ],
        },
        intrinsics: [
            1256.7414812095406,
            1256.7414812095406,
            792.1125740759628,
            492.7757465151356,
        ],
        offset_us: -528,
    },
    CameraCalibration {
        mounting: Mounting {
            channel: "CAM_FRONT_LEFT",
            translation: [1.52387798135, 0.494631336551, 1.50932822144],
            rotation: [
                0.6757265034669446,
                -0.6736266522251881,
                0.21214015046209478,
                -0.21122827103904068,
            ],
        },
        intrinsics: [
            1272.5979470598488,
            1272.5979470598488,
            826.6154927353808,
            479.75165386361925,
        ],
        offset_us: -43107,
    },
];

/// LIDAR_TOP's mounting.
pub const LIDAR: Mounting = Mounting {
    channel: "LIDAR_TOP",
    translation: [0.985793, 0.0, 1.84019],
    rotation: [
        0.706749235646644,
        -0.015300993788500868,
        0.01739745181256607,
        -0.7070846669051719,
    ],
};

impl Mounting {
    /// ego_from_sensor, the quaternion normalised (as the devkit's pyquaternion does).
    pub fn ego_from_sensor(&self) -> Matrix4<f64> {
        pose_matrix(self.translation, self.rotation)
    }
}

/// The 4x4 matrix of a translation and a quaternion [w, x, y, z] (normalised).
pub fn pose_matrix(translation: [f64; 3], rotation: [f64; 4]) -> Matrix4<f64> {
    let [w, x, y, z] = rotation;
    let r = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)).to_rotation_matrix();
    let mut m = Matrix4::identity();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(r.matrix());
    m.fixed_view_mut::<3, 1>(0, 3)
        .copy_from(&Vector3::from(translation));
    m
}

/// [fx, fy, cx, cy] of a camera's image scaled by `scale` (pixel centres stay at integers).
pub fn scaled_intrinsics(k: [f64; 4], scale: f64) -> [f64; 4] {
    [
        k[0] * scale,
        k[1] * scale,
        (k[2] + 0.5) * scale - 0.5,
        (k[3] + 0.5) * scale - 0.5,
    ]
}
