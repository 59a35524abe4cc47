//! The exact reference rendered only where a test compares it: `Scene::render_with` through a
//! camera that refuses the footprint samples no compared pixel needs, so that they are never
//! traced. The compared pixels come out exactly as a whole render gives them
//! (`render_where_equals_render_with_at_the_kept_pixels` checks it); `psnr` compares them.

use nalgebra::{Point2, Vector3};
use panoconv::camera::{CameraModel, ImageSize, ProjectionReject};
use panoconv::image::RgbImage;
use panoconv::tools::synth::Scene;

/// A window of a camera's image: pixel (0, 0) is the camera's `origin`.
#[derive(Debug)]
pub struct Window<'a> {
    pub inner: &'a dyn CameraModel,
    pub origin: Point2<f64>,
    pub size: ImageSize,
}

impl CameraModel for Window<'_> {
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        self.inner
            .project(d)
            .map(|p| Point2::from(p - self.origin.coords))
    }

    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        self.inner
            .unproject(&Point2::from(p.coords + self.origin.coords))
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.inner.distance(p)
    }

    fn size(&self) -> ImageSize {
        self.size
    }
}

/// `render_with`'s footprint half-width for σ = `sigma` px: 1.5 px at its default σ of 0.55 px,
/// in proportion otherwise.
fn footprint_reach(sigma: f64) -> f64 {
    1.5 * sigma.max(0.55) / 0.55
}

/// `camera` with every pixel farther than the footprint from a kept pixel refused.
#[derive(Debug)]
struct Masked<'a> {
    inner: &'a dyn CameraModel,
    /// Pixels within the footprint of a kept pixel, row-major.
    near: Vec<bool>,
}

impl CameraModel for Masked<'_> {
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        self.inner.project(d)
    }

    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        let size = self.inner.size();
        let (u, v) = (p.x.round(), p.y.round());
        // samples outside the image are the inner camera's to answer
        let inside = u >= 0.0 && v >= 0.0 && u < size.width as f64 && v < size.height as f64;
        if inside && !self.near[v as usize * size.width as usize + u as usize] {
            return Err(ProjectionReject::OutsideDomain);
        }
        self.inner.unproject(p)
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.inner.distance(p)
    }

    fn size(&self) -> ImageSize {
        self.inner.size()
    }
}

/// `scene.render_with(camera, centre, sigma, n)` at the pixels where `keep(u, v)`; the other
/// pixels hold partial sums or black and are not to be read.
pub fn render_where(
    scene: &Scene,
    camera: &dyn CameraModel,
    centre: &Vector3<f64>,
    sigma: f64,
    n: usize,
    keep: impl Fn(u32, u32) -> bool,
) -> RgbImage {
    let size = camera.size();
    let (w, h) = (size.width as usize, size.height as usize);
    // a sample within the reach of a kept pixel's centre rounds to a pixel within r of it
    let r = footprint_reach(sigma).ceil() as usize + 1;
    // square dilation of the kept pixels by r, rows then columns
    let mut rows = vec![false; w * h];
    for v in 0..h {
        for u in 0..w {
            if keep(u as u32, v as u32) {
                for x in u.saturating_sub(r)..(u + r + 1).min(w) {
                    rows[v * w + x] = true;
                }
            }
        }
    }
    let mut near = vec![false; w * h];
    for v in 0..h {
        for u in 0..w {
            if rows[v * w + u] {
                for y in v.saturating_sub(r)..(v + r + 1).min(h) {
                    near[y * w + u] = true;
                }
            }
        }
    }
    let masked = Masked {
        inner: camera,
        near,
    };
    scene.render_with(&masked, centre, sigma, n)
}

/// PSNR (dB) of `a` against `b` over the pixels where `keep(u, v)`, and how many there were:
/// the comparison the tests make between a warp and the exact render.
pub fn psnr(a: &RgbImage, b: &RgbImage, keep: impl Fn(u32, u32) -> bool) -> (f64, usize) {
    let (mut se, mut n) = (0.0, 0usize);
    for v in 0..a.height() {
        for u in 0..a.width() {
            if keep(u, v) {
                let (p, q) = (a.pixel(u, v), b.pixel(u, v));
                se += (0..3)
                    .map(|c| (p[c] as f64 - q[c] as f64).powi(2))
                    .sum::<f64>();
                n += 1;
            }
        }
    }
    (10.0 * (255.0f64.powi(2) / (se / (3 * n) as f64)).log10(), n)
}

#[test]
fn render_where_equals_render_with_at_the_kept_pixels() {
    use panoconv::camera::{Intrinsics, Perspective};
    use panoconv::tools::synth::{frames, SynthCalib};
    let scene = &frames()[0].scene;
    let centre = SynthCalib::standard().centre();
    let camera = Perspective::new(
        Intrinsics::new(90.0, 90.0, 59.5, 39.5),
        ImageSize::new(120, 80),
    );
    // a block and single pixels, corners included
    let keep = |u: u32, v: u32| {
        ((10..40).contains(&u) && (5..30).contains(&v))
            || [(0, 0), (119, 79), (119, 0), (70, 50), (100, 20)].contains(&(u, v))
    };
    for (sigma, n) in [(0.55, 6), (1.7, 8)] {
        let whole = scene.render_with(&camera, &centre, sigma, n);
        let part = render_where(scene, &camera, &centre, sigma, n, keep);
        let (mut kept, mut skipped_differ) = (0, 0);
        for v in 0..80 {
            for u in 0..120 {
                if keep(u, v) {
                    assert_eq!(part.pixel(u, v), whole.pixel(u, v), "σ {sigma}: ({u}, {v})");
                    kept += 1;
                } else if part.pixel(u, v) != whole.pixel(u, v) {
                    skipped_differ += 1;
                }
            }
        }
        // the pixels far from any kept one were not rendered
        assert!(
            kept == 755 && skipped_differ > 3000,
            "{kept} kept, {skipped_differ} skipped"
        );
    }
}
