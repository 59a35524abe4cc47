//! `panoconv preview`: boxes drawn from the written calib land inside the written 2D boxes
//! (synthetic and real KITTI frames, equirect, cylindrical and perspective), edges are split at
//! the ±180° seam, text labels, depth overlays and contact sheets.

use crate::common::*;
use panoconv::camera::{ImageSize, Intrinsics, Projection};
use panoconv::image::RgbImage;
use panoconv::kitti::Cam;
use panoconv::kitti::{Calib, Label, LabelFile};
use panoconv::tools::preview::{depth_colour, draw_box_3d, draw_text, label_text, text_size};
use std::path::{Path, PathBuf};

fn synthetic_dir() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/synthetic_kitti"
    ))
}

const MARK: [u8; 3] = [0, 255, 0];

/// Converts `input` to `to` in a temp dir (training split only), asserting success.
fn convert(input: &Path, to: &str, extra: &[&str]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut args = vec!["--split", "training", "--quiet"];
    args.extend_from_slice(extra);
    let run = kitti(to, input, &out, &args);
    assert_success(&run);
    dir
}

fn png_size(path: &Path) -> ImageSize {
    let p = read_png(path);
    ImageSize::new(p.width, p.height)
}

/// For every labelled object with a 3D box in every training frame of `out`: draws only its 3D
/// box on a black image of the output size and checks every drawn pixel lies inside the written
/// 2D box expanded by 1 px. Returns the number of boxes checked.
fn check_boxes_inside(out: &Path, what: &str) -> usize {
    let split = out.join("training");
    let mut checked = 0;
    for e in std::fs::read_dir(split.join("label_2")).unwrap() {
        let label_path = e.unwrap().path();
        let id = label_path.file_stem().unwrap().to_str().unwrap().to_owned();
        let size = png_size(&split.join("image_2").join(format!("{id}.png")));
        let calib = Calib::read(&split.join("calib").join(format!("{id}.txt"))).unwrap();
        assert!(calib.projection.is_some(), "{what}: written calib");
        let (camera, centre) = calib.image_camera(Cam::C2, size).unwrap();
        for label in LabelFile::read(&label_path).unwrap().labels {
            if !label.has_box_3d() {
                continue;
            }
            let mut img = RgbImage::new(size.width, size.height);
            draw_box_3d(&mut img, &label, camera.as_ref(), &centre, MARK);
            let [l, t, r, b] = label.bbox;
            let mut drawn = 0;
            for y in 0..size.height {
                for x in 0..size.width {
                    if img.pixel(x, y) == [0, 0, 0] {
                        continue;
                    }
                    drawn += 1;
                    let (xf, yf) = (x as f64, y as f64);
                    assert!(
                        xf >= l - 1.0 && xf <= r + 1.0 && yf >= t - 1.0 && yf <= b + 1.0,
                        "{what} {id}: {} pixel ({x}, {y}) outside its 2D box {:?}",
                        label.kind,
                        label.bbox
                    );
                }
            }
            assert!(
                drawn > 0,
                "{what} {id}: nothing drawn for {:?}",
                label.tokens
            );
            checked += 1;
        }
    }
    checked
}

#[test]
fn drawn_boxes_lie_inside_the_written_2d_boxes_synthetic() {
    for to in ["equirect", "cylindrical", "perspective"] {
        let dir = convert(&synthetic_dir(), to, &[]);
        let n = check_boxes_inside(&dir.path().join("out"), &format!("synthetic {to}"));
        assert!(n >= 8, "synthetic {to}: only {n} boxes checked");
    }
    // full 360° and a coarser scale too
    let dir = convert(
        &synthetic_dir(),
        "equirect",
        &["--full-360", "--pano-width", "2048"],
    );
    assert!(check_boxes_inside(&dir.path().join("out"), "synthetic equirect 360") >= 8);
}

#[test]
fn drawn_boxes_lie_inside_the_written_2d_boxes_real_kitti() {
    for to in ["equirect", "cylindrical"] {
        let dir = convert(&real_kitti(), to, &[]);
        let n = check_boxes_inside(&dir.path().join("out"), &format!("KITTI {to}"));
        // 10 objects with a 3D box in the 6 labelled frames
        assert_eq!(n, 10, "KITTI {to}");
    }
}

/// A box straight behind the camera straddles the ±180° seam of a 360° panorama: it is drawn
/// at both edges, and no edge is drawn across the image.
#[test]
fn edges_are_split_at_the_seam_of_a_360_output() {
    let dir = convert(
        &synthetic_dir(),
        "equirect",
        &["--full-360", "--pano-width", "2048"],
    );
    let out = dir.path().join("out/training");
    let size = png_size(&out.join("image_2/000000.png"));
    let calib = Calib::read(&out.join("calib/000000.txt")).unwrap();
    let (camera, centre) = calib.image_camera(Cam::C2, size).unwrap();
    let period = 2.0 * std::f64::consts::PI * calib.k_out[2].unwrap().fu;
    assert!(
        (period - size.width as f64).abs() <= 1.0,
        "a 360° panorama is one period wide: {period} vs {}",
        size.width
    );
    for yaw in ["0.00", "0.60", "-1.20"] {
        let line = format!("Car 0.00 0 0.00 0 0 0 0 1.52 1.65 3.90 0.00 1.65 -7.00 {yaw}");
        let label = Label::parse(Path::new("l.txt"), 1, &line).unwrap();
        let mut img = RgbImage::new(size.width, size.height);
        draw_box_3d(&mut img, &label, camera.as_ref(), &centre, MARK);
        let (w, mut left, mut right, mut middle) = (size.width, 0, 0, 0);
        for y in 0..size.height {
            for x in 0..w {
                if img.pixel(x, y) == MARK {
                    if x < w / 8 {
                        left += 1;
                    } else if x >= w - w / 8 {
                        right += 1;
                    } else {
                        middle += 1;
                    }
                }
            }
        }
        assert!(
            left > 50 && right > 50,
            "yaw {yaw}: {left} left, {right} right"
        );
        assert_eq!(middle, 0, "yaw {yaw}: an edge was drawn across the seam");
    }
}

#[test]
fn text_labels_name_the_class_and_the_paired_distance() {
    let k = Intrinsics::new(300.0, 300.0, 500.0, 100.0);
    let size = ImageSize::new(1000, 200);
    let label = Label::parse(
        Path::new("l.txt"),
        1,
        "Car 0.00 0 0.00 0 0 0 0 1.50 1.60 4.00 3.00 1.65 4.00 0.00",
    )
    .unwrap();
    let centre = nalgebra::Vector3::zeros();
    // box centre (3, 0.9, 4): z 4, range sqrt(9+0.81+16) = 5.08, rho 5
    let want = [
        (Projection::Perspective, "Car 4.0m"),
        (Projection::Equirect, "Car 5.1m"),
        (Projection::Cylindrical, "Car 5.0m"),
    ];
    for (p, text) in want {
        assert_eq!(
            label_text(&label, p.camera(k, size).as_ref(), &centre),
            text
        );
    }
    let dc = Label::parse(
        Path::new("l.txt"),
        1,
        "DontCare -1 -1 -10 5.00 229.89 214.12 367.61 -1 -1 -1 -1000 -1000 -1000 -10",
    )
    .unwrap();
    let cam = Projection::Equirect.camera(k, size);
    assert_eq!(label_text(&dc, cam.as_ref(), &centre), "DontCare");

    // glyphs stay inside the text's box, every character of the alphabet draws something
    let text = "ABCDEFGHIJKLMNOPQRSTUVWXYZ 0123456789 .m-_:/x";
    for scale in [1, 2] {
        let (tw, th) = text_size(text, scale);
        let mut img = RgbImage::new(tw + 20, th + 20);
        draw_text(&mut img, 10, 10, text, scale, [255, 255, 255], None);
        for y in 0..img.height() {
            for x in 0..img.width() {
                if img.pixel(x, y) != [0, 0, 0] {
                    assert!(x >= 10 && x < 10 + tw && y >= 10 && y < 10 + th);
                }
            }
        }
        for (i, c) in text.chars().enumerate() {
            if c == ' ' {
                continue;
            }
            let x0 = 10 + scale * (1 + 6 * i as u32);
            let lit = (0..5 * scale)
                .flat_map(|dx| (0..7 * scale).map(move |dy| (dx, dy)))
                .filter(|&(dx, dy)| img.pixel(x0 + dx, 10 + scale + dy) != [0, 0, 0])
                .count();
            assert!(lit > 0, "glyph {c:?} is empty");
        }
    }
}

#[test]
fn preview_cli_draws_depth_in_colour_and_text() {
    let dir = convert(&synthetic_dir(), "cylindrical", &[]);
    let out = dir.path().join("out");
    let image = out.join("training/image_2/000001.png");
    let size = png_size(&image);
    // a depth map with a few known pixels: 2 m, 20 m, 79 m
    let depth_dir = out.join("training/depth_2");
    std::fs::create_dir_all(&depth_dir).unwrap();
    let mut values = vec![0u16; (size.width * size.height) as usize];
    let marks = [(10u32, 10u32, 2.0f64), (20, 12, 20.0), (30, 14, 79.0)];
    for &(x, y, d) in &marks {
        values[(y * size.width + x) as usize] = (d * 256.0).round() as u16;
    }
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
    write_png(
        &depth_dir.join("000001.png"),
        &Png {
            width: size.width,
            height: size.height,
            color: png::ColorType::Grayscale,
            depth: png::BitDepth::Sixteen,
            data: bytes,
        },
    );
    let p = dir.path().join("p.png");
    let run = panoconv([
        "preview".as_ref(),
        out.as_os_str(),
        "--frame".as_ref(),
        "000001".as_ref(),
        "--no-text".as_ref(),
        "--output".as_ref(),
        p.as_os_str(),
    ]);
    assert_success(&run);
    let shown = read_rgb8(&p);
    let src = read_rgb8(&image);
    assert_eq!((shown.width, shown.height), (size.width, size.height));
    for &(x, y, d) in &marks {
        let i = ((y * size.width + x) * 3) as usize;
        assert_eq!(
            &shown.data[i..i + 3],
            &depth_colour(d),
            "depth pixel ({x}, {y})"
        );
    }
    assert_ne!(depth_colour(2.0), depth_colour(20.0));
    assert_ne!(depth_colour(20.0), depth_colour(79.0));
    // --no-depth leaves those pixels as the image has them
    let q = dir.path().join("q.png");
    let run = panoconv([
        "preview".as_ref(),
        out.as_os_str(),
        "--frame".as_ref(),
        "000001".as_ref(),
        "--no-depth".as_ref(),
        "--output".as_ref(),
        q.as_os_str(),
    ]);
    assert_success(&run);
    let plain = read_rgb8(&q);
    let i = ((10 * size.width + 10) * 3) as usize;
    assert_eq!(&plain.data[i..i + 3], &src.data[i..i + 3]);
    // the text (black background, class colour) changes pixels --no-text does not
    let differ = shown
        .data
        .chunks_exact(3)
        .zip(plain.data.chunks_exact(3))
        .filter(|(a, b)| a != b)
        .count();
    assert!(differ > 100);

    // a depth map of the wrong size is an error naming the file
    write_png(
        &depth_dir.join("000001.png"),
        &Png {
            width: 4,
            height: 4,
            color: png::ColorType::Grayscale,
            depth: png::BitDepth::Sixteen,
            data: vec![0; 32],
        },
    );
    let run = panoconv([
        "preview".as_ref(),
        out.as_os_str(),
        "--frame".as_ref(),
        "000001".as_ref(),
        "--output".as_ref(),
        p.as_os_str(),
    ]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("depth_2/000001.png"), "{}", run.stderr);
}

#[test]
fn preview_cli_contact_sheet_and_plain_kitti() {
    let dir = convert(&synthetic_dir(), "equirect", &[]);
    let out = dir.path().join("out");
    let sheet = dir.path().join("sheet.png");
    let run = panoconv([
        "preview".as_ref(),
        out.as_os_str(),
        "--grid".as_ref(),
        "2x2".as_ref(),
        "--tile-width".as_ref(),
        "200".as_ref(),
        "--output".as_ref(),
        sheet.as_os_str(),
    ]);
    assert_success(&run);
    let s = read_rgb8(&sheet);
    assert_eq!(s.width, 2 * 200 + 3 * 4);
    // three training frames: two rows
    let tallest = (0..3)
        .map(|i| {
            let z = png_size(&out.join(format!("training/image_2/00000{i}.png")));
            (z.height as f64 * 200.0 / z.width as f64).round() as u32
        })
        .max()
        .unwrap();
    assert_eq!(s.height, 2 * tallest + 3 * 4);

    let run = panoconv([
        "preview".as_ref(),
        out.as_os_str(),
        "--grid".as_ref(),
        "3x1".as_ref(),
        "--frames".as_ref(),
        "000002".as_ref(),
        "--tile-width".as_ref(),
        "100".as_ref(),
        "--output".as_ref(),
        sheet.as_os_str(),
    ]);
    assert_success(&run);
    assert_eq!(read_rgb8(&sheet).width, 3 * 100 + 4 * 4);

    // --frame and --grid exclude each other; one of them is needed
    let run = panoconv([
        "preview".as_ref(),
        out.as_os_str(),
        "--output".as_ref(),
        sheet.as_os_str(),
    ]);
    assert_eq!(run.code, 2);

    // plain KITTI (no projection: line) is drawn as perspective from P2
    let p = dir.path().join("k.png");
    let run = panoconv([
        "preview".as_ref(),
        real_kitti().as_os_str(),
        "--frame".as_ref(),
        "000003".as_ref(),
        "--output".as_ref(),
        p.as_os_str(),
    ]);
    assert_success(&run);
    let shown = read_rgb8(&p);
    let src = read_rgb8(&real_kitti().join("training/image_2/000003.png"));
    assert_eq!((shown.width, shown.height), (src.width, src.height));
    // the car's 2D box (614.24 181.78 727.31 284.77) is outlined in white
    let px = |x: u32, y: u32| {
        let i = ((y * shown.width + x) * 3) as usize;
        [shown.data[i], shown.data[i + 1], shown.data[i + 2]]
    };
    assert_eq!(px(670, 285), [255, 255, 255]);
    assert_eq!(px(614, 230), [255, 255, 255]);
}
