//! Whole tiles of a fixed stitch's pinhole weights decided at once: where every pixel of a
//! tile provably has a margin of at least the blend width, each weight is exactly 1 and no
//! pixel's projection is needed.
//!
//! Between adjacent output centres the bearing turns by at most A (the reach bound's largest
//! turn), so every centre of a tile lies within α = k·A of its middle's bearing (k the most
//! positions between them). The proxy points of those bearings lie on the proxy sphere of
//! radius s, within the chord s·α of the middle's point, so camera i sees them within
//! α' = asin(s·α / ρ) of it (ρ the middle point's distance from the camera). With θ the
//! middle's angle from the optical axis, every pixel's direction lies within θ + α' of the axis
//! and, the gnomonic projection stretching an arc by at most sec²(θ + α'), its image point
//! within F·α'·(1 + r²) of the middle's (F the larger focal length, r = tan(θ + α')). Its
//! distance from the image border is therefore at least the middle's less that, and where
//! this still meets [`super::saturated`]'s test at r, and the field of view's margin exceeds
//! the blend width at θ + α', each pixel's weight saturates.

use super::{Proxy, StitchCamera, FOV_SLACK};
use crate::camera::Intrinsics;
use nalgebra::Vector3;

/// Output pixels per side of a tile decided whole.
pub(super) const TILE: usize = 8;

/// The widest angle from the optical axis a tile may reach: r = tan θ stays below 2.9, within
/// [`super::saturated`]'s r ≤ 3 with the rounding of every pixel's r far below the gap.
const WIDEST_R: f64 = 2.9;

/// What decides camera i's tiles: its pinhole intrinsics and field of view, the blend width
/// and the output's largest turn between adjacent centres.
#[derive(Debug, Clone, Copy)]
pub(super) struct TileBound {
    pub(super) k: Intrinsics,
    /// The widest angle from the axis at which the margin saturates, radians.
    pub(super) widest: f64,
    pub(super) width: f64,
    /// A, radians.
    pub(super) step: f64,
    /// The proxy sphere's radius s, metres.
    pub(super) distance: f64,
}

impl TileBound {
    /// The bound of a fixed stitch's `camera` (None: not a pinhole, a rotation not orthonormal
    /// to 1e-9, or no blend width), `step` the output's largest turn.
    pub(super) fn of(
        camera: &StitchCamera,
        width: f64,
        step: f64,
        distance: f64,
    ) -> Option<TileBound> {
        let k = camera.model.pinhole()?;
        let r = &camera.rotation;
        let off = (r.transpose() * r - nalgebra::Matrix3::identity()).amax();
        if !(off < 1e-9 && width > 0.0 && width.is_finite() && step.is_finite()) {
            return None;
        }
        if !(distance > 0.0 && distance.is_finite()) {
            return None;
        }
        // (the per-pixel field of view's margin, by the angle or its cosine, is at least the
        // width 1e-6 rad inside this)
        let fov = camera
            .max_theta
            .map_or(f64::INFINITY, |t| t - width - FOV_SLACK - 1e-6);
        Some(TileBound {
            k,
            widest: WIDEST_R.atan().min(fov),
            width,
            step,
            distance,
        })
    }

    /// Whether every pixel of a tile whose centres lie within `k` positions of its middle,
    /// whose bearing is `middle`, has a weight of exactly 1 in `proxy`'s camera (every centre of
    /// the tile with a bearing, the caller checks).
    pub(super) fn saturates(&self, proxy: &Proxy, middle: &Vector3<f64>, k: usize) -> bool {
        // (1e-9 rad and a part in 1e9 cover the rounding of the angles and lengths)
        let alpha = k as f64 * self.step + 1e-9;
        let q = proxy.local(middle);
        let rho = q.norm();
        let chord = self.distance * alpha * (1.0 + 1e-9);
        if !(chord < 0.5 * rho) {
            return false;
        }
        let turn = (chord / rho).asin() * (1.0 + 1e-9) + 1e-9;
        self.saturates_within(proxy, &q, turn)
    }

    /// [`TileBound::saturates`] for a depth-guided stitch, each pixel's point at its own
    /// distance t ≥ `nearest` from the output centre along its unit bearing n: camera i sees
    /// it at q = t·(R·n + w/t + R·m/t), w = R·(centre − eye) (`offset` = centre − eye) and m
    /// the depth's motion of it, |m| ≤ `motion`. Of unit `middle` n₀, R·n lies within the
    /// chord k·A of R·n₀, and w/t on the segment from 0 to w/`nearest`, so q/t lies within
    /// ρ = k·A + |w|/(2·`nearest`) + `motion`/`nearest` of a = R·n₀ + w/(2·`nearest`), and q
    /// within asin(ρ/|a|) of a's direction.
    pub(super) fn saturates_guided(
        &self,
        proxy: &Proxy,
        middle: &Vector3<f64>,
        k: usize,
        (offset, motion): (&Vector3<f64>, f64),
        nearest: f64,
    ) -> bool {
        if !(nearest > 0.0 && motion >= 0.0) {
            return false;
        }
        let rotation = &proxy.camera.rotation;
        let half = rotation * offset / (2.0 * nearest);
        let a = rotation * middle + half;
        let rho = (k as f64 * self.step + 1e-9 + half.norm() + motion / nearest) * (1.0 + 1e-8);
        let along = a.norm();
        if !(rho < 0.5 * along) {
            return false;
        }
        // (1e-8 rad covers the rotation's departure from orthonormal, under 1e-9)
        let turn = (rho / along).asin() * (1.0 + 1e-9) + 1e-8;
        self.saturates_within(proxy, &a, turn)
    }

    /// Whether every camera point within angle `turn` of camera point `q` has a weight of
    /// exactly 1 in `proxy`'s camera.
    fn saturates_within(&self, proxy: &Proxy, q: &Vector3<f64>, turn: f64) -> bool {
        let theta = q.x.hypot(q.y).atan2(q.z) + turn;
        if !(theta <= self.widest) {
            return false;
        }
        let r = theta.tan() * (1.0 + 1e-9);
        let kk = &self.k;
        let (x, y) = kk.to_pixel(q.x / q.z, q.y / q.z);
        let size = proxy.camera.model.size();
        let border = (x + 0.5)
            .min(size.width as f64 - 0.5 - x)
            .min(y + 0.5)
            .min(size.height as f64 - 0.5 - y);
        let f = kk.fu.abs().max(kk.fv.abs());
        let moved = f * turn * (1.0 + r * r) * (1.0 + 1e-9) + 1e-6;
        let most = f * (1.0 + (r + 0.01).powi(2)) * 1.001 * (1.0 + 1e-9);
        border - moved >= self.width * most
    }
}

#[cfg(test)]
mod tests {
    use super::super::{margin, margin_capped, smoothstep, Saturation};
    use super::*;
    use crate::camera::{CameraModel, Equirect, ImageSize, Perspective};
    use crate::warp::reach::Reach;
    use nalgebra::Rotation3;

    /// The tile tests' pinholes: a wide one off-centre and a narrow one.
    fn pinholes() -> (Perspective, Perspective) {
        let wide = Perspective::new(
            Intrinsics::new(400.0, 380.0, 300.5, 250.0),
            ImageSize::new(640, 480),
        );
        let narrow = Perspective::new(
            Intrinsics::new(1500.0, 1500.0, 959.5, 539.5),
            ImageSize::new(1920, 1080),
        );
        (wide, narrow)
    }

    /// camera_from_reference's rotation of a camera turned by `yaw` and `pitch` (degrees).
    fn turn(yaw: f64, pitch: f64) -> nalgebra::Matrix3<f64> {
        *Rotation3::from_euler_angles(pitch.to_radians(), yaw.to_radians(), 0.0).matrix()
    }

    /// The tile tests' output: a 1440x720 equirect panorama.
    fn equirect_1440() -> Equirect {
        let (w, h) = (1440u32, 720u32);
        let k = Intrinsics::new(
            w as f64 / std::f64::consts::TAU,
            h as f64 / std::f64::consts::PI,
            w as f64 / 2.0 - 0.5,
            h as f64 / 2.0 - 0.5,
        );
        Equirect::new(k, ImageSize::new(w, h))
    }

    /// Per bound, the tiles it decides whole and, of those, the ones with a pixel whose
    /// measured weight is below 1.
    fn decide(
        camera: &StitchCamera,
        output: &Equirect,
        reach: &Reach,
        loosen: f64,
    ) -> (usize, usize) {
        let (width, distance) = (5f64.to_radians(), 10.0);
        let proxy = Proxy::new(*camera, Vector3::new(0.05, -0.1, 0.02), distance);
        let bound = TileBound::of(camera, width, reach.step() * loosen, distance).unwrap();
        let saturation = Saturation { width, k: bound.k };
        let size = output.size();
        let (w, h) = (size.width as usize, size.height as usize);
        let (mut whole, mut wrong) = (0, 0);
        for v0 in (0..h).step_by(TILE) {
            for u0 in (0..w).step_by(TILE) {
                let (u1, v1) = ((u0 + TILE).min(w), (v0 + TILE).min(h));
                let (mu, mv) = ((u0 + u1 - 1) / 2, (v0 + v1 - 1) / 2);
                let k = (mu - u0).max(u1 - 1 - mu).max(mv - v0).max(v1 - 1 - mv);
                let d = reach.bearing(mu, mv).unwrap();
                if !bound.saturates(&proxy, &d, k) {
                    continue;
                }
                whole += 1;
                // the per-pixel decision at every pixel of the tile: the pinhole's saturation
                // test passes (and the measured weight is exactly 1)
                let one = (v0..v1).all(|v| {
                    (u0..u1).all(|u| {
                        let q = proxy.local(&reach.bearing(u, v).unwrap());
                        let shortcut = margin_capped(camera, &q, None, Some(&saturation));
                        let measured = margin(camera, &q).map(|m| smoothstep(m / width) as f32);
                        shortcut == Some(width) && measured == Some(1.0)
                    })
                });
                wrong += usize::from(!one);
            }
        }
        (whole, wrong)
    }

    #[test]
    fn a_tile_decided_whole_has_every_weight_one_and_a_looser_bound_fails() {
        // a wide pinhole off-centre with a baseline, turned and tilted; a narrow one; one with
        // a field of view (the fov's margin, not the border's, sets part of its band)
        let (wide, narrow) = pinholes();
        let cameras = [
            (&wide, turn(30.0, 10.0), Vector3::new(0.4, 0.1, -0.3), None),
            (
                &narrow,
                turn(-70.0, -5.0),
                Vector3::new(-0.2, 0.0, 0.5),
                None,
            ),
            (&wide, turn(160.0, 0.0), Vector3::zeros(), Some(0.6)),
        ]
        .map(|(model, rotation, translation, max_theta)| StitchCamera {
            model: model as &dyn CameraModel,
            rotation,
            translation,
            max_theta,
        });
        let output = equirect_1440();
        let reach = Reach::new(&output, &[], None);
        for (i, camera) in cameras.iter().enumerate() {
            let (whole, wrong) = decide(camera, &output, &reach, 1.0);
            assert!(wrong == 0 && whole > 300, "camera {i}: {whole} {wrong}");
            // half the turn: some tile decided whole has a pixel the per-pixel test does not
            // saturate (at 0.8 of it none, on these cameras)
            let (_, wrong) = decide(camera, &output, &reach, 0.5);
            assert!(wrong > 0, "camera {i}: a looser bound passes");
        }
    }

    /// xorshift in [0, 1).
    fn uniform(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// [`decide`] for a depth-guided stitch: each pixel's point at its own distance (4-34 m,
    /// drawn per pixel) moved by up to `motion` (drawn), the bound told the parallax's
    /// distance times `loosen`.
    fn decide_guided(
        camera: &StitchCamera,
        output: &Equirect,
        reach: &Reach,
        motion: f64,
        loosen: f64,
    ) -> (usize, usize) {
        let width = 5f64.to_radians();
        let centre = Vector3::new(0.05, -0.1, 0.02);
        let proxy = Proxy::new(*camera, centre, 10.0);
        let bound = TileBound::of(camera, width, reach.step(), 10.0).unwrap();
        let saturation = Saturation { width, k: bound.k };
        let offset = centre + camera.rotation.transpose() * camera.translation;
        let size = output.size();
        let (w, h) = (size.width as usize, size.height as usize);
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let distances: Vec<f64> = (0..w * h)
            .map(|_| 4.0 + 30.0 * uniform(&mut state))
            .collect();
        let (mut whole, mut wrong) = (0, 0);
        for v0 in (0..h).step_by(TILE) {
            for u0 in (0..w).step_by(TILE) {
                let (u1, v1) = ((u0 + TILE).min(w), (v0 + TILE).min(h));
                let (mu, mv) = ((u0 + u1 - 1) / 2, (v0 + v1 - 1) / 2);
                let k = (mu - u0).max(u1 - 1 - mu).max(mv - v0).max(v1 - 1 - mv);
                let d = reach.bearing(mu, mv).unwrap().normalize();
                let nearest = (v0..v1)
                    .flat_map(|v| (u0..u1).map(move |u| v * w + u))
                    .map(|at| distances[at])
                    .fold(f64::INFINITY, f64::min);
                let parallax = (&offset, motion);
                if !bound.saturates_guided(&proxy, &d, k, parallax, nearest * loosen) {
                    continue;
                }
                whole += 1;
                let one = (v0..v1).all(|v| {
                    (u0..u1).all(|u| {
                        let n = reach.bearing(u, v).unwrap().normalize();
                        let shift = Vector3::new(
                            uniform(&mut state) - 0.5,
                            uniform(&mut state) - 0.5,
                            uniform(&mut state) - 0.5,
                        );
                        let x = centre + n * distances[v * w + u] + shift.normalize() * motion;
                        let q = camera.rotation * x + camera.translation;
                        let shortcut = margin_capped(camera, &q, None, Some(&saturation));
                        let measured = margin(camera, &q).map(|m| smoothstep(m / width) as f32);
                        shortcut == Some(width) && measured == Some(1.0)
                    })
                });
                wrong += usize::from(!one);
            }
        }
        (whole, wrong)
    }

    #[test]
    fn a_guided_tile_decided_whole_has_every_weight_one_and_a_looser_bound_fails() {
        // pinholes with baselines of 0.5-0.8 m, one with a field of view, the points 4 m away
        // and farther moved by up to 0.3 m
        let (wide, narrow) = pinholes();
        let cameras = [
            (&wide, turn(30.0, 10.0), Vector3::new(0.4, 0.1, -0.3), None),
            (
                &narrow,
                turn(-70.0, -5.0),
                Vector3::new(-0.6, 0.2, 0.3),
                None,
            ),
            (
                &wide,
                turn(160.0, 0.0),
                Vector3::new(0.6, 0.0, 0.3),
                Some(0.6),
            ),
        ]
        .map(|(model, rotation, translation, max_theta)| StitchCamera {
            model: model as &dyn CameraModel,
            rotation,
            translation,
            max_theta,
        });
        let output = equirect_1440();
        let reach = Reach::new(&output, &[], None);
        for (i, camera) in cameras.iter().enumerate() {
            let (whole, wrong) = decide_guided(camera, &output, &reach, 0.3, 1.0);
            assert!(wrong == 0 && whole > 50, "camera {i}: {whole} {wrong}");
            // the parallax's distance taken 10 times as far: a tile decided whole has a pixel
            // the per-pixel test does not saturate
            let (_, wrong) = decide_guided(camera, &output, &reach, 0.3, 10.0);
            assert!(wrong > 0, "camera {i}: a looser bound passes");
        }
    }
}
