//! `panoconv pano`'s views of a 360° panorama through the source's pyramid above 2 source
//! pixels (the KITTI targets' rule), its levels wrapping at the ±180° seam: against the exact
//! render as close as the per-source-pixel taps, no more moiré than they show, and a view
//! across the seam the view of the panorama rolled by half a turn.

use crate::common::{psnr, real_panos, render_where};
use nalgebra::{Matrix3, Point2, Vector3};
use panoconv::camera::{
    CameraModel, ImageSize, Intrinsics, Perspective, Projection, ProjectionReject,
};
use panoconv::codec::png::decode_rgb8;
use panoconv::convert::folder::FolderView;
use panoconv::convert::pano::{PanoSource, PanoViews};
use panoconv::geometry::Scale;
use panoconv::image::RgbImage;
use panoconv::tools::synth::{frames, SynthCalib};
use panoconv::warp::{RemapTable, Wrap};

/// A view camera turned into the panorama's frame (`source_from_output`), for the exact render.
#[derive(Debug)]
pub(crate) struct Turned<'a> {
    pub(crate) inner: &'a dyn CameraModel,
    pub(crate) source_from_output: Matrix3<f64>,
}

impl CameraModel for Turned<'_> {
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        self.inner
            .project(&(self.source_from_output.transpose() * d))
    }

    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        self.inner.unproject(p).map(|d| self.source_from_output * d)
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.inner
            .distance(&(self.source_from_output.transpose() * p))
    }

    fn size(&self) -> ImageSize {
        self.inner.size()
    }
}

/// `pano --to projection --yaw yaw --hfov --vfov --pano-width pano_width` of a panorama of
/// `size` (degrees).
fn view(
    size: ImageSize,
    projection: Projection,
    yaw: f64,
    fov: (f64, f64),
    width: u32,
) -> FolderView {
    let views = PanoViews {
        projection,
        yaws: vec![yaw.to_radians()],
        pitch: 0.0,
        hfov: fov.0.to_radians(),
        vfov: fov.1.to_radians(),
        scale: Scale::PanoWidth(width),
    };
    views.plan(size).unwrap().remove(0)
}

/// Today's per-source-pixel taps (at most 8×8) of `view`.
fn taps(view: &FolderView, source: &PanoSource) -> RemapTable {
    let camera: &dyn CameraModel = view.camera.as_ref();
    RemapTable::build(camera, source, &view.source_from_output, Wrap::Horizontal)
}

/// Views 2.6 to 5 times coarser than a synthetic frame's 1024×512 panorama, two of them
/// across the seam: PSNR against the exact render (σ 0.55 output px) within 0.2 dB of the
/// taps' or better. Figures (pyramid / taps): equirect 360° at yaw 180, 300 px wide, 48.32 /
/// 46.89 dB; cylindrical 360° at 200 px 46.41 / 45.72 dB; perspective 90° at yaw 180, 400 px,
/// 51.71 / 51.82 dB.
#[test]
fn panorama_views_through_the_pyramid_match_the_exact_render_as_the_taps_do() {
    let size = ImageSize::new(1024, 512);
    let source = PanoSource::new(size);
    let scene = &frames()[0].scene;
    let centre = SynthCalib::standard().centre();
    let image = scene.render(&source, &centre);
    let cases = [
        (Projection::Equirect, 180.0, (360.0, 120.0), 300),
        (Projection::Cylindrical, 0.0, (360.0, 100.0), 200),
        (Projection::Perspective, 180.0, (90.0, 70.0), 400),
    ];
    for (projection, yaw, fov, width) in cases {
        let view = view(size, projection, yaw, fov, width);
        assert!(view.table.levels() > 1, "{projection}: no level sampled");
        // the command builds it serially; bands of rows in parallel give the same table
        let camera: &dyn CameraModel = view.camera.as_ref();
        let rot = &view.source_from_output;
        let parallel =
            RemapTable::build_pyramid_above_wrap(camera, &source, rot, Wrap::Horizontal, 2.0, true);
        assert!(
            parallel == *view.table,
            "{projection}: the parallel build differs"
        );
        let turned = Turned {
            inner: view.camera.as_ref(),
            source_from_output: view.source_from_output,
        };
        let exact = render_where(scene, &turned, &centre, 0.55, 6, |_, _| true);
        let (db_taps, n) = psnr(&taps(&view, &source).apply(&image), &exact, |_, _| true);
        let (db_pyr, _) = psnr(&view.table.apply(&image), &exact, |_, _| true);
        eprintln!(
            "{projection} yaw {yaw} at {width}: PSNR taps {db_taps:.2} dB, pyramid above 2 px \
             {db_pyr:.2} dB ({} levels) over {n} px",
            view.table.levels()
        );
        assert!(
            db_pyr >= db_taps - 0.2,
            "{projection}: {db_pyr:.2} < {db_taps:.2} - 0.2 dB"
        );
    }
}

/// RMS deviation from the mean (grey levels) of `image` where `keep`, 2 px from the border
/// (also the fisheye command's moiré check).
pub(crate) fn deviation(image: &RgbImage, keep: impl Fn(u32, u32) -> bool) -> f64 {
    let (w, h) = (image.width(), image.height());
    let values: Vec<f64> = (2..h - 2)
        .flat_map(|v| (2..w - 2).map(move |u| (u, v)))
        .filter(|&(u, v)| keep(u, v))
        .map(|(u, v)| image.pixel(u, v)[0] as f64)
        .collect();
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let se: f64 = values.iter().map(|x| (x - mean) * (x - mean)).sum();
    (se / values.len() as f64).sqrt()
}

/// A checkerboard of squares of 2 source pixels turned by atan(3/4) (as
/// `tests/table_parts.rs`' moiré check; the fisheye command's too), `w`×`h`.
pub(crate) fn checkerboard(w: u32, h: u32) -> RgbImage {
    let mut image = RgbImage::new(w, h);
    for (i, px) in image.as_raw_mut().chunks_mut(3).enumerate() {
        let (x, y) = ((i as u32 % w) as f64, (i as u32 / w) as f64);
        let (a, b) = (x * 0.8 + y * 0.6, -x * 0.6 + y * 0.8);
        let white = ((a / 2.0).floor() + (b / 2.0).floor()).rem_euclid(2.0) == 0.0;
        px.fill(if white { 255 } else { 0 });
    }
    image
}

/// The checkerboard panorama (1600×800) to equirect views across the seam 2.2 to 5 times
/// coarser (the same scale everywhere): the checkerboard is beyond what the views can show,
/// so their deviation from flat grey is aliasing. Through the pyramid it is the KITTI rule's
/// at the same scale (a pinhole checkerboard to a pinhole view) within 1.5 grey levels, and it
/// exceeds the taps' by at most the KITTI rule's largest excess over its own taps at these
/// scales, plus 1. Figures (RMS grey levels, pyramid / taps, KITTI's): 2.2x 37.8 / 40.5
/// (37.9 / 40.7), 2.67x 38.0 / 26.3 (37.3 / 26.3: level 1's box and tent pass more of the
/// 2.8-px period than 3×3 taps), 3.3x 15.5 / 24.0 (15.6 / 24.1), 5x 16.4 / 8.4 (15.3 / 19.8:
/// the panorama's 5×5 taps are its pixels' exact box there).
#[test]
fn a_fine_checkerboard_panorama_shows_the_kitti_rules_moire_through_the_pyramid() {
    let (w, h) = (1600u32, 800u32);
    let size = ImageSize::new(w, h);
    let source = PanoSource::new(size);
    let image = checkerboard(w, h);
    let pinhole = Perspective::new(
        Intrinsics::new(600.0, 600.0, 399.5, 299.5),
        ImageSize::new(800, 600),
    );
    let flat = checkerboard(800, 600);
    let mut figures = Vec::new();
    for width in [727, 599, 485, 320] {
        let view = view(size, Projection::Equirect, 180.0, (360.0, 120.0), width);
        assert!(view.table.levels() > 1, "{width}: no level sampled");
        let by_taps = deviation(&taps(&view, &source).apply(&image), |_, _| true);
        let by_pyramid = deviation(&view.table.apply(&image), |_, _| true);
        // the KITTI targets' table at the same scale (a view within the pinhole's field)
        let f = 600.0 * width as f64 / w as f64;
        let out = Perspective::new(Intrinsics::new(f, f, 59.5, 44.5), ImageSize::new(120, 90));
        let id = Matrix3::identity();
        let kitti_taps = RemapTable::build(&out, &pinhole, &id, Wrap::None);
        let kitti = RemapTable::build_pyramid_above(&out, &pinhole, &id, 2.0, false);
        let (k_taps, k_pyramid) = (
            deviation(&kitti_taps.apply(&flat), |_, _| true),
            deviation(&kitti.apply(&flat), |_, _| true),
        );
        eprintln!(
            "checkerboard panorama to {width} px ({:.2}x): moiré {by_pyramid:.2} grey levels RMS \
             through the pyramid, {by_taps:.2} through the taps (KITTI rule {k_pyramid:.2}, \
             taps {k_taps:.2})",
            w as f64 / width as f64
        );
        assert!(
            (by_pyramid - k_pyramid).abs() <= 1.5,
            "{width}: {by_pyramid:.2}, the KITTI rule's {k_pyramid:.2}"
        );
        figures.push((width, by_pyramid - by_taps, k_pyramid - k_taps));
    }
    let bound = figures.iter().map(|f| f.2).fold(0.0, f64::max) + 1.0;
    for (width, excess, _) in figures {
        assert!(
            excess <= bound,
            "{width}: {excess:.2} over the taps > {bound:.2}"
        );
    }
}

/// The world map (sharp grid lines; 800 px wide: levels of 400, 200, 100, 50 and 25 columns)
/// seen across the ±180° seam, 4 times coarser (levels 2 and 3), is its view at yaw 0 of the
/// panorama rolled by half a turn (whose levels are the rolled levels), within one grey level
/// (the two turns' positions differ by rounding): no black or mismatched column at the seam.
#[test]
fn a_view_across_the_seam_through_the_pyramid_is_the_rolled_panoramas_view() {
    let path = real_panos().join("worldmap_800x400.png");
    let img = decode_rgb8(&std::fs::read(&path).unwrap(), &path).unwrap();
    let (w, h) = (img.width(), img.height());
    let mut rolled = RgbImage::new(w, h);
    for v in 0..h {
        for u in 0..w {
            rolled.put_pixel(u, v, img.pixel((u + w / 2) % w, v));
        }
    }
    let size = ImageSize::new(w, h);
    for (projection, fov) in [
        (Projection::Perspective, (100.0, 60.0)),
        (Projection::Equirect, (360.0, 120.0)),
    ] {
        let across = view(size, projection, 180.0, fov, 200);
        let facing = view(size, projection, 0.0, fov, 200);
        assert!(
            across.table.levels() > 2,
            "{projection}: level 2 not sampled"
        );
        let (a, b) = (across.table.apply(&img), facing.table.apply(&rolled));
        let mut worst = (0, 0, 0);
        for v in 0..a.height() {
            for u in 0..a.width() {
                let (p, q) = (a.pixel(u, v), b.pixel(u, v));
                let d = (0..3).map(|c| p[c].abs_diff(q[c])).max().unwrap();
                worst = worst.max((d, u, v));
            }
        }
        eprintln!(
            "{projection} across the seam ({}x{}, {} levels): the rolled view's within {} \
             (at {}, {})",
            a.width(),
            a.height(),
            across.table.levels(),
            worst.0,
            worst.1,
            worst.2
        );
        assert!(worst.0 <= 1, "{projection}: {worst:?}");
        for u in 0..a.width() {
            let black = (0..a.height()).all(|v| a.pixel(u, v) == [0, 0, 0]);
            assert!(!black, "{projection}: column {u} is black");
        }
    }
}
