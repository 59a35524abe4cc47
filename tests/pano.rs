//! Equirect panoramas: the ±180° seam wraps, latitudes clamp at the poles, the axes picture's
//! orientation, and the `pano` subcommand on ../shared/pano.

use crate::common;

use crate::common::{panoconv, read_text, Run};
use panoconv::camera::{ImageSize, Projection};
use panoconv::codec::png::{decode_rgb8, encode_rgb8, PngCompression};
use panoconv::convert::pano::PanoViews;
use panoconv::fs::read_file;
use panoconv::geometry::Scale;
use panoconv::image::RgbImage;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

fn pano_dir() -> PathBuf {
    common::real_panos()
}

fn load(name: &str) -> RgbImage {
    let p = pano_dir().join(name);
    decode_rgb8(&read_file(&p).unwrap(), &p).unwrap()
}

const PNGS: [&str; 2] = ["synthetic_axes_1024x512.png", "worldmap_800x400.png"];

fn views(projection: Projection, yaws: &[f64], pitch: f64, hfov: f64, vfov: f64) -> PanoViews {
    PanoViews {
        projection,
        yaws: yaws.iter().map(|y| y.to_radians()).collect(),
        pitch: pitch.to_radians(),
        hfov: hfov.to_radians(),
        vfov: vfov.to_radians(),
        scale: Scale::SourceFocal,
    }
}

fn warp(img: &RgbImage, v: &PanoViews) -> Vec<RgbImage> {
    v.plan(ImageSize::new(img.width(), img.height()))
        .unwrap()
        .iter()
        .map(|view| view.table.apply(img))
        .collect()
}

/// Mean absolute difference between columns a and b.
fn column_diff(img: &RgbImage, a: u32, b: u32) -> f64 {
    let mut s = 0.0;
    for v in 0..img.height() {
        let (p, q) = (img.pixel(a, v), img.pixel(b, v));
        for c in 0..3 {
            s += (p[c] as f64 - q[c] as f64).abs();
        }
    }
    s / (3 * img.height()) as f64
}

/// (seam difference, 99th percentile and max of the other adjacent-column differences).
fn seam_stats(img: &RgbImage, left: u32, right: u32) -> (f64, f64, f64) {
    let w = img.width();
    let mut others: Vec<f64> = (0..w)
        .map(|u| (u, (u + 1) % w))
        .filter(|&(a, b)| (a, b) != (left, right))
        .map(|(a, b)| column_diff(img, a, b))
        .collect();
    others.sort_by(|a, b| a.total_cmp(b));
    let p99 = others[others.len() * 99 / 100];
    (column_diff(img, left, right), p99, *others.last().unwrap())
}

fn assert_no_black_column(img: &RgbImage) {
    for u in 0..img.width() {
        let black = (0..img.height()).all(|v| img.pixel(u, v) == [0, 0, 0]);
        assert!(!black, "column {u} is black");
    }
}

#[test]
fn yaw_180_rolls_the_panorama_exactly() {
    // Same scale, 180° turn: every output sample lands on a source pixel centre, so the output
    // is the source rolled by half its width, the seam moved to the middle. Bit for bit, except
    // the one column whose footprint straddles the source's wrap: RemapTable's supersampling
    // estimate reads the wrap as a jump of a whole width there and box-filters that column
    // (see the report; a fix in src/warp/table.rs is proposed). That column must still match
    // its unfiltered value within the box filter's reach.
    for name in PNGS {
        let img = load(name);
        let out = &warp(
            &img,
            &views(Projection::Equirect, &[180.0], 0.0, 360.0, 180.0),
        )[0];
        assert_eq!((out.width(), out.height()), (img.width(), img.height()));
        let (w, h) = (img.width(), img.height());
        let (mut worst, mut worst_seam) = (0, 0.0f64);
        for u in 0..w {
            let mut sum = 0.0;
            for v in 0..h {
                let (p, q) = (out.pixel(u, v), img.pixel((u + w / 2) % w, v));
                for c in 0..3 {
                    let d = (p[c] as i32 - q[c] as i32).abs();
                    sum += d as f64;
                    // the seam column included: the table takes steps across the wrap the short way
                    worst = worst.max(d);
                }
            }
            if u == w / 2 {
                worst_seam = sum / (3 * h) as f64;
            }
        }
        eprintln!(
            "{name}: yaw 180 vs rolled source: max difference {worst} (seam column included), \
             mean difference {worst_seam:.2} on the seam column"
        );
        assert!(worst <= 1, "{name}: {worst}");
        assert!(worst_seam <= 0.5, "{name}: {worst_seam}");
    }
}

#[test]
fn the_seam_is_invisible_in_360_outputs() {
    for name in PNGS {
        let img = load(name);
        // An equirect at a coarser, non-integer scale turned by 180°: the source seam is between
        // columns W/2-1 and W/2; a cylindrical 360° output wraps between its last and first column.
        let mut strip = views(Projection::Equirect, &[180.0], 0.0, 360.0, 120.0);
        strip.scale = Scale::PanoWidth(img.width() * 7 / 10);
        let cyl = views(Projection::Cylindrical, &[0.0], 0.0, 360.0, 100.0);
        for (what, out, left, right) in [
            ("equirect yaw 180", &warp(&img, &strip)[0], None, None),
            (
                "cylindrical 360",
                &warp(&img, &cyl)[0],
                Some(u32::MAX),
                Some(0),
            ),
        ] {
            let w = out.width();
            let (l, r) = match (left, right) {
                (Some(_), Some(_)) => (w - 1, 0),
                _ => (w / 2 - 1, w / 2),
            };
            assert_no_black_column(out);
            let (seam, p99, max) = seam_stats(out, l, r);
            eprintln!(
                "{name} {what} {}x{}: seam columns {l}|{r} differ by {seam:.2} (other adjacent columns: p99 {p99:.2}, max {max:.2})",
                w,
                out.height()
            );
            assert!(
                seam <= p99.max(1.0),
                "{name} {what}: seam {seam} > p99 {p99}"
            );
        }
    }
}

#[test]
fn poles_clamp_and_views_cover_everything() {
    let img = load("worldmap_800x400.png");
    for pitch in [90.0, -90.0, 60.0, -75.0] {
        // Odd size: the centre pixel looks exactly at the pole for ±90°.
        let mut v = views(Projection::Perspective, &[0.0, 37.0], pitch, 91.0, 91.0);
        v.scale = Scale::PixelsPerDegree(1.0);
        for out in warp(&img, &v) {
            assert_eq!(out.width() % 2, 1);
            for y in 0..out.height() {
                for x in 0..out.width() {
                    assert_ne!(
                        out.pixel(x, y),
                        [0, 0, 0],
                        "pitch {pitch}: black at {x},{y}"
                    );
                }
            }
        }
    }
    // Straight up sees the top row's mean colour: the pole rows are repeated, not wrapped to
    // the other pole.
    let mut up = views(Projection::Perspective, &[0.0], 90.0, 11.0, 11.0);
    up.scale = Scale::PixelsPerDegree(1.0);
    let out = &warp(&img, &up)[0];
    let c = out.pixel(out.width() / 2, out.height() / 2);
    let (w, h) = (img.width(), img.height());
    let mean = |row: u32| -> [f64; 3] {
        let mut m = [0.0; 3];
        for u in 0..w {
            let p = img.pixel(u, row);
            for k in 0..3 {
                m[k] += p[k] as f64 / w as f64;
            }
        }
        m
    };
    let (top, bottom) = (mean(0), mean(h - 1));
    let dist = |m: [f64; 3]| (0..3).map(|k| (m[k] - c[k] as f64).abs()).sum::<f64>();
    assert!(
        dist(top) <= dist(bottom),
        "{c:?} top {top:?} bottom {bottom:?}"
    );
}

fn classify(p: [u8; 3]) -> &'static str {
    match p {
        [r, g, b] if r > 200 && g < 60 && b < 60 => "red",
        [r, g, b] if r < 160 && g > 200 && b < 60 => "green",
        [r, g, b] if r > 200 && g > 200 && b < 60 => "yellow",
        [r, g, b] if r < 80 && g < 80 && b > 200 => "blue",
        _ => "other",
    }
}

#[test]
fn the_axes_picture_has_plus_x_right_of_plus_z() {
    let img = load("synthetic_axes_1024x512.png");
    let v = views(
        Projection::Perspective,
        &[0.0, 90.0, 180.0, -90.0],
        0.0,
        150.0,
        60.0,
    );
    let outs = warp(&img, &v);
    // The most common face colour in a column (the white letters are ignored).
    let probe = |o: &RgbImage, fx: f64| {
        let u = (fx * (o.width() - 1) as f64) as u32;
        let mut counts = std::collections::BTreeMap::new();
        for v in 0..o.height() {
            let c = classify(o.pixel(u, v));
            if c != "other" {
                *counts.entry(c).or_insert(0) += 1;
            }
        }
        counts
            .into_iter()
            .max_by_key(|&(_, n)| n)
            .map_or("other", |(c, _)| c)
    };
    // Yaw 0 looks at +Z (red); +X (green) to its right, −X (yellow) to its left.
    assert_eq!(probe(&outs[0], 0.5), "red");
    assert_eq!(probe(&outs[0], 0.95), "green");
    assert_eq!(probe(&outs[0], 0.05), "yellow");
    assert_eq!(probe(&outs[1], 0.5), "green");
    assert_eq!(probe(&outs[2], 0.5), "blue");
    assert_eq!(probe(&outs[3], 0.5), "yellow");
}

#[test]
fn coarse_outputs_are_antialiased() {
    // A 1/4-scale equirect of the world map (sharp grid lines) against a box-filtered reference:
    // the supersampled table is much closer than a single bilinear tap per pixel.
    let img = load("worldmap_800x400.png");
    let mut v = views(Projection::Equirect, &[0.0], 0.0, 360.0, 180.0);
    v.scale = Scale::PanoWidth(200);
    let aa = &warp(&img, &v)[0];
    assert_eq!((aa.width(), aa.height()), (200, 100));
    let src = panoconv::convert::pano::PanoSource::new(ImageSize::new(800, 400));
    let out = panoconv::geometry::view_camera(
        Projection::Equirect,
        200.0 / (2.0 * PI),
        100.0 / PI,
        2.0 * PI,
        PI,
    )
    .unwrap();
    let plain = panoconv::warp::RemapTable::build_with(
        out.as_ref(),
        &src,
        &nalgebra::Matrix3::identity(),
        panoconv::warp::Wrap::Horizontal,
        1,
    )
    .apply(&img);
    let mut reference = RgbImage::new(200, 100);
    for y in 0..100 {
        for x in 0..200 {
            let mut m = [0u32; 3];
            for j in 0..4 {
                for i in 0..4 {
                    let p = img.pixel(4 * x + i, 4 * y + j);
                    for k in 0..3 {
                        m[k] += p[k] as u32;
                    }
                }
            }
            reference.put_pixel(x, y, m.map(|s| ((s + 8) / 16) as u8));
        }
    }
    let rmse = |a: &RgbImage| {
        let s: f64 = a
            .as_raw()
            .iter()
            .zip(reference.as_raw())
            .map(|(&p, &q)| (p as f64 - q as f64).powi(2))
            .sum();
        (s / a.as_raw().len() as f64).sqrt()
    };
    let (ea, ep) = (rmse(aa), rmse(&plain));
    eprintln!("1/4 world map: RMSE vs box filter: antialiased {ea:.2}, plain bilinear {ep:.2}");
    assert!(ea < 0.5 * ep, "{ea} vs {ep}");
}

// ---------------------------------------------------------------------------------------------
// CLI

fn pano(to: &str, input: &Path, output: &Path, extra: &[&str]) -> Run {
    let mut args: Vec<std::ffi::OsString> = vec![
        "pano".into(),
        "--to".into(),
        to.into(),
        "--input".into(),
        input.into(),
        "--output".into(),
        output.into(),
    ];
    args.extend(extra.iter().map(|s| s.into()));
    panoconv(args)
}

fn png_copies(dir: &Path) -> PathBuf {
    let input = dir.join("panos");
    std::fs::create_dir_all(&input).unwrap();
    for name in PNGS {
        std::fs::copy(pano_dir().join(name), input.join(name)).unwrap();
    }
    input
}

#[test]
fn cli_pano_perspective_views_and_cylindrical() {
    let tmp = tempfile::tempdir().unwrap();
    let input = png_copies(tmp.path());
    let out = tmp.path().join("views");
    let run = pano(
        "perspective",
        &input,
        &out,
        &["--yaw", "0,90,180,-90", "--fov", "90", "-j", "2"],
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    for stem in ["synthetic_axes_1024x512", "worldmap_800x400"] {
        for yaw in ["0", "90", "180", "-90"] {
            let png = common::read_rgb8(&out.join(format!("{stem}_yaw{yaw}.png")));
            assert_eq!(png.width, png.height);
            let txt = read_text(&out.join(format!("{stem}_yaw{yaw}.txt")));
            assert!(txt.starts_with("projection: perspective\n"), "{txt}");
            let k = common::calib_values(&txt, "K").unwrap();
            // 90° wide: fu = W/2.
            assert!((k[0] - png.width as f64 / 2.0).abs() < 1.0, "{k:?}");
            assert!(common::calib_values(&txt, "R").unwrap().len() == 9);
        }
    }
    let cyl = tmp.path().join("cyl");
    let run = pano("cylindrical", &input, &cyl, &["--vfov", "60"]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let txt = read_text(&cyl.join("worldmap_800x400.txt"));
    let k = common::calib_values(&txt, "K").unwrap();
    let png = common::read_rgb8(&cyl.join("worldmap_800x400.png"));
    // Full 360° at the source's scale; f_phi = f_y; height = 2 f_y tan(30°).
    assert_eq!(png.width, 800);
    assert!((k[0] - 800.0 / (2.0 * PI)).abs() < 1e-9 && k[0] == k[4]);
    assert_eq!(
        png.height,
        (2.0 * k[4] * 30f64.to_radians().tan()).ceil() as u32
    );
    assert!(txt.starts_with("projection: cylindrical\n"));
    // Equirect strip.
    let strip = tmp.path().join("strip");
    let run = pano(
        "equirect",
        &input,
        &strip,
        &["--vfov", "60", "--yaw", "180"],
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    let png = common::read_rgb8(&strip.join("synthetic_axes_1024x512.png"));
    assert_eq!((png.width, png.height), (1024, 171));
}

#[test]
fn cli_pano_bad_images_fail_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let input = png_copies(tmp.path());
    std::fs::write(input.join("broken.png"), b"not a png").unwrap();
    std::fs::write(
        input.join("square.png"),
        encode_rgb8(&RgbImage::new(64, 64), PngCompression::Fast),
    )
    .unwrap();
    std::fs::write(input.join("photo.jpg"), b"\xff\xd8\xff").unwrap();
    let out = tmp.path().join("out");
    let run = pano("cylindrical", &input, &out, &[]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    let failures = run.frame_failures();
    assert_eq!(failures.len(), 3, "{}", run.stderr);
    for (name, words) in [
        ("broken.png", "cannot decode PNG"),
        ("square.png", "image is 64x64, not a 2:1 equirect panorama"),
        ("photo.jpg", "cannot decode JPEG"),
    ] {
        let path = input.join(name);
        assert!(
            run.stderr.contains(&format!("{}: {words}", path.display())),
            "{name}: {}",
            run.stderr
        );
    }
    let files = common::tree_files(&out);
    assert_eq!(files.len(), 5, "{files:?}");
    let m = common::read_manifest(&out);
    assert_eq!(m["summary"]["converted"], 2);
    assert_eq!(m["summary"]["failed"], 3);
    // Set-up errors: nothing written.
    let inside = input.join("o");
    let run = pano("cylindrical", &input, &inside, &[]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(!inside.exists());
    let o2 = tmp.path().join("o2");
    let run = pano("perspective", &input, &o2, &["--fov", "200"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(!o2.exists());
}

/// Every panorama in ../shared/pano — PNG and JPEG, up to 6656x3328 — converts to a 360°
/// cylindrical strip at the 1024-px scale (antialiased: up to 6.5x coarser) with no black
/// column and no seam.
#[test]
fn every_shared_panorama_converts_without_a_seam() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let run = pano(
        "cylindrical",
        &pano_dir(),
        &out,
        &["--vfov", "90", "--pano-width", "1024"],
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    let mut names: Vec<String> = std::fs::read_dir(pano_dir())
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".png") || n.ends_with(".jpg"))
        .collect();
    names.sort();
    assert_eq!(names.len(), 4, "{names:?}");
    for name in names {
        let stem = name.rsplit_once('.').unwrap().0;
        let path = out.join(format!("{stem}.png"));
        let img = decode_rgb8(&std::fs::read(&path).unwrap(), &path).unwrap();
        assert_eq!(img.width(), 1024, "{name}");
        assert_no_black_column(&img);
        let (seam, p99, _) = seam_stats(&img, img.width() - 1, 0);
        eprintln!("{name}: seam {seam:.2} (p99 of other adjacent columns {p99:.2})");
        assert!(seam <= p99.max(1.0), "{name}: seam {seam} p99 {p99}");
    }
}

/// TIFF (8 and 16 bits) and lossless WebP panoramas, written here with the `image` crate from
/// a shared PNG's pixels, convert to exactly the views of the PNG itself.
#[test]
fn tiff_and_webp_inputs_give_the_png_inputs_views() {
    let tmp = tempfile::tempdir().unwrap();
    let source = load("worldmap_800x400.png");
    let (w, h) = (source.width(), source.height());
    let rgb8 = ::image::RgbImage::from_raw(w, h, source.as_raw().to_vec()).unwrap();
    let rgb16 = ::image::ImageBuffer::<::image::Rgb<u16>, Vec<u16>>::from_raw(
        w,
        h,
        source.as_raw().iter().map(|&v| v as u16 * 257).collect(),
    )
    .unwrap();
    let write = |folder: &str, name: &str, save: &dyn Fn(&Path)| -> PathBuf {
        let dir = tmp.path().join(folder);
        std::fs::create_dir_all(&dir).unwrap();
        save(&dir.join(name));
        dir
    };
    let png = write("png", "world.png", &|p| {
        std::fs::write(p, encode_rgb8(&source, PngCompression::Fast)).unwrap()
    });
    let tiff8 = write("tiff8", "world.tif", &|p| rgb8.save(p).unwrap());
    let tiff16 = write("tiff16", "world.TIFF", &|p| {
        rgb16
            .save_with_format(p, ::image::ImageFormat::Tiff)
            .unwrap()
    });
    let webp = write("webp", "world.webp", &|p| rgb8.save(p).unwrap());
    let convert = |input: &Path, out: &str| -> PathBuf {
        let output = tmp.path().join(out);
        let run = pano(
            "perspective",
            input,
            &output,
            &["--yaw", "0,90", "--fov", "80", "--quiet"],
        );
        assert_eq!(run.code, 0, "{}", run.stderr);
        output
    };
    let expected = convert(&png, "out-png");
    for (input, label) in [(&tiff8, "tiff8"), (&tiff16, "tiff16"), (&webp, "webp")] {
        let out = convert(input, &format!("out-{label}"));
        for view in ["world_yaw0.png", "world_yaw90.png"] {
            assert_eq!(
                read_file(&out.join(view)).unwrap(),
                read_file(&expected.join(view)).unwrap(),
                "{label}: {view} differs from the PNG input's"
            );
        }
    }
    // a file that claims to be a TIFF but is not one fails alone, naming itself
    let bad = write("bad", "broken.tiff", &|p| {
        std::fs::write(p, b"II*\0not a tiff").unwrap()
    });
    std::fs::copy(png.join("world.png"), bad.join("world.png")).unwrap();
    let run = pano(
        "perspective",
        &bad,
        &tmp.path().join("out-bad"),
        &["--quiet"],
    );
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert!(
        run.stderr.contains("broken.tiff") && run.stderr.contains("cannot decode image"),
        "{}",
        run.stderr
    );
}
