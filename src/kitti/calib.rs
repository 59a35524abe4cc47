//! KITTI calibration files (`calib/NNNNNN.txt`).
//!
//! Every line is kept verbatim so that the written file still parses in ordinary KITTI readers;
//! the known matrices are parsed and checked. KITTI tracking's spellings (`R_rect`,
//! `Tr_velo_cam`, `Tr_imu_velo`, with or without a colon) are accepted as aliases.

use crate::camera::{
    FisheyeCamera, ImageSize, Intrinsics, Lens, OutputCamera, OutputProjection, Perspective,
    Projection,
};
use crate::error::{Error, Result};
use crate::fs::read_lines;
use crate::kitti::Cam;
use nalgebra::{Matrix3, Matrix3x4, Vector3};
use std::path::{Path, PathBuf};

/// A KITTI calibration file (`calib/NNNNNN.txt`): the numbers panoconv uses, and its lines
/// verbatim so a converted calib can repeat them.
#[derive(Debug, Clone)]
pub struct Calib {
    /// The file it was read from (errors name it).
    pub path: PathBuf,
    /// The input's lines, verbatim (line terminators removed).
    pub lines: Vec<String>,
    /// P0..P3, rectified projection matrices of cameras 0..3.
    pub p: [Option<Matrix3x4<f64>>; 4],
    /// `R0_rect`: rect from camera 0's unrectified axes.
    pub r0_rect: Option<Matrix3<f64>>,
    /// `Tr_velo_to_cam`: camera 0 from Velodyne, [R | t] in metres.
    pub tr_velo_to_cam: Option<Matrix3x4<f64>>,
    /// `Tr_imu_to_velo`: Velodyne from the IMU, [R | t] in metres.
    pub tr_imu_to_velo: Option<Matrix3x4<f64>>,
    /// The `projection:` line panoconv adds (present when the file describes a converted image).
    pub projection: Option<OutputProjection>,
    /// `K0:`..`K3:`: the intrinsics of each converted camera's output image.
    pub k_out: [Option<Intrinsics>; 4],
    /// `C0:`..`C3:`: each converted camera's optical centre in rect, metres.
    pub c_out: [Option<Vector3<f64>>; 4],
    /// A fisheye output's lens lines (`model2:`, `D2:`, `fov2:`, `R2:`) per camera.
    pub lens_out: [LensLines; 4],
}

/// What the lens lines of one camera of a fisheye output say (written by the calib writer's
/// `lens_lines`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LensLines {
    /// `model2:`: the lens model's name (as in a camera description).
    pub model: Option<String>,
    /// `D2:`: the model's parameters, in `Lens::parameters`' order.
    pub parameters: Vec<f64>,
    /// Full field of view, degrees.
    pub fov_deg: Option<f64>,
    /// The camera's axes in rect, row-major.
    pub rect_from_camera: Option<Matrix3<f64>>,
}

/// A rectified camera of the dataset: intrinsics and optical centre in rect.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceCamera {
    /// The intrinsics of `P`: pixel = K · (x/z, y/z, 1).
    pub k: Intrinsics,
    /// Optical centre in the rect frame, metres: C = -K⁻¹ · P[:, 3].
    pub centre: Vector3<f64>,
}

impl SourceCamera {
    /// The perspective camera of an image of `size` taken with it (about its own centre).
    pub fn camera(&self, size: ImageSize) -> Perspective {
        Perspective::new(self.k, size)
    }
}

/// `K2`, `C3`, ...: the output-camera lines panoconv writes.
fn output_key(name: &str, letter: char) -> Option<usize> {
    name.strip_prefix(letter).and_then(camera_index)
}

/// A camera number 0..3 written as one digit.
fn camera_index(digits: &str) -> Option<usize> {
    let n = digits.parse::<usize>().ok()?;
    (digits.len() == 1 && n < 4).then_some(n)
}

enum Key {
    P(usize),
    R0Rect,
    TrVeloToCam,
    TrImuToVelo,
}

fn known_key(name: &str) -> Option<Key> {
    Some(match name {
        "P0" => Key::P(0),
        "P1" => Key::P(1),
        "P2" => Key::P(2),
        "P3" => Key::P(3),
        "R0_rect" | "R_rect" => Key::R0Rect,
        "Tr_velo_to_cam" | "Tr_velo_cam" => Key::TrVeloToCam,
        "Tr_imu_to_velo" | "Tr_imu_velo" => Key::TrImuToVelo,
        _ => return None,
    })
}

fn parse_numbers(
    path: &Path,
    line_no: usize,
    key: &str,
    values: &str,
    count: usize,
) -> Result<Vec<f64>> {
    let tokens: Vec<&str> = values.split_whitespace().collect();
    if tokens.len() != count {
        return Err(Error::parse(
            path,
            line_no,
            key,
            format!("expected {count} numbers, found {}", tokens.len()),
        ));
    }
    tokens
        .iter()
        .enumerate()
        .map(|(i, t)| match t.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(Error::parse(
                path,
                line_no,
                format!("{key}[{i}]"),
                format!("{t:?} is not finite"),
            )),
            Err(_) => Err(Error::parse(
                path,
                line_no,
                format!("{key}[{i}]"),
                format!("{t:?} is not a number"),
            )),
        })
        .collect()
}

impl Calib {
    /// Reads and parses a calib file; errors name the file, line and field.
    pub fn read(path: &Path) -> Result<Calib> {
        let lines = read_lines(path)?;
        Self::parse(path, lines)
    }

    /// Parses the lines of a calib file (`path` tags errors). Unknown keys are kept verbatim.
    pub fn parse(path: &Path, lines: Vec<String>) -> Result<Calib> {
        let mut calib = Calib {
            path: path.to_path_buf(),
            lines: Vec::new(),
            p: [None; 4],
            r0_rect: None,
            tr_velo_to_cam: None,
            tr_imu_to_velo: None,
            projection: None,
            k_out: [None; 4],
            c_out: [None; 4],
            lens_out: Default::default(),
        };
        for (i, line) in lines.iter().enumerate() {
            let line_no = i + 1;
            let trimmed = line.trim();
            if trimmed.is_empty() {
                continue;
            }
            let (name, rest) = match trimmed.split_once(|c: char| c == ':' || c.is_whitespace()) {
                Some((n, r)) => (n.trim(), r),
                None => (trimmed, ""),
            };
            let rest = rest.trim_start_matches(':');
            calib.read_line(path, line_no, name, rest)?;
        }
        calib.lines = lines;
        Ok(calib)
    }

    /// One line's value, `name` its key and `rest` its value text (unknown keys are kept only
    /// in the verbatim lines).
    fn read_line(&mut self, path: &Path, line_no: usize, name: &str, rest: &str) -> Result<()> {
        if name == "projection" {
            let other = rest.trim();
            self.projection = Some(OutputProjection::parse(other).ok_or_else(|| {
                Error::parse(
                    path,
                    line_no,
                    "projection",
                    format!("unknown projection {other:?}"),
                )
            })?);
            return Ok(());
        }
        if let Some(n) = output_key(name, 'K') {
            let v = parse_numbers(path, line_no, name, rest, 9)?;
            self.k_out[n] = Some(Intrinsics::new(v[0], v[4], v[2], v[5]));
            return Ok(());
        }
        if let Some(n) = output_key(name, 'C') {
            let v = parse_numbers(path, line_no, name, rest, 3)?;
            self.c_out[n] = Some(Vector3::new(v[0], v[1], v[2]));
            return Ok(());
        }
        if let Some(n) = name.strip_prefix("model").and_then(camera_index) {
            self.lens_out[n].model = Some(rest.trim().to_owned());
            return Ok(());
        }
        if let Some(n) = output_key(name, 'D') {
            let count = rest.split_whitespace().count();
            self.lens_out[n].parameters = parse_numbers(path, line_no, name, rest, count)?;
            return Ok(());
        }
        if let Some(n) = name.strip_prefix("fov").and_then(camera_index) {
            self.lens_out[n].fov_deg = Some(parse_numbers(path, line_no, name, rest, 1)?[0]);
            return Ok(());
        }
        if let Some(n) = output_key(name, 'R') {
            let v = parse_numbers(path, line_no, name, rest, 9)?;
            self.lens_out[n].rect_from_camera = Some(Matrix3::from_row_slice(&v));
            return Ok(());
        }
        let Some(key) = known_key(name) else {
            return Ok(());
        };
        match key {
            Key::P(n) => {
                let v = parse_numbers(path, line_no, name, rest, 12)?;
                self.p[n] = Some(Matrix3x4::from_row_slice(&v));
            }
            Key::R0Rect => {
                let v = parse_numbers(path, line_no, name, rest, 9)?;
                self.r0_rect = Some(Matrix3::from_row_slice(&v));
            }
            Key::TrVeloToCam => {
                let v = parse_numbers(path, line_no, name, rest, 12)?;
                self.tr_velo_to_cam = Some(Matrix3x4::from_row_slice(&v));
            }
            Key::TrImuToVelo => {
                let v = parse_numbers(path, line_no, name, rest, 12)?;
                self.tr_imu_to_velo = Some(Matrix3x4::from_row_slice(&v));
            }
        }
        Ok(())
    }

    /// Camera `n` (2 = left colour, 3 = right colour) from `Pn = K [I | t]`.
    pub fn camera(&self, n: Cam) -> Result<SourceCamera> {
        let field = format!("P{n}");
        let p = self.p[n.number()]
            .ok_or_else(|| Error::file(&self.path, format!("no {field} line")))?;
        let bad = |msg: &str| Error::file(&self.path, format!("{field}: {msg}"));
        let w = p[(2, 2)];
        if !(w > 0.0) {
            return Err(bad("P[2][2] must be positive (P = K [I | t])"));
        }
        let p = p / w;
        if p.iter().any(|v| !v.is_finite()) {
            return Err(bad("not finite once divided by P[2][2]"));
        }
        let scale = p[(0, 0)].abs().max(p[(1, 1)].abs()).max(1.0);
        let tol = 1e-9 * scale;
        if p[(1, 0)].abs() > tol || p[(2, 0)].abs() > tol || p[(2, 1)].abs() > tol {
            return Err(bad("not of the form K [I | t] (a rectified camera)"));
        }
        if p[(0, 1)].abs() > tol {
            return Err(bad("a skewed K is not supported"));
        }
        let (fu, fv) = (p[(0, 0)], p[(1, 1)]);
        if !(fu > 0.0 && fv > 0.0) {
            return Err(bad("focal lengths must be positive (singular K)"));
        }
        let k = Intrinsics::new(fu, fv, p[(0, 2)], p[(1, 2)]);
        let km = Matrix3::new(fu, 0.0, k.cu, 0.0, fv, k.cv, 0.0, 0.0, 1.0);
        let t = km.try_inverse().ok_or_else(|| bad("singular K"))?
            * Vector3::new(p[(0, 3)], p[(1, 3)], p[(2, 3)]);
        if !(t.iter().all(|v| v.is_finite()) && fu.is_finite() && fv.is_finite()) {
            return Err(bad(
                "K is (nearly) singular: the optical centre is not finite",
            ));
        }
        Ok(SourceCamera { k, centre: -t })
    }

    /// The camera image `n` was taken or written with: the output camera when panoconv's lines
    /// are present (a converted dataset), else the perspective camera of `Pn` (plain KITTI).
    pub fn image_camera(
        &self,
        n: Cam,
        size: ImageSize,
    ) -> Result<(Box<dyn OutputCamera>, Vector3<f64>)> {
        if self.projection.is_some() {
            self.output_camera(n, size)
        } else {
            let c = self.camera(n)?;
            Ok((Box::new(c.camera(size)), c.centre))
        }
    }

    /// The camera `n` a converted image was written with (`projection:`, `Kn:`, `Cn:` lines,
    /// and for a fisheye the lens lines), and its centre.
    pub fn output_camera(
        &self,
        n: Cam,
        size: ImageSize,
    ) -> Result<(Box<dyn OutputCamera>, Vector3<f64>)> {
        let missing = |what: &str| {
            Error::file(
                &self.path,
                format!("no {what} line: not a calib written by panoconv"),
            )
        };
        let projection = self.projection.ok_or_else(|| missing("projection:"))?;
        let k = self.k_out[n.number()].ok_or_else(|| missing(&format!("K{n}:")))?;
        let c = self.c_out[n.number()].ok_or_else(|| missing(&format!("C{n}:")))?;
        let lines = match projection {
            OutputProjection::Linear(p) => return Ok((p.camera(k, size), c)),
            OutputProjection::Fisheye => &self.lens_out[n.number()],
        };
        let model = lines
            .model
            .as_deref()
            .ok_or_else(|| missing(&format!("model{n}:")))?;
        let fov = lines.fov_deg.ok_or_else(|| missing(&format!("fov{n}:")))?;
        let rect_from_camera = lines
            .rect_from_camera
            .ok_or_else(|| missing(&format!("R{n}:")))?;
        let lens = Lens::from_parameters(model, k, &lines.parameters, size, fov.to_radians() / 2.0)
            .map_err(|e| Error::file(&self.path, format!("camera {n}: {e}")))?;
        Ok((
            Box::new(FisheyeCamera {
                lens,
                rect_from_camera,
            }),
            c,
        ))
    }

    /// The output calib: every input line verbatim, then the description of the output cameras
    /// (all of one projection). For a perspective output, `Pn` is rewritten as K_out·[I | −C]
    /// for the converted cameras.
    pub fn render_output(&self, cameras: &[(Cam, &dyn OutputCamera, Vector3<f64>)]) -> String {
        let projection = cameras
            .first()
            .map_or(Projection::Perspective.into(), |(_, cam, _)| {
                cam.projection()
            });
        let mut out = String::new();
        for line in &self.lines {
            let name = line
                .trim_start()
                .split(|c: char| c == ':' || c.is_whitespace())
                .next()
                .unwrap_or("");
            let rewritten = cameras
                .iter()
                .find(|(n, _, _)| projection == Projection::Perspective && name == format!("P{n}"));
            match rewritten {
                Some((n, cam, c)) => {
                    let k = cam.intrinsics();
                    let t = -(Vector3::new(k.fu * c.x + k.cu * c.z, k.fv * c.y + k.cv * c.z, c.z));
                    let p = [
                        k.fu, 0.0, k.cu, t.x, 0.0, k.fv, k.cv, t.y, 0.0, 0.0, 1.0, t.z,
                    ];
                    out.push_str(&format!("P{n}: {}\n", join_sci(&p)));
                }
                None => {
                    out.push_str(line);
                    out.push('\n');
                }
            }
        }
        out.push_str(&format!("projection: {}\n", projection.name()));
        for (n, cam, c) in cameras {
            out.push_str(&format!("K{n}: {}\n", join_sci(&cam.intrinsics().matrix())));
            out.push_str(&format!("C{n}: {}\n", join_sci(&[c.x, c.y, c.z])));
            if let Some(fisheye) = cam.as_fisheye() {
                out.push_str(&lens_lines(*n, fisheye));
            }
        }
        out
    }
}

/// KITTI's number style: C's `%.12e` (e.g. `7.215377000000e+02`).
pub fn format_sci(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    let s = format!("{v:.12e}");
    let (mantissa, exp) = s.split_once('e').expect("formatted with an exponent");
    let exp: i32 = exp.parse().expect("integer exponent");
    let sign = if exp < 0 { '-' } else { '+' };
    format!("{mantissa}e{sign}{:02}", exp.abs())
}

/// `model{n}:` the lens model, `D{n}:` its parameters (in [`Lens::parameters`]'s order, absent
/// when there are none), `fov{n}:` its full field of view in degrees, `R{n}:` the camera's axes
/// in rect (row-major).
///
/// [`Lens::parameters`]: crate::camera::Lens::parameters
fn lens_lines(n: Cam, camera: &FisheyeCamera) -> String {
    let values: Vec<f64> = camera.lens.parameters().iter().map(|(_, v)| *v).collect();
    let r = &camera.rect_from_camera;
    let rows: Vec<f64> = (0..3)
        .flat_map(|i| (0..3).map(move |j| r[(i, j)]))
        .collect();
    let mut out = format!("model{n}: {}\n", camera.lens.name());
    if !values.is_empty() {
        out.push_str(&format!("D{n}: {}\n", join_sci(&values)));
    }
    let fov_deg = 2.0 * camera.lens.max_theta() * 180.0 / std::f64::consts::PI;
    out.push_str(&format!("fov{n}: {}\n", join_sci(&[fov_deg])));
    out.push_str(&format!("R{n}: {}\n", join_sci(&rows)));
    out
}

fn join_sci(values: &[f64]) -> String {
    values
        .iter()
        .map(|&v| format_sci(v))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// KITTI's most common calibration (f = 721.5377), as the shipped sample's first frame has
    /// it.
    fn standard() -> Calib {
        Calib::read(
            &Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("fixtures/synthetic_kitti/training/calib/000000.txt"),
        )
        .unwrap()
    }

    #[test]
    fn scientific_format_is_kittis() {
        assert_eq!(format_sci(721.5377), "7.215377000000e+02");
        assert_eq!(format_sci(-0.0027), "-2.700000000000e-03");
        assert_eq!(format_sci(0.0), "0.000000000000e+00");
    }

    #[test]
    fn written_lines_read_back_exactly() {
        let calib = standard();
        let k = Intrinsics::new(325.949, 325.949, 230.5, 80.25);
        let c = calib.camera(Cam::C2).unwrap().centre;
        let cam = Projection::Equirect.camera(k, ImageSize::new(460, 160));
        let text = calib.render_output(&[(Cam::C2, cam.as_ref(), c)]);
        // every input line first, verbatim
        assert!(text.starts_with(&(calib.lines.join("\n") + "\n")));
        let back = Calib::parse(
            Path::new("o.txt"),
            text.lines().map(str::to_owned).collect(),
        )
        .unwrap();
        assert_eq!(back.projection, Some(Projection::Equirect.into()));
        let k2 = back.k_out[2].unwrap();
        assert!((k2.fu - k.fu).abs() < 1e-9 && (k2.cv - k.cv).abs() < 1e-9);
        assert!((back.c_out[2].unwrap() - c).norm() < 1e-12);
        // P2 still describes the source camera
        assert_eq!(back.p[2], calib.p[2]);
    }

    #[test]
    fn perspective_output_rewrites_p2_as_k_out_i_minus_c() {
        let calib = standard();
        let src = calib.camera(Cam::C2).unwrap();
        let k = Intrinsics::new(600.0, 600.0, 700.0, 200.0);
        let cam = Projection::Perspective.camera(k, ImageSize::new(1400, 400));
        let text = calib.render_output(&[(Cam::C2, cam.as_ref(), src.centre)]);
        let back = Calib::parse(
            Path::new("o.txt"),
            text.lines().map(str::to_owned).collect(),
        )
        .unwrap();
        let cam = back.camera(Cam::C2).unwrap();
        assert!((cam.k.fu - 600.0).abs() < 1e-9 && (cam.k.cu - 700.0).abs() < 1e-9);
        assert!(
            (cam.centre - src.centre).norm() < 1e-9,
            "{:?} vs {:?}",
            cam.centre,
            src.centre
        );
        assert_eq!(
            back.p[3], calib.p[3],
            "P3 is untouched when image_3 is not converted"
        );
    }

    #[test]
    fn malformed_numbers_name_the_line_and_field() {
        let lines = vec![
            "P0: 1 2 3".to_owned(),
            String::new(),
            "P2: 1 0 0 0 0 1 0 0 0 0 x 0".to_owned(),
        ];
        let err = Calib::parse(Path::new("calib/000001.txt"), lines)
            .unwrap_err()
            .to_string();
        assert_eq!(err, "calib/000001.txt:1: P0: expected 12 numbers, found 3");
        let lines = vec!["P2: 1 0 0 0 0 1 0 0 0 0 x 0".to_owned()];
        let err = Calib::parse(Path::new("c.txt"), lines)
            .unwrap_err()
            .to_string();
        assert_eq!(err, "c.txt:1: P2[10]: \"x\" is not a number");
        let lines = vec!["P2: 1 0 0 0 0 1 0 0 0 0 inf 0".to_owned()];
        let err = Calib::parse(Path::new("c.txt"), lines)
            .unwrap_err()
            .to_string();
        assert_eq!(err, "c.txt:1: P2[10]: \"inf\" is not finite");
    }

    #[test]
    fn singular_or_missing_p2_is_refused() {
        let c = Calib::parse(
            Path::new("c.txt"),
            vec!["P0: 1 0 0 0 0 1 0 0 0 0 1 0".into()],
        )
        .unwrap();
        assert_eq!(
            c.camera(Cam::C2).unwrap_err().to_string(),
            "c.txt: no P2 line"
        );
        let c = Calib::parse(
            Path::new("c.txt"),
            vec!["P2: 0 0 0 0 0 0 0 0 0 0 1 0".into()],
        )
        .unwrap();
        assert!(c
            .camera(Cam::C2)
            .unwrap_err()
            .to_string()
            .contains("focal lengths must be positive"));
    }
}
