//! Labels that training and checking tools read as meant: Omni3D's `behind_camera` in a
//! panorama (Cube R-CNN drops flagged objects, so there it means "not visible in this image"),
//! and preview texts that never hide one another. Each through the real binary.

use crate::common::*;
use panoconv::camera::ImageSize;
use panoconv::image::RgbImage;
use panoconv::kitti::{Calib, Cam, LabelFile};
use panoconv::tools::preview::{class_colour, draw_text, label_text, text_size};
use std::ffi::OsStr;
use std::path::Path;

fn omni3d_annotations(dataset: &Path, work: &Path) -> Vec<serde_json::Value> {
    let ann = work.join("ann");
    assert_success(&panoconv([
        OsStr::new("export"),
        dataset.as_os_str(),
        OsStr::new("--format"),
        OsStr::new("omni3d"),
        OsStr::new("--output"),
        ann.as_os_str(),
    ]));
    let doc: serde_json::Value =
        serde_json::from_str(&read_text(&ann.join("Omni3D_train.json"))).unwrap();
    doc["annotations"].as_array().unwrap().clone()
}

#[test]
fn omni3d_behind_camera_means_not_visible_in_a_panorama() {
    let s = Scratch::synth();
    // a car beside the camera, its rear half behind the optical axis: outside the source
    // image, but in a 360° panorama
    let label = s.input_file("training/label_2/000001.txt");
    let mut text = read_text(&label);
    text.push_str("Car 0.00 0 1.57 0.00 0.00 10.00 10.00 1.52 1.65 3.90 6.00 1.65 0.20 0.00\n");
    write_text(&label, &text);
    for to in ["equirect", "cylindrical"] {
        let out = s.path(to);
        assert_success(&kitti(
            to,
            &s.input,
            &out,
            &["--full-360", "--split", "training"],
        ));
        let labels = read_text(&out.join("training/label_2/000001.txt"));
        assert!(
            labels.contains("6.00 1.65 0.20"),
            "{to}: the car beside the camera is in the panorama"
        );
        let anns = omni3d_annotations(&out, &s.path(&format!("{to}_work")));
        let beside: Vec<&serde_json::Value> = anns
            .iter()
            .filter(|a| {
                let c = &a["center_cam"];
                (c[2].as_f64().unwrap() - 0.2).abs() < 0.05 && c[0].as_f64().unwrap() > 5.0
            })
            .collect();
        assert_eq!(beside.len(), 1, "{to}");
        let a = beside[0];
        let corners = a["bbox3D_cam"].as_array().unwrap();
        assert!(
            corners.iter().any(|c| c[2].as_f64().unwrap() <= 0.0),
            "{to}: a corner is behind the optical axis"
        );
        assert_eq!(
            a["behind_camera"], false,
            "{to}: visible in the panorama, so not 'behind the camera' for Cube R-CNN"
        );
        for a in &anns {
            assert_eq!(
                a["behind_camera"], false,
                "{to}: every object here is visible"
            );
        }
    }
}

/// Where `block` (w×h pixels, row-major) occurs exactly in `img`.
fn find_block(img: &RgbImage, block: &RgbImage) -> bool {
    let (w, h) = (block.width(), block.height());
    if w > img.width() || h > img.height() {
        return false;
    }
    (0..=img.height() - h).any(|y| {
        (0..=img.width() - w).any(|x| {
            (0..h).all(|dy| (0..w).all(|dx| img.pixel(x + dx, y + dy) == block.pixel(dx, dy)))
        })
    })
}

#[test]
fn preview_texts_never_hide_one_another() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("equi");
    assert_success(&kitti(
        "equirect",
        &real_kitti(),
        &out,
        // the paper's scale: the objects are small and their texts crowd
        &[
            "--frames",
            "000001",
            "--split",
            "training",
            "--pano-width",
            "2048",
        ],
    ));
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
    let labels = LabelFile::read(&out.join("training/label_2/000001.txt"))
        .unwrap()
        .labels;
    let scale = 1 + img.height / 600;
    let mut found = 0;
    for label in labels.iter().filter(|l| l.kind != "DontCare") {
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
            Some([0, 0, 0]),
        );
        assert!(
            find_block(&image, &block),
            "the text {text:?} is not whole anywhere in the preview: another label hides it"
        );
        found += 1;
    }
    assert_eq!(found, 3, "Truck, Car and Cyclist");
}

/// Each Omni3D annotation names the label_2 line it comes from (`label_line`, from 1): that
/// line's class and 2D box are the annotation's, DontCare lines are never named, and every
/// other line is named once (Omni3D keeps one annotation per object).
#[test]
fn omni3d_annotations_name_their_label_line() {
    let s = Scratch::synth();
    // a DontCare line first, so object lines do not start at line 1
    let label = s.input_file("training/label_2/000001.txt");
    let text = read_text(&label);
    write_text(
        &label,
        &format!(
            "DontCare -1 -1 -10 10.00 10.00 40.00 40.00 -1 -1 -1 -1000 -1000 -1000 -10\n{text}"
        ),
    );
    let out = s.path("equirect");
    assert_success(&kitti("equirect", &s.input, &out, &["--split", "training"]));
    let anns = omni3d_annotations(&out, &s.path("work"));
    let doc: serde_json::Value =
        serde_json::from_str(&read_text(&s.path("work/ann/Omni3D_train.json"))).unwrap();
    let image = doc["images"]
        .as_array()
        .unwrap()
        .iter()
        .find(|i| i["file_path"].as_str().unwrap().ends_with("000001.png"))
        .expect("frame 000001's image")["id"]
        .clone();
    let written = read_text(&out.join("training/label_2/000001.txt"));
    let lines: Vec<&str> = written.lines().collect();
    let mut named = vec![0usize; lines.len()];
    let mut checked = 0;
    for a in anns.iter().filter(|a| a["image_id"] == image) {
        let n = a["label_line"].as_u64().expect("label_line") as usize;
        assert!(
            (1..=lines.len()).contains(&n),
            "label_line {n} of {}",
            lines.len()
        );
        let fields: Vec<&str> = lines[n - 1].split_whitespace().collect();
        assert_ne!(fields[0], "DontCare", "line {n}");
        assert_eq!(
            a["category_name"].as_str().unwrap().to_lowercase(),
            fields[0].to_lowercase(),
            "line {n}"
        );
        for (k, v) in a["bbox2D_tight"].as_array().unwrap().iter().enumerate() {
            let f: f64 = fields[4 + k].parse().unwrap();
            assert!((v.as_f64().unwrap() - f).abs() < 1e-9, "line {n} bbox[{k}]");
        }
        named[n - 1] += 1;
        checked += 1;
    }
    assert!(checked >= 2, "the frame has objects: {checked}");
    for (i, line) in lines.iter().enumerate() {
        let want = usize::from(!line.starts_with("DontCare"));
        assert_eq!(named[i], want, "line {}: {line}", i + 1);
    }
}
