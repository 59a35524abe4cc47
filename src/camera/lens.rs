//! [`Lens`]: a wide-angle camera of any [`LensModel`], as [`super::Linear`] is a linear camera of
//! any projection: the parts every lens shares (affine intrinsics, image size, half field of
//! view) are its fields, read in one place; the model only says how its normalised lens maps
//! bearings and what its parameters are. `Lens` alone (the default `Box<dyn LensModel>`) is a
//! lens of any model, as descriptions, calibration files and output cameras hold one;
//! `Lens<M>` is a lens of model `M` (`Fisheye`, `Unified`, `Eucm`, `DoubleSphere`).

use super::lens_domain::{check_intrinsics, field_angle, front_halfspace_of, FisheyeError};
use super::lens_model::LensModel;
use super::{CameraModel, ImageSize, Intrinsics, ProjectionReject};
use nalgebra::{Point2, Vector3};
use std::any::Any;
use std::f64::consts::PI;

/// A wide-angle lens of model `M` (any model by default).
#[derive(Debug, Clone, PartialEq)]
pub struct Lens<M = Box<dyn LensModel>> {
    /// The model and its parameters.
    pub model: M,
    /// The affine part: pixel = (fx·a (+ skew·b) + cx, fy·b + cy) of the model's normalised
    /// coordinates (a, b); pixel centres at integers. For WoodScape fx = 1, fy = aspect
    /// ratio; for MEI γ1, γ2, u0, v0.
    pub k: Intrinsics,
    /// Image size in pixels.
    pub size: ImageSize,
    /// Half the field of view (radians): bearings beyond it have no image.
    pub max_theta: f64,
    /// [`LensModel::edge_radius`] of `max_theta`.
    edge: f64,
}

impl<M: LensModel + Clone> Lens<M> {
    /// A lens of `model` with intrinsics `k`, an image of `size` and half field of view
    /// `max_theta` (radians): refuses unusable intrinsics, then the model's parameters, then a
    /// field of view the model cannot represent.
    pub fn with_model(
        model: M,
        k: Intrinsics,
        size: ImageSize,
        max_theta: f64,
    ) -> Result<Self, FisheyeError> {
        check_intrinsics(&k, size)?;
        model.check()?;
        let max_theta = model.usable_max_theta(max_theta)?;
        let edge = model.edge_radius(max_theta);
        Ok(Self {
            model,
            k,
            size,
            max_theta,
            edge,
        })
    }

    /// The model's name as in the camera description's `model` field.
    pub fn name(&self) -> &'static str {
        self.model.name()
    }

    /// The affine intrinsics ([`Lens::k`]): the values the half-pixel rule of crops and resizes
    /// applies to.
    pub fn intrinsics(&self) -> Intrinsics {
        self.k
    }

    /// The same lens with new affine intrinsics and image size (a crop or a resize).
    pub fn with_intrinsics(&self, k: Intrinsics, size: ImageSize) -> Result<Self, FisheyeError> {
        let mut model = self.model.clone();
        model.rescale(&self.k, &k);
        Self::with_model(model, k, size, self.max_theta)
    }

    /// Half the field of view (radians): bearings beyond it have no image.
    pub fn max_theta(&self) -> f64 {
        self.max_theta
    }

    /// The same lens seeing up to `max_theta` (half field of view, radians).
    pub fn with_max_theta(&self, max_theta: f64) -> Result<Self, FisheyeError> {
        Self::with_model(self.model.clone(), self.k, self.size, max_theta)
    }

    /// Pixels per radian at the image centre, with the principal point: the scale an output
    /// keeps by default.
    pub fn centre_intrinsics(&self) -> Intrinsics {
        self.model.centre_intrinsics(&self.k)
    }

    /// The model's parameters besides fx, fy, cx, cy, named as in the camera description
    /// (`k` listed as k1..k4), for calib lines and reports.
    pub fn parameters(&self) -> Vec<(&'static str, f64)> {
        self.model.parameters()
    }

    /// The same lens with `max_theta` lowered to what the image shows: the largest field angle
    /// of its four corners (the whole valid field of view when a corner lies beyond it). Native
    /// calibration files state no field of view; this is theirs.
    pub fn covering_image(&self) -> Result<Self, FisheyeError> {
        let s = self.size;
        let (w, h) = (s.width as f64 - 0.5, s.height as f64 - 0.5);
        let mut widest: f64 = 0.0;
        for corner in [(-0.5, -0.5), (w, -0.5), (-0.5, h), (w, h)] {
            match self.unproject(&Point2::new(corner.0, corner.1)) {
                Ok(d) => widest = widest.max(field_angle(&d)),
                Err(_) => return Ok(self.clone()),
            }
        }
        if widest >= self.max_theta || !(widest > 0.0) {
            return Ok(self.clone());
        }
        self.with_max_theta(widest.min(PI * (1.0 - 1e-9)))
    }

    /// This lens as a lens of any model.
    pub fn erased(self) -> Lens {
        let any: &dyn Any = &self.model;
        let model = match any.downcast_ref::<Box<dyn LensModel>>() {
            Some(already) => already.clone(),
            None => self.model.boxed(),
        };
        Lens {
            model,
            k: self.k,
            size: self.size,
            max_theta: self.max_theta,
            edge: self.edge,
        }
    }
}

impl Lens {
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
        let model = super::LENS_MODELS
            .iter()
            .find_map(|read| read(name, values))
            .ok_or_else(|| {
                FisheyeError::Parameter("model", format!("unknown camera model {name:?}"))
            })??;
        Lens::with_model(model, k, size, max_theta)
    }

    /// This lens as a lens of model `T`, when it is one.
    pub fn downcast<T: LensModel + Clone>(&self) -> Option<Lens<T>> {
        let model: &dyn LensModel = &*self.model;
        let model = model.as_any().downcast_ref::<T>()?;
        Some(Lens {
            model: model.clone(),
            k: self.k,
            size: self.size,
            max_theta: self.max_theta,
            edge: self.edge,
        })
    }
}

impl<M: LensModel> CameraModel for Lens<M> {
    #[inline]
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        self.model.project(&self.k, self.max_theta, d)
    }

    #[inline]
    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        self.model.unproject(&self.k, self.max_theta, self.edge, p)
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        p.norm()
    }

    fn size(&self) -> ImageSize {
        self.size
    }

    fn front_halfspace(&self) -> Option<Vector3<f64>> {
        front_halfspace_of(self.max_theta)
    }

    /// This lens, its model boxed (see [`CameraModel::lens`]).
    fn lens(&self) -> Option<Lens> {
        let model = match self.model.as_any().downcast_ref::<Box<dyn LensModel>>() {
            Some(already) => already.clone(),
            None => self.model.boxed(),
        };
        Some(Lens {
            model,
            k: self.k,
            size: self.size,
            max_theta: self.max_theta,
            edge: self.edge,
        })
    }

    /// The model by its name and parameters (what makes two models equal), then every field.
    fn exact_key(&self, key: &mut super::ExactKey) -> bool {
        let Lens {
            model,
            k,
            size,
            max_theta,
            edge,
        } = self;
        key.name(model.name());
        for (name, value) in model.parameters() {
            key.name(name);
            key.float(value);
        }
        key.intrinsics(k, *size);
        key.floats(&[*max_theta, *edge]);
        true
    }
}
