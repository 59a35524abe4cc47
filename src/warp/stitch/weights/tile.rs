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
        let wide = Perspective::new(
            Intrinsics::new(400.0, 380.0, 300.5, 250.0),
            ImageSize::new(640, 480),
        );
        let narrow = Perspective::new(
            Intrinsics::new(1500.0, 1500.0, 959.5, 539.5),
            ImageSize::new(1920, 1080),
        );
        let turn = |yaw: f64, pitch: f64| {
            *Rotation3::from_euler_angles(pitch.to_radians(), yaw.to_radians(), 0.0).matrix()
        };
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
        let (w, h) = (1440u32, 720u32);
        let k = Intrinsics::new(
            w as f64 / std::f64::consts::TAU,
            h as f64 / std::f64::consts::PI,
            w as f64 / 2.0 - 0.5,
            h as f64 / 2.0 - 0.5,
        );
        let output = Equirect::new(k, ImageSize::new(w, h));
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
}
