//! Camera models behind one trait.
//!
//! Axes (every model, every frame): x right, y down, z forward, as KITTI's rectified camera
//! frame. A *bearing* is a unit vector from the camera's optical centre. Pixel centres lie at
//! integer coordinates: pixel (0, 0) covers [-0.5, 0.5)², as KITTI's P matrices assume.
//!
//! Each projection is one file implementing [`CameraModel`] (the K-based ones implement only
//! their (a, b) [`Mapping`]; [`Linear`] adds K once for all of them). Each wide-angle model is
//! one file implementing [`LensModel`] (its parameters and its normalised lens); [`Lens`] holds
//! the intrinsics, size and field of view once for all of them. The warp, the label transform
//! and the output-geometry search only talk to [`CameraModel`], so a new model is one file.

mod calib_files;
mod cylindrical;
pub mod description;
mod double_sphere;
mod equirect;
mod eucm;
mod exact_key;
mod fisheye;
pub mod fit;
mod intrinsics;
mod lens;
mod lens_domain;
mod lens_model;
mod linear;
mod output;
mod perspective;
mod projection;
mod projection_camera;
pub(crate) mod rotated;
mod separable;
mod unified;
mod yaml_subset;

pub use cylindrical::Cylindrical;
pub use double_sphere::{DoubleSphere, DoubleSphereModel};
pub use equirect::Equirect;
pub use eucm::{Eucm, EucmModel};
pub use exact_key::ExactKey;
pub use fisheye::{Fisheye, RadialModel};
pub use intrinsics::{ImageSize, Intrinsics};
pub use lens::Lens;
pub use lens_domain::FisheyeError;
pub use lens_model::{BoxedLensModel, LensModel, ReadLensModel};
pub use linear::{Linear, Mapping};
pub use output::{FisheyeCamera, OutputCamera};
pub use perspective::Perspective;
pub(crate) use perspective::{pinhole_lanes, pinhole_point_lanes};
pub use projection::{OutputProjection, Projection, PROJECTIONS};
pub use rotated::{perpendiculars, rotation_ypr, Rotated};
pub use separable::{Separable, Share};
pub use unified::{MeiDistortion, MeiModel, Unified};

use nalgebra::{Point2, Vector3};

/// Every lens model that calib lines and [`Lens::from_parameters`] can name, tried in order: a
/// new model is its file, its `mod` line above and its line here.
const LENS_MODELS: &[lens_model::ModelReader] = &[
    lens_model::reader::<RadialModel>,
    lens_model::reader::<MeiModel>,
    lens_model::reader::<EucmModel>,
    lens_model::reader::<DoubleSphereModel>,
];

/// Why a bearing or a pixel has no counterpart in a camera.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProjectionReject {
    /// The ray points away from a camera that only sees its front half-space.
    BehindCamera,
    /// The ray is (numerically) on the projection's singular axis (cylinder axis, zero vector).
    Singular,
    /// The pixel lies outside the domain the projection maps (e.g. beyond a pole).
    OutsideDomain,
}

/// A central camera: maps unit bearings (camera frame, axes above) to pixels and back.
pub trait CameraModel: Send + Sync + std::fmt::Debug {
    /// Pixel of a bearing. The pixel may lie outside the image; use [`CameraModel::size`].
    fn project(&self, bearing: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject>;

    /// Unit bearing of a pixel.
    fn unproject(&self, pixel: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject>;

    /// The distance this projection pairs with for a point `p` relative to the centre: the
    /// quantity a detector regresses (z for perspective, range, or cylindrical rho).
    fn distance(&self, p: &Vector3<f64>) -> f64;

    /// Image size in pixels.
    fn size(&self) -> ImageSize;

    /// For a model that only sees one half-space: the normal n such that only bearings with
    /// n·d > 0 can have an image. Used to clip 3D geometry before projecting it.
    fn front_halfspace(&self) -> Option<Vector3<f64>> {
        None
    }

    /// Pixels per full turn when the horizontal pixel coordinate is an angle about the y axis
    /// (so that u and u ± period are the same direction).
    fn horizontal_period(&self) -> Option<f64> {
        None
    }

    /// Appends to `out` the pixel of each bearing of `bearings` (None for None and for the
    /// bearings [`CameraModel::project`] rejects): exactly `project`'s pixels, in one call for
    /// many bearings (remap tables). The linear projections override it only to spare the
    /// dynamic call per bearing; a camera wrapping another with other pixels keeps the default.
    fn project_all(&self, bearings: &[Option<Vector3<f64>>], out: &mut Vec<Option<Point2<f64>>>) {
        out.extend(bearings.iter().map(|d| self.project(d.as_ref()?).ok()));
    }

    /// This camera's unprojection as a column share and a row share, where it separates so:
    /// the batch form of [`CameraModel::unproject`] for grids of pixels (remap tables; see
    /// [`Separable`]). The linear projections have it, each implemented once in its
    /// [`Mapping`]; the others keep this default, None (each pixel unprojected alone), and so
    /// does a camera wrapping another with other bearings (a turned one, [`Rotated`]).
    fn separable(&self) -> Option<&dyn Separable> {
        None
    }

    /// Appends to `out` the bearings of the pixel centres of row `v`, columns -1..=width,
    /// exactly as [`CameraModel::unproject`] gives them (None for its errors), and gives true
    /// where this camera holds them already (a stitch's output gated by its reach bound: a
    /// remap table reads them instead of unprojecting each centre); false, `out` unchanged,
    /// for the others (this default).
    fn stored_centres(&self, _v: isize, _out: &mut Vec<Option<Vector3<f64>>>) -> bool {
        false
    }

    /// [`CameraModel::stored_centres`] of the positions of row `v` from the first to the last
    /// that may have a bearing alone (the others have none): appends theirs and gives their
    /// range, 0 for column -1; None, `out` unchanged, where this camera stores no centres
    /// (this default).
    fn stored_centre_span(
        &self,
        _v: isize,
        _out: &mut Vec<Option<Vector3<f64>>>,
    ) -> Option<std::ops::Range<usize>> {
        None
    }

    /// Whether [`CameraModel::project_all`] gives each bearing the same position wherever it
    /// lies in the slice (true, this default, for every camera but a depth-guided stitch's
    /// proxy, which reads a whole row of output pixel centres at once): then a remap table
    /// may project a part of a row alone.
    fn projects_bearing_by_bearing(&self) -> bool {
        true
    }

    /// `Some(K)` where this camera is a pinhole of intrinsics K in its own axes: its
    /// [`CameraModel::project`] is exactly [`Perspective`]'s (the front test, then K · (x/z,
    /// y/z)), so that a remap table may project many bearings in batches of its own. None
    /// otherwise, and for a camera wrapping another ([`Rotated`]).
    fn pinhole(&self) -> Option<Intrinsics> {
        None
    }

    /// `Some(lens)` where this camera is a [`Lens`] in its own axes: its
    /// [`CameraModel::project`] and [`CameraModel::project_point`] are exactly that lens's, so
    /// that a stitch's table may project many points in lanes of its own (a unified/MEI lens:
    /// [`Lens::downcast`]). None otherwise, and for a camera wrapping another.
    fn lens(&self) -> Option<Lens> {
        None
    }

    /// Project a point given relative to the optical centre (any length).
    fn project_point(&self, p: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        let n = p.norm();
        if !(n > 1e-12) {
            return Err(ProjectionReject::Singular);
        }
        self.project(&(p / n))
    }

    /// One coordinate (`axis` 0: u, 1: v) of [`CameraModel::project_point`]: the same f64 and
    /// the same rejection, for searches that compare one coordinate (the 2D box of a 3D box
    /// probes each edge thousands of times). A model overrides it only where one coordinate
    /// costs less than both, and only with the very operations `project_point` does.
    fn project_point_coordinate(
        &self,
        p: &Vector3<f64>,
        axis: usize,
    ) -> Result<f64, ProjectionReject> {
        self.project_point(p).map(|px| px[axis])
    }

    /// Whether every bearing d in front of the camera, n·d >= 1e-6·|d| with n its
    /// [`CameraModel::front_halfspace`], has a pixel: the model's domain is the whole front
    /// half-space, so a face in front of the near plane never leaves it (the 2D box of a 3D box
    /// then need not look for a rim). Conservative: false unless the model guarantees it, and
    /// always false for a model without a front half-space.
    fn sees_whole_front(&self) -> bool {
        false
    }

    /// Feeds `key` the exact bits of everything this camera's projections read and says true;
    /// false (the default) where it cannot (a wrapper of parts it does not know): what is built
    /// from such a camera is never reused for another (a rig run's kept stitches).
    fn exact_key(&self, _key: &mut ExactKey) -> bool {
        false
    }

    /// Whether a continuous pixel position lies on the image ([-0.5, size - 0.5)).
    fn contains(&self, px: &Point2<f64>) -> bool {
        let s = self.size();
        px.x >= -0.5 && px.y >= -0.5 && px.x < s.width as f64 - 0.5 && px.y < s.height as f64 - 0.5
    }
}

/// A camera whose pixels are an affine map `K` of projection coordinates (a, b):
/// pixel = K · (a, b, 1). Perspective, equirect and cylindrical are such cameras; their
/// calib lines (`K2:`) describe them completely.
pub trait LinearCamera: OutputCamera {
    /// Projection coordinates (a, b) of a bearing, before K (see the table in docs/geometry.md).
    fn bearing_to_ab(&self, bearing: &Vector3<f64>) -> Result<(f64, f64), ProjectionReject>;
    /// Bearing of projection coordinates (a, b).
    fn ab_to_bearing(&self, a: f64, b: f64) -> Result<Vector3<f64>, ProjectionReject>;
    /// A boxed copy, for sharing an output camera between frames.
    fn boxed_clone(&self) -> Box<dyn LinearCamera>;
}
