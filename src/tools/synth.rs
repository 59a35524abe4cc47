//! A synthetic KITTI scene rendered analytically: a textured ground plane, a sky, and textured
//! boxes with exact labels. The same ray caster renders through any [`CameraModel`], so tests
//! compare a warped image with the exact render in the target projection.
//!
//! Textures are smooth and fade with distance (fog), and pixels are integrated with a Gaussian
//! footprint, so the images are band-limited the way real camera images are.

use crate::camera::{CameraModel, ImageSize, Intrinsics, Perspective};
use crate::codec::png::{encode_rgb8, PngCompression};
use crate::error::{Error, Result};
use crate::fs::write_atomic;
use crate::image::RgbImage;
use crate::kitti::calib::format_sci;
use crate::reproject::labels::{box_bounds, clip, clipped_fraction};
use nalgebra::{Point2, Vector3};
use rayon::prelude::*;
use std::path::Path;

/// Height of the ground below the rect origin (camera 0), metres.
pub const GROUND_Y: f64 = 1.65;

/// A textured box of the scene, placed as a KITTI 3D label is.
#[derive(Debug, Clone)]
pub struct SceneBox {
    /// The KITTI type written in `label_2` (`Car`, `Pedestrian`, `Van`).
    pub kind: &'static str,
    /// height, width, length, metres.
    pub dimensions: [f64; 3],
    /// Bottom centre in rect, metres.
    pub location: Vector3<f64>,
    /// Rotation about rect's y axis, radians (KITTI's rotation_y).
    pub rotation_y: f64,
    /// Base RGB colour, 0 to 255, before texture and shading.
    pub colour: [f64; 3],
    /// A lean from upright (pitch, roll): a rotation about the bottom centre in the box's own
    /// axes (x length, y down, z width), applied before the yaw; None for an upright box.
    pub tilt: Option<nalgebra::Matrix3<f64>>,
}

/// A synthetic scene: the ground plane at [`GROUND_Y`], the sky, and these boxes.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    /// The boxes; each one camera 2 sees is a label line.
    pub boxes: Vec<SceneBox>,
}

fn ground_colour(p: &Vector3<f64>, dist: f64) -> [f64; 3] {
    let (x, z) = (p.x, p.z);
    let t = 40.0 * (0.9 * x).sin() * (0.7 * z).cos() + 18.0 * (1.7 * x + 0.6 * z).sin();
    let fine = 10.0 * (2.3 * x).sin() * (2.9 * z).sin() * (-dist / 12.0).exp();
    let tex = [
        110.0 + t + fine,
        100.0 + 0.8 * t - fine,
        90.0 + 0.5 * t + fine,
    ];
    let fog = (-dist / 30.0).exp();
    let far = [150.0, 150.0, 155.0];
    std::array::from_fn(|c| far[c] + (tex[c] - far[c]) * fog)
}

fn sky_colour(d: &Vector3<f64>) -> [f64; 3] {
    let up = (-d.y).clamp(-1.0, 1.0);
    let lon = d.x.atan2(d.z);
    let wave = 12.0 * (3.0 * lon).sin() * (1.0 - up);
    [
        150.0 - 60.0 * up + wave,
        170.0 - 40.0 * up,
        200.0 - 10.0 * up - wave,
    ]
}

impl SceneBox {
    /// Ray (origin o, unit direction d) against the box: distance and colour of the first hit.
    fn intersect(&self, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<(f64, [f64; 3])> {
        let [h, w, l] = self.dimensions;
        // Most rays miss most boxes: rejected against the sphere about the bottom centre
        // through the farthest corners (the tilt turns about that point too), before the
        // transforms. Widened by a relative 1e-9, so that no ray the slabs below would hit is
        // rejected: a render is the same to the bit, only faster.
        let oc = self.location - o;
        let (along, dd) = (oc.dot(d), d.norm_squared());
        // the squared radius, widened; the tests multiplied through by |d|²
        let reach2 = (l * l / 4.0 + h * h + w * w / 4.0) * (1.0 + 4e-9) + 1e-12;
        if (along < 0.0 && along * along > reach2 * dd)
            || oc.norm_squared() * dd - along * along > reach2 * dd
        {
            return None;
        }
        let (s, c) = self.rotation_y.sin_cos();
        // world = R(ry)·local + location; local = R(ry)ᵀ·(world - location)
        let yawed = |v: &Vector3<f64>| Vector3::new(c * v.x - s * v.z, v.y, s * v.x + c * v.z);
        // a tilted box: world = R(ry)·T·local + location
        let to_local = |v: &Vector3<f64>| match &self.tilt {
            Some(t) => t.transpose() * yawed(v),
            None => yawed(v),
        };
        let lo = to_local(&(o - self.location));
        let ld = to_local(d);
        let min = Vector3::new(-l / 2.0, -h, -w / 2.0);
        let max = Vector3::new(l / 2.0, 0.0, w / 2.0);
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        let mut axis = 0;
        for a in 0..3 {
            if ld[a].abs() < 1e-15 {
                if lo[a] < min[a] || lo[a] > max[a] {
                    return None;
                }
                continue;
            }
            let (mut ta, mut tb) = ((min[a] - lo[a]) / ld[a], (max[a] - lo[a]) / ld[a]);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            if ta > t0 {
                t0 = ta;
                axis = a;
            }
            t1 = t1.min(tb);
        }
        if t0 > t1 || t0 <= 1e-9 {
            return None;
        }
        let p = lo + ld * t0;
        // face coordinates: the two axes other than the hit one
        let (u, v) = match axis {
            0 => (p.z, p.y),
            1 => (p.x, p.z),
            _ => (p.x, p.y),
        };
        let shade = [0.85, 1.0, 0.7][axis];
        let pattern = 22.0 * (3.1 * u).sin() * (2.7 * v).cos();
        let colour = std::array::from_fn(|i| (self.colour[i] + pattern) * shade);
        Some((t0, colour))
    }

    /// The box's KITTI type.
    pub fn label_kind(&self) -> &'static str {
        self.kind
    }
}

impl Scene {
    /// Colour seen along a ray from `origin` with unit direction `d`.
    pub fn trace(&self, origin: &Vector3<f64>, d: &Vector3<f64>) -> [f64; 3] {
        self.first_hit(origin, d)
            .map(|(_, c)| c)
            .unwrap_or_else(|| sky_colour(d))
    }

    /// Distance along the unit ray to the first surface, and its colour; None for the sky.
    pub fn first_hit(&self, origin: &Vector3<f64>, d: &Vector3<f64>) -> Option<(f64, [f64; 3])> {
        let mut best: Option<(f64, [f64; 3])> = None;
        if d.y > 1e-12 {
            let t = (GROUND_Y - origin.y) / d.y;
            if t > 0.0 {
                let p = origin + d * t;
                best = Some((t, ground_colour(&p, t)));
            }
        }
        for b in &self.boxes {
            if let Some((t, c)) = b.intersect(origin, d) {
                if best.is_none_or(|(bt, _)| t < bt) {
                    best = Some((t, c));
                }
            }
        }
        best
    }

    /// A LiDAR scan like KITTI's HDL-64E (64 beams from +2° to −24.8°, 0.1° azimuth steps,
    /// ±45° around the forward direction, 80 m range) from a sensor whose frame maps to rect by
    /// `rect_from_velo` = (R, t). Points are in the LiDAR frame (x forward, y left, z up).
    pub fn lidar_scan(
        &self,
        rect_from_velo: &(nalgebra::Matrix3<f64>, Vector3<f64>),
    ) -> Vec<(Vector3<f64>, f32)> {
        let (r, t) = rect_from_velo;
        let mut points = Vec::new();
        for beam in 0..64 {
            let elevation = (2.0 - 26.8 * beam as f64 / 63.0).to_radians();
            let mut az = -45.0f64;
            while az <= 45.0 {
                let a = az.to_radians();
                let d_velo = Vector3::new(
                    elevation.cos() * a.cos(),
                    elevation.cos() * a.sin(),
                    elevation.sin(),
                );
                if let Some((dist, c)) = self.first_hit(t, &(r * d_velo)) {
                    if dist < 80.0 {
                        points.push((d_velo * dist, (c[0] / 255.0) as f32));
                    }
                }
                az += 0.1;
            }
        }
        points
    }

    /// Renders through `camera` placed at `centre` (rect axes), integrating each pixel over a
    /// Gaussian footprint (σ = 0.55 px, 6×6 samples over ±1.5 px). Pixels without a ray stay black.
    pub fn render(&self, camera: &dyn CameraModel, centre: &Vector3<f64>) -> RgbImage {
        self.render_with(camera, centre, 0.55, 6)
    }

    /// As [`Scene::render`] with a footprint of `sigma` pixels sampled on an n×n grid over
    /// ±2.73σ: a reference for an image resized by s uses σ = 0.55·s, the source's blur.
    pub fn render_with(
        &self,
        camera: &dyn CameraModel,
        centre: &Vector3<f64>,
        sigma: f64,
        n: usize,
    ) -> RgbImage {
        const BASE_SIGMA: f64 = 0.55;
        const BASE_REACH: f64 = 1.5;
        let (n_samples, sig) = (n, sigma);
        // the default footprint keeps its exact sample positions (the shipped sample depends on them)
        let reach = if sigma == BASE_SIGMA {
            BASE_REACH
        } else {
            BASE_REACH * sigma / BASE_SIGMA
        };
        let offsets: Vec<(f64, f64, f64)> = (0..n_samples * n_samples)
            .map(|k| {
                let (i, j) = (k % n_samples, k / n_samples);
                let du = ((i as f64 + 0.5) / n_samples as f64 * 2.0 - 1.0) * reach;
                let dv = ((j as f64 + 0.5) / n_samples as f64 * 2.0 - 1.0) * reach;
                (du, dv, (-(du * du + dv * dv) / (2.0 * sig * sig)).exp())
            })
            .collect();
        let size = camera.size();
        let mut img = RgbImage::new(size.width, size.height);
        let w = size.width as usize;
        if w == 0 {
            return img;
        }
        let dus: Vec<f64> = offsets[..n_samples].iter().map(|o| o.0).collect();
        let dvs: Vec<f64> = offsets
            .iter()
            .step_by(n_samples.max(1))
            .map(|o| o.1)
            .collect();
        let columns = Lattice::new(0..w, &dus);
        // bands of rows whose positions fit LATTICE_POINTS (one row where no pixel shares)
        let band_rows = (LATTICE_POINTS / (columns.values.len() * n_samples).max(1)).clamp(1, 16);
        img.as_raw_mut()
            .par_chunks_mut(w * 3 * band_rows)
            .enumerate()
            .for_each(|(band, rows)| {
                let v0 = band * band_rows;
                let lines = Lattice::new(v0..v0 + rows.len() / (w * 3), &dvs);
                // each distinct sample position traced once: neighbouring pixels' footprints
                // share them where the grid's step divides a pixel (the default footprint's
                // 0.5 px), and a position is the same f64 pair whichever pixel names it
                let colours: Vec<Option<[f64; 3]>> = (lines.values.iter())
                    .flat_map(|&y| columns.values.iter().map(move |&x| (x, y)))
                    .map(|(x, y)| {
                        let d = camera.unproject(&Point2::new(x, y)).ok()?;
                        Some(self.trace(centre, &d))
                    })
                    .collect();
                for (r, row) in rows.chunks_mut(w * 3).enumerate() {
                    for u in 0..w {
                        let mut acc = [0.0; 3];
                        let mut total = 0.0;
                        for (k, &(_, _, wt)) in offsets.iter().enumerate() {
                            let y = lines.index[r * n_samples + k / n_samples];
                            let x = columns.index[u * n_samples + k % n_samples];
                            let Some(c) = colours[y * columns.values.len() + x] else {
                                continue;
                            };
                            for k in 0..3 {
                                acc[k] += wt * c[k];
                            }
                            total += wt;
                        }
                        if total > 0.0 {
                            for k in 0..3 {
                                row[u * 3 + k] = (acc[k] / total).round().clamp(0.0, 255.0) as u8;
                            }
                        }
                    }
                }
            });
        img
    }
}

/// Most sample positions a render band traces at once (a colour each: 16 MiB).
const LATTICE_POINTS: usize = 1 << 19;

/// The distinct sample coordinates of a run of pixels along one axis (pixel p's offsets `d`
/// at `p as f64 + d`), and for each (pixel, offset) its coordinate's place among them.
struct Lattice {
    values: Vec<f64>,
    /// `index[(p - first) * d.len() + i]`.
    index: Vec<usize>,
}

impl Lattice {
    fn new(pixels: std::ops::Range<usize>, d: &[f64]) -> Self {
        let all: Vec<f64> = pixels
            .flat_map(|p| d.iter().map(move |o| p as f64 + o))
            .collect();
        let mut values = all.clone();
        values.sort_by(f64::total_cmp);
        values.dedup();
        let index = all
            .iter()
            .map(|x| values.partition_point(|v| v < x))
            .collect();
        Lattice { values, index }
    }
}

/// A synthetic camera 2: its true intrinsics and optical centre, from which P2 is made.
pub struct SynthCalib {
    /// Camera 2's intrinsics, pixels.
    pub k: Intrinsics,
    /// Camera 2's optical centre in rect (the ground truth `C2:` must reproduce).
    pub centre: Vector3<f64>,
    /// Image size of cameras 2 and 3, pixels.
    pub size: ImageSize,
}

impl SynthCalib {
    /// KITTI's most common calibration (1242x375, f = 721.5377), camera 2 six cm left of camera 0.
    pub fn standard() -> Self {
        Self {
            k: Intrinsics::new(721.5377, 721.5377, 609.5593, 172.854),
            centre: Vector3::new(-0.0598, 0.0004, -0.0027),
            size: ImageSize::new(1242, 375),
        }
    }

    /// A second KITTI calibration (1224x370, f = 707.0493).
    pub fn narrow() -> Self {
        Self {
            k: Intrinsics::new(707.0493, 707.0493, 604.0814, 180.5066),
            centre: Vector3::new(-0.0612, 0.0009, -0.0050),
            size: ImageSize::new(1224, 370),
        }
    }

    /// Camera 2's intrinsics, pixels.
    pub fn intrinsics(&self) -> Intrinsics {
        self.k
    }

    /// P = K [I | -C], row-major.
    pub fn p(&self, centre: &Vector3<f64>) -> [f64; 12] {
        let k = self.k;
        let t = -centre;
        [
            k.fu,
            0.0,
            k.cu,
            k.fu * t.x + k.cu * t.z,
            0.0,
            k.fv,
            k.cv,
            k.fv * t.y + k.cv * t.z,
            0.0,
            0.0,
            1.0,
            t.z,
        ]
    }

    /// Camera 2's projection matrix P2, row-major 3×4, as calib/*.txt holds it.
    pub fn p2(&self) -> [f64; 12] {
        self.p(&self.centre)
    }

    /// Camera 2's optical centre in rect, metres.
    pub fn centre(&self) -> Vector3<f64> {
        self.centre
    }

    /// Camera 3 (the right colour camera), 0.537 m right of camera 2.
    pub fn centre3(&self) -> Vector3<f64> {
        self.centre + Vector3::new(0.537, 0.0, 0.0)
    }

    /// KITTI's LiDAR mounting: 8 cm above and 27 cm behind camera 0; rect = R·velo + t.
    pub fn rect_from_velo() -> (nalgebra::Matrix3<f64>, Vector3<f64>) {
        (
            nalgebra::Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0),
            Vector3::new(0.0, -0.08, -0.27),
        )
    }

    /// The frame's calib/*.txt: P0 to P3 (camera 0 at the rect origin, camera 1 0.537 m right of
    /// it), R0_rect = identity, Tr_velo_to_cam and Tr_imu_to_velo, in KITTI's scientific notation.
    pub fn text(&self) -> String {
        let row = |v: &[f64]| {
            v.iter()
                .map(|&x| format_sci(x))
                .collect::<Vec<_>>()
                .join(" ")
        };
        let c0 = Vector3::zeros();
        let c1 = Vector3::new(0.537, 0.0, 0.0);
        let c3 = self.centre3();
        format!(
            "P0: {}\nP1: {}\nP2: {}\nP3: {}\nR0_rect: {}\nTr_velo_to_cam: {}\nTr_imu_to_velo: {}\n",
            row(&self.p(&c0)),
            row(&self.p(&c1)),
            row(&self.p2()),
            row(&self.p(&c3)),
            row(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]),
            row(&[0.0, -1.0, 0.0, 0.0, 0.0, 0.0, -1.0, -0.08, 1.0, 0.0, 0.0, -0.27]),
            row(&[1.0, 0.0, 0.0, -0.81, 0.0, 1.0, 0.0, 0.32, 0.0, 0.0, 1.0, -0.8]),
        )
    }
}

fn car(x: f64, z: f64, ry: f64, colour: [f64; 3]) -> SceneBox {
    SceneBox {
        kind: "Car",
        dimensions: [1.52, 1.65, 3.9],
        location: Vector3::new(x, GROUND_Y, z),
        rotation_y: ry,
        colour,
        tilt: None,
    }
}

/// One synthetic frame.
pub struct SynthFrame {
    /// The KITTI split the frame is written to: `training` or `testing`.
    pub split: &'static str,
    /// The frame id (file stem).
    pub id: &'static str,
    /// Its camera 2.
    pub calib: SynthCalib,
    /// What the frame shows.
    pub scene: Scene,
    /// A DontCare rectangle in the source image, if any.
    pub dont_care: Option<[f64; 4]>,
}

/// The synthetic frames.
pub fn frames() -> Vec<SynthFrame> {
    let mut pedestrian = car(-3.2, 9.0, 0.3, [90.0, 140.0, 90.0]);
    pedestrian.kind = "Pedestrian";
    pedestrian.dimensions = [1.75, 0.6, 0.8];
    let mut van = car(4.8, 16.0, -1.2, [70.0, 90.0, 160.0]);
    van.kind = "Van";
    van.dimensions = [2.1, 1.9, 4.8];
    let frame = |split, id, calib, boxes, dont_care| SynthFrame {
        split,
        id,
        calib,
        scene: Scene { boxes },
        dont_care,
    };
    vec![
        frame(
            "training",
            "000000",
            SynthCalib::standard(),
            vec![
                car(-4.5, 6.5, 1.45, [170.0, 60.0, 60.0]),
                car(2.5, 11.0, -1.65, [60.0, 70.0, 170.0]),
                car(-1.2, 24.0, 1.57, [200.0, 200.0, 80.0]),
                car(6.3, 4.2, 0.2, [150.0, 90.0, 40.0]),
            ],
            None,
        ),
        frame(
            "training",
            "000001",
            SynthCalib::narrow(),
            vec![car(3.8, 8.0, 0.8, [60.0, 160.0, 160.0]), pedestrian, van],
            Some([880.0, 150.0, 1000.0, 200.0]),
        ),
        frame(
            "training",
            "000002",
            SynthCalib::standard(),
            vec![
                car(0.4, 8.5, -1.52, [180.0, 180.0, 190.0]),
                car(-7.5, 14.0, 0.05, [120.0, 50.0, 140.0]),
                car(-3.0, 3.0, -1.60, [60.0, 150.0, 60.0]),
            ],
            None,
        ),
        frame(
            "testing",
            "000003",
            SynthCalib::standard(),
            vec![car(1.5, 12.0, 0.9, [160.0, 110.0, 60.0])],
            None,
        ),
    ]
}

/// The KITTI label lines of a scene seen by a synthetic camera (2D boxes exact, clipped).
pub fn label_lines(calib: &SynthCalib, scene: &Scene, dont_care: Option<[f64; 4]>) -> String {
    let camera = Perspective::new(calib.intrinsics(), calib.size);
    let centre = calib.centre();
    let mut out = String::new();
    for b in &scene.boxes {
        let label = crate::kitti::Label {
            tokens: Vec::new(),
            kind: b.kind.to_owned(),
            truncated: 0.0,
            occluded: 0,
            alpha: 0.0,
            bbox: [0.0; 4],
            dimensions: b.dimensions,
            location: b.location,
            rotation_y: b.rotation_y,
            score: None,
        };
        let corners = label.corners().map(|c| c - centre);
        let Some(unclipped) = box_bounds(&corners, &camera) else {
            continue;
        };
        let Some(bbox) = clip(unclipped, calib.size.width, calib.size.height) else {
            continue;
        };
        let truncated = clipped_fraction(unclipped, bbox);
        let l = &b.location;
        let mut alpha = b.rotation_y - l.x.atan2(l.z);
        alpha = (alpha + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI)
            - std::f64::consts::PI;
        let [h, w, len] = b.dimensions;
        out.push_str(&format!(
            "{} {:.2} 0 {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2}\n",
            b.kind,
            truncated,
            alpha,
            bbox[0],
            bbox[1],
            bbox[2],
            bbox[3],
            h,
            w,
            len,
            l.x,
            l.y,
            l.z,
            b.rotation_y
        ));
    }
    if let Some(r) = dont_care {
        out.push_str(&format!(
            "DontCare -1 -1 -10 {:.2} {:.2} {:.2} {:.2} -1 -1 -1 -1000 -1000 -1000 -10\n",
            r[0], r[1], r[2], r[3]
        ));
    }
    out
}

/// Refuses a synthetic output folder that holds anything, unless `overwrite`.
pub(crate) fn require_empty(root: &Path, overwrite: bool) -> Result<()> {
    if root.exists()
        && !overwrite
        && std::fs::read_dir(root)
            .map_err(|e| Error::io(root, e))?
            .next()
            .is_some()
    {
        return Err(Error::OutputNotEmpty {
            output: root.to_path_buf(),
            advice: "use --overwrite",
        });
    }
    Ok(())
}

/// Writes the synthetic dataset under `root` (KITTI object layout).
pub fn write_dataset(
    root: &Path,
    overwrite: bool,
    progress: &dyn crate::run::Progress,
) -> Result<()> {
    require_empty(root, overwrite)?;
    let frames = frames();
    progress.start(frames.len());
    for SynthFrame {
        split,
        id,
        calib,
        scene,
        dont_care,
    } in frames
    {
        let dir = root.join(split);
        let mut subdirs = vec!["image_2", "image_3", "calib", "velodyne"];
        if split == "training" {
            subdirs.push("label_2");
        }
        for s in subdirs {
            std::fs::create_dir_all(dir.join(s)).map_err(|e| Error::io(&dir.join(s), e))?;
        }
        let camera = Perspective::new(calib.intrinsics(), calib.size);
        let image = scene.render(&camera, &calib.centre());
        write_atomic(
            &dir.join("image_2").join(format!("{id}.png")),
            &encode_rgb8(&image, PngCompression::Best),
        )?;
        let right = scene.render(&camera, &calib.centre3());
        write_atomic(
            &dir.join("image_3").join(format!("{id}.png")),
            &encode_rgb8(&right, PngCompression::Best),
        )?;
        let scan = scene.lidar_scan(&SynthCalib::rect_from_velo());
        write_atomic(
            &dir.join("velodyne").join(format!("{id}.bin")),
            &crate::kitti::velodyne::encode(&scan),
        )?;
        write_atomic(
            &dir.join("calib").join(format!("{id}.txt")),
            calib.text().as_bytes(),
        )?;
        if split == "training" {
            let labels = label_lines(&calib, &scene, dont_care);
            write_atomic(
                &dir.join("label_2").join(format!("{id}.txt")),
                labels.as_bytes(),
            )?;
        }
        progress.frame_done();
    }
    progress.finish();
    Ok(())
}
