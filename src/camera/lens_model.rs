//! [`LensModel`]: what makes one wide-angle model differ from another, as data behind one
//! trait: its name and parameters, the rules of its field of view, and its mapping between
//! bearings and pixels given the parts every lens shares (intrinsics, half field of view),
//! which [`super::Lens`] holds once for all models.
//!
//! A model's mapping takes the shared intrinsics as arguments rather than returning normalised
//! coordinates, so that each model keeps its own order of floating-point operations (outputs
//! stay byte-identical whatever the wrapper). `Box<dyn LensModel>` is itself a model: the lens
//! of any model that descriptions, calibration files and output cameras hold.

use super::lens_domain::FisheyeError;
use super::{ImageSize, Intrinsics, ProjectionReject};
use nalgebra::{Point2, Vector3};
use serde_json::{json, Value};
use std::any::Any;

/// A wide-angle model: the parameters of its normalised lens and its mapping (see the module
/// documentation). Implementations are plain data (`Clone`, compared by name and parameters).
pub trait LensModel: Send + Sync + std::fmt::Debug + BoxedLensModel + 'static {
    /// The model's name as in a camera description's `model` field and calib lines.
    fn name(&self) -> &'static str;

    /// The parameters besides fx, fy, cx, cy, named as in calib lines (`k` listed as k1..k4),
    /// in the order [`ReadLensModel::from_parameters`] reads them back.
    fn parameters(&self) -> Vec<(&'static str, f64)>;

    /// Refuses parameters outside the range the model is defined for (checked after the
    /// intrinsics, before the field of view).
    fn check(&self) -> Result<(), FisheyeError> {
        Ok(())
    }

    /// The half field of view (radians) a lens of this model sees when `max_theta` is asked
    /// for, or why the model cannot represent it.
    fn usable_max_theta(&self, max_theta: f64) -> Result<f64, FisheyeError>;

    /// The normalised image radius at `max_theta`, when [`LensModel::unproject`] bounds its
    /// search with it (kept by the lens so that it is computed once).
    fn edge_radius(&self, _max_theta: f64) -> f64 {
        f64::INFINITY
    }

    /// Pixel of a bearing (any non-zero length) for intrinsics `k` and half field of view
    /// `max_theta`.
    fn project(
        &self,
        k: &Intrinsics,
        max_theta: f64,
        d: &Vector3<f64>,
    ) -> Result<Point2<f64>, ProjectionReject>;

    /// Unit bearing of a pixel; `edge` is [`LensModel::edge_radius`] of `max_theta`.
    fn unproject(
        &self,
        k: &Intrinsics,
        max_theta: f64,
        edge: f64,
        p: &Point2<f64>,
    ) -> Result<Vector3<f64>, ProjectionReject>;

    /// Pixels per radian at the image centre, with the principal point of `k`: the scale an
    /// output keeps by default.
    fn centre_intrinsics(&self, k: &Intrinsics) -> Intrinsics;

    /// Adjusts parameters given in pixels when a crop or a resize moves the intrinsics from
    /// `from` to `to` (MEI's skew scales with fx); most models have none.
    fn rescale(&mut self, _from: &Intrinsics, _to: &Intrinsics) {}

    /// The model's fields of a camera description (after version, model, size and field of
    /// view), in the order they are written: by default fx, fy, cx, cy and each parameter.
    fn description_fields(&self, k: &Intrinsics, _size: ImageSize) -> Vec<(&'static str, Value)> {
        let mut out = affine_fields(k);
        out.extend(self.parameters().into_iter().map(|(n, v)| (n, json!(v))));
        out
    }
}

/// A model read back from its name and the values of [`LensModel::parameters`] (calib lines).
pub trait ReadLensModel: LensModel + Sized {
    /// The model `name` names with parameter `values`; None when `name` is not this model's.
    fn from_parameters(name: &str, values: &[f64]) -> Option<Result<Self, FisheyeError>>;
}

/// What `Box<dyn LensModel>` needs of every model: a boxed copy and a view for downcasting.
/// Implemented for every `Clone` model.
pub trait BoxedLensModel {
    /// A boxed copy.
    fn boxed(&self) -> Box<dyn LensModel>;
    /// The model as `Any`, for [`super::Lens::downcast`].
    fn as_any(&self) -> &dyn Any;
}

impl<T: LensModel + Clone> BoxedLensModel for T {
    fn boxed(&self) -> Box<dyn LensModel> {
        Box::new(self.clone())
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// fx, fy, cx, cy as a camera description writes them.
pub(crate) fn affine_fields(k: &Intrinsics) -> Vec<(&'static str, Value)> {
    vec![
        ("fx", json!(k.fu)),
        ("fy", json!(k.fv)),
        ("cx", json!(k.cu)),
        ("cy", json!(k.cv)),
    ]
}

/// How the registry of models (`camera/mod.rs`) reads one model back from its parameters.
pub(crate) type ModelReader = fn(&str, &[f64]) -> Option<Result<Box<dyn LensModel>, FisheyeError>>;

/// The [`ModelReader`] of model `M`.
pub(crate) fn reader<M: ReadLensModel + Clone>(
    name: &str,
    values: &[f64],
) -> Option<Result<Box<dyn LensModel>, FisheyeError>> {
    M::from_parameters(name, values).map(|m| m.map(|m| Box::new(m) as Box<dyn LensModel>))
}

impl Clone for Box<dyn LensModel> {
    fn clone(&self) -> Self {
        (**self).boxed()
    }
}

/// Two models are equal when they are the same model with the same parameters.
impl PartialEq for dyn LensModel {
    fn eq(&self, other: &Self) -> bool {
        self.name() == other.name() && self.parameters() == other.parameters()
    }
}

impl LensModel for Box<dyn LensModel> {
    fn name(&self) -> &'static str {
        (**self).name()
    }

    fn parameters(&self) -> Vec<(&'static str, f64)> {
        (**self).parameters()
    }

    fn check(&self) -> Result<(), FisheyeError> {
        (**self).check()
    }

    fn usable_max_theta(&self, max_theta: f64) -> Result<f64, FisheyeError> {
        (**self).usable_max_theta(max_theta)
    }

    fn edge_radius(&self, max_theta: f64) -> f64 {
        (**self).edge_radius(max_theta)
    }

    #[inline]
    fn project(
        &self,
        k: &Intrinsics,
        max_theta: f64,
        d: &Vector3<f64>,
    ) -> Result<Point2<f64>, ProjectionReject> {
        (**self).project(k, max_theta, d)
    }

    #[inline]
    fn unproject(
        &self,
        k: &Intrinsics,
        max_theta: f64,
        edge: f64,
        p: &Point2<f64>,
    ) -> Result<Vector3<f64>, ProjectionReject> {
        (**self).unproject(k, max_theta, edge, p)
    }

    fn centre_intrinsics(&self, k: &Intrinsics) -> Intrinsics {
        (**self).centre_intrinsics(k)
    }

    fn rescale(&mut self, from: &Intrinsics, to: &Intrinsics) {
        (**self).rescale(from, to)
    }

    fn description_fields(&self, k: &Intrinsics, size: ImageSize) -> Vec<(&'static str, Value)> {
        (**self).description_fields(k, size)
    }
}
