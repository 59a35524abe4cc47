//! `preview` keeps each class/distance text beside its box: in a crowded frame a text moves at
//! most `MAX_TEXT_SHIFT` text rows from its box, and the texts with no free place near their
//! boxes are left out instead of stacked up over the sky. Through the binary on the synthetic
//! sample converted at the paper's scale, its label file crowded with ten more cars.

use crate::common::*;
use panoconv::camera::ImageSize;
use panoconv::image::RgbImage;
use panoconv::kitti::{Calib, Cam, LabelFile};
use panoconv::tools::preview::{class_colour, draw_text, label_text, text_size, MAX_TEXT_SHIFT};
use std::ffi::OsStr;

#[test]
fn crowded_preview_texts_stay_beside_their_boxes() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("equi");
    let args = [
        "--frames",
        "000001",
        "--split",
        "training",
        "--pano-width",
        "2048",
    ];
    assert_success(&kitti("equirect", synth_source(), &out, &args));
    // ten more cars beside the first object, 4 px apart: their texts cannot all sit near
    let label_path = out.join("training/label_2/000001.txt");
    let text = read_text(&label_path);
    let first = text.lines().find(|l| !l.starts_with("DontCare")).unwrap();
    let mut tokens: Vec<String> = first.split(' ').map(str::to_owned).collect();
    tokens[0] = "Car".into();
    let mut crowded = text.clone();
    for k in 1..=10 {
        let mut t = tokens.clone();
        for i in [4, 6] {
            let v: f64 = t[i].parse().unwrap();
            t[i] = format!("{:.2}", v + 4.0 * k as f64);
        }
        crowded.push_str(&t.join(" "));
        crowded.push('\n');
    }
    write_text(&label_path, &crowded);
    let preview = tmp.path().join("p.png");
    assert_success(&panoconv([
        OsStr::new("preview"),
        out.as_os_str(),
        OsStr::new("--frame"),
        OsStr::new("000001"),
        OsStr::new("--output"),
        preview.as_os_str(),
    ]));
    let img = read_rgb8(&preview);
    let image = RgbImage::from_raw(img.width, img.height, img.data.clone()).unwrap();
    let calib = Calib::read(&out.join("training/calib/000001.txt")).unwrap();
    let (camera, centre) = calib
        .image_camera(Cam::C2, ImageSize::new(img.width, img.height))
        .unwrap();
    let labels = LabelFile::read(&label_path).unwrap().labels;
    let scale = 1 + img.height / 600;
    let (mut drawn, mut objects) = (0, 0);
    for label in labels.iter().filter(|l| l.kind != "DontCare") {
        objects += 1;
        let text = label_text(label, camera.as_ref(), &centre);
        let (w, h) = text_size(&text, scale);
        let mut block = RgbImage::new(w, h);
        draw_text(
            &mut block,
            0,
            0,
            &text,
            scale,
            class_colour(&label.kind),
            Some([0; 3]),
        );
        let x = (label.bbox[0].round() as u32).min(img.width - w);
        let top = label.bbox[1].round() as i64;
        let reach = (MAX_TEXT_SHIFT + 1) * (h as i64 + 1) + 2;
        for y in 0..=img.height - h {
            let whole = (0..h)
                .all(|dy| (0..w).all(|dx| image.pixel(x + dx, y + dy) == block.pixel(dx, dy)));
            if whole {
                let y = y as i64;
                assert!(
                    y >= top - reach && y <= top + reach,
                    "{text:?} at row {y}, its box's top at {top}: more than {MAX_TEXT_SHIFT} rows away"
                );
                drawn += 1;
            }
        }
    }
    assert!(drawn >= 3, "{drawn} texts drawn");
    assert!(
        drawn < objects,
        "the crowd is thinned out: {drawn} of {objects}"
    );
}
