//! A stitch of a synthetic rig against the scene rendered exactly from the output centre C2:
//! over the pixels some camera sees, the PSNR of the whole panorama, of each camera's region and
//! of each object's own pixels, and the misregistration of every pixel. The depth-guided
//! stitch tests of KITTI-360 and nuScenes share it.

use nalgebra::{Matrix3, Point2, Vector3};
use panoconv::camera::CameraModel;
use panoconv::image::RgbImage;
use panoconv::tools::synth::Scene;
use panoconv::warp::{Stitch, FALLBACK_SOURCE, FAR_SOURCE};
use rayon::prelude::*;

/// The scene a stitch is measured against, and how the reference is rendered.
pub struct Truth<'a> {
    /// The synthetic scene (its own axes).
    pub scene: &'a Scene,
    /// scene_from_level: the reference frame's axes in the scene's.
    pub scene_from_level: Matrix3<f64>,
    /// C2 in the reference frame, and in the scene.
    pub centre: (Vector3<f64>, Vector3<f64>),
    /// Each camera's centre in the reference frame, and in the scene.
    pub eyes: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// The stitch's output camera (bearings in the reference frame's axes).
    pub output: &'a dyn CameraModel,
    /// The same camera with bearings in the scene's axes (for the reference render).
    pub direct: &'a dyn CameraModel,
    /// Per camera, the blur the stitch gives its region, output pixels (σ of the reference).
    pub sigma: Vec<f64>,
    /// Per camera, reference samples per pixel side.
    pub grid: Vec<usize>,
}

/// One stitch's figures.
#[derive(Debug)]
pub struct Figures {
    pub overall_db: f64,
    pub region_db: Vec<f64>,
    /// Each object covering at least `min_object_px`: its box index, pixels and dB, then the
    /// pixels and dB of those whose eight neighbours show the same surface from C2 (more than a
    /// pixel from its silhouette).
    pub objects: Vec<ObjectFigures>,
    pub p95_mrad: f64,
    pub covered: usize,
    /// Covered pixels whose 5×5 neighbourhood shows one surface from C2 (two pixels or more
    /// from every outline), and how many of them are off by more than [`GHOST_LEVELS`] in a
    /// channel: a surface shown where C2 sees another (an object appearing twice, a seam's
    /// misplaced copy) is off by far more than resampling; the largest such error.
    pub interior: usize,
    pub ghost_px: usize,
    pub interior_max_err: u8,
}

/// A channel error (levels) beyond any resampling error away from an outline.
pub const GHOST_LEVELS: u8 = 20;

/// One object's figures.
#[derive(Debug)]
pub struct ObjectFigures {
    pub index: usize,
    pub pixels: usize,
    pub db: f64,
    pub inner_pixels: usize,
    pub inner_db: f64,
}

/// What C2 sees through a pixel's centre.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Surface {
    Box(usize),
    Ground,
    Sky,
}

fn psnr(se: f64, n: usize) -> f64 {
    10.0 * (255.0f64 * 255.0 / (se / (3 * n) as f64)).log10()
}

impl Truth<'_> {
    fn bearing(&self, i: usize) -> Vector3<f64> {
        let w = self.output.size().width as usize;
        self.output
            .unproject(&Point2::new((i % w) as f64, (i / w) as f64))
            .unwrap()
    }

    /// What the unit ray from C2 (scene axes) meets first.
    fn surface(&self, d: &Vector3<f64>) -> Surface {
        let o = &self.centre.1;
        let Some((t, _)) = self.scene.first_hit(o, d) else {
            return Surface::Sky;
        };
        let ground = Scene { boxes: vec![] }.first_hit(o, d).map(|h| h.0);
        if ground == Some(t) {
            return Surface::Ground;
        }
        self.scene
            .boxes
            .iter()
            .position(|b| {
                let alone = Scene {
                    boxes: vec![b.clone()],
                };
                alone.first_hit(o, d).is_some_and(|(tb, _)| tb == t)
            })
            .map_or(Surface::Ground, Surface::Box)
    }

    /// Output pixel `i`'s misregistration, mrad: where each contributing camera's sample comes
    /// from (its ray through the stitch's point at `distance`, met with the scene, seen from
    /// C2) against the pixel's bearing, the worst of them.
    fn misregistration(&self, stitch: &Stitch, i: usize, distance: f64) -> f64 {
        let w = self.output.size().width as usize;
        let d = self.bearing(i);
        let d_scene = self.scene_from_level * d;
        let x = self.centre.0 + d * distance;
        let (u, v) = ((i % w) as u32, (i / w) as u32);
        (0..self.eyes.len())
            .filter(|&cam| stitch.weight(cam, u, v) > 0.0)
            .map(|cam| {
                let (eye, eye_scene) = &self.eyes[cam];
                let ray = self.scene_from_level * (x - eye).normalize();
                let seen = match self.scene.first_hit(eye_scene, &ray) {
                    Some((t, _)) => eye_scene + ray * t - self.centre.1,
                    None => ray,
                };
                seen.angle(&d_scene) * 1e3
            })
            .fold(0.0, f64::max)
    }

    /// The 95th percentile of the misregistration over the pixels some camera sees, each at
    /// `distances(i)`, mrad.
    pub fn p95_mrad(&self, stitch: &Stitch, distances: &dyn Fn(usize) -> f64) -> f64 {
        let n = self.output.size().width as usize * self.output.size().height as usize;
        let mut mrad: Vec<f64> = (0..n)
            .filter(|&i| {
                let w = self.output.size().width as usize;
                let (u, v) = ((i % w) as u32, (i / w) as u32);
                !stitch.fell_back(u, v)
                    && (0..self.eyes.len()).any(|cam| stitch.weight(cam, u, v) > 0.0)
            })
            .map(|i| self.misregistration(stitch, i, distances(i)))
            .collect();
        mrad.sort_by(f64::total_cmp);
        mrad[mrad.len() * 95 / 100]
    }

    /// The figures of `stitch` applied to `images`, its pixels at `distances(i)`; objects
    /// covering fewer than `min_object_px` pixels are left out.
    pub fn figures(
        &self,
        stitch: &Stitch,
        images: &[&RgbImage],
        distances: &dyn Fn(usize) -> f64,
        min_object_px: usize,
    ) -> Figures {
        let size = self.output.size();
        let w = size.width as usize;
        let stitched = stitch.apply(images);
        // the fallback's and the far fill's pixels are not claimed to be right: measured as
        // uncovered
        let source: &Vec<u8> = &stitched
            .source
            .iter()
            .map(|&s| {
                if s & (FALLBACK_SOURCE | FAR_SOURCE) != 0 {
                    255
                } else {
                    s
                }
            })
            .collect();
        // the reference, each camera's region with its blur
        let mut direct = RgbImage::new(size.width, size.height);
        for cam in 0..self.eyes.len() as u8 {
            if !source.contains(&cam) {
                continue;
            }
            let part = super::render_where(
                self.scene,
                self.direct,
                &self.centre.1,
                self.sigma[cam as usize],
                self.grid[cam as usize],
                |u, v| source[(v * size.width + u) as usize] == cam,
            );
            for (i, &s) in source.iter().enumerate() {
                if s == cam {
                    let (u, v) = ((i % w) as u32, (i / w) as u32);
                    direct.put_pixel(u, v, part.pixel(u, v));
                }
            }
        }
        // the surface of every covered pixel and of its neighbours
        let h = size.height as usize;
        let near_covered = |i: usize| {
            let (u, v) = ((i % w) as isize, (i / w) as isize);
            (-1..=1).any(|dv| {
                (-1..=1).any(|du| {
                    let (x, y) = (u + du, v + dv);
                    x >= 0
                        && y >= 0
                        && (x as usize) < w
                        && (y as usize) < h
                        && source[y as usize * w + x as usize] != 255
                })
            })
        };
        let surfaces: Vec<Option<Surface>> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                near_covered(i).then(|| self.surface(&(self.scene_from_level * self.bearing(i))))
            })
            .collect();
        // whether pixel i's (2r + 1)² neighbourhood shows one surface from C2: it lies r pixels
        // or more from every outline
        let uniform = |i: usize, r: usize| {
            let (u, v) = (i % w, i / w);
            u >= r
                && v >= r
                && u + r < w
                && v + r < h
                && (v - r..=v + r)
                    .all(|y| (u - r..=u + r).all(|x| surfaces[y * w + x] == surfaces[i]))
        };
        let (mut interior_px, mut ghost_px, mut interior_max_err) = (0, 0, 0u8);
        let (mut se, mut n) = (0.0, 0);
        let mut region = vec![(0.0, 0usize); self.eyes.len()];
        // per box: (squared error, pixels) of all its pixels and of its inner ones
        let mut objects = vec![[(0.0, 0usize); 2]; self.scene.boxes.len()];
        let mut mrad = Vec::new();
        for (i, &s) in source.iter().enumerate() {
            if s == 255 {
                continue;
            }
            let (u, v) = ((i % w) as u32, (i / w) as u32);
            let (a, b) = (stitched.image.pixel(u, v), direct.pixel(u, v));
            let e = (0..3)
                .map(|c| (a[c] as f64 - b[c] as f64).powi(2))
                .sum::<f64>();
            se += e;
            n += 1;
            if uniform(i, 2) {
                let worst = (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap_or(0);
                interior_px += 1;
                ghost_px += usize::from(worst > GHOST_LEVELS);
                interior_max_err = interior_max_err.max(worst);
            }
            region[s as usize].0 += e;
            region[s as usize].1 += 1;
            if let Some(Surface::Box(b)) = surfaces[i] {
                objects[b][0].0 += e;
                objects[b][0].1 += 1;
                if uniform(i, 1) {
                    objects[b][1].0 += e;
                    objects[b][1].1 += 1;
                }
            }
            mrad.push(self.misregistration(stitch, i, distances(i)));
        }
        mrad.sort_by(f64::total_cmp);
        Figures {
            overall_db: psnr(se, n),
            region_db: region.iter().map(|(e, m)| psnr(*e, (*m).max(1))).collect(),
            objects: objects
                .iter()
                .enumerate()
                .filter(|(_, [(_, m), _])| *m >= min_object_px)
                .map(|(index, [(e, m), (ei, mi)])| ObjectFigures {
                    index,
                    pixels: *m,
                    db: psnr(*e, *m),
                    inner_pixels: *mi,
                    inner_db: psnr(*ei, (*mi).max(1)),
                })
                .collect(),
            p95_mrad: mrad[mrad.len() * 95 / 100],
            covered: n,
            interior: interior_px,
            ghost_px,
            interior_max_err,
        }
    }

    /// One line of `f`, each object named by its kind.
    pub fn report(&self, name: &str, f: &Figures) -> String {
        let objects: Vec<String> = f
            .objects
            .iter()
            .map(|o| {
                format!(
                    "{}#{} {:.1} dB/{} px (inner {:.1} dB/{} px)",
                    self.scene.boxes[o.index].kind,
                    o.index,
                    o.db,
                    o.pixels,
                    o.inner_db,
                    o.inner_pixels
                )
            })
            .collect();
        format!(
            "{name}: {:.2} dB over {} px, regions {:.2?} dB, misregistration p95 {:.3} mrad, \
             {} of {} px away from outlines off by more than {GHOST_LEVELS} levels (worst {}), \
             objects [{}]",
            f.overall_db,
            f.covered,
            f.region_db,
            f.p95_mrad,
            f.ghost_px,
            f.interior,
            f.interior_max_err,
            objects.join(", ")
        )
    }
}
