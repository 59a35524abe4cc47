//! Calibration files in their native formats, recognised by their content so that `--camera`
//! takes them as they come:
//!
//! - KITTI-360 `image_02.yaml` / `image_03.yaml` (`model_type: MEI`, `mirror_parameters`,
//!   `distortion_parameters`, `projection_parameters`, `image_width`, `image_height`);
//! - WoodScape calibration JSON (`intrinsic: {model: radial_poly, k1..k4, aspect_ratio,
//!   cx_offset, cy_offset, width, height}`; the `extrinsic` is the mounting on the vehicle and is
//!   not used: the camera's axes are the output's);
//! - OpenCV `FileStorage` YAML or JSON with `K` and `D` (`cv::fisheye`, Kannala-Brandt) or `K`,
//!   `D` and `xi` (`cv::omnidir`, MEI), plus the image size (`image_width`/`image_height`,
//!   `width`/`height` or `image_size: [w, h]`).
//!
//! None of them states a field of view: it is the model's valid one, narrowed to what the image
//! shows (the widest field angle of the image's corners; see [`Lens::covering_image`]); OpenCV's
//! fisheye model is defined for z > 0 only, so at most 180°. Errors name the file, the line and
//! the field.

use super::fisheye::{Fisheye, RadialModel};
use super::lens::Lens;
use super::lens_domain::FisheyeError;
use super::unified::{MeiDistortion, Unified};
use super::yaml_subset::{self, Node};
use super::{ImageSize, Intrinsics};
use crate::error::{Error, Result};
use std::f64::consts::{FRAC_PI_2, PI};
use std::path::Path;

/// The lens of a native calibration file, or None when `text` is not one (a camera
/// description JSON, or JSON too broken to tell: the description parser reports it).
pub fn parse_native(text: &str, path: &Path) -> Result<Option<Lens>> {
    let body = text.trim_start_matches('\u{feff}').trim_start();
    if body.starts_with('{') {
        let Ok(value) = serde_json::from_str::<serde_json::Value>(text) else {
            return Ok(None);
        };
        let Some(object) = value.as_object() else {
            return Ok(None);
        };
        if object.contains_key("version") {
            return Ok(None);
        }
        let root = json_node(&value, text, &mut 0, 1);
        if object.contains_key("intrinsic") {
            return woodscape(&root, path).map(Some);
        }
        let storage = root.get("opencv_storage").unwrap_or(&root);
        if storage.get("K").is_some() {
            return opencv(storage, path).map(Some);
        }
        return Ok(None);
    }
    let root =
        yaml_subset::parse(text).map_err(|e| Error::parse(path, e.line, "yaml", e.message))?;
    if root.get("model_type").is_some() {
        return kitti360(&root, path).map(Some);
    }
    if root.get("K").is_some() {
        return opencv(&root, path).map(Some);
    }
    Err(Error::file(
        path,
        "not a camera file panoconv knows: expected a camera description JSON (docs/fisheye.md), \
         a KITTI-360 MEI YAML (model_type: MEI), a WoodScape calibration JSON (intrinsic: ...) \
         or an OpenCV FileStorage file with K and D",
    ))
}

/// JSON as [`Node`]s; each key's line is that of its first occurrence after its parent's.
fn json_node(value: &serde_json::Value, text: &str, cursor: &mut usize, line: usize) -> Node {
    use serde_json::Value;
    match value {
        Value::Object(map) => {
            let mut entries = Vec::new();
            let mut tag = None;
            for (key, v) in map {
                let needle = format!("\"{key}\"");
                let at = text[*cursor..]
                    .find(&needle)
                    .map_or(*cursor, |i| *cursor + i);
                *cursor = at;
                let key_line = text[..at].matches('\n').count() + 1;
                if key == "type_id" {
                    tag = v.as_str().map(str::to_owned);
                }
                entries.push((key.clone(), json_node(v, text, cursor, key_line)));
            }
            Node::Map { tag, entries, line }
        }
        Value::Array(items) => Node::Seq {
            items: items
                .iter()
                .map(|v| match v {
                    Value::String(s) => s.clone(),
                    other => other.to_string(),
                })
                .collect(),
            line,
        },
        Value::String(s) => Node::Scalar {
            text: s.clone(),
            line,
        },
        other => Node::Scalar {
            text: other.to_string(),
            line,
        },
    }
}

/// Field access with errors naming the file, the line and the (dotted) field.
struct Fields<'a> {
    path: &'a Path,
}

impl Fields<'_> {
    fn node<'n>(&self, parent: &'n Node, key: &str, field: &str) -> Result<&'n Node> {
        parent.get(key).ok_or_else(|| {
            Error::parse(
                self.path,
                parent.line(),
                field,
                format!("missing field `{key}`"),
            )
        })
    }

    fn number(&self, parent: &Node, key: &str, field: &str) -> Result<f64> {
        match self.node(parent, key, field)? {
            Node::Scalar { text, line } => text
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    Error::parse(
                        self.path,
                        *line,
                        field,
                        format!("not a finite number: {text:?}"),
                    )
                }),
            other => Err(Error::parse(
                self.path,
                other.line(),
                field,
                "expected a number",
            )),
        }
    }

    fn text(&self, parent: &Node, key: &str, field: &str) -> Result<(String, usize)> {
        match self.node(parent, key, field)? {
            Node::Scalar { text, line } => Ok((text.clone(), *line)),
            other => Err(Error::parse(
                self.path,
                other.line(),
                field,
                "expected a name",
            )),
        }
    }

    /// A positive whole number of pixels (`1280` or `1280.0`).
    fn pixels(&self, parent: &Node, key: &str, field: &str) -> Result<u32> {
        let v = self.number(parent, key, field)?;
        if !(v >= 1.0 && v <= u32::MAX as f64 && v.fract() == 0.0) {
            let line = parent.get(key).map_or(parent.line(), Node::line);
            return Err(Error::parse(
                self.path,
                line,
                field,
                format!("must be a positive whole number of pixels, not {v}"),
            ));
        }
        Ok(v as u32)
    }

    /// An OpenCV matrix (`!!opencv-matrix` / `type_id: opencv-matrix` with rows, cols, data),
    /// a plain number or a plain sequence, as (values, rows, cols).
    fn matrix(&self, parent: &Node, key: &str) -> Result<(Vec<f64>, usize, usize, usize)> {
        let node = self.node(parent, key, key)?;
        let numbers = |items: &[String], line: usize| -> Result<Vec<f64>> {
            items
                .iter()
                .map(|s| {
                    s.parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| {
                            Error::parse(
                                self.path,
                                line,
                                key,
                                format!("not a finite number: {s:?}"),
                            )
                        })
                })
                .collect()
        };
        match node {
            Node::Scalar { .. } => {
                let v = self.number(parent, key, key)?;
                Ok((vec![v], 1, 1, node.line()))
            }
            Node::Seq { items, line } => {
                let v = numbers(items, *line)?;
                let n = v.len();
                Ok((v, 1, n, *line))
            }
            Node::Map { .. } => {
                if let Some(tag) = node.tag().filter(|t| *t != "opencv-matrix") {
                    return Err(Error::parse(
                        self.path,
                        node.line(),
                        key,
                        format!("expected an opencv-matrix, found {tag:?}"),
                    ));
                }
                let rows = self.pixels(node, "rows", &format!("{key}.rows"))? as usize;
                let cols = self.pixels(node, "cols", &format!("{key}.cols"))? as usize;
                let data_field = format!("{key}.data");
                let (v, line) = match self.node(node, "data", &data_field)? {
                    Node::Seq { items, line } => (numbers(items, *line)?, *line),
                    other => {
                        return Err(Error::parse(
                            self.path,
                            other.line(),
                            data_field,
                            "expected [ ... ]",
                        ))
                    }
                };
                if v.len() != rows * cols {
                    return Err(Error::parse(
                        self.path,
                        line,
                        data_field,
                        format!("{} values for a {rows}x{cols} matrix", v.len()),
                    ));
                }
                Ok((v, rows, cols, node.line()))
            }
        }
    }
}

/// Maps a model's refusal onto the file's field.
fn refused(path: &Path, line: usize, field: &str, e: FisheyeError) -> Error {
    let field = match &e {
        FisheyeError::Parameter(f, _) => f,
        _ => field,
    };
    Error::parse(path, line, field, e.to_string())
}

/// The widest half field of view a lens can be built with from its (supremum) limit.
fn usable(limit: f64, finite_at_limit: bool) -> f64 {
    if finite_at_limit {
        limit
    } else {
        limit * (1.0 - 1e-9)
    }
}

/// The largest θ ≤ `cap` up to which a radial function keeps increasing.
fn radial_limit(model: &RadialModel, cap: f64) -> f64 {
    const SAMPLES: usize = 4096;
    for i in 1..=SAMPLES {
        let t = cap * i as f64 / SAMPLES as f64;
        if !(model.derivative(t) > 0.0) {
            return cap * (i - 1) as f64 / SAMPLES as f64;
        }
    }
    cap
}

fn mei_lens(
    path: &Path,
    line: usize,
    xi: f64,
    distortion: MeiDistortion,
    k: Intrinsics,
    skew: f64,
    size: ImageSize,
) -> Result<Lens> {
    let (limit, finite) = Unified::fov_limit(xi, &distortion);
    let camera = Unified::new(xi, distortion, k, skew, size, usable(limit, finite))
        .map_err(|e| refused(path, line, "xi", e))?;
    camera
        .erased()
        .covering_image()
        .map_err(|e| refused(path, line, "xi", e))
}

fn kitti360(root: &Node, path: &Path) -> Result<Lens> {
    let f = Fields { path };
    let (model, line) = f.text(root, "model_type", "model_type")?;
    if !model.eq_ignore_ascii_case("MEI") {
        return Err(Error::parse(
            path,
            line,
            "model_type",
            format!(
                "only MEI calibration files are read (KITTI-360's fisheye cameras), not {model:?}"
            ),
        ));
    }
    let size = ImageSize::new(
        f.pixels(root, "image_width", "image_width")?,
        f.pixels(root, "image_height", "image_height")?,
    );
    let mirror = f.node(root, "mirror_parameters", "mirror_parameters")?;
    let dist = f.node(root, "distortion_parameters", "distortion_parameters")?;
    let proj = f.node(root, "projection_parameters", "projection_parameters")?;
    let xi = f.number(mirror, "xi", "mirror_parameters.xi")?;
    let xi_line = mirror.get("xi").map_or(mirror.line(), Node::line);
    if !(xi >= 0.0) {
        return Err(Error::parse(
            path,
            xi_line,
            "mirror_parameters.xi",
            format!("xi must be ≥ 0, not {xi}"),
        ));
    }
    let d = |k: &str| f.number(dist, k, &format!("distortion_parameters.{k}"));
    let distortion = MeiDistortion {
        k1: d("k1")?,
        k2: d("k2")?,
        p1: d("p1")?,
        p2: d("p2")?,
    };
    let p = |k: &str| f.number(proj, k, &format!("projection_parameters.{k}"));
    let k = Intrinsics::new(p("gamma1")?, p("gamma2")?, p("u0")?, p("v0")?);
    mei_lens(path, xi_line, xi, distortion, k, 0.0, size)
}

fn woodscape(root: &Node, path: &Path) -> Result<Lens> {
    let f = Fields { path };
    let intrinsic = f.node(root, "intrinsic", "intrinsic")?;
    let (model, line) = f.text(intrinsic, "model", "intrinsic.model")?;
    if model != "radial_poly" {
        return Err(Error::parse(
            path,
            line,
            "intrinsic.model",
            format!("only the radial_poly model is known, not {model:?}"),
        ));
    }
    if intrinsic.get("poly_order").is_some() {
        let order = f.number(intrinsic, "poly_order", "intrinsic.poly_order")?;
        if order != 4.0 {
            let line = intrinsic.get("poly_order").map_or(line, Node::line);
            return Err(Error::parse(
                path,
                line,
                "intrinsic.poly_order",
                format!("only 4th-order polynomials (k1..k4) are known, not {order}"),
            ));
        }
    }
    let n = |k: &str| f.number(intrinsic, k, &format!("intrinsic.{k}"));
    let coefficients = [n("k1")?, n("k2")?, n("k3")?, n("k4")?];
    let aspect = n("aspect_ratio")?;
    if !(aspect > 0.0) {
        return Err(Error::parse(
            path,
            intrinsic.get("aspect_ratio").map_or(line, Node::line),
            "intrinsic.aspect_ratio",
            format!("must be positive, not {aspect}"),
        ));
    }
    let size = ImageSize::new(
        f.pixels(intrinsic, "width", "intrinsic.width")?,
        f.pixels(intrinsic, "height", "intrinsic.height")?,
    );
    // WoodScape: principal point = image centre + offset (pixel centres at integers).
    let k = Intrinsics::new(
        1.0,
        aspect,
        size.width as f64 / 2.0 - 0.5 + n("cx_offset")?,
        size.height as f64 / 2.0 - 0.5 + n("cy_offset")?,
    );
    let model = RadialModel::Polynomial(coefficients);
    let max_theta = radial_limit(&model, PI * (1.0 - 1e-9));
    let k_line = intrinsic.get("k1").map_or(line, Node::line);
    let camera = Fisheye::new(model, k, size, 2.0 * max_theta)
        .map_err(|e| refused(path, k_line, "intrinsic.k1", e))?;
    camera
        .erased()
        .covering_image()
        .map_err(|e| refused(path, k_line, "intrinsic.k1", e))
}

/// The image size of an OpenCV file: `image_width`/`image_height`, `width`/`height` or
/// `image_size`/`imageSize` = [w, h].
fn opencv_size(f: &Fields, root: &Node) -> Result<ImageSize> {
    for (w, h) in [("image_width", "image_height"), ("width", "height")] {
        if root.get(w).is_some() || root.get(h).is_some() {
            return Ok(ImageSize::new(f.pixels(root, w, w)?, f.pixels(root, h, h)?));
        }
    }
    for key in ["image_size", "imageSize", "img_size"] {
        if root.get(key).is_some() {
            let (v, _, _, line) = f.matrix(root, key)?;
            let ok = v.len() == 2 && v.iter().all(|x| *x >= 1.0 && x.fract() == 0.0);
            if !ok {
                return Err(Error::parse(f.path, line, key, "expected [width, height]"));
            }
            return Ok(ImageSize::new(v[0] as u32, v[1] as u32));
        }
    }
    Err(Error::parse(
        f.path,
        root.line(),
        "image_width",
        "the file gives no image size: add image_width and image_height",
    ))
}

fn opencv(root: &Node, path: &Path) -> Result<Lens> {
    let f = Fields { path };
    let (kv, rows, cols, k_line) = f.matrix(root, "K")?;
    if (rows, cols) != (3, 3) || kv[3] != 0.0 || kv[6] != 0.0 || kv[7] != 0.0 || kv[8] != 1.0 {
        return Err(Error::parse(
            path,
            k_line,
            "K",
            "expected a 3x3 camera matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]]",
        ));
    }
    let (d, _, _, d_line) = f.matrix(root, "D")?;
    if d.len() != 4 {
        return Err(Error::parse(
            path,
            d_line,
            "D",
            format!(
                "expected 4 coefficients (fisheye: k1..k4; omnidir: k1, k2, p1, p2), found {}",
                d.len()
            ),
        ));
    }
    let size = opencv_size(&f, root)?;
    let k = Intrinsics::new(kv[0], kv[4], kv[2], kv[5]);
    if root.get("xi").is_some() {
        let (xi, _, _, xi_line) = f.matrix(root, "xi")?;
        if xi.len() != 1 {
            return Err(Error::parse(path, xi_line, "xi", "expected one value"));
        }
        let distortion = MeiDistortion {
            k1: d[0],
            k2: d[1],
            p1: d[2],
            p2: d[3],
        };
        return mei_lens(path, xi_line, xi[0], distortion, k, kv[1], size);
    }
    if kv[1] != 0.0 {
        return Err(Error::parse(
            path,
            k_line,
            "K",
            "a skewed K (K[0][1] ≠ 0) is not supported for the fisheye model",
        ));
    }
    let model = RadialModel::KannalaBrandt([d[0], d[1], d[2], d[3]]);
    // cv::fisheye is defined through atan(r) of the pinhole point: z > 0 only.
    let max_theta = radial_limit(&model, FRAC_PI_2);
    let camera =
        Fisheye::new(model, k, size, 2.0 * max_theta).map_err(|e| refused(path, d_line, "D", e))?;
    camera
        .erased()
        .covering_image()
        .map_err(|e| refused(path, d_line, "D", e))
}
