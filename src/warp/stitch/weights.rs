//! A stitch's remap tables and blend weights (steps 2, 3 and 6 of the stitch's model): each
//! camera's angular margin, smoothed over the blend width, zero where its ego mask is touched.

use super::centre_fill::{CentreFill, CentreSample};
use super::far_fill::{far_pixels, FarScene};
use super::proxy::{Centres, Proxy, FOV_SLACK};
use super::{Stitch, StitchCamera, StitchDepth, StitchOptions};
use crate::camera::{perpendiculars, CameraModel, Intrinsics};
use crate::warp::mask::EgoMask;
use crate::warp::reach::{border_cone, Cone, Frustum, Gated, NearBound, Reach};
use crate::warp::table::{RemapTable, Surfaces, TAPS_BELOW};
use nalgebra::{Matrix3, Point2, Rotation3, Unit, Vector3};
use rayon::prelude::*;
use std::sync::LazyLock;
use tile::{TileBound, TILE};

mod tile;

/// A depth-guided sample's footprint radius, source pixels: the source's blur (σ 0.55 px,
/// reaching 1.5 px) and the bilinear taps' reach.
const FOOTPRINT_PX: f64 = 1.5;
/// Angle of the small turns that measure a camera's local scale, radians.
const SCALE_PROBE: f64 = 1e-4;

/// S(t) = t²(3 − 2t) on [0, 1].
fn smoothstep(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Camera i's angular margin m_i at camera point `q` (step 3 of the model), None without an
/// image.
#[cfg(test)]
fn margin(camera: &StitchCamera, q: &Vector3<f64>) -> Option<f64> {
    margin_capped(camera, q, None, None)
}

/// [`margin`], or any value ≥ `cap` where the margin is at least `cap`: with `inner_cos` =
/// cos(θ_max − cap − [`FOV_SLACK`]), a point at a cosine above it has a field-of-view margin
/// beyond the cap, and its angle is not computed (the weight saturates there).
/// With `saturation`, any value ≥ its width where the border's margin certainly reaches it
/// (see [`saturated`]).
fn margin_capped(
    camera: &StitchCamera,
    q: &Vector3<f64>,
    inner_cos: Option<(f64, f64)>,
    saturation: Option<&Saturation>,
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
    if let Some(s) = saturation.filter(|s| fov >= s.width && saturated(s, &p, border)) {
        return Some(s.width);
    }
    let n = q.normalize();
    let (a, b) = perpendiculars(&n);
    let mut scale: f64 = 0.0;
    for axis in [a, b] {
        let turned = probe_turn(&Unit::new_normalize(axis)) * n;
        if let Ok(t) = camera.model.project_point(&turned) {
            scale = scale.max((t - p).norm() / SCALE_PROBE);
        }
    }
    if !(scale > 0.0) {
        return None;
    }
    Some(fov.min(border / scale))
}

/// A pinhole camera's intrinsics and the blend width: where its margin certainly reaches
/// the width, the weight saturates and the local scale need not be measured.
#[derive(Debug, Clone, Copy)]
struct Saturation {
    width: f64,
    k: Intrinsics,
}

/// Whether a pinhole's border margin at pixel `p` (`border` pixels from the nearest edge)
/// certainly reaches the width, whatever the local scale measures: a turn by ε moves the
/// normalised image point by at most ε·max(1 + r²) over the turn (sec² θ, the gnomonic
/// projection's largest stretch; r = tan θ grows by less than 0.01 over ε at r ≤ 3), so the
/// scale is at most max(|fu|, |fv|)·(1 + (r + 0.01)²), here with 0.1 % to spare.
fn saturated(s: &Saturation, p: &Point2<f64>, border: f64) -> bool {
    let k = &s.k;
    let (x, y) = ((p.x - k.cu) / k.fu, (p.y - k.cv) / k.fv);
    let test = |r: f64| {
        let most = k.fu.abs().max(k.fv.abs()) * (1.0 + (r + 0.01).powi(2)) * 1.001;
        r <= 3.0 && border >= s.width * most
    };
    // the test is monotone in r (each rounded step is): √(x² + y²) within 1e-12 of the
    // hypotenuse on either side decides it without libm's `hypot` unless it falls between
    let r = (x * x + y * y).sqrt();
    let (below, above) = (r * (1.0 - 1e-12) - 1e-150, r * (1.0 + 1e-12) + 1e-150);
    match (test(above), test(below)) {
        (true, _) => true,
        (false, false) => false,
        _ => test(x.hypot(y)),
    }
}

/// sin and cos of [`SCALE_PROBE`], computed once.
static PROBE_SIN_COS: LazyLock<(f64, f64)> = LazyLock::new(|| SCALE_PROBE.sin_cos());

/// The turn by [`SCALE_PROBE`] about `axis`: nalgebra's `Rotation3::from_axis_angle`, the
/// same arithmetic term by term (so the same bits), with the angle's sine and cosine computed
/// once instead of at every pixel.
fn probe_turn(axis: &Unit<Vector3<f64>>) -> Rotation3<f64> {
    let (sin, cos) = *PROBE_SIN_COS;
    let (ux, uy, uz) = (axis[0], axis[1], axis[2]);
    let (sqx, sqy, sqz) = (ux * ux, uy * uy, uz * uz);
    let one_m_cos = 1.0 - cos;
    Rotation3::from_matrix_unchecked(Matrix3::new(
        sqx + (1.0 - sqx) * cos,
        ux * uy * one_m_cos - uz * sin,
        ux * uz * one_m_cos + uy * sin,
        ux * uy * one_m_cos + uz * sin,
        sqy + (1.0 - sqy) * cos,
        uy * uz * one_m_cos - ux * sin,
        ux * uz * one_m_cos - uy * sin,
        uy * uz * one_m_cos + ux * sin,
        sqz + (1.0 - sqz) * cos,
    ))
}

/// The distance from a sample's position within which a masked pixel centre is touched: half
/// the footprint `rho` and a pixel, or for a pyramid sample (a table with levels, a pixel
/// coarse enough to sample one) the reach of a bilinear tap of the level, whose pixels are up
/// to 4/3 of the footprint, and of the taps along an anisotropic footprint's longer axis.
fn touch_radius(rho: f64, pyramid: bool) -> f64 {
    let taps = 1.0 + rho / 2.0;
    if pyramid && rho >= 0.5 * TAPS_BELOW {
        taps.max(3.0 * rho)
    } else {
        taps
    }
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
    pyramid: bool,
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
    mask.touches(&p, touch_radius(rho, pyramid))
}

impl Stitch {
    pub(super) fn tables_and_weights(
        output: &dyn CameraModel,
        centre: &Vector3<f64>,
        cameras: &[StitchCamera],
        masks: &[Option<&EgoMask>],
        options: StitchOptions,
        bounded: bool,
        depth: Option<&dyn StitchDepth>,
    ) -> TablesAndWeights {
        let size = output.size();
        let proxies: Vec<Proxy> = cameras
            .iter()
            .enumerate()
            .map(|(i, camera)| Proxy::guided((i, *camera), *centre, options.distance, depth))
            .collect();
        // with a depth, the bound works on the bearings' directions (see `guided_cone`)
        let locals: Vec<_> = proxies
            .iter()
            .map(|proxy| {
                move |d: &Vector3<f64>| match depth {
                    None => proxy.local(d),
                    Some(_) => proxy.camera.rotation * d,
                }
            })
            .collect();
        let cones: Vec<Cone> = proxies
            .iter()
            .zip(&locals)
            .map(|(proxy, local)| cone_of(proxy, local, centre, options, bounded, depth.is_some()))
            .collect();
        // a tile's lower bound is at least the scene's nearest distance
        let near = |d: &Vector3<f64>, radius: f64| {
            depth.map_or(0.0, |depth| {
                depth.nearest_within(d, radius).max(depth.nearest())
            })
        };
        let reach = Reach::new(output, &cones, depth.map(|_| &near as NearBound));
        let mut distances = depth
            .map(|depth| super::guided::pixel_distances(&reach, size, depth, (cameras, centre)));
        // the far fill: pixels no camera's image holds at the scene's distance, at the proxy's
        let far = distances.as_mut().map(|distances| {
            let far = far_pixels(&reach, size, distances, &proxies, options.distance);
            for (t, _) in distances.iter_mut().zip(&far).filter(|(_, f)| **f) {
                *t = options.distance;
            }
            far
        });
        // (no far pixel: the scene as it is, without a lookup per ray)
        let far_pixels_of = far.as_deref().filter(|f| f.contains(&true));
        let far_scene = depth.zip(far_pixels_of).map(|(inner, far)| FarScene {
            inner,
            output,
            centre: *centre,
            far,
            distance: options.distance,
        });
        let depth: Option<&dyn StitchDepth> = match &far_scene {
            Some(scene) => Some(scene),
            None => depth,
        };
        // (the bound's proxies serve unless the far fill changed the depth)
        let refilled: Option<Vec<Proxy>> = far_scene.as_ref().map(|_| {
            cameras
                .iter()
                .enumerate()
                .map(|(i, camera)| Proxy::guided((i, *camera), *centre, options.distance, depth))
                .collect()
        });
        let proxies = refilled.as_deref().unwrap_or(&proxies);
        let mut tables = Vec::with_capacity(cameras.len());
        let mut weights = Vec::with_capacity(cameras.len());
        let pass = WeightPass {
            output,
            reach: &reach,
            distances: distances.as_deref(),
            scene: far_scene.as_ref().map(|s| (s.inner, s.far)),
            depth,
            centre: *centre,
            options,
        };
        for (i, (camera, proxy)) in cameras.iter().zip(proxies).enumerate() {
            let gated = Gated {
                output,
                reach: &reach,
                camera: i,
            };
            // the table's pixel centres at the distances already cast for the map
            let centred = match &distances {
                Some(distances) => proxy.with_centres(Centres {
                    output,
                    reach: &reach,
                    distances,
                }),
                None => *proxy,
            };
            // a depth-guided table samples the pyramid only where a pixel's footprint lies on
            // one surface: across a depth edge it measures a wide one the level would blur over
            let surfaces = depth.map(|_| &centred as &dyn Surfaces);
            let table = RemapTable::build_pyramid_guided(
                &gated,
                &centred,
                &Matrix3::identity(),
                TAPS_BELOW,
                surfaces,
                true,
            );
            let mask = masks.get(i).copied().flatten();
            weights.push(pass.weights(i, camera, proxy, &table, mask));
            tables.push(table);
        }
        let mut fallback = depth.map(|_| super::fallback::resolve(&mut weights));
        // the pixels no camera weighs whose centre an image holds ([`super::centre_fill`])
        let centre = match (depth, &distances, fallback.as_mut()) {
            (Some(depth), Some(distances), Some(fallback)) if cameras.len() <= 64 => CentreFill {
                reach: &reach,
                tables: &tables,
                size,
                distances,
                proxies,
                masks,
                depth,
            }
            .samples(&weights, fallback),
            _ => Vec::new(),
        };
        TablesAndWeights {
            tables,
            weights,
            distances,
            fallback,
            far,
            centre,
        }
    }
}

/// Camera `proxy`'s reach cone (`local` its bearings' map): with a depth (`guided`) the guided
/// cone on the bearings' directions, else the proxy's with its parallax.
fn cone_of<'a>(
    proxy: &Proxy,
    local: &'a (dyn Fn(&Vector3<f64>) -> Vector3<f64> + Sync),
    centre: &Vector3<f64>,
    options: StitchOptions,
    bounded: bool,
    guided: bool,
) -> Cone<'a> {
    let camera = &proxy.camera;
    let inverse = camera.rotation.try_inverse();
    let baseline = inverse.map(|r| (-(r * camera.translation) - centre).norm());
    if guided {
        // a moving object's point lies up to the motion bound further from the bearing
        let baseline = baseline.map(|b| b + proxy.motion_bound());
        return super::guided::guided_cone(camera, local, baseline, bounded);
    }
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
        baseline: None,
        // a pinhole's image border planes bound it within its cone
        frustum: Frustum::of(camera.model).filter(|_| bounded),
    }
}

/// The angle of a sample's footprint in `camera` ([`FOOTPRINT_PX`] of its pixels at its axis):
/// nothing nearer than the point may lie within it.
fn footprint_angle(camera: &StitchCamera) -> f64 {
    let axis = camera.model.project_point(&Vector3::z());
    let off = camera.model.project_point(&Vector3::new(1e-3, 0.0, 1.0));
    match (axis, off) {
        (Ok(p), Ok(q)) => FOOTPRINT_PX / ((q - p).norm() / 1e-3),
        _ => 0.0,
    }
}

/// What every camera's weights are computed with (steps 3 and 6, and step 2 of the guided
/// model).
struct WeightPass<'a> {
    output: &'a dyn CameraModel,
    reach: &'a Reach,
    distances: Option<&'a [f64]>,
    /// With far pixels, the scene without them and the far pixels: a pixel's test asks its own
    /// flag, not the far scene's projection of the point back into the output.
    scene: Option<(&'a dyn StitchDepth, &'a [bool])>,
    depth: Option<&'a dyn StitchDepth>,
    centre: Vector3<f64>,
    options: StitchOptions,
}

impl WeightPass<'_> {
    /// Camera `i`'s weight at every output pixel (negative: a fallback weight, where the
    /// camera does not see the scene's point; [`super::fallback`]).
    fn weights(
        &self,
        i: usize,
        camera: &StitchCamera,
        proxy: &Proxy,
        table: &RemapTable,
        mask: Option<&EgoMask>,
    ) -> Vec<f32> {
        let size = self.output.size();
        let (w, h) = (size.width as usize, size.height as usize);
        let (reach, options) = (self.reach, self.options);
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
        let saturation = (camera.model.pinhole())
            .filter(|_| b > 0.0 && b.is_finite())
            .map(|k| Saturation { width: b, k });
        let tiles = TileBound::of(camera, b, reach.step(), options.distance);
        // with a depth each pixel's point lies at its own distance: its direction from the
        // eye departs from its bearing's by the eye's offset from the centre (and the
        // depth's motion) over that distance
        let offset = self.centre + camera.rotation.transpose() * camera.translation;
        let pass = CameraPass {
            pass: self,
            i,
            camera,
            proxy,
            table,
            mask,
            deep,
            saturation,
            footprint: footprint_angle(camera),
            moves: proxy.motion_bound() > 0.0,
            offset,
        };
        let mut wi = vec![0f32; w * h];
        wi.par_chunks_mut((w * TILE).max(1))
            .enumerate()
            .for_each(|(band, rows)| {
                let (v0, v1) = (band * TILE, band * TILE + rows.len() / w);
                for u0 in (0..w).step_by(TILE) {
                    let u1 = (u0 + TILE).min(w);
                    // (most tiles lie beyond the camera's reach: nothing to weigh)
                    let any = reach.may_reach_block(i, u0..u1, v0..v1)
                        && (v0..v1).any(|v| (u0..u1).any(|u| pass.gives(u, v)));
                    if !any {
                        continue;
                    }
                    let whole = tiles
                        .as_ref()
                        .is_some_and(|t| pass.saturates(t, (u0, u1), (v0, v1)));
                    for v in v0..v1 {
                        let row = &mut rows[(v - v0) * w..][..w];
                        for (u, out) in row.iter_mut().enumerate().take(u1).skip(u0) {
                            *out = if whole {
                                pass.saturated(u, v)
                            } else {
                                pass.pixel(u, v)
                            };
                        }
                    }
                }
            });
        wi
    }
}

/// One camera's weights pass.
struct CameraPass<'a> {
    pass: &'a WeightPass<'a>,
    i: usize,
    camera: &'a StitchCamera<'a>,
    proxy: &'a Proxy<'a>,
    table: &'a RemapTable,
    mask: Option<&'a EgoMask>,
    /// The field of view's cosine shortcut (see [`margin_capped`]).
    deep: Option<(f64, f64)>,
    saturation: Option<Saturation>,
    footprint: f64,
    /// Whether the depth moves points for this camera ([`StitchDepth::seen_at`]).
    moves: bool,
    /// The output centre less the camera's eye, metres.
    offset: Vector3<f64>,
}

impl CameraPass<'_> {
    /// Whether every pixel of the tile `us` × `vs` has a bearing and provably a margin of at
    /// least the blend width (see [`tile`]).
    fn saturates(
        &self,
        bound: &TileBound,
        (u0, u1): (usize, usize),
        (v0, v1): (usize, usize),
    ) -> bool {
        let reach = self.pass.reach;
        if !(v0..v1).all(|v| (u0..u1).all(|u| reach.bearing(u, v).is_some())) {
            return false;
        }
        let (mu, mv) = ((u0 + u1 - 1) / 2, (v0 + v1 - 1) / 2);
        let k = (mu - u0).max(u1 - 1 - mu).max(mv - v0).max(v1 - 1 - mv);
        let Some(d) = reach.bearing(mu, mv) else {
            return false;
        };
        let Some(distances) = self.pass.distances else {
            return bound.saturates(self.proxy, &d, k);
        };
        // the nearest of the tile's points (none decided where one is not finite)
        let w = self.pass.output.size().width as usize;
        let nearest = (v0..v1)
            .flat_map(|v| &distances[v * w + u0..v * w + u1])
            .try_fold(f64::INFINITY, |a, &t| t.is_finite().then(|| a.min(t)));
        let Some(nearest) = nearest else {
            return false;
        };
        let parallax = (&self.offset, self.proxy.motion_bound());
        bound.saturates_guided(self.proxy, &d.normalize(), k, parallax, nearest)
    }

    /// Whether the camera may give output pixel (u, v) a weight: within its reach, and its
    /// sample wholly inside the image (a sample partly beyond it, a supersampled pixel at its
    /// edge, is darkened by the taps outside: the camera gives nothing there).
    fn gives(&self, u: usize, v: usize) -> bool {
        self.pass.reach.may_reach_pixel(self.i, u, v) && self.table.is_inside(u as u32, v as u32)
    }

    /// [`CameraPass::pixel`] where the margin is known to reach the blend width.
    fn saturated(&self, u: usize, v: usize) -> f32 {
        let reach = self.pass.reach;
        if !self.gives(u, v) {
            return 0.0;
        }
        let Some(d) = reach.bearing(u, v) else {
            return 0.0;
        };
        let (q, verdict) = self.point(u, v, &d);
        if self.mask.is_some_and(|mask| self.touches(mask, u, v, &q)) {
            return 0.0;
        }
        if self.seen(verdict) {
            1.0
        } else {
            -1.0
        }
    }

    /// Whether the sample of pixel (u, v), seeing camera point `q`, touches `mask`.
    fn touches(&self, mask: &EgoMask, u: usize, v: usize, q: &Vector3<f64>) -> bool {
        let pyramid = self.table.levels() > 1;
        touches_mask(self.pass.output, self.proxy, mask, u, v, q, pyramid)
    }

    /// The camera point of the scene's point at distance `t` along unit bearing `n`, and
    /// what decides whether the camera sees it cleanly, `far` the pixel's far flag and `inner`
    /// the scene without far pixels: as the far scene's [`Proxy::point_at`],
    /// [`Proxy::local_at`] and [`StitchDepth::sees_clean`] give them (a far pixel's point does
    /// not move and is not seen; another's is `inner`'s), without projecting each point back
    /// to its pixel.
    fn seen_through<'b>(
        &self,
        inner: &'b dyn StitchDepth,
        far: bool,
        n: &Vector3<f64>,
        t: f64,
    ) -> (Vector3<f64>, Verdict<'b>) {
        let x = self.pass.centre + n * t;
        let x = match self.moves && !far {
            true => inner.seen_at(self.i, &x),
            false => x,
        };
        let q = self.camera.rotation * x + self.camera.translation;
        (
            q,
            if far {
                Verdict::Hidden
            } else {
                Verdict::Ask(inner, x)
            },
        )
    }

    /// The camera's weight at output pixel (u, v) (negative: a fallback weight). The occlusion
    /// test, the costliest step, comes last: a pixel whose weight the margin or the ego mask
    /// sets to 0 needs no verdict.
    fn pixel(&self, u: usize, v: usize) -> f32 {
        let WeightPass { reach, options, .. } = *self.pass;
        if !self.gives(u, v) {
            return 0.0;
        }
        let Some(d) = reach.bearing(u, v) else {
            return 0.0;
        };
        let (q, verdict) = self.point(u, v, &d);
        let Some(m) = margin_capped(self.camera, &q, self.deep, self.saturation.as_ref()) else {
            return 0.0;
        };
        let wm = smoothstep(m / options.blend_width) as f32;
        if wm == 0.0 {
            return 0.0;
        }
        if self.mask.is_some_and(|mask| self.touches(mask, u, v, &q)) {
            return 0.0;
        }
        if self.seen(verdict) {
            wm
        } else {
            -wm
        }
    }

    /// The camera point output pixel (u, v) (bearing `d`) samples, and what decides whether
    /// the camera sees it cleanly.
    fn point(&self, u: usize, v: usize, d: &Vector3<f64>) -> (Vector3<f64>, Verdict<'_>) {
        let proxy = self.proxy;
        match (self.pass.distances, self.pass.depth) {
            (Some(t), Some(depth)) => {
                let n = d.normalize();
                let at = v * self.pass.output.size().width as usize + u;
                // step 2 of the guided model: a camera that does not see the scene's point
                // gives only a fallback there
                match self.pass.scene {
                    Some((inner, far)) => self.seen_through(inner, far[at], &n, t[at]),
                    None => (
                        proxy.local_at(&n, t[at]),
                        Verdict::Ask(depth, proxy.point_at(&n, t[at])),
                    ),
                }
            }
            _ => (proxy.local(d), Verdict::Seen),
        }
    }

    /// Whether the camera sees the pixel's point cleanly (the occlusion test, the costliest
    /// step: asked last, only where the weight needs it).
    fn seen(&self, verdict: Verdict) -> bool {
        match verdict {
            Verdict::Seen => true,
            Verdict::Hidden => false,
            Verdict::Ask(depth, x) => depth.sees_clean(self.i, &x, self.footprint),
        }
    }
}

/// Whether a camera sees a pixel's scene point cleanly ([`CameraPass::pixel`]): known, or the
/// scene's test of reference point `x`, asked only where the weight needs it.
enum Verdict<'a> {
    Seen,
    Hidden,
    Ask(&'a dyn StitchDepth, Vector3<f64>),
}

/// What a stitch's build gives: per camera its table and weights, and with a depth the
/// distance of every output pixel's centre (0 without a bearing).
pub(super) struct TablesAndWeights {
    pub(super) tables: Vec<RemapTable>,
    pub(super) weights: Vec<Vec<f32>>,
    pub(super) distances: Option<Vec<f64>>,
    /// With a depth, the pixels filled by the fallback rule ([`super::fallback`]).
    pub(super) fallback: Option<Vec<bool>>,
    /// With a depth, the pixels stitched at the proxy distance ([`super::far_fill`]).
    pub(super) far: Option<Vec<bool>>,
    /// With a depth, the centre fill's pixels ([`super::centre_fill`]).
    pub(super) centre: Vec<CentreSample>,
}

#[cfg(test)]
mod tests;
