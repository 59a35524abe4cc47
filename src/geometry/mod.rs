//! Output geometry: which output camera (intrinsics and canvas) a source camera maps to.
//!
//! Defaults follow the issue and the papers: the angular resolution at the centre equals the
//! source focal length (fu = fx px/rad; cylindrical keeps f_phi/f_y = f_X/f_Y as Plaut et al.),
//! and the canvas is the tight bounding box of the source field of view in the target
//! projection, rounded outward to whole pixels.

pub mod augment;
mod view;

pub use view::view_camera;

use crate::camera::{
    CameraModel, FisheyeCamera, ImageSize, Intrinsics, Lens, LinearCamera, OutputCamera,
    OutputProjection, Projection,
};
use crate::error::{Error, Result};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::path::PathBuf;

/// Pixels per radian at the centre of the output.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Scale {
    /// The source camera's focal length (the default).
    SourceFocal,
    /// The width of a full 360° panorama at this scale (2048 gives 325.95 px/rad).
    PanoWidth(u32),
    /// Pixels per degree at the centre.
    PixelsPerDegree(f64),
}

impl Scale {
    /// The scale `--pano-width` or `--px-per-deg` asks for (default: the source's own).
    pub fn from_flags(pano_width: Option<u32>, px_per_deg: Option<f64>) -> Result<Scale> {
        match (pano_width, px_per_deg) {
            (Some(0), _) => Err(Error::Setup("--pano-width must be positive".into())),
            (Some(w), _) => Ok(Scale::PanoWidth(w)),
            (None, Some(d)) if !(d > 0.0 && d.is_finite()) => {
                Err(Error::Setup("--px-per-deg must be positive".into()))
            }
            (None, Some(d)) => Ok(Scale::PixelsPerDegree(d)),
            (None, None) => Ok(Scale::SourceFocal),
        }
    }

    /// Pixels per radian, given the source's own at its centre.
    pub fn px_per_rad(self, source: f64) -> f64 {
        match self {
            Scale::SourceFocal => source,
            Scale::PanoWidth(w) => w as f64 / (2.0 * PI),
            Scale::PixelsPerDegree(d) => d * 180.0 / PI,
        }
    }
}

/// The extent of the output canvas, before crop and resize (`--full-360`, `--size`; else tight).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Canvas {
    /// The tight bounding box of the source field of view.
    Tight,
    /// The whole 360° of azimuth (and for equirect the whole 180° of latitude).
    Full360,
    /// An explicit size, centred on the source field of view.
    Size(ImageSize),
    /// The whole 360° of azimuth and, vertically, the band the source cameras cover together
    /// (a rig's panorama by default: no rows where no camera sees).
    Band,
}

/// A window of the output canvas, in its pixels (before any resize).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Crop {
    /// The canvas column that becomes the window's column 0; negative reaches left of the canvas.
    pub x: i64,
    /// The canvas row that becomes the window's row 0; negative reaches above the canvas.
    pub y: i64,
    /// Width of the window, pixels (positive).
    pub width: u32,
    /// Height of the window, pixels (positive).
    pub height: u32,
}

/// The output camera to build from each source camera: projection, scale and canvas, then an
/// optional crop and resize.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OutputSpec {
    /// The target projection (`--to`).
    pub projection: Projection,
    /// Pixels per radian at the centre of the output.
    pub scale: Scale,
    /// Which part of the target projection the canvas covers.
    pub canvas: Canvas,
    /// Applied to the canvas first; may reach beyond it (black there).
    #[serde(default)]
    pub crop: Option<Crop>,
    /// Then the (cropped) image is resized to this size. Both only change K and the size: the
    /// image is resampled once, straight from the source.
    #[serde(default)]
    pub resize: Option<ImageSize>,
}

impl OutputSpec {
    /// A spec for `projection` with the defaults: the source focal length, a tight canvas, no crop
    /// and no resize.
    pub fn new(projection: Projection) -> Self {
        Self {
            projection,
            scale: Scale::SourceFocal,
            canvas: Canvas::Tight,
            crop: None,
            resize: None,
        }
    }

    /// Whether this spec maps a perspective source onto itself.
    pub fn is_identity(&self) -> bool {
        self.projection == Projection::Perspective
            && self.scale == Scale::SourceFocal
            && self.canvas == Canvas::Tight
    }
}

/// A real fisheye camera to render into: a camera description or a native calibration file
/// (docs/fisheye.md), at the source camera's centre, turned by the file's rotation relative to
/// KITTI's rectified axes. Its size and intrinsics are the file's (then `--crop`/`--resize`).
#[derive(Debug, Clone, Serialize)]
pub struct FisheyeTarget {
    /// The file, as given.
    pub camera: PathBuf,
    /// Its blake3: `--resume` refuses a run whose camera file changed.
    pub camera_blake3: String,
    /// The lens model's name.
    pub model: String,
    /// The lens model and its parameters, read from the file.
    #[serde(skip)]
    pub lens: Lens,
    /// The camera's axes in rect: a lens bearing d is `rect_from_camera · d`.
    #[serde(skip)]
    pub rect_from_camera: Matrix3<f64>,
}

impl FisheyeTarget {
    /// The fisheye target described by `file` (a camera description or a native calibration
    /// file), with the file's hash for the manifest.
    pub fn read(file: &std::path::Path) -> Result<Self> {
        let desc = crate::camera::description::CameraDescription::read(file)?;
        let bytes = crate::fs::read_file(file)?;
        Ok(FisheyeTarget {
            camera: file.to_path_buf(),
            camera_blake3: crate::fs::hash_hex(&bytes),
            model: desc.camera.name().to_owned(),
            lens: desc.camera,
            rect_from_camera: desc.output_from_camera,
        })
    }
}

/// Rounds up, forgiving floating-point noise so that an exact fit is not one pixel wider.
fn ceil_px(x: f64) -> u32 {
    (x - 1e-6).ceil().max(1.0) as u32
}

/// Projection coordinates (a, b) of the source field of view: its border densely and its
/// interior on a grid (a wide source can reach its extremes inside, e.g. a pole).
fn fov_bounds(target: &dyn LinearCamera, source: &dyn CameraModel) -> Result<[f64; 4]> {
    let size = source.size();
    let (w, h) = (size.width as f64, size.height as f64);
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut add = |x: f64, y: f64| {
        if let Ok(d) = source.unproject(&nalgebra::Point2::new(x, y)) {
            if let Ok((a, bb)) = target.bearing_to_ab(&d) {
                b[0] = b[0].min(a);
                b[1] = b[1].min(bb);
                b[2] = b[2].max(a);
                b[3] = b[3].max(bb);
            }
        }
    };
    let steps_x = (2.0 * w) as usize;
    let steps_y = (2.0 * h) as usize;
    for i in 0..=steps_x {
        let x = -0.5 + w * i as f64 / steps_x as f64;
        add(x, -0.5);
        add(x, h - 0.5);
    }
    for j in 0..=steps_y {
        let y = -0.5 + h * j as f64 / steps_y as f64;
        add(-0.5, y);
        add(w - 0.5, y);
    }
    for j in 0..=16 {
        for i in 0..=16 {
            add(-0.5 + w * i as f64 / 16.0, -0.5 + h * j as f64 / 16.0);
        }
    }
    if !b.iter().all(|v| v.is_finite()) {
        return Err(Error::Setup(format!(
            "the source field of view has no image in the {} projection",
            target.projection()
        )));
    }
    Ok(b)
}

/// Intrinsics and size after cropping the window `crop` out of an image.
pub fn crop_intrinsics(k: Intrinsics, crop: &Crop) -> (Intrinsics, ImageSize) {
    (
        Intrinsics::new(k.fu, k.fv, k.cu - crop.x as f64, k.cv - crop.y as f64),
        ImageSize::new(crop.width, crop.height),
    )
}

/// Intrinsics after resizing an image of `from` pixels to `to` pixels. Pixel centres are at
/// integers, so a point at u maps to s(u + 0.5) − 0.5: fu' = s·fu, cu' = s(cu + 0.5) − 0.5.
pub fn resize_intrinsics(k: Intrinsics, from: ImageSize, to: ImageSize) -> Intrinsics {
    let sx = to.width as f64 / from.width as f64;
    let sy = to.height as f64 / from.height as f64;
    Intrinsics::new(
        k.fu * sx,
        k.fv * sy,
        sx * (k.cu + 0.5) - 0.5,
        sy * (k.cv + 0.5) - 0.5,
    )
}

/// What a conversion renders into: a linear projection (with its scale and canvas rules) or
/// a real fisheye camera, whose size and scale are its file's. Either way the spec's crop and
/// resize apply.
#[derive(Debug, Clone)]
pub enum Target {
    /// A linear projection: `spec.projection` at `spec.scale` over `spec.canvas`.
    Linear(OutputSpec),
    /// A real fisheye camera (`--to fisheye --camera FILE`).
    Fisheye {
        /// The camera, read from its file.
        camera: Box<FisheyeTarget>,
        /// Applied to the camera's image first; may reach beyond it.
        crop: Option<Crop>,
        /// Then the (cropped) image is resized to this size.
        resize: Option<ImageSize>,
    },
}

/// The manifest's record of a [`Target`]'s projection and geometry (`output_spec`), in the
/// shape of [`OutputSpec`]: a fisheye target's scale and canvas are its camera's own.
#[derive(Debug, Serialize)]
pub struct TargetRecord {
    projection: &'static str,
    scale: Scale,
    canvas: Canvas,
    crop: Option<Crop>,
    resize: Option<ImageSize>,
}

impl Target {
    /// The projection the written calib names.
    pub fn projection(&self) -> OutputProjection {
        match self {
            Target::Linear(spec) => OutputProjection::Linear(spec.projection),
            Target::Fisheye { .. } => OutputProjection::Fisheye,
        }
    }

    /// The fisheye camera, for a fisheye target.
    pub fn fisheye(&self) -> Option<&FisheyeTarget> {
        match self {
            Target::Linear(_) => None,
            Target::Fisheye { camera, .. } => Some(camera),
        }
    }

    /// Whether every output image has the target camera's own size (then cropped and
    /// resized) whatever the source: a fisheye target's.
    pub fn has_fixed_size(&self) -> bool {
        match self {
            Target::Linear(_) => false,
            Target::Fisheye { .. } => true,
        }
    }

    /// The scale of the output (a fisheye target's is its camera's: [`Scale::SourceFocal`]).
    pub fn scale(&self) -> Scale {
        match self {
            Target::Linear(spec) => spec.scale,
            Target::Fisheye { .. } => Scale::SourceFocal,
        }
    }

    /// What the manifest records of the target's geometry.
    pub fn record(&self) -> TargetRecord {
        let (scale, canvas, crop, resize) = match self {
            Target::Linear(s) => (s.scale, s.canvas, s.crop, s.resize),
            Target::Fisheye { crop, resize, .. } => {
                (Scale::SourceFocal, Canvas::Tight, *crop, *resize)
            }
        };
        TargetRecord {
            projection: self.projection().name(),
            scale,
            canvas,
            crop,
            resize,
        }
    }

    /// The camera a conversion writes: the fisheye target's lens, or the linear output camera
    /// of [`output_camera`] for a source camera (intrinsics `src_k` of a perspective source
    /// for the default scale; `source` for the field of view), after the crop and resize
    /// either way.
    pub fn camera(
        &self,
        src_k: Intrinsics,
        source: &dyn CameraModel,
    ) -> Result<Box<dyn OutputCamera>> {
        self.camera_over(src_k, source, &[])
    }

    /// As [`Target::camera`], with the other cameras whose fields of view a
    /// [`Canvas::Band`] covers besides `source`'s.
    pub fn camera_over(
        &self,
        src_k: Intrinsics,
        source: &dyn CameraModel,
        others: &[&dyn CameraModel],
    ) -> Result<Box<dyn OutputCamera>> {
        match self {
            Target::Fisheye {
                camera: f,
                crop,
                resize,
            } => {
                let camera = FisheyeCamera {
                    lens: f.lens.clone(),
                    rect_from_camera: f.rect_from_camera,
                };
                let (k, size) =
                    crop_and_resize(*crop, *resize, camera.intrinsics(), camera.size())?;
                camera
                    .with_intrinsics(k, size)
                    .map_err(|e| Error::Setup(format!("{}: {e}", f.camera.display())))
            }
            Target::Linear(spec) => Ok(output_camera_over(spec, src_k, source, others)?),
        }
    }
}

/// The output camera for a source camera (intrinsics `src_k` of a perspective source for the
/// default scale; `source` for the field of view), after the spec's crop and resize.
pub fn output_camera(
    spec: &OutputSpec,
    src_k: Intrinsics,
    source: &dyn CameraModel,
) -> Result<Box<dyn LinearCamera>> {
    output_camera_over(spec, src_k, source, &[])
}

/// As [`output_camera`], a [`Canvas::Band`] covering `others`' fields of view too.
pub fn output_camera_over(
    spec: &OutputSpec,
    src_k: Intrinsics,
    source: &dyn CameraModel,
    others: &[&dyn CameraModel],
) -> Result<Box<dyn LinearCamera>> {
    let canvas = canvas_camera(spec, src_k, source, others)?;
    if let Some(crop) = spec.crop.filter(|_| spec.projection.wraps()) {
        crop_within_one_turn(spec.projection, &crop, canvas.intrinsics())?;
    }
    let (k, size) = crop_and_resize(spec.crop, spec.resize, canvas.intrinsics(), canvas.size())?;
    Ok(spec.projection.camera(k, size))
}

/// A crop of a projection whose longitude wraps must keep its columns within ±180°: past it the
/// image shows the same longitudes a turn later, where no label or depth point is placed.
fn crop_within_one_turn(projection: Projection, crop: &Crop, k: Intrinsics) -> Result<()> {
    // the edges of the columns at ±π (pixel centres at integers)
    let first = (k.cu - PI * k.fu + 0.5 - 1e-6).ceil() as i64;
    let end = (k.cu + PI * k.fu + 0.5 + 1e-6).floor() as i64;
    let crop_end = crop.x + i64::from(crop.width);
    if crop.x >= first && crop_end <= end {
        return Ok(());
    }
    Err(Error::Setup(format!(
        "crop {},{},{},{}: its columns {} to {} reach past ±180° of the {projection} output \
         (columns {first} to {end}), where the image repeats a turn later but its labels and \
         depth do not; keep the crop within columns {first} to {end}",
        crop.x, crop.y, crop.width, crop.height, crop.x, crop_end
    )))
}

/// Intrinsics and size of a canvas after the spec's crop, then resize.
fn crop_and_resize(
    crop: Option<Crop>,
    resize: Option<ImageSize>,
    k: Intrinsics,
    size: ImageSize,
) -> Result<(Intrinsics, ImageSize)> {
    let (mut k, mut size) = (k, size);
    if let Some(c) = &crop {
        if c.width == 0 || c.height == 0 {
            return Err(Error::Setup(
                "crop width and height must be positive".into(),
            ));
        }
        (k, size) = crop_intrinsics(k, c);
    }
    if let Some(to) = resize {
        if to.width == 0 || to.height == 0 {
            return Err(Error::Setup(
                "resize width and height must be positive".into(),
            ));
        }
        k = resize_intrinsics(k, size, to);
        size = to;
    }
    if !([k.fu, k.fv, k.cu, k.cv].iter().all(|v| v.is_finite()) && k.fu > 0.0 && k.fv > 0.0) {
        return Err(Error::Setup(format!(
            "the output intrinsics are not finite ({k:?}): check P2"
        )));
    }
    Ok((k, size))
}

/// The output camera before crop and resize.
fn canvas_camera(
    spec: &OutputSpec,
    src_k: Intrinsics,
    source: &dyn CameraModel,
    others: &[&dyn CameraModel],
) -> Result<Box<dyn LinearCamera>> {
    let proj = spec.projection;
    if proj == Projection::Perspective
        && spec.scale == Scale::SourceFocal
        && spec.canvas == Canvas::Tight
    {
        return Ok(proj.camera(src_k, source.size()));
    }
    let fu = spec.scale.px_per_rad(src_k.fu);
    if !(fu > 0.0 && fu.is_finite()) {
        return Err(Error::Setup(format!("invalid output scale {fu} px/rad")));
    }
    let fv = proj.fv(fu, src_k.fu, src_k.fv);
    let unit = proj.camera(Intrinsics::new(1.0, 1.0, 0.0, 0.0), ImageSize::new(1, 1));
    let [a0, mut b0, a1, mut b1] = fov_bounds(unit.as_ref(), source)?;
    if spec.canvas == Canvas::Band {
        for other in others {
            let [_, lo, _, hi] = fov_bounds(unit.as_ref(), *other)?;
            (b0, b1) = (b0.min(lo), b1.max(hi));
        }
    }
    let tight = |f: f64, lo: f64, hi: f64| {
        let n = ceil_px(f * (hi - lo));
        // centre the rounding slack
        let c = -0.5 - f * lo + (n as f64 - f * (hi - lo)) / 2.0;
        (n, c)
    };
    let (width, height, k) = match spec.canvas {
        Canvas::Tight => {
            let (w, cu) = tight(fu, a0, a1);
            let (h, cv) = tight(fv, b0, b1);
            (w, h, Intrinsics::new(fu, fv, cu, cv))
        }
        Canvas::Size(s) => {
            let cu = (s.width as f64 - 1.0) / 2.0 - fu * (a0 + a1) / 2.0;
            let cv = (s.height as f64 - 1.0) / 2.0 - fv * (b0 + b1) / 2.0;
            (s.width, s.height, Intrinsics::new(fu, fv, cu, cv))
        }
        Canvas::Full360 | Canvas::Band => {
            if !proj.wraps() {
                return Err(Error::Setup(format!("a {proj} image cannot cover 360°")));
            }
            // The width must hold exactly 2π so that the panorama wraps without a seam.
            let w = match spec.scale {
                Scale::PanoWidth(w) => w,
                _ => (2.0 * PI * fu).round() as u32,
            };
            let fu = w as f64 / (2.0 * PI);
            let cu = w as f64 / 2.0 - 0.5;
            match proj {
                Projection::Equirect if spec.canvas == Canvas::Band => {
                    let fv = fu;
                    let (h, cv) = tight(fv, b0, b1);
                    (w, h, Intrinsics::new(fu, fv, cu, cv))
                }
                Projection::Equirect => {
                    let h = w.div_ceil(2);
                    let fv = h as f64 / PI;
                    (w, h, Intrinsics::new(fu, fv, cu, h as f64 / 2.0 - 0.5))
                }
                Projection::Perspective | Projection::Cylindrical => {
                    let fv = fu * src_k.fv / src_k.fu;
                    let (h, cv) = tight(fv, b0, b1);
                    (w, h, Intrinsics::new(fu, fv, cu, cv))
                }
            }
        }
    };
    if width > 65535 || height > 65535 {
        return Err(Error::Setup(format!(
            "output of {width}x{height} pixels is too large"
        )));
    }
    Ok(proj.camera(k, ImageSize::new(width, height)))
}
