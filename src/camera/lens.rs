//! [`Lens`]: any of the wide-angle camera models a camera description or a native calibration
//! file can name, behind one [`CameraModel`], with what the rest of panoconv needs from a lens
//! besides projecting: its affine intrinsics (the fx, fy, cx, cy that crops and resizes move),
//! its field of view, its name and parameters.

use super::double_sphere::DoubleSphere;
use super::eucm::Eucm;
use super::fisheye::{Fisheye, FisheyeError, RadialModel};
use super::lens_domain::{field_angle, front_halfspace_of};
use super::unified::Unified;
use super::{CameraModel, ImageSize, Intrinsics, ProjectionReject};
use nalgebra::{Point2, Vector3};
use std::f64::consts::PI;

/// A wide-angle lens of any supported model.
#[derive(Debug, Clone, PartialEq)]
pub enum Lens {
    /// Radially symmetric r = R(θ): equidistant, equisolid, stereographic, orthographic,
    /// Kannala-Brandt, WoodScape.
    Radial(Fisheye),
    /// Unified model with Mei's distortion (KITTI-360, OpenCV omnidir).
    Unified(Unified),
    /// Extended unified camera model (Khomutenko et al.).
    Eucm(Eucm),
    /// Double sphere model (Usenko et al.).
    DoubleSphere(DoubleSphere),
}

impl From<Fisheye> for Lens {
    fn from(f: Fisheye) -> Self {
        Lens::Radial(f)
    }
}

impl Lens {
    /// The model's name as in the camera description's `model` field.
    pub fn name(&self) -> &'static str {
        match self {
            Lens::Radial(f) => f.model.name(),
            Lens::Unified(_) => "mei",
            Lens::Eucm(_) => "eucm",
            Lens::DoubleSphere(_) => "double_sphere",
        }
    }

    /// The affine part: pixel = (fx·a (+ skew·b) + cx, fy·b + cy) of the model's normalised
    /// coordinates (a, b). These are the values the half-pixel rule of crops and resizes applies
    /// to (for WoodScape fx = 1, fy = aspect ratio; for MEI γ1, γ2, u0, v0).
    pub fn intrinsics(&self) -> Intrinsics {
        match self {
            Lens::Radial(f) => f.k,
            Lens::Unified(m) => m.k,
            Lens::Eucm(m) => m.k,
            Lens::DoubleSphere(m) => m.k,
        }
    }

    /// The same lens with new affine intrinsics and image size (a crop or a resize); MEI's skew
    /// scales with fx as a resize scales it.
    pub fn with_intrinsics(&self, k: Intrinsics, size: ImageSize) -> Result<Lens, FisheyeError> {
        Ok(match self {
            Lens::Radial(f) => {
                Lens::Radial(Fisheye::new(f.model.clone(), k, size, 2.0 * f.max_theta)?)
            }
            Lens::Unified(m) => Lens::Unified(Unified::new(
                m.xi,
                m.distortion,
                k,
                m.skew * k.fu / m.k.fu,
                size,
                m.max_theta,
            )?),
            Lens::Eucm(m) => Lens::Eucm(Eucm::new(m.alpha, m.beta, k, size, m.max_theta)?),
            Lens::DoubleSphere(m) => {
                Lens::DoubleSphere(DoubleSphere::new(m.xi, m.alpha, k, size, m.max_theta)?)
            }
        })
    }

    /// Half the field of view (radians): bearings beyond it have no image.
    pub fn max_theta(&self) -> f64 {
        match self {
            Lens::Radial(f) => f.max_theta,
            Lens::Unified(m) => m.max_theta,
            Lens::Eucm(m) => m.max_theta,
            Lens::DoubleSphere(m) => m.max_theta,
        }
    }

    /// The same lens seeing up to `max_theta` (half field of view, radians).
    pub fn with_max_theta(&self, max_theta: f64) -> Result<Lens, FisheyeError> {
        Ok(match self {
            Lens::Radial(f) => {
                Lens::Radial(Fisheye::new(f.model.clone(), f.k, f.size, 2.0 * max_theta)?)
            }
            Lens::Unified(m) => Lens::Unified(Unified::new(
                m.xi,
                m.distortion,
                m.k,
                m.skew,
                m.size,
                max_theta,
            )?),
            Lens::Eucm(m) => Lens::Eucm(Eucm::new(m.alpha, m.beta, m.k, m.size, max_theta)?),
            Lens::DoubleSphere(m) => {
                Lens::DoubleSphere(DoubleSphere::new(m.xi, m.alpha, m.k, m.size, max_theta)?)
            }
        })
    }

    /// Pixels per radian at the image centre, with the principal point: the scale an output
    /// keeps by default.
    pub fn centre_intrinsics(&self) -> Intrinsics {
        match self {
            Lens::Radial(f) => f.centre_intrinsics(),
            // r ≈ θ/(1 + ξ) near the axis (the distortion is 1 + O(r²) there).
            Lens::Unified(m) => {
                let s = 1.0 / (1.0 + m.xi);
                Intrinsics::new(m.k.fu * s, m.k.fv * s, m.k.cu, m.k.cv)
            }
            Lens::Eucm(m) => m.k,
            Lens::DoubleSphere(m) => {
                let s = 1.0 / (1.0 + m.xi);
                Intrinsics::new(m.k.fu * s, m.k.fv * s, m.k.cu, m.k.cv)
            }
        }
    }

    /// The model's parameters besides fx, fy, cx, cy, named as in the camera description
    /// (`k` listed as k1..k4), for calib lines and reports.
    pub fn parameters(&self) -> Vec<(&'static str, f64)> {
        match self {
            Lens::Radial(f) => match &f.model {
                RadialModel::KannalaBrandt(k) | RadialModel::Polynomial(k) => {
                    vec![("k1", k[0]), ("k2", k[1]), ("k3", k[2]), ("k4", k[3])]
                }
                _ => vec![],
            },
            Lens::Unified(m) => vec![
                ("xi", m.xi),
                ("k1", m.distortion.k1),
                ("k2", m.distortion.k2),
                ("p1", m.distortion.p1),
                ("p2", m.distortion.p2),
                ("skew", m.skew),
            ],
            Lens::Eucm(m) => vec![("alpha", m.alpha), ("beta", m.beta)],
            Lens::DoubleSphere(m) => vec![("xi", m.xi), ("alpha", m.alpha)],
        }
    }

    /// The lens a model `name` (as [`Lens::name`]) makes with intrinsics `k`, the values of
    /// [`Lens::parameters`] in that order, an image `size` and half field of view `max_theta`:
    /// the inverse of those three, used to read a lens back from calib lines.
    pub fn from_parameters(
        name: &str,
        k: Intrinsics,
        values: &[f64],
        size: ImageSize,
        max_theta: f64,
    ) -> Result<Lens, FisheyeError> {
        let want = |n: usize| -> Result<(), FisheyeError> {
            if values.len() == n {
                Ok(())
            } else {
                Err(FisheyeError::Parameter(
                    "parameters",
                    format!("model {name} takes {n} parameters, found {}", values.len()),
                ))
            }
        };
        let four = || -> [f64; 4] { std::array::from_fn(|i| values[i]) };
        let radial =
            |model: RadialModel| Fisheye::new(model, k, size, 2.0 * max_theta).map(Lens::Radial);
        match name {
            "equidistant" | "equisolid" | "stereographic" | "orthographic" => {
                want(0)?;
                radial(match name {
                    "equidistant" => RadialModel::Equidistant,
                    "equisolid" => RadialModel::Equisolid,
                    "stereographic" => RadialModel::Stereographic,
                    _ => RadialModel::Orthographic,
                })
            }
            "kannala_brandt" => {
                want(4)?;
                radial(RadialModel::KannalaBrandt(four()))
            }
            "woodscape" => {
                want(4)?;
                radial(RadialModel::Polynomial(four()))
            }
            "mei" => {
                want(6)?;
                let distortion = super::unified::MeiDistortion {
                    k1: values[1],
                    k2: values[2],
                    p1: values[3],
                    p2: values[4],
                };
                Unified::new(values[0], distortion, k, values[5], size, max_theta)
                    .map(Lens::Unified)
            }
            "eucm" => {
                want(2)?;
                Eucm::new(values[0], values[1], k, size, max_theta).map(Lens::Eucm)
            }
            "double_sphere" => {
                want(2)?;
                DoubleSphere::new(values[0], values[1], k, size, max_theta).map(Lens::DoubleSphere)
            }
            other => Err(FisheyeError::Parameter(
                "model",
                format!("unknown camera model {other:?}"),
            )),
        }
    }

    /// The same lens with `max_theta` lowered to what the image shows: the largest field angle
    /// of its four corners (the whole valid field of view when a corner lies beyond it). Native
    /// calibration files state no field of view; this is theirs.
    pub fn covering_image(&self) -> Result<Lens, FisheyeError> {
        let s = self.size();
        let (w, h) = (s.width as f64 - 0.5, s.height as f64 - 0.5);
        let mut widest: f64 = 0.0;
        for corner in [(-0.5, -0.5), (w, -0.5), (-0.5, h), (w, h)] {
            match self.unproject(&Point2::new(corner.0, corner.1)) {
                Ok(d) => widest = widest.max(field_angle(&d)),
                Err(_) => return Ok(self.clone()),
            }
        }
        if widest >= self.max_theta() || !(widest > 0.0) {
            return Ok(self.clone());
        }
        self.with_max_theta(widest.min(PI * (1.0 - 1e-9)))
    }
}

impl CameraModel for Lens {
    #[inline]
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        match self {
            Lens::Radial(m) => m.project(d),
            Lens::Unified(m) => m.project(d),
            Lens::Eucm(m) => m.project(d),
            Lens::DoubleSphere(m) => m.project(d),
        }
    }

    #[inline]
    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        match self {
            Lens::Radial(m) => m.unproject(p),
            Lens::Unified(m) => m.unproject(p),
            Lens::Eucm(m) => m.unproject(p),
            Lens::DoubleSphere(m) => m.unproject(p),
        }
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        p.norm()
    }

    fn size(&self) -> ImageSize {
        match self {
            Lens::Radial(m) => m.size,
            Lens::Unified(m) => m.size,
            Lens::Eucm(m) => m.size,
            Lens::DoubleSphere(m) => m.size,
        }
    }

    fn front_halfspace(&self) -> Option<Vector3<f64>> {
        front_halfspace_of(self.max_theta())
    }
}
