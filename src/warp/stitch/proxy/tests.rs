//! The proxy's unit tests: a guided table by a depth edge and within a camera's image.

use super::*;
use crate::camera::{Equirect, Intrinsics, Perspective};
use crate::image::RgbImage;
use crate::warp::reach::Reach;
use crate::warp::table::{RemapTable, Wrap, MAX_SUPERSAMPLE};
use nalgebra::Matrix3;

/// A scene at one distance everywhere, seen by every camera.
#[derive(Debug)]
pub(in crate::warp::stitch) struct Sphere(pub(in crate::warp::stitch) f64);

impl StitchDepth for Sphere {
    fn distance(&self, _: &Vector3<f64>) -> f64 {
        self.0
    }
    fn sees(&self, _: usize, _: &Vector3<f64>) -> bool {
        true
    }
    fn nearest(&self) -> f64 {
        self.0
    }
}

/// A near panel (the plane z = 2 m, within a window of bearings) before a far wall (20 m).
#[derive(Debug)]
struct Panel;

impl StitchDepth for Panel {
    fn distance(&self, d: &Vector3<f64>) -> f64 {
        let n = d.normalize();
        let on = n.z > 0.0 && (n.x / n.z).abs() < 0.3 && (n.y / n.z).abs() < 0.2;
        if on {
            2.0 / n.z
        } else {
            20.0
        }
    }
    fn sees(&self, _: usize, _: &Vector3<f64>) -> bool {
        true
    }
    fn nearest(&self) -> f64 {
        2.0
    }
}

/// A 320×240 pinhole, about 3.5 of its pixels a 360×180 equirect's pixel.
fn side_model() -> Perspective {
    Perspective::new(
        Intrinsics::new(200.0, 200.0, 159.5, 119.5),
        ImageSize::new(320, 240),
    )
}

/// `model` looking along the output's axis from 0.4 m beside its centre.
fn side_camera(model: &Perspective) -> StitchCamera<'_> {
    StitchCamera {
        model,
        rotation: Matrix3::identity(),
        translation: Vector3::new(-0.4, 0.0, 0.0),
        max_theta: None,
    }
}

/// The full-sphere equirect of `w`×`h` pixels.
fn full_equirect(w: usize, h: usize) -> Equirect {
    Equirect::new(
        Intrinsics::new(
            w as f64 / std::f64::consts::TAU,
            h as f64 / std::f64::consts::PI,
            (w as f64 - 1.0) / 2.0,
            (h as f64 - 1.0) / 2.0,
        ),
        ImageSize::new(w as u32, h as u32),
    )
}

#[test]
fn a_guided_table_keeps_the_taps_across_a_depth_edge_and_samples_the_pyramid_elsewhere() {
    // a camera 0.4 m beside the output centre, about 3.5 of its pixels an output pixel:
    // on the panel and on the wall its pixels sample the pyramid (level 1), a pixel whose
    // footprint meets both (the panel's outline, 9 m of parallax apart) keeps its taps,
    // each through its own surface
    let model = side_model();
    let camera = side_camera(&model);
    let (w, h) = (360usize, 180usize);
    let output = full_equirect(w, h);
    let options = super::super::StitchOptions {
        distance: 10.0,
        blend_width: 5f64.to_radians(),
        even_exposure: false,
    };
    let built = super::super::Stitch::tables_and_weights(
        &output,
        &Vector3::zeros(),
        &[camera],
        &[None],
        options,
        true,
        Some(&Panel),
    );
    let table = &built.tables[0];
    assert!(table.levels() > 1);
    // per pixel: whether it has a block, and one in a pyramid level (beyond the source)
    let source = 320 * 240;
    let (mut blocks, mut level) = (vec![false; w * h], vec![false; w * h]);
    for v in 0..h {
        table.row_blocks(v, |u, p, _| {
            blocks[v * w + u] = true;
            level[v * w + u] |= p >= source;
        });
    }
    // a pixel across the edge: its footprint (5×5 positions within half a pixel of its
    // centre) meets both distances
    let across = |u: usize, v: usize| {
        let t = (0..25).filter_map(|k| {
            let p = Point2::new(
                u as f64 + (k % 5) as f64 / 4.0 - 0.5,
                v as f64 + (k / 5) as f64 / 4.0 - 0.5,
            );
            output.unproject(&p).ok().map(|d| Panel.distance(&d))
        });
        let (lo, hi) = t.fold((f64::INFINITY, 0.0f64), |(l, h), t| (l.min(t), h.max(t)));
        hi > 2.0 * lo
    };
    let (mut edge, mut pyramid) = (0, 0);
    for (v, u) in (0..h).flat_map(|v| (0..w).map(move |u| (v, u))) {
        if !blocks[v * w + u] {
            continue;
        }
        if across(u, v) {
            assert!(
                !level[v * w + u],
                "({u}, {v}) across the edge samples the pyramid"
            );
            edge += 1;
        } else {
            pyramid += level[v * w + u] as usize;
        }
    }
    assert!(
        edge > 80 && pyramid > 2000,
        "{edge} edge, {pyramid} pyramid pixels"
    );
}

#[test]
fn a_guided_proxy_maps_only_into_the_image_and_its_table_spends_nothing_beyond() {
    let model = Perspective::new(
        Intrinsics::new(80.0, 80.0, 59.5, 39.5),
        ImageSize::new(120, 80),
    );
    let camera = StitchCamera {
        model: &model,
        rotation: Matrix3::identity(),
        translation: Vector3::new(-0.4, 0.1, 0.0),
        max_theta: None,
    };
    let centre = Vector3::new(0.05, 0.0, 0.0);
    let sphere = Sphere(3.0);
    let guided = Proxy::guided((0, camera), centre, 10.0, Some(&sphere));
    let fixed = Proxy::new(camera, centre, 3.0);
    let output = Equirect::new(
        Intrinsics::new(
            60.0 / std::f64::consts::PI,
            60.0 / std::f64::consts::PI,
            59.5,
            29.5,
        ),
        ImageSize::new(120, 60),
    );
    // the same positions inside the image (to the rounding: the guided proxy projects a
    // pinhole's point directly, the fixed one through its unit bearing), none outside
    let (mut inside, mut outside) = (0, 0);
    for v in 0..60 {
        for u in 0..120 {
            let d = output.unproject(&Point2::new(u as f64, v as f64)).unwrap();
            let mut got = Vec::new();
            guided.project_all(&[Some(d)], &mut got);
            match fixed.project(&d).ok().filter(|p| in_image(p, 120.0, 80.0)) {
                Some(p) => {
                    let q = got[0].expect("a position");
                    assert!((q - p).norm() < 1e-9, "({u}, {v}): {q} vs {p}");
                    inside += 1;
                }
                None => {
                    assert_eq!(got[0], None, "({u}, {v})");
                    outside += 1;
                }
            }
        }
    }
    assert!(inside > 300 && outside > 2000, "{inside} {outside}");
    // the tables: a pixel the fixed one covers wholly is covered by the guided one, with the
    // same value where its neighbours' centres are inside too (the same scale estimate)
    let build = |p: &Proxy| {
        RemapTable::build_parallel(
            &output,
            p,
            &Matrix3::identity(),
            Wrap::None,
            MAX_SUPERSAMPLE,
        )
    };
    let (g, f) = (build(&guided), build(&fixed));
    let mut src = RgbImage::new(120, 80);
    for (y, x) in (0..80).flat_map(|y| (0..120).map(move |x| (y, x))) {
        src.put_pixel(x, y, [(x * 2) as u8, (y * 3) as u8, (x ^ y) as u8]);
    }
    let (gi, fi) = (g.apply(&src), f.apply(&src));
    let centre_inside = |u: i64, v: i64| {
        (0..120).contains(&u)
            && (0..60).contains(&v)
            && fixed
                .project(&output.unproject(&Point2::new(u as f64, v as f64)).unwrap())
                .is_ok_and(|p| in_image(&p, 120.0, 80.0))
    };
    let mut same = 0;
    for v in 0..60u32 {
        for u in 0..120u32 {
            if f.is_inside(u, v) {
                assert!(g.is_inside(u, v), "({u}, {v})");
            }
            let (a, b) = (u as i64, v as i64);
            let interior = [(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1)]
                .iter()
                .all(|(du, dv)| centre_inside(a + du, b + dv));
            if interior && f.is_inside(u, v) {
                assert_eq!(gi.pixel(u, v), fi.pixel(u, v), "({u}, {v})");
                same += 1;
            }
            if !centre_inside(a, b) {
                assert!(
                    !g.is_inside(u, v) && gi.pixel(u, v) == [0, 0, 0],
                    "({u}, {v})"
                );
            }
        }
    }
    assert!(same > 250, "{same}");
}

#[test]
fn one_surface_row_decides_as_one_surface_pixel_by_pixel() {
    // a drawn distance map: a smooth far surface, near splats (2-3 m: a depth edge for a
    // 0.4 m baseline), centres without a distance (0, infinite, NaN); whole rows, spans at
    // the borders and inside, and one pixel, each against the per-pixel rule
    let model = side_model();
    let camera = side_camera(&model);
    let (w, h) = (97usize, 41usize);
    let output = full_equirect(w, h);
    let reach = Reach::new(&output, &[], None);
    let mut state = 12345u64;
    let mut draw = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) as f64 / (1u64 << 31) as f64
    };
    let distances: Vec<f64> = (0..w * h)
        .map(|i| match draw() {
            r if r < 0.01 => 0.0,
            r if r < 0.015 => f64::INFINITY,
            r if r < 0.02 => f64::NAN,
            r if r < 0.08 => 2.0 + r,
            r => 10.0 + 0.001 * (i % w + i / w) as f64 + 1e-4 * r,
        })
        .collect();
    let sphere = Sphere(10.0);
    let proxy =
        Proxy::guided((0, camera), Vector3::zeros(), 10.0, Some(&sphere)).with_centres(Centres {
            output: &output,
            reach: &reach,
            distances: &distances,
        });
    let (mut row, mut one, mut edge) = (Vec::new(), 0, 0);
    for v in 0..h {
        for (a, b) in [(0, w), (3, 17), (w - 5, w), (40, 41)] {
            proxy.one_surface_row(v, a..b, &mut row);
            assert_eq!(row.len(), b - a);
            for (k, u) in (a..b).enumerate() {
                let expected = proxy.one_surface(u, v);
                assert_eq!(row[k], expected, "({u}, {v}) in {a}..{b}");
                if expected {
                    one += 1;
                } else {
                    edge += 1;
                }
            }
        }
    }
    assert!(one > 100 && edge > 100, "{one} on one surface, {edge} not");
}

/// The proxy as a table's scene without its shortcuts for a pixel's taps: each tap's bearing
/// unprojected alone by the gated output (no `tap_output`) and each tap's cell of centres
/// read alone. It counts the pixels it places and their taps cast on their own ray.
struct TapByTap<'a> {
    proxy: &'a Proxy<'a>,
    pixels: std::sync::atomic::AtomicUsize,
    cast: std::sync::atomic::AtomicUsize,
}

impl Surfaces for TapByTap<'_> {
    fn one_surface(&self, u: usize, v: usize) -> bool {
        self.proxy.one_surface(u, v)
    }

    fn one_surface_row(&self, v: usize, columns: Range<usize>, out: &mut Vec<bool>) {
        self.proxy.one_surface_row(v, columns, out)
    }

    fn project_taps(
        &self,
        at: &[Point2<f64>],
        ds: &[Option<Vector3<f64>>],
        out: &mut Vec<Option<Point2<f64>>>,
    ) {
        (self.pixels).fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let p = self.proxy;
        let (w, h) = (p.size().width as f64, p.size().height as f64);
        out.extend(at.iter().zip(ds).map(|(at, d)| {
            let d = d.as_ref()?;
            match p.between_centres_at(at) {
                Some(t) => p.project_at(d, t),
                None => {
                    (self.cast).fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    p.project(d)
                }
            }
            .ok()
            .filter(|q| in_image(q, w, h))
        }));
    }
}

#[test]
fn a_guided_tables_taps_by_columns_rows_and_cells_are_the_tap_by_tap_ones_bit_for_bit() {
    // the panel before the wall seen by a camera beside the centre, whose reach is cut by a
    // cone narrower than its image (34° against 38.7° across): the table whose taps take
    // their columns' and rows' shares and read each cell of centres once a pixel is the one
    // built tap by tap through the gated output, to the bit
    let model = side_model();
    let camera = side_camera(&model);
    let (w, h) = (360usize, 180usize);
    let output = full_equirect(w, h);
    let local = |d: &Vector3<f64>| d.normalize() * 10.0 + camera.translation;
    let cone = crate::warp::reach::Cone {
        local: &local,
        half_angle: Some(0.6),
        parallax: None,
        baseline: None,
        frustum: None,
    };
    let reach = Reach::new(&output, &[cone], None);
    let gated = crate::warp::reach::Gated {
        output: &output,
        reach: &reach,
        camera: 0,
    };
    // the scene's distances at the centres, some without one
    let distances: Vec<f64> = (0..w * h)
        .map(|i| match i % 89 {
            0 => 0.0,
            _ => (output.unproject(&Point2::new((i % w) as f64, (i / w) as f64)))
                .map_or(f64::NAN, |d| Panel.distance(&d)),
        })
        .collect();
    let proxy =
        Proxy::guided((0, camera), Vector3::zeros(), 10.0, Some(&Panel)).with_centres(Centres {
            output: &output,
            reach: &reach,
            distances: &distances,
        });
    let build = |s: &dyn Surfaces| {
        let (id, below) = (Matrix3::identity(), crate::warp::table::TAPS_BELOW);
        RemapTable::build_pyramid_guided(&gated, &proxy, &id, below, Some(s), false)
    };
    let alone = TapByTap {
        proxy: &proxy,
        pixels: Default::default(),
        cast: Default::default(),
    };
    assert!(build(&proxy) == build(&alone));
    // (pixels by the panel's outline: some of their taps cast their own ray)
    let (placed, cast) = (alone.pixels.into_inner(), alone.cast.into_inner());
    assert!(
        placed > 500 && cast > 1000,
        "{placed} pixels' taps placed, {cast} cast"
    );
}

/// The proxy as a table's scene, asking `alone` pixels of a row alone before the rest of the
/// row at once; it counts the pixels asked alone and the rows asked at once.
struct Asking<'a> {
    proxy: &'a Proxy<'a>,
    alone: usize,
    pixels: std::sync::atomic::AtomicUsize,
    rows: std::sync::atomic::AtomicUsize,
}

impl<'a> Asking<'a> {
    fn new(proxy: &'a Proxy<'a>, alone: usize) -> Self {
        Asking {
            proxy,
            alone,
            pixels: Default::default(),
            rows: Default::default(),
        }
    }
}

impl Surfaces for Asking<'_> {
    fn one_surface(&self, u: usize, v: usize) -> bool {
        (self.pixels).fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.proxy.one_surface(u, v)
    }

    fn one_surface_row(&self, v: usize, columns: Range<usize>, out: &mut Vec<bool>) {
        (self.rows).fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.proxy.one_surface_row(v, columns, out)
    }

    fn asked_alone(&self) -> usize {
        self.alone
    }

    fn project_taps(
        &self,
        at: &[Point2<f64>],
        ds: &[Option<Vector3<f64>>],
        out: &mut Vec<Option<Point2<f64>>>,
    ) {
        self.proxy.project_taps(at, ds, out)
    }

    fn tap_output(&self) -> Option<&dyn Separable> {
        self.proxy.tap_output()
    }
}

#[test]
fn a_guided_table_asks_its_rows_alone_or_at_once_alike() {
    // the panel before the wall, each output pixel about 3.5 camera pixels (every pixel asks
    // whether it lies on one surface): the table that asks each row's first pixels alone and
    // the rest at once is the one that asks every pixel alone, and the one that asks each row
    // at once, to the bit
    let model = side_model();
    let camera = side_camera(&model);
    let (w, h) = (360usize, 180usize);
    let output = full_equirect(w, h);
    let local = |d: &Vector3<f64>| d.normalize() * 10.0 + camera.translation;
    let cone = crate::warp::reach::Cone {
        local: &local,
        half_angle: Some(0.8),
        parallax: None,
        baseline: None,
        frustum: None,
    };
    let reach = Reach::new(&output, &[cone], None);
    let gated = crate::warp::reach::Gated {
        output: &output,
        reach: &reach,
        camera: 0,
    };
    let distances: Vec<f64> = (0..w * h)
        .map(|i| match i % 89 {
            0 => 0.0,
            _ => (output.unproject(&Point2::new((i % w) as f64, (i / w) as f64)))
                .map_or(f64::NAN, |d| Panel.distance(&d)),
        })
        .collect();
    let proxy =
        Proxy::guided((0, camera), Vector3::zeros(), 10.0, Some(&Panel)).with_centres(Centres {
            output: &output,
            reach: &reach,
            distances: &distances,
        });
    let build = |s: &dyn Surfaces| {
        let (id, below) = (Matrix3::identity(), crate::warp::table::TAPS_BELOW);
        RemapTable::build_pyramid_guided(&gated, &proxy, &id, below, Some(s), false)
    };
    let some = Asking::new(&proxy, proxy.asked_alone());
    let each = Asking::new(&proxy, usize::MAX);
    let rows = Asking::new(&proxy, 0);
    let table = build(&some);
    assert!(table == build(&each));
    assert!(table == build(&rows));
    let counts = |a: Asking| (a.pixels.into_inner(), a.rows.into_inner());
    let (some, each, rows) = (counts(some), counts(each), counts(rows));
    // (each way taken: the first pixels of a row alone, then the rest of it at once)
    assert!(some.0 > 500 && some.1 > 50, "{some:?}");
    assert!(each.0 > 3000 && each.1 == 0, "{each:?}");
    assert!(rows.0 == 0 && rows.1 > 50, "{rows:?}");
    assert!(
        some.0 < each.0 && some.0 >= 16 * some.1,
        "{some:?} {each:?}"
    );
}
