//! A camera's occlusion tests in the scene ([`StitchDepth::sees`], [`StitchDepth::hidden_near`]
//! and both at once, [`StitchDepth::sees_clean`], the weight pass's question at every pixel a
//! camera covers): its ray to a point against the ground, the boxes and the splats, and the rim
//! of its sample's footprint against the boxes. The two tests share one walk of the boxes
//! listed near the ray, each box's place beside the ray computed once.
//!
//! [`StitchDepth::sees`]: crate::warp::StitchDepth::sees
//! [`StitchDepth::hidden_near`]: crate::warp::StitchDepth::hidden_near
//! [`StitchDepth::sees_clean`]: crate::warp::StitchDepth::sees_clean

use super::splats::angles;
use super::{grid, SceneDepth, Solid, RING_RAYS, SURFACE_TOLERANCE};
use crate::camera::perpendiculars;
use nalgebra::Vector3;
use std::cell::Cell;
use std::f64::consts::TAU;

/// A ray from an eye to a point ([`SceneDepth::eye_ray`]).
pub(super) struct EyeRay {
    eye: Vector3<f64>,
    d: Vector3<f64>,
    length: f64,
}

/// A box's bounding sphere beside a unit ray: its centre's distance along the ray and squared
/// distance off it.
struct Beside {
    along: f64,
    off2: f64,
}

impl Beside {
    fn of(s: &Solid, o: &Vector3<f64>, d: &Vector3<f64>) -> Self {
        let oc = s.centre - o;
        let along = oc.dot(d);
        let off2 = oc.norm_squared() - along * along;
        Beside { along, off2 }
    }
}

/// Whether box `s` (`b` beside unit ray (o, d)) lies on the ray nearer than `limit`.
fn blocks(s: &Solid, b: &Beside, o: &Vector3<f64>, d: &Vector3<f64>, limit: f64) -> bool {
    // (an entry point lies in the bounding sphere: not before along − radius)
    b.along - s.radius < limit
        && s.hit_beside(o, d, b.along, b.off2)
            .is_some_and(|t| t < limit)
}

/// tan(`radius`), the last value kept per thread: a camera's footprint radius is the same at
/// every pixel of its pass.
fn tan_of(radius: f64) -> f64 {
    thread_local! {
        static LAST: Cell<(f64, f64)> = const { Cell::new((0.0, 0.0)) };
    }
    LAST.with(|last| {
        let (r, t) = last.get();
        if r == radius {
            return t;
        }
        let t = radius.tan();
        last.set((radius, t));
        t
    })
}

/// A camera sample's footprint of angular `radius` around its ray to `x`
/// ([`StitchDepth::hidden_near`](crate::warp::StitchDepth::hidden_near)).
struct Footprint<'a> {
    scene: &'a SceneDepth,
    camera: usize,
    x: &'a Vector3<f64>,
    eye: Vector3<f64>,
    d: Vector3<f64>,
    length: f64,
    radius: f64,
    spread: f64,
    /// A box's entry nearer than this hides the point.
    nearer: f64,
    /// The eye's offset from the output centre.
    base: Vector3<f64>,
    /// The rim's rays, made for the first box near enough (most samples have none).
    rim: Option<[Vector3<f64>; RING_RAYS]>,
}

impl<'a> Footprint<'a> {
    /// The footprint of `radius` (> 0) around `ray`, camera `camera`'s ray to `x`.
    fn new(
        scene: &'a SceneDepth,
        camera: usize,
        x: &'a Vector3<f64>,
        ray: &EyeRay,
        radius: f64,
    ) -> Self {
        let EyeRay { eye, d, length } = *ray;
        Footprint {
            scene,
            camera,
            x,
            eye,
            d,
            length,
            radius,
            spread: tan_of(radius),
            nearer: length * 0.95 - SURFACE_TOLERANCE,
            // the box's outline moves by the parallax across the eye's offset from the centre
            base: eye - scene.centre,
            rim: None,
        }
    }

    /// Whether box `s` (index `k`, `b` beside the ray) hides the point on the footprint's rim.
    fn hides(&mut self, s: &Solid, k: usize, b: &Beside) -> bool {
        let (eye, d, length, nearer, spread) =
            (self.eye, self.d, self.length, self.nearer, self.spread);
        // (the cone's test first: most listed boxes lie away from the footprint)
        let reach = s.radius + b.along.max(0.0) * spread;
        if b.along - s.radius >= nearer || b.off2 > reach * reach {
            return false;
        }
        if s.contains(self.x, SURFACE_TOLERANCE) {
            return false;
        }
        // a rim ray's entry before `nearer` lies within nearer·spread of the ray's first
        // `nearer` metres: a box farther from them than that is met by none
        if !(nearer > 0.0) || !s.near_segment(&eye, &d, nearer, nearer * spread) {
            return false;
        }
        // a box that moved by m since the centre saw it: as if the eye had moved by −m
        let base = self.base - self.scene.motion.shift(self.camera, k);
        let radius = self.radius;
        let rays = self.rim.get_or_insert_with(|| ring(&d, spread));
        rays.iter().any(|ray| {
            // under a tenth of the footprint the blur mixes the box in as the centre sees it
            let across = (base - ray * base.dot(ray)).norm();
            s.hit(&eye, ray)
                .is_some_and(|t| t < nearer && across * (1.0 / t - 1.0 / length) > radius / 10.0)
        })
    }
}

impl SceneDepth {
    /// The unit ray from camera `camera`'s eye to `x`: the eye, the direction and its length
    /// (None without such a camera or for `x` at the eye).
    pub(super) fn eye_ray(&self, camera: usize, x: &Vector3<f64>) -> Option<EyeRay> {
        let eye = *self.eyes.get(camera)?;
        let v = x - eye;
        let length = v.norm();
        if !(length > 0.0) {
            return None;
        }
        let d = v / length;
        Some(EyeRay { eye, d, length })
    }

    /// The distance before which an exact surface on `ray` hides its point.
    fn exact_limit(ray: &EyeRay) -> f64 {
        ray.length - SURFACE_TOLERANCE - 1e-9 * ray.length
    }

    /// Whether the ground or the splats hide `ray`'s point from camera `camera`.
    fn ground_or_splats_hide(&self, camera: usize, ray: &EyeRay) -> bool {
        let EyeRay { eye, d, length } = ray;
        let limit = Self::exact_limit(ray);
        if (self.ground.as_ref()).is_some_and(|g| g.meets_before(eye, d, limit)) {
            return true;
        }
        self.splats.get(camera + 1).is_some_and(|s| {
            let (lon, lat) = angles(d);
            s.range(lon, lat) < length - self.noise.margin(*length)
        })
    }

    /// [`StitchDepth::sees`](crate::warp::StitchDepth::sees) along `ray`
    /// ([`SceneDepth::eye_ray`]).
    pub(super) fn sees_along(&self, camera: usize, ray: &EyeRay) -> bool {
        if self.ground_or_splats_hide(camera, ray) {
            return false;
        }
        let (eye, d, limit) = (&ray.eye, &ray.d, Self::exact_limit(ray));
        let solids = self.solids_of(camera + 1);
        !self.grids[camera + 1].any(d, solids.len(), |k| {
            let s = &solids[k];
            blocks(s, &Beside::of(s, eye, d), eye, d, limit)
        })
    }

    /// [`StitchDepth::hidden_near`](crate::warp::StitchDepth::hidden_near) along `ray`
    /// ([`SceneDepth::eye_ray`]).
    pub(super) fn hidden_along(
        &self,
        camera: usize,
        x: &Vector3<f64>,
        ray: &EyeRay,
        radius: f64,
    ) -> bool {
        if !(radius > 0.0) {
            return false;
        }
        let mut footprint = Footprint::new(self, camera, x, ray, radius);
        let solids = self.solids_of(camera + 1);
        let hides = |k: usize| {
            let s = &solids[k];
            footprint.hides(s, k, &Beside::of(s, &ray.eye, &ray.d))
        };
        // the grid lists every box a rim ray within its reach may meet
        if radius <= grid::REACH {
            self.grids[camera + 1].any(&ray.d, solids.len(), hides)
        } else {
            (0..solids.len()).any(hides)
        }
    }

    /// [`SceneDepth::sees_along`] and not [`SceneDepth::hidden_along`]: one walk of the boxes
    /// listed near the ray serves both.
    pub(super) fn clean_along(
        &self,
        camera: usize,
        x: &Vector3<f64>,
        ray: &EyeRay,
        radius: f64,
    ) -> bool {
        if self.ground_or_splats_hide(camera, ray) {
            return false;
        }
        let (eye, d, limit) = (&ray.eye, &ray.d, Self::exact_limit(ray));
        let solids = self.solids_of(camera + 1);
        let mut footprint = (radius > 0.0).then(|| Footprint::new(self, camera, x, ray, radius));
        // the grid lists every box a rim ray within its reach may meet
        let listed = radius <= grid::REACH;
        let spoiled = self.grids[camera + 1].any(d, solids.len(), |k| {
            let s = &solids[k];
            let b = Beside::of(s, eye, d);
            blocks(s, &b, eye, d, limit)
                || (listed && footprint.as_mut().is_some_and(|f| f.hides(s, k, &b)))
        });
        if spoiled {
            return false;
        }
        match footprint {
            Some(mut f) if !listed => !(0..solids.len()).any(|k| {
                let s = &solids[k];
                f.hides(s, k, &Beside::of(s, eye, d))
            }),
            _ => true,
        }
    }
}

/// The [`RING_RAYS`] unit rays at angle atan(`spread`) around unit `d`.
fn ring(d: &Vector3<f64>, spread: f64) -> [Vector3<f64>; RING_RAYS] {
    static TURNS: std::sync::OnceLock<[(f64, f64); RING_RAYS]> = std::sync::OnceLock::new();
    let turns = TURNS.get_or_init(|| {
        std::array::from_fn(|k| {
            let turn = k as f64 * TAU / RING_RAYS as f64;
            (turn.cos(), turn.sin())
        })
    });
    let (a, b) = perpendiculars(d);
    std::array::from_fn(|k| (d + (a * turns[k].0 + b * turns[k].1) * spread).normalize())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::SourceBox;
    use crate::warp::StitchDepth;

    /// xorshift in [0, 1).
    fn uniform(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn a_rim_ray_meets_a_box_before_the_limit_only_where_the_segment_passes_near_it() {
        let mut state = 0x853c_49e6_748f_ea9b_u64;
        let (mut met, mut culled, mut cases) = (0, 0, 0);
        for n in 0..20_000 {
            let mut r = || uniform(&mut state);
            let size = [0.5 + 4.0 * r(), 0.5 + 2.0 * r(), 0.5 + 5.0 * r()];
            let centre = Vector3::new(8.0 * r() - 4.0, 2.0 * r() - 1.0, 6.0 + 10.0 * r());
            let s = Solid::new(&SourceBox::from_kitti("Car", size, centre, 6.0 * r()));
            let eye = Vector3::new(r() - 0.5, r() - 0.5, r() - 0.5);
            // rays towards the box's bounding sphere, some grazing its outline
            let aim = centre + Vector3::new(r() - 0.5, r() - 0.5, r() - 0.5) * 2.0 * s.radius;
            let d = (aim - eye).normalize();
            let spread = [1e-3, 4e-3, 0.02, 0.1][n % 4];
            let nearer = (centre - eye).norm() * (0.5 + r());
            let hit = ring(&d, spread)
                .iter()
                .any(|ray| s.hit(&eye, ray).is_some_and(|t| t < nearer));
            let near = s.near_segment(&eye, &d, nearer, nearer * spread);
            assert!(
                near || !hit,
                "box {centre} {size:?}, ray {d}, spread {spread}"
            );
            met += usize::from(hit);
            culled += usize::from(!near);
            cases += 1;
        }
        // both kinds are common: the test sees rays that meet and rays it may skip
        assert!(
            cases == 20_000 && met > 2000 && culled > 2000,
            "{met} {culled}"
        );
    }

    #[test]
    fn the_clean_test_in_one_walk_agrees_with_its_two_tests() {
        let mut points = Vec::new();
        for i in -40..=40 {
            for j in -40..=40 {
                let (x, z) = (i as f64 * 0.5, j as f64 * 0.5);
                points.push(Vector3::new(x, 1.6 + 0.01 * x, z));
            }
        }
        // a wall of residual points and a row of parked cars, some near the eyes
        for i in 0..200 {
            for j in 0..30 {
                points.push(Vector3::new(
                    -12.0,
                    1.5 - j as f64 * 0.1,
                    i as f64 * 0.2 - 20.0,
                ));
            }
        }
        let objects: Vec<SourceBox> = (0..8)
            .map(|k| {
                let at = Vector3::new([-3.0, 3.5][k % 2], 0.8, k as f64 * 5.0 - 17.0);
                SourceBox::from_kitti("Car", [1.5, 1.8, 4.2], at, 0.1 * k as f64)
            })
            .collect();
        let frame = super::super::tests::frame(points, objects);
        let eyes = vec![
            Vector3::new(0.8, -0.2, 0.5),
            Vector3::new(-0.7, 0.1, -0.9),
            Vector3::new(0.0, -0.4, 1.2),
        ];
        let scene = SceneDepth::new(&frame, Vector3::zeros(), eyes);
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let (mut seen, mut hidden, mut blocked) = (0, 0, 0);
        for n in 0..30_000 {
            let mut r = || uniform(&mut state);
            // the scene's own points, as the centre sees them (and some beyond)
            let d = Vector3::new(r() - 0.5, 0.6 * r() - 0.1, r() - 0.5).normalize();
            let x = d * scene.distance(&d).min(60.0) * [1.0, 1.0, 1.3][n % 3];
            let camera = n % 3;
            // footprints within the grid's reach and one beyond it
            let radius = [1.5e-3, 5e-3, 0.015, 0.05][n % 4];
            let sees = scene.sees(camera, &x);
            let near = scene.hidden_near(camera, &x, radius);
            assert_eq!(
                scene.sees_clean(camera, &x, radius),
                sees && !near,
                "camera {camera}, point {x}, radius {radius}"
            );
            seen += usize::from(sees && !near);
            hidden += usize::from(sees && near);
            blocked += usize::from(!sees);
        }
        assert!(
            seen > 5000 && hidden > 150 && blocked > 3000,
            "{seen} {hidden} {blocked}"
        );
    }
}
