//! Stitching: N source cameras with their own optical centres remapped into one output camera.
//!
//! The model (every pixel can be recomputed from it):
//!
//! 1. An output pixel's ray leaves the output centre C with unit direction d (the output
//!    camera's `unproject`, in the reference frame's axes). The scene along it is taken to lie
//!    at the *proxy distance* s: the point X = C + s·d.
//! 2. Camera i sees X at q_i = camera_from_reference_i(X) and samples it at its pixel
//!    p_i = project_i(q_i). The output pixel's value from camera i is camera i's image resampled
//!    there by a [`RemapTable`] (bilinear taps, supersampled where the output is coarser than
//!    the source, exact integer weights), built through the same mapping.
//! 3. Camera i's weight is w_i = S(min(1, m_i / b)), with S(t) = t²(3 − 2t) (smoothstep), b the
//!    blend width (radians) and m_i the angular margin of q_i inside the camera's view: the
//!    smaller of (a) its field of view's margin θ_max,i − θ(q_i), θ the angle from the optical
//!    axis (for a lens with a field of view), and (b) the distance of p_i to the nearest image
//!    edge (pixels; the edges at −0.5 and size − 0.5) divided by the local scale at p_i (pixels
//!    per radian: the larger of the image displacements of q_i turned by 1e-4 rad about two
//!    axes perpendicular to it). m_i ≤ 0, or no image of q_i, gives w_i = 0.
//! 4. The output value is Σ w_i·g_i·v_i / Σ w_i per channel, rounded to the nearest integer
//!    (ties away from zero), clamped to 0..=255, black where Σ w_i = 0. The source map names the
//!    camera of largest weight (the first on a tie), 255 where none.
//! 5. The exposure gains g_i are 1 when exposure evening is off. Otherwise, per frame: over the
//!    output pixels where cameras i and j both have w > 0 (N_ij of them), m_ij is the mean of
//!    camera i's resampled values there (all three channels, 0..=255; sums kept as integers).
//!    g minimises Σ_{i<j} N_ij (g_i·m_ij − g_j·m_ji)² + μ Σ_i (g_i − 1)², μ = 1e-6·Σ_{i<j} N_ij
//!    (a prior that only fixes the common scale the first term leaves free, and cameras
//!    without overlaps), solved exactly as its normal equations; then every g_i is divided by
//!    g_0, so the first camera keeps its exposure. Gains that are not finite and positive, or
//!    a singular system, give g_i = 1.
//! 6. With an ego mask for camera i ([`EgoMask`], `Stitch::build_masked`), w_i = 0 wherever
//!    camera i's sample would touch its mask: where a masked pixel centre lies within
//!    1 + ρ/2 pixels of p_i in x and in y, ρ the larger distance from p_i to the samples of the
//!    output pixels to the right and below (the footprint a supersampled tap can reach).
//!
//! When every camera's centre is C (a zero-baseline rig) the proxy distance plays no part and
//! the remap is exact; otherwise objects at the proxy distance are stitched exactly and nearer
//! or farther ones show the parallax between the cameras at the seams.

use super::mask::EgoMask;
use super::reach::{border_cone, Cone, Gated, Reach};
use super::table::{RemapTable, Wrap, MAX_SUPERSAMPLE};
use crate::camera::{CameraModel, ImageSize, ProjectionReject};
use crate::error::{Error, Result};
use crate::image::RgbImage;
use nalgebra::{Matrix3, Point2, Vector3};
use rayon::prelude::*;

/// Angle of the small turns that measure a camera's local scale, radians.
const SCALE_PROBE: f64 = 1e-4;

/// A source camera of a stitch.
#[derive(Debug, Clone, Copy)]
pub struct StitchCamera<'a> {
    /// The camera's model (bearings in its own axes).
    pub model: &'a dyn CameraModel,
    /// camera_from_reference's linear part: a point X of the reference frame is
    /// `rotation · X + translation` in camera coordinates.
    pub rotation: Matrix3<f64>,
    /// camera_from_reference's translation.
    pub translation: Vector3<f64>,
    /// Half the field of view for a lens that has one (its image beyond is not used).
    pub max_theta: Option<f64>,
}

/// The stitch's two parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StitchOptions {
    /// Proxy distance s, metres.
    pub distance: f64,
    /// Blend width b, radians.
    pub blend_width: f64,
    /// Even the exposure of the cameras with per-frame gains (step 5 of the model).
    pub even_exposure: bool,
}

impl Default for StitchOptions {
    /// s = 10 m, b = 5°, exposure evening on.
    fn default() -> Self {
        Self {
            distance: 10.0,
            blend_width: 5f64.to_radians(),
            even_exposure: true,
        }
    }
}

/// The mapping from output bearings to one camera's pixels through the proxy point, as a
/// camera model for [`RemapTable`] (which asks the source model for `project` only).
#[derive(Debug)]
struct Proxy<'a> {
    camera: StitchCamera<'a>,
    centre: Vector3<f64>,
    distance: f64,
    /// cos of the field of view's half-angle less and plus [`FOV_SLACK`]: a point whose
    /// cosine from the axis lies outside that interval is decided without `atan2` (None:
    /// no lens bound, or one too near 0 or π for the shortcut).
    fov_cos: Option<(f64, f64)>,
}

/// Radians between the half field of view and the angles the shortcut of [`Proxy::within`]
/// decides: far beyond the rounding of a cosine, so its answer is `atan2`'s.
const FOV_SLACK: f64 = 1e-6;

impl<'a> Proxy<'a> {
    fn new(camera: StitchCamera<'a>, centre: Vector3<f64>, distance: f64) -> Self {
        let fov_cos = camera
            .max_theta
            .filter(|t| *t > 1e-3 && *t < 3.0)
            .map(|t| ((t - FOV_SLACK).cos(), (t + FOV_SLACK).cos()));
        Self {
            camera,
            centre,
            distance,
            fov_cos,
        }
    }

    fn local(&self, d: &Vector3<f64>) -> Vector3<f64> {
        let x = self.centre + d.normalize() * self.distance;
        self.camera.rotation * x + self.camera.translation
    }

    /// Whether camera point `q` lies within the lens's field of view: θ(q) ≤ θ_max, θ the
    /// angle from the optical axis (`atan2` only within [`FOV_SLACK`] of the edge).
    #[inline]
    fn within(&self, q: &Vector3<f64>) -> bool {
        let Some(t) = self.camera.max_theta else {
            return true;
        };
        if let Some((inner, outer)) = self.fov_cos.filter(|_| q.iter().all(|x| x.is_finite())) {
            let n = q.norm();
            if q.z >= inner * n && n > 0.0 {
                return true;
            }
            if q.z < outer * n {
                return false;
            }
        }
        !(q.x.hypot(q.y).atan2(q.z) > t)
    }
}

impl CameraModel for Proxy<'_> {
    fn project(&self, d: &Vector3<f64>) -> std::result::Result<Point2<f64>, ProjectionReject> {
        let q = self.local(d);
        if !self.within(&q) {
            return Err(ProjectionReject::OutsideDomain);
        }
        self.camera.model.project_point(&q)
    }

    /// The output bearing whose proxy point the pixel sees: the camera's ray met with the
    /// sphere of radius s around the output centre.
    fn unproject(&self, p: &Point2<f64>) -> std::result::Result<Vector3<f64>, ProjectionReject> {
        let b = self.camera.model.unproject(p)?;
        let inv = self
            .camera
            .rotation
            .try_inverse()
            .ok_or(ProjectionReject::Singular)?;
        let origin = -(inv * self.camera.translation) - self.centre;
        let dir = (inv * b).normalize();
        // |origin + λ·dir| = s, λ > 0
        let half_b = origin.dot(&dir);
        let c = origin.norm_squared() - self.distance * self.distance;
        let disc = half_b * half_b - c;
        if !(disc >= 0.0) {
            return Err(ProjectionReject::OutsideDomain);
        }
        let lambda = -half_b + disc.sqrt();
        if !(lambda > 0.0) {
            return Err(ProjectionReject::OutsideDomain);
        }
        Ok((origin + dir * lambda).normalize())
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        p.norm()
    }

    fn size(&self) -> ImageSize {
        self.camera.model.size()
    }
}

/// Tables and weights of a stitch, built once per output camera and rig, applied per frame.
#[derive(Debug)]
pub struct Stitch {
    size: ImageSize,
    tables: Vec<RemapTable>,
    /// Per camera, per output pixel (row-major): w_i.
    weights: Vec<Vec<f32>>,
    even_exposure: bool,
}

/// One frame's stitch.
#[derive(Debug)]
pub struct Stitched {
    /// The stitched image.
    pub image: RgbImage,
    /// Per output pixel, the camera of largest weight (255 for none).
    pub source: Vec<u8>,
    /// The exposure gain g_i of each camera (all 1 with exposure evening off).
    pub gains: Vec<f64>,
}

/// S(t) = t²(3 − 2t) on [0, 1].
fn smoothstep(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Two unit vectors perpendicular to `q` and to each other.
fn perpendiculars(q: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let n = q.normalize();
    let helper = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let a = n.cross(&helper).normalize();
    (a, n.cross(&a))
}

/// Camera i's angular margin m_i at camera point `q` (step 3 of the model), None without an
/// image.
#[cfg(test)]
fn margin(camera: &StitchCamera, q: &Vector3<f64>) -> Option<f64> {
    margin_capped(camera, q, None)
}

/// [`margin`], or any value ≥ `cap` where the margin is at least `cap`: with `inner_cos` =
/// cos(θ_max − cap − [`FOV_SLACK`]), a point at a cosine above it has a field-of-view margin
/// beyond the cap, and its angle is not computed (the weight saturates there).
fn margin_capped(
    camera: &StitchCamera,
    q: &Vector3<f64>,
    inner_cos: Option<(f64, f64)>,
) -> Option<f64> {
    let deep = inner_cos.is_some_and(|(c, cap)| {
        let n = q.norm();
        cap.is_finite() && n.is_finite() && n > 0.0 && q.z >= c * n
    });
    let fov = match (camera.max_theta, inner_cos) {
        (Some(_), Some((_, cap))) if deep => cap,
        (Some(t), _) => t - q.x.hypot(q.y).atan2(q.z),
        (None, _) => f64::INFINITY,
    };
    let p = camera.model.project_point(q).ok()?;
    let size = camera.model.size();
    let border = (p.x + 0.5)
        .min(size.width as f64 - 0.5 - p.x)
        .min(p.y + 0.5)
        .min(size.height as f64 - 0.5 - p.y);
    let (a, b) = perpendiculars(q);
    let n = q.normalize();
    let mut scale: f64 = 0.0;
    for axis in [a, b] {
        let turned =
            nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), SCALE_PROBE)
                * n;
        if let Ok(t) = camera.model.project_point(&turned) {
            scale = scale.max((t - p).norm() / SCALE_PROBE);
        }
    }
    if !(scale > 0.0) {
        return None;
    }
    Some(fov.min(border / scale))
}

/// Step 6 of the model: whether camera `proxy`'s sample for output pixel (u, v), seeing camera
/// point `q`, touches `mask`.
fn touches_mask(
    output: &dyn CameraModel,
    proxy: &Proxy,
    mask: &EgoMask,
    u: usize,
    v: usize,
    q: &Vector3<f64>,
) -> bool {
    let Ok(p) = proxy.camera.model.project_point(q) else {
        return false;
    };
    let sample = |u: usize, v: usize| {
        let d = output.unproject(&Point2::new(u as f64, v as f64)).ok()?;
        proxy.camera.model.project_point(&proxy.local(&d)).ok()
    };
    let rho = [sample(u + 1, v), sample(u, v + 1)]
        .into_iter()
        .flatten()
        .map(|n| (n - p).norm())
        .filter(|r| r.is_finite())
        .fold(0.0, f64::max);
    mask.touches(&p, 1.0 + rho / 2.0)
}

impl Stitch {
    /// The stitch of `cameras` into `output` (its bearings in the reference frame's axes,
    /// from `centre`).
    pub fn build(
        output: &dyn CameraModel,
        centre: &Vector3<f64>,
        cameras: &[StitchCamera],
        options: StitchOptions,
    ) -> Stitch {
        let (tables, weights) =
            Self::tables_and_weights(output, centre, cameras, &[], options, true);
        Stitch {
            size: output.size(),
            tables,
            weights,
            even_exposure: options.even_exposure,
        }
    }

    /// [`Stitch::build`] with an ego mask per camera (`masks[i]` for `cameras[i]`; None, or a
    /// shorter list, for cameras without one): step 6 of the model. A mask of another size
    /// than its camera's image is an error.
    pub fn build_masked(
        output: &dyn CameraModel,
        centre: &Vector3<f64>,
        cameras: &[StitchCamera],
        masks: &[Option<&EgoMask>],
        options: StitchOptions,
    ) -> Result<Stitch> {
        if masks.len() > cameras.len() {
            return Err(Error::Setup(format!(
                "{} ego masks for {} cameras",
                masks.len(),
                cameras.len()
            )));
        }
        for (i, (camera, mask)) in cameras.iter().zip(masks).enumerate() {
            if let Some(mask) = mask {
                let (a, b) = (mask.size(), camera.model.size());
                if a != b {
                    return Err(Error::Setup(format!(
                        "camera {i}: an ego mask of {}x{} for an image of {}x{}",
                        a.width, a.height, b.width, b.height
                    )));
                }
            }
        }
        let (tables, weights) =
            Self::tables_and_weights(output, centre, cameras, masks, options, true);
        Ok(Stitch {
            size: output.size(),
            tables,
            weights,
            even_exposure: options.even_exposure,
        })
    }

    fn tables_and_weights(
        output: &dyn CameraModel,
        centre: &Vector3<f64>,
        cameras: &[StitchCamera],
        masks: &[Option<&EgoMask>],
        options: StitchOptions,
        bounded: bool,
    ) -> (Vec<RemapTable>, Vec<Vec<f32>>) {
        let size = output.size();
        let (w, h) = (size.width as usize, size.height as usize);
        let proxies: Vec<Proxy> = cameras
            .iter()
            .map(|camera| Proxy::new(*camera, *centre, options.distance))
            .collect();
        let locals: Vec<_> = proxies
            .iter()
            .map(|proxy| move |d: &Vector3<f64>| proxy.local(d))
            .collect();
        let cones: Vec<Cone> = proxies
            .iter()
            .zip(&locals)
            .map(|(proxy, local)| {
                let camera = &proxy.camera;
                let inverse = camera.rotation.try_inverse();
                let baseline = inverse.map(|r| (-(r * camera.translation) - centre).norm());
                Cone {
                    local,
                    // unbounded: every pixel mapped (the tests' reference)
                    half_angle: camera
                        .max_theta
                        .or_else(|| border_cone(camera.model))
                        .filter(|_| bounded),
                    parallax: baseline
                        .filter(|b| b.is_finite() && *b < options.distance)
                        .map(|b| options.distance / (options.distance - b)),
                }
            })
            .collect();
        let reach = Reach::new(output, &cones);
        let mut tables = Vec::with_capacity(cameras.len());
        let mut weights = Vec::with_capacity(cameras.len());
        for (i, (camera, proxy)) in cameras.iter().zip(&proxies).enumerate() {
            let mask = masks.get(i).copied().flatten();
            let gated = Gated {
                output,
                reach: &reach,
                camera: i,
            };
            tables.push(RemapTable::build_parallel(
                &gated,
                proxy,
                &Matrix3::identity(),
                Wrap::None,
                MAX_SUPERSAMPLE,
            ));
            // w_i > 0 needs an image of the centre's proxy point within the camera's cone:
            // the pixels beyond the bound keep w_i = 0
            // where the field of view's margin exceeds the blend width the weight is set by
            // the border's margin alone (or saturates): its angle is not needed there
            let b = options.blend_width;
            let deep = camera
                .max_theta
                .map(|t| t - b - FOV_SLACK)
                .filter(|a| b > 0.0 && b.is_finite() && *a > 1e-3 && *a < 3.0)
                .map(|a| (a.cos(), b));
            let mut wi = vec![0f32; w * h];
            wi.par_chunks_mut(w.max(1))
                .enumerate()
                .for_each(|(v, row)| {
                    for (u, out) in row.iter_mut().enumerate() {
                        if !reach.may_reach_pixel(i, u, v) {
                            continue;
                        }
                        let Some(d) = reach.bearing(u, v) else {
                            continue;
                        };
                        let q = proxy.local(&d);
                        if let Some(m) = margin_capped(camera, &q, deep) {
                            *out = smoothstep(m / options.blend_width) as f32;
                        }
                        if let Some(mask) = mask.filter(|_| *out > 0.0) {
                            if touches_mask(output, proxy, mask, u, v, &q) {
                                *out = 0.0;
                            }
                        }
                    }
                });
            weights.push(wi);
        }
        (tables, weights)
    }

    /// The output image's size.
    pub fn size(&self) -> ImageSize {
        self.size
    }

    /// How many cameras it blends.
    pub fn cameras(&self) -> usize {
        self.tables.len()
    }

    /// Camera i's weight at output pixel (u, v).
    pub fn weight(&self, i: usize, u: u32, v: u32) -> f32 {
        self.weights[i][v as usize * self.size.width as usize + u as usize]
    }

    /// Step 5 of the model: the gains that even the exposure of the `remapped` images.
    fn gains(&self, remapped: &[RgbImage]) -> Vec<f64> {
        let n = remapped.len();
        let ones = vec![1.0; n];
        if !self.even_exposure || n < 2 {
            return ones;
        }
        // integer sums: exact, so the gains do not depend on the thread count
        let pixels = self.size.width as usize * self.size.height as usize;
        let zero = || (vec![0u64; n * n], vec![0u64; n * n]);
        let (count, sum) = (0..pixels)
            .into_par_iter()
            .fold(zero, |(mut count, mut sum), p| {
                for i in 0..n {
                    if !(self.weights[i][p] > 0.0) {
                        continue;
                    }
                    let px = &remapped[i].as_raw()[p * 3..p * 3 + 3];
                    let level = px.iter().map(|&c| c as u64).sum::<u64>();
                    for j in (0..n).filter(|&j| j != i) {
                        if self.weights[j][p] > 0.0 {
                            count[i * n + j] += 1;
                            sum[i * n + j] += level;
                        }
                    }
                }
                (count, sum)
            })
            .reduce(zero, |(mut c1, mut s1), (c2, s2)| {
                for k in 0..n * n {
                    c1[k] += c2[k];
                    s1[k] += s2[k];
                }
                (c1, s1)
            });
        let mean = |i: usize, j: usize| sum[i * n + j] as f64 / (3.0 * count[i * n + j] as f64);
        let total: u64 = (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .map(|(i, j)| count[i * n + j])
            .sum();
        let mu = 1e-6 * total.max(1) as f64;
        let mut a = nalgebra::DMatrix::<f64>::zeros(n, n);
        let b = nalgebra::DVector::<f64>::from_element(n, mu);
        for i in 0..n {
            a[(i, i)] += mu;
            for j in (0..n).filter(|&j| j != i && count[i * n + j] > 0) {
                let nij = count[i * n + j] as f64;
                let (mij, mji) = (mean(i, j), mean(j, i));
                a[(i, i)] += nij * mij * mij;
                a[(i, j)] -= nij * mij * mji;
            }
        }
        let Some(g) = a.lu().solve(&b) else {
            return ones;
        };
        let g0 = g[0];
        let gains: Vec<f64> = g.iter().map(|gi| gi / g0).collect();
        if gains.iter().all(|gi| gi.is_finite() && *gi > 0.0) {
            gains
        } else {
            ones
        }
    }

    /// The stitch of one frame's `images` (in the cameras' order, each of its camera's size).
    pub fn apply(&self, images: &[&RgbImage]) -> Stitched {
        assert_eq!(images.len(), self.tables.len(), "one image per camera");
        let remapped: Vec<RgbImage> = self
            .tables
            .iter()
            .zip(images)
            .map(|(t, img)| t.apply(img))
            .collect();
        let gains = self.gains(&remapped);
        let (w, h) = (self.size.width as usize, self.size.height as usize);
        let mut out = RgbImage::new(self.size.width, self.size.height);
        let mut source = vec![255u8; w * h];
        out.as_raw_mut()
            .par_chunks_mut((w * 3).max(1))
            .zip(source.par_chunks_mut(w.max(1)))
            .enumerate()
            .for_each(|(v, (row, src_row))| {
                for u in 0..w {
                    let i = v * w + u;
                    let (mut acc, mut total, mut best) = ([0f64; 3], 0f64, (0f32, 255u8));
                    for (k, img) in remapped.iter().enumerate() {
                        let wk = self.weights[k][i];
                        if !(wk > 0.0) {
                            continue;
                        }
                        let px = &img.as_raw()[i * 3..i * 3 + 3];
                        for c in 0..3 {
                            acc[c] += wk as f64 * gains[k] * px[c] as f64;
                        }
                        total += wk as f64;
                        if wk > best.0 {
                            best = (wk, k as u8);
                        }
                    }
                    if total > 0.0 {
                        for c in 0..3 {
                            row[u * 3 + c] = (acc[c] / total).round().clamp(0.0, 255.0) as u8;
                        }
                    }
                    src_row[u] = best.1;
                }
            });
        Stitched {
            image: out,
            source,
            gains,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Equirect, Intrinsics, Perspective};

    #[test]
    fn the_reach_bound_changes_no_table_entry_and_no_weight() {
        let wide = Perspective::new(
            Intrinsics::new(60.0, 60.0, 99.5, 49.5),
            ImageSize::new(200, 100),
        );
        let narrow = Perspective::new(
            Intrinsics::new(300.0, 300.0, 70.0, 40.0),
            ImageSize::new(150, 90),
        );
        let turn =
            |deg: f64| *nalgebra::Rotation3::from_euler_angles(0.1, deg.to_radians(), 0.0).matrix();
        let cameras = [
            StitchCamera {
                model: &wide,
                rotation: turn(80.0),
                translation: Vector3::new(0.3, 0.0, -0.2),
                max_theta: Some(1.0),
            },
            StitchCamera {
                model: &narrow,
                rotation: Matrix3::identity(),
                translation: Vector3::new(-0.5, 0.1, 0.0),
                max_theta: None,
            },
            StitchCamera {
                model: &wide,
                rotation: turn(-100.0),
                translation: Vector3::new(0.0, 0.0, 0.4),
                max_theta: None,
            },
        ];
        let output = Equirect::new(
            Intrinsics::new(
                320.0 / (2.0 * std::f64::consts::PI),
                320.0 / (2.0 * std::f64::consts::PI),
                160.0,
                80.0,
            ),
            ImageSize::new(320, 160),
        );
        let centre = Vector3::new(0.05, -0.02, 0.1);
        let options = StitchOptions::default();
        let build =
            |bounded| Stitch::tables_and_weights(&output, &centre, &cameras, &[], options, bounded);
        let (bounded, every) = (build(true), build(false));
        for i in 0..cameras.len() {
            assert!(bounded.0[i] == every.0[i], "camera {i}: tables differ");
            let bits = |w: &[f32]| w.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(&bounded.1[i]),
                bits(&every.1[i]),
                "camera {i}: weights"
            );
            // the camera is seen somewhere, and not everywhere
            let seen = every.1[i].iter().filter(|w| **w > 0.0).count();
            assert!(
                seen > 100 && seen < every.1[i].len() / 2,
                "camera {i}: {seen}"
            );
        }
    }

    #[test]
    fn the_cosine_shortcuts_decide_as_the_angle_does() {
        let model = crate::camera::Unified::new(
            2.0,
            crate::camera::MeiDistortion {
                k1: 0.01,
                k2: 0.3,
                p1: 4e-4,
                p2: 4e-4,
            },
            Intrinsics::new(300.0, 300.0, 349.5, 349.5),
            0.0,
            ImageSize::new(700, 700),
            92.5f64.to_radians(),
        )
        .unwrap();
        let t = 92.5f64.to_radians();
        let camera = StitchCamera {
            model: &model,
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
            max_theta: Some(t),
        };
        let proxy = Proxy::new(camera, Vector3::zeros(), 10.0);
        let b = 5f64.to_radians();
        let deep = Some(((t - b - FOV_SLACK).cos(), b));
        let (mut inside, mut outside, mut saturated) = (0, 0, 0);
        // angles on both sides of the field of view's edge and of the blend band's, down to
        // 1e-9 rad away, at several azimuths
        for k in 0..4000 {
            let offset = (k as f64 / 4000.0 - 0.5) * 2e-3 * (1e-6f64).powf((k % 7) as f64 / 6.0);
            let edge = if k % 2 == 0 { t } else { t - b };
            let theta = edge + offset;
            let phi = k as f64 * 0.37;
            let q = Vector3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ) * (0.5 + (k % 5) as f64);
            let exact = !(q.x.hypot(q.y).atan2(q.z) > t);
            assert_eq!(proxy.within(&q), exact, "θ = {theta}");
            if exact {
                inside += 1;
            } else {
                outside += 1;
            }
            let w = |m: Option<f64>| m.map(|m| smoothstep(m / b).to_bits());
            let full = margin(&camera, &q);
            assert_eq!(w(margin_capped(&camera, &q, deep)), w(full), "θ = {theta}");
            saturated += usize::from(full.is_some_and(|m| m >= b));
        }
        assert!(
            inside > 1000 && outside > 500 && saturated > 100,
            "{inside} {outside} {saturated}"
        );
    }

    #[test]
    fn weights_fall_off_towards_the_edges_and_the_proxy_inverts() {
        let model = Perspective::new(
            Intrinsics::new(100.0, 100.0, 99.5, 49.5),
            ImageSize::new(200, 100),
        );
        let camera = StitchCamera {
            model: &model,
            rotation: Matrix3::identity(),
            translation: Vector3::new(-0.5, 0.0, 0.0),
            max_theta: None,
        };
        // at the image centre: 50 px to the top and bottom edges at 100 px/rad
        let m = margin(&camera, &Vector3::z()).unwrap();
        assert!((m - 0.5).abs() < 1e-6, "{m}");
        // near the right edge the margin shrinks to the pixel distance over the local scale
        let q = Vector3::new(0.95, 0.0, 1.0);
        let m = margin(&camera, &q).unwrap();
        let p = model.project_point(&q).unwrap();
        let want = (199.5 - p.x) / (100.0 * (1.0 + 0.95f64.powi(2)));
        assert!((m - want).abs() < 1e-3 * want, "{m} vs {want}");
        assert_eq!(smoothstep(-1.0), 0.0);
        assert_eq!(smoothstep(0.5), 0.5);
        assert_eq!(smoothstep(2.0), 1.0);
        let defaults = StitchOptions::default();
        assert!(defaults.even_exposure && defaults.distance == 10.0);
        // the proxy's unproject is its project's inverse, with a baseline
        let proxy = Proxy::new(camera, Vector3::new(0.1, 0.2, 0.0), 7.0);
        let d = Vector3::new(0.2, -0.1, 1.0).normalize();
        let px = proxy.project(&d).unwrap();
        let back = proxy.unproject(&px).unwrap();
        assert!((back - d).norm() < 1e-12, "{back} vs {d}");
    }
}
