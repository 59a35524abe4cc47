//! Camera description files (JSON, `"version": 1`): a lens model, its intrinsics, image size,
//! maximum field of view and its rotation relative to the output frame. See docs/fisheye.md.
//! [`CameraDescription::read`] also takes the native calibration files of
//! `camera/calib_files.rs` (recognised by their content).
//!
//! Errors name the file, the field and the line (and column, in the message).

use super::double_sphere::DoubleSphere;
use super::eucm::Eucm;
use super::fisheye::{Fisheye, RadialModel};
use super::lens::Lens;
use super::lens_domain::FisheyeError;
use super::rotated::{is_rotation, rotation_ypr};
use super::unified::{MeiDistortion, Unified};
use super::{ImageSize, Intrinsics};
use crate::error::{Error, Result};
use nalgebra::Matrix3;
use serde::Deserialize;
use std::path::Path;

/// The format version this build reads.
pub const VERSION: u32 = 1;

#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
enum ModelName {
    Equidistant,
    Equisolid,
    Stereographic,
    Orthographic,
    #[serde(alias = "opencv_fisheye")]
    KannalaBrandt,
    Woodscape,
    #[serde(alias = "unified", alias = "omnidir")]
    Mei,
    Eucm,
    DoubleSphere,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RotationFile {
    yaw_deg: Option<f64>,
    pitch_deg: Option<f64>,
    roll_deg: Option<f64>,
    matrix: Option<[[f64; 3]; 3]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraFile {
    version: u32,
    model: ModelName,
    width: u32,
    height: u32,
    max_fov_deg: f64,
    fx: Option<f64>,
    fy: Option<f64>,
    cx: Option<f64>,
    cy: Option<f64>,
    k: Option<Vec<f64>>,
    aspect_ratio: Option<f64>,
    cx_offset: Option<f64>,
    cy_offset: Option<f64>,
    xi: Option<f64>,
    alpha: Option<f64>,
    beta: Option<f64>,
    p: Option<Vec<f64>>,
    skew: Option<f64>,
    rotation: Option<RotationFile>,
    /// Free text, ignored.
    #[allow(dead_code)]
    comment: Option<String>,
}

/// A loaded camera description.
#[derive(Debug, Clone)]
pub struct CameraDescription {
    /// The lens: model, intrinsics, image size and field of view.
    pub camera: Lens,
    /// The camera's axes in the output frame: a camera bearing d is `output_from_camera · d`.
    pub output_from_camera: Matrix3<f64>,
}

/// 1-based line and column of byte offset `at` in `text`.
fn line_col(text: &str, at: usize) -> (usize, usize) {
    let before = &text[..at.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    (line, col)
}

/// Byte offset of line/column (1-based).
fn offset_of(text: &str, line: usize, col: usize) -> usize {
    let mut at = 0;
    for (i, l) in text.split_inclusive('\n').enumerate() {
        if i + 1 == line {
            return (at + col.saturating_sub(1)).min(text.len());
        }
        at += l.len();
    }
    text.len()
}

/// The last `"key":` that starts before byte `at`: the field a serde error position is in.
fn field_before(text: &str, at: usize) -> Option<String> {
    let head = &text[..at.min(text.len())];
    let mut best = None;
    let mut search = 0;
    while let Some(q) = head[search..].find('"') {
        let start = search + q + 1;
        let Some(len) = head[start..].find('"') else {
            break;
        };
        let key = &head[start..start + len];
        let after = head[start + len + 1..].trim_start();
        if after.starts_with(':') {
            best = Some(key.to_owned());
        }
        search = start + len + 1;
    }
    best
}

/// The line of the first occurrence of `"key"` (1 when absent).
fn line_of_key(text: &str, key: &str) -> usize {
    text.find(&format!("\"{key}\""))
        .map_or(1, |at| line_col(text, at).0)
}

impl CameraDescription {
    /// Reads and validates a camera description file, or a native calibration file (KITTI-360
    /// YAML, WoodScape JSON, OpenCV FileStorage), recognised by its content.
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = crate::fs::read_file(path)?;
        let text = String::from_utf8(bytes)
            .map_err(|_| Error::file(path, "camera description is not valid UTF-8"))?;
        Self::parse_any(&text, path)
    }

    /// [`CameraDescription::parse`], or a native calibration file when the text is one.
    pub fn parse_any(text: &str, path: &Path) -> Result<Self> {
        match super::calib_files::parse_native(text, path)? {
            Some(camera) => Ok(Self {
                camera,
                output_from_camera: Matrix3::identity(),
            }),
            None => Self::parse(text, path),
        }
    }

    /// Parses the text of a camera description; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let file = read_json(text, path)?;
        let fields = Fields {
            file: &file,
            text,
            path,
        };
        let bad = |field: &str, message: String| fields.bad(field, message);
        let need = |v: Option<f64>, field: &str| fields.need(v, field);
        if file.version != VERSION {
            return Err(bad(
                "version",
                format!(
                    "unsupported camera description version {} (this panoconv reads version {VERSION})",
                    file.version
                ),
            ));
        }
        let size = ImageSize::new(file.width, file.height);
        if file.width == 0 || file.height == 0 {
            return Err(bad("width", format!("image size {size} must be positive")));
        }
        let (model, k) = match file.model {
            ModelName::Woodscape => woodscape(&fields)?,
            m => {
                let k = focal_intrinsics(&fields, m)?;
                let model = match m {
                    ModelName::Equidistant => RadialModel::Equidistant,
                    ModelName::Equisolid => RadialModel::Equisolid,
                    ModelName::Stereographic => RadialModel::Stereographic,
                    ModelName::Orthographic => RadialModel::Orthographic,
                    ModelName::KannalaBrandt => {
                        RadialModel::KannalaBrandt(fields.coefficients("k")?)
                    }
                    ModelName::Woodscape => unreachable!("handled above"),
                    ModelName::Mei | ModelName::Eucm | ModelName::DoubleSphere => {
                        let camera = self::unified_family(&file, m, k, size, &bad, &need)?;
                        return Ok(Self {
                            camera,
                            output_from_camera: rotation_of(&file, &bad)?,
                        });
                    }
                };
                if !matches!(model, RadialModel::KannalaBrandt(_)) {
                    fields.forbid(file.k.is_some(), "k")?;
                }
                (model, k)
            }
        };
        Ok(Self {
            camera: radial_fisheye(&file, model, k, size, &bad)?,
            output_from_camera: rotation_of(&file, &bad)?,
        })
    }
}

/// The description's JSON read into its fields: an error names the field it is in (serde_json
/// names a missing or unknown one; otherwise the key the error position is in) and its line.
fn read_json(text: &str, path: &Path) -> Result<CameraFile> {
    serde_json::from_str(text).map_err(|e| {
        let (line, col) = (e.line(), e.column());
        let message = e.to_string();
        let field = ["missing field `", "unknown field `"]
            .iter()
            .find_map(|p| {
                message
                    .strip_prefix(p)
                    .and_then(|r| r.split('`').next())
                    .map(str::to_owned)
            })
            .or_else(|| {
                matches!(e.classify(), serde_json::error::Category::Data)
                    .then(|| field_before(text, offset_of(text, line, col)))
                    .flatten()
            })
            .unwrap_or_else(|| "json".to_owned());
        // serde_json's message ends with "at line L column C".
        Error::parse(path, line, field, message)
    })
}

/// A description's fields with its text, for errors that name a field and its line.
struct Fields<'a> {
    file: &'a CameraFile,
    text: &'a str,
    path: &'a Path,
}

impl Fields<'_> {
    /// An error at `field`'s line.
    fn bad(&self, field: &str, message: String) -> Error {
        Error::parse(self.path, line_of_key(self.text, field), field, message)
    }

    /// A field the model needs, finite.
    fn need(&self, v: Option<f64>, field: &str) -> Result<f64> {
        let v = v.ok_or_else(|| {
            self.bad(
                "model",
                format!("model {:?} needs the field `{field}`", self.file.model),
            )
        })?;
        if !v.is_finite() {
            return Err(self.bad(field, "must be a finite number".into()));
        }
        Ok(v)
    }

    /// Refuses a field the model does not use.
    fn forbid(&self, present: bool, field: &str) -> Result<()> {
        if present {
            return Err(self.bad(
                field,
                format!("not used by model {:?}: remove it", self.file.model),
            ));
        }
        Ok(())
    }

    /// The polynomial coefficients `k`, at most 4, zeros after those given.
    fn coefficients(&self, field: &str) -> Result<[f64; 4]> {
        let k = self.file.k.clone().unwrap_or_default();
        if k.len() > 4 {
            return Err(self.bad(
                field,
                format!("expected at most 4 coefficients, found {}", k.len()),
            ));
        }
        Ok(std::array::from_fn(|i| k.get(i).copied().unwrap_or(0.0)))
    }
}

/// A WoodScape lens: its polynomial and intrinsics (aspect ratio, principal point offset).
fn woodscape(fields: &Fields) -> Result<(RadialModel, Intrinsics)> {
    let file = fields.file;
    let forbid = |present: bool, field: &str| fields.forbid(present, field);
    for (present, f) in [
        (file.fx.is_some(), "fx"),
        (file.fy.is_some(), "fy"),
        (file.cx.is_some(), "cx"),
        (file.cy.is_some(), "cy"),
    ] {
        forbid(present, f)?;
    }
    forbid_unified_fields(&forbid, file, &[])?;
    if file.k.is_none() {
        return Err(fields.bad("model", "model woodscape needs the field `k`".into()));
    }
    let k = fields.coefficients("k")?;
    let aspect = file.aspect_ratio.unwrap_or(1.0);
    if !(aspect > 0.0 && aspect.is_finite()) {
        return Err(fields.bad("aspect_ratio", format!("must be positive, not {aspect}")));
    }
    // WoodScape: principal point = offset + image centre (pixel centres at integers).
    let cu = file.width as f64 / 2.0 - 0.5 + file.cx_offset.unwrap_or(0.0);
    let cv = file.height as f64 / 2.0 - 0.5 + file.cy_offset.unwrap_or(0.0);
    Ok((
        RadialModel::Polynomial(k),
        Intrinsics::new(1.0, aspect, cu, cv),
    ))
}

/// The intrinsics of a model other than WoodScape's (fx, fy defaulting to fx, cx, cy), its
/// fields checked against the model's.
fn focal_intrinsics(fields: &Fields, m: ModelName) -> Result<Intrinsics> {
    let file = fields.file;
    let forbid = |present: bool, field: &str| fields.forbid(present, field);
    for (present, f) in [
        (file.aspect_ratio.is_some(), "aspect_ratio"),
        (file.cx_offset.is_some(), "cx_offset"),
        (file.cy_offset.is_some(), "cy_offset"),
    ] {
        forbid(present, f)?;
    }
    let allowed: &[&str] = match m {
        ModelName::Mei => &["xi", "p", "skew"],
        ModelName::Eucm => &["alpha", "beta"],
        ModelName::DoubleSphere => &["xi", "alpha"],
        _ => &[],
    };
    forbid_unified_fields(&forbid, file, allowed)?;
    let fx = fields.need(file.fx, "fx")?;
    let fy = fields.need(file.fy.or(file.fx), "fy")?;
    let cx = fields.need(file.cx, "cx")?;
    let cy = fields.need(file.cy, "cy")?;
    for (v, f) in [(fx, "fx"), (fy, "fy")] {
        if !(v > 0.0) {
            return Err(fields.bad(f, format!("focal length must be positive, not {v}")));
        }
    }
    Ok(Intrinsics::new(fx, fy, cx, cy))
}

/// A radial fisheye of `model` and `k` with the description's field of view.
fn radial_fisheye(
    file: &CameraFile,
    model: RadialModel,
    k: Intrinsics,
    size: ImageSize,
    bad: &dyn Fn(&str, String) -> Error,
) -> Result<Lens> {
    let fov = file.max_fov_deg;
    if !(fov > 0.0 && fov < 360.0) {
        return Err(bad(
            "max_fov_deg",
            format!("must be in (0, 360) degrees, not {fov}"),
        ));
    }
    let camera = Fisheye::new(model, k, size, fov.to_radians()).map_err(|e| {
        let field = match (&e, file.model) {
            (FisheyeError::NotMonotonic(_), ModelName::KannalaBrandt | ModelName::Woodscape) => "k",
            (FisheyeError::Intrinsics(_), _) => "model",
            _ => "max_fov_deg",
        };
        bad(field, e.to_string())
    })?;
    Ok(camera.erased())
}

/// Refuses the fields of the MEI, EUCM and double sphere models that `allowed` does not list.
fn forbid_unified_fields(
    forbid: &dyn Fn(bool, &str) -> Result<()>,
    file: &CameraFile,
    allowed: &[&str],
) -> Result<()> {
    for (present, f) in [
        (file.xi.is_some(), "xi"),
        (file.alpha.is_some(), "alpha"),
        (file.beta.is_some(), "beta"),
        (file.p.is_some(), "p"),
        (file.skew.is_some(), "skew"),
    ] {
        if !allowed.contains(&f) {
            forbid(present, f)?;
        }
    }
    Ok(())
}

/// The MEI, EUCM and double sphere cameras of a description (fx, fy, cx, cy already checked).
fn unified_family(
    file: &CameraFile,
    model: ModelName,
    k: Intrinsics,
    size: ImageSize,
    bad: &dyn Fn(&str, String) -> Error,
    need: &dyn Fn(Option<f64>, &str) -> Result<f64>,
) -> Result<Lens> {
    let fov = file.max_fov_deg;
    if !(fov > 0.0 && fov < 360.0) {
        return Err(bad(
            "max_fov_deg",
            format!("must be in (0, 360) degrees, not {fov}"),
        ));
    }
    let max_theta = fov.to_radians() / 2.0;
    let at_most = |v: &Option<Vec<f64>>, field: &str| at_most_two(v, field, bad);
    let built = match model {
        ModelName::Mei => {
            let [k1, k2] = at_most(&file.k, "k")?;
            let [p1, p2] = at_most(&file.p, "p")?;
            let skew = match file.skew {
                Some(s) => need(Some(s), "skew")?,
                None => 0.0,
            };
            Unified::new(
                need(file.xi, "xi")?,
                MeiDistortion { k1, k2, p1, p2 },
                k,
                skew,
                size,
                max_theta,
            )
            .map(Lens::erased)
        }
        ModelName::Eucm => {
            if file.k.is_some() {
                return Err(bad("k", "not used by model Eucm: remove it".into()));
            }
            Eucm::new(
                need(file.alpha, "alpha")?,
                need(file.beta, "beta")?,
                k,
                size,
                max_theta,
            )
            .map(Lens::erased)
        }
        _ => {
            if file.k.is_some() {
                return Err(bad("k", "not used by model DoubleSphere: remove it".into()));
            }
            DoubleSphere::new(
                need(file.xi, "xi")?,
                need(file.alpha, "alpha")?,
                k,
                size,
                max_theta,
            )
            .map(Lens::erased)
        }
    };
    built.map_err(|e| {
        let field = match &e {
            FisheyeError::Parameter(f, _) => f,
            FisheyeError::Intrinsics(_) => "model",
            FisheyeError::NotMonotonic(_) => "k",
            FisheyeError::FieldOfView(_) => "max_fov_deg",
        };
        bad(field, e.to_string())
    })
}

/// Up to two finite coefficients of `field`, zeros after those given.
fn at_most_two(
    v: &Option<Vec<f64>>,
    field: &str,
    bad: &dyn Fn(&str, String) -> Error,
) -> Result<[f64; 2]> {
    let v = v.clone().unwrap_or_default();
    if v.len() > 2 {
        return Err(bad(
            field,
            format!("expected at most 2 coefficients, found {}", v.len()),
        ));
    }
    if !v.iter().all(|c| c.is_finite()) {
        return Err(bad(field, "coefficients must be finite".into()));
    }
    Ok(std::array::from_fn(|i| v.get(i).copied().unwrap_or(0.0)))
}

/// The description's rotation (`output_from_camera`), identity when absent.
fn rotation_of(file: &CameraFile, bad: &dyn Fn(&str, String) -> Error) -> Result<Matrix3<f64>> {
    Ok(match &file.rotation {
        None => Matrix3::identity(),
        Some(r) => {
            let angles = [r.yaw_deg, r.pitch_deg, r.roll_deg];
            match (&r.matrix, angles.iter().any(Option::is_some)) {
                (Some(_), true) => {
                    return Err(bad(
                        "rotation",
                        "give either `matrix` or yaw_deg/pitch_deg/roll_deg, not both".into(),
                    ))
                }
                (Some(m), false) => {
                    let m = Matrix3::from_fn(|i, j| m[i][j]);
                    if !is_rotation(&m, 1e-6) {
                        return Err(bad(
                                "matrix",
                                "rotation.matrix is not a rotation (orthonormal, determinant +1 within 1e-6)"
                                    .into(),
                            ));
                    }
                    // Re-orthonormalise so that round trips stay exact.
                    nalgebra::Rotation3::from_matrix(&m).into_inner()
                }
                (None, _) => {
                    let [y, p, ro] = angles.map(|a| a.unwrap_or(0.0));
                    if ![y, p, ro].iter().all(|a| a.is_finite()) {
                        return Err(bad("rotation", "angles must be finite".into()));
                    }
                    rotation_ypr(y.to_radians(), p.to_radians(), ro.to_radians())
                }
            }
        }
    })
}

impl CameraDescription {
    /// The description as a version-1 JSON file that [`CameraDescription::parse`] reads back to
    /// the same lens (numbers written in their shortest round-trip form); `comment` goes into
    /// the `comment` field.
    pub fn to_json(&self, comment: Option<&str>) -> String {
        use serde_json::{json, Map, Value};
        let lens = &self.camera;
        let size = lens.size;
        let k = lens.intrinsics();
        let mut out = Map::new();
        out.insert("version".into(), json!(VERSION));
        out.insert("model".into(), json!(lens.name()));
        out.insert("width".into(), json!(size.width));
        out.insert("height".into(), json!(size.height));
        out.insert(
            "max_fov_deg".into(),
            json!(2.0 * lens.max_theta().to_degrees()),
        );
        for (field, value) in lens.model.description_fields(&k, size) {
            out.insert(field.into(), value);
        }
        if self.output_from_camera != Matrix3::identity() {
            let m = self.output_from_camera;
            let rows: Vec<[f64; 3]> = (0..3).map(|i| [m[(i, 0)], m[(i, 1)], m[(i, 2)]]).collect();
            out.insert("rotation".into(), json!({ "matrix": rows }));
        }
        if let Some(c) = comment {
            out.insert("comment".into(), json!(c));
        }
        let mut text = serde_json::to_string_pretty(&Value::Object(out)).expect("plain JSON");
        text.push('\n');
        text
    }
}
