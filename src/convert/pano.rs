//! Views of equirect panoramas and of fisheye cameras: the planners `panoconv pano` and
//! `panoconv fisheye` hand to [`crate::convert::folder::run_folder`].

use crate::camera::description::CameraDescription;
use crate::camera::rotated::rotation_ypr;
use crate::camera::{CameraModel, Equirect, ImageSize, Intrinsics, Projection, ProjectionReject};
use crate::convert::folder::{FolderJob, FolderPlan, FolderView};
use crate::error::{Error, Result};
use crate::geometry::{view_camera, Scale};
use crate::warp::{RemapTable, Wrap, LENS_TAPS_BELOW, TAPS_BELOW};
use nalgebra::{Matrix3, Point2, Vector3};
use serde::Serialize;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A full 360°×180° equirect panorama as a source camera: longitude wraps (the table's
/// [`Wrap::Horizontal`]) and latitude clamps at the poles: the pole rows are repeated, never
/// wrapped, and a ray exactly at the pole reads the last row instead of falling off the image.
#[derive(Debug, Clone)]
pub struct PanoSource {
    /// The panorama's camera (fu = width / 2π).
    pub equirect: Equirect,
}

impl PanoSource {
    /// The panorama camera of a `width`×`height` (2:1) image: fu = W/2π, fv = H/π, longitude 0
    /// at the centre column.
    pub fn new(size: ImageSize) -> Self {
        let (w, h) = (size.width as f64, size.height as f64);
        Self {
            equirect: Equirect::new(
                Intrinsics::new(w / (2.0 * PI), h / PI, w / 2.0 - 0.5, h / 2.0 - 0.5),
                size,
            ),
        }
    }
}

impl CameraModel for PanoSource {
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        let p = self.equirect.project(d)?;
        let h = self.equirect.size.height as f64;
        Ok(Point2::new(p.x, p.y.clamp(-0.5, h - 1.0)))
    }

    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        self.equirect.unproject(p)
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        p.norm()
    }

    fn size(&self) -> ImageSize {
        self.equirect.size
    }

    fn horizontal_period(&self) -> Option<f64> {
        self.equirect.horizontal_period()
    }
}

/// A scale as folder manifests write it (see [`serialize_scale`]).
struct FolderScale(Scale);

impl Serialize for FolderScale {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        serialize_scale(&self.0, s)
    }
}

/// Folder manifests call the source's own scale `source` (KITTI manifests `source_focal`):
/// the names of manifests already written.
fn serialize_scale<S: serde::Serializer>(
    scale: &Scale,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
    match scale {
        Scale::SourceFocal => s.serialize_unit_variant("Scale", 0, "source"),
        other => other.serialize(s),
    }
}

/// What `panoconv pano` makes of each panorama.
#[derive(Debug, Clone, serde::Serialize)]
pub struct PanoViews {
    /// Equirect, cylindrical or perspective.
    pub projection: Projection,
    /// View centres (radians): one output per yaw, right positive.
    pub yaws: Vec<f64>,
    /// Up positive (radians).
    pub pitch: f64,
    /// Horizontal field of view of each view, radians.
    pub hfov: f64,
    /// Vertical field of view of each view, radians.
    pub vfov: f64,
    /// Pixels per radian at the view centre (default: the panorama's own).
    #[serde(serialize_with = "serialize_scale")]
    pub scale: Scale,
}

/// `_yaw90`, `_yaw-45`, `_yaw22.5` (degrees as given) when there are several views.
fn yaw_suffix(yaws: &[f64], yaw: f64) -> String {
    if yaws.len() <= 1 {
        String::new()
    } else {
        let deg = (yaw.to_degrees() * 1e6).round() / 1e6;
        format!("_yaw{deg}")
    }
}

impl PanoViews {
    /// Checks the view geometry (set-up errors) on a nominal panorama.
    pub fn validate(&self) -> Result<()> {
        if self.yaws.is_empty() {
            return Err(Error::Setup("--yaw needs at least one angle".into()));
        }
        let f = self.scale.px_per_rad(2048.0 / (2.0 * PI));
        view_camera(self.projection, f, f, self.hfov, self.vfov).map(|_| ())
    }

    /// The views of a panorama of `size` (which must be 2:1).
    pub fn plan(&self, size: ImageSize) -> Result<Vec<FolderView>> {
        if size.width != 2 * size.height {
            return Err(Error::Setup(format!(
                "image is {size}, not a 2:1 equirect panorama"
            )));
        }
        let source = PanoSource::new(size);
        let f = self.scale.px_per_rad(source.equirect.k.fu);
        let camera: Arc<dyn crate::camera::LinearCamera> =
            Arc::from(view_camera(self.projection, f, f, self.hfov, self.vfov)?);
        Ok(self
            .yaws
            .iter()
            .map(|&yaw| {
                let source_from_output = rotation_ypr(yaw, self.pitch, 0.0);
                // the KITTI targets' rule: the pyramid (wrapping) above 2 source pixels
                let table = RemapTable::build_pyramid_above_wrap(
                    camera.as_ref(),
                    &source,
                    &source_from_output,
                    Wrap::Horizontal,
                    TAPS_BELOW,
                    false,
                );
                FolderView {
                    suffix: yaw_suffix(&self.yaws, yaw),
                    camera: camera.clone(),
                    source_from_output,
                    table: Arc::new(table),
                }
            })
            .collect())
    }
}

impl FolderPlan for PanoViews {
    fn command(&self) -> &'static str {
        "pano"
    }

    fn parameters(&self, job: &FolderJob) -> serde_json::Value {
        serde_json::json!({
            "input": job.input,
            "views": self,
            "png_compression": job.png_compression,
        })
    }

    fn views(&self, size: ImageSize) -> Result<Vec<FolderView>> {
        self.plan(size)
    }
}

/// What `panoconv fisheye` makes of each fisheye image.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FisheyeView {
    /// Equirect, cylindrical or perspective.
    pub projection: Projection,
    /// Radians; None: the camera's own (horizontal up to 360°, vertical capped for the
    /// projection).
    pub hfov: Option<f64>,
    /// Radians; None: the camera's own, capped for the projection.
    pub vfov: Option<f64>,
    /// Pixels per radian at the view centre (default: the lens's own at its centre).
    #[serde(serialize_with = "serialize_scale")]
    pub scale: Scale,
}

impl FisheyeView {
    /// The output frame of a camera: level (the description's rotation undone but for the
    /// heading), turned to the camera's heading. Returns `source_from_output`.
    pub fn source_from_output(desc: &CameraDescription) -> Matrix3<f64> {
        let forward = desc.output_from_camera * Vector3::z();
        let heading = forward.x.atan2(forward.z);
        desc.output_from_camera.transpose() * rotation_ypr(heading, 0.0, 0.0)
    }

    /// The field of view (radians) used for `desc`.
    pub fn fov(&self, desc: &CameraDescription) -> (f64, f64) {
        let (h, v) = self
            .projection
            .default_fisheye_view(2.0 * desc.camera.max_theta());
        let hfov = self.hfov.unwrap_or(h);
        let vfov = self.vfov.unwrap_or(v);
        (hfov, vfov)
    }

    /// The plan of a fisheye folder of `camera_file`'s camera: the single view, built now
    /// (its errors are set-up errors), for every image of the camera's size; an image of
    /// another size fails.
    pub fn plan_folder(&self, camera_file: &Path, desc: &CameraDescription) -> Result<FisheyePlan> {
        let (hfov, vfov) = self.fov(desc);
        Ok(FisheyePlan {
            camera_file: camera_file.to_path_buf(),
            camera_model: desc.camera.name(),
            size: desc.camera.size(),
            view: self.plan(desc)?,
            spec: self.clone(),
            hfov,
            vfov,
        })
    }

    /// The single view of every image of the camera (built at set-up: errors are set-up errors).
    pub fn plan(&self, desc: &CameraDescription) -> Result<FolderView> {
        let centre = desc.camera.centre_intrinsics();
        let fu = self.scale.px_per_rad(centre.fu);
        let fv = self.projection.fv(fu, centre.fu, centre.fv);
        let (hfov, vfov) = self.fov(desc);
        let camera: Arc<dyn crate::camera::LinearCamera> =
            Arc::from(view_camera(self.projection, fu, fv, hfov, vfov)?);
        let source_from_output = Self::source_from_output(desc);
        // a lens source's rule: the pyramid above 3 source pixels (tests/fisheye_pyramid.rs)
        let table = RemapTable::build_pyramid_above(
            camera.as_ref(),
            &desc.camera,
            &source_from_output,
            LENS_TAPS_BELOW,
            false,
        );
        Ok(FolderView {
            suffix: String::new(),
            camera,
            source_from_output,
            table: Arc::new(table),
        })
    }
}

/// A fisheye folder's plan: one view for every image of the camera.
pub struct FisheyePlan {
    camera_file: PathBuf,
    camera_model: &'static str,
    size: ImageSize,
    view: FolderView,
    spec: FisheyeView,
    hfov: f64,
    vfov: f64,
}

impl FolderPlan for FisheyePlan {
    fn command(&self) -> &'static str {
        "fisheye"
    }

    fn parameters(&self, job: &FolderJob) -> serde_json::Value {
        serde_json::json!({
            "input": job.input,
            "camera": self.camera_file,
            "camera_model": self.camera_model,
            "projection": self.spec.projection,
            "hfov_deg": self.hfov.to_degrees(),
            "vfov_deg": self.vfov.to_degrees(),
            "scale": FolderScale(self.spec.scale),
            "png_compression": job.png_compression,
        })
    }

    fn views(&self, size: ImageSize) -> Result<Vec<FolderView>> {
        if size != self.size {
            return Err(Error::Setup(format!(
                "image is {size}, the camera description says {}",
                self.size
            )));
        }
        Ok(vec![self.view.clone()])
    }
}
