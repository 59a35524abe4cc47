//! COCO through pycocotools; YOLO read back against the COCO boxes.

use super::*;
use crate::common::*;
use std::path::Path;

#[test]
fn pycocotools_reads_the_coco_export_and_self_evaluation_gives_ap_1() {
    let (_real_equi_dir, real_equi) = convert(&real_kitti(), "equirect", &["--split", "training"]);
    let (_synth_dir, synth_persp) =
        convert(&synthetic_dir(), "perspective", &["--split", "training"]);
    // A plain KITTI root is read as it is: P2 is a perspective camera.
    for (dataset, images) in [(real_kitti(), 6.0), (real_equi, 6.0), (synth_persp, 3.0)] {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("annotations");
        assert_success(&export(&dataset, "coco", &out, &[]));
        let figures = coco_eval(&out.join("instances_train.json"), &dataset);
        assert_eq!(figures["images"], images);
        assert_eq!(
            figures["missing_images"], 0.0,
            "file_name must exist under the root"
        );
        assert!(figures["objects"] >= 3.0);
        assert_eq!(
            figures["ap_self"], 1.0,
            "ground truth as detections: AP 1.000"
        );
        assert_eq!(
            figures["ap_with_ignore_detections"], 1.0,
            "DontCare must be ignored"
        );
        assert!(
            figures["ap_shifted"] < 0.8,
            "a shifted copy must score less"
        );
        assert_eq!(figures["ap50_shifted"], 1.0, "IoU 0.6 still matches at 0.5");
    }
    let tmp = tempfile::tempdir().unwrap();
    assert_success(&export(&real_kitti(), "coco", tmp.path(), &[]));
    let real = read_json(&tmp.path().join("instances_train.json"));
    // The real frames hold DontCare regions: one crowd annotation per category each.
    let crowd = real["annotations"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|a| a["iscrowd"] == 1)
        .count();
    let dont_care: usize = (0..6)
        .map(|i| {
            read_text(&real_kitti().join(format!("training/label_2/00000{i}.txt")))
                .lines()
                .filter(|l| l.starts_with("DontCare"))
                .count()
        })
        .sum();
    assert!(dont_care > 0);
    assert_eq!(crowd, dont_care * 8);
    assert_eq!(real["images"][0]["camera"]["projection"], "perspective");
}

/// An independent reader of the Ultralytics layout: data.yaml, labels/<split>/*.txt and the
/// image links, checked against the COCO export of the same dataset.
#[test]
fn yolo_labels_match_the_coco_boxes() {
    let (_dir, equi) = convert(&real_kitti(), "equirect", &["--split", "training"]);
    let (_dir2, synth) = convert(&synthetic_dir(), "cylindrical", &[]);
    let mut max_diff = 0.0f64;
    let mut boxes = 0;
    for dataset in [equi, synth] {
        let tmp = tempfile::tempdir().unwrap();
        let (coco_dir, yolo) = (tmp.path().join("coco"), tmp.path().join("yolo"));
        assert_success(&export(&dataset, "coco", &coco_dir, &[]));
        assert_success(&export(&dataset, "yolo", &yolo, &[]));
        let coco = read_json(&coco_dir.join("instances_train.json"));

        let yaml = read_text(&yolo.join("data.yaml"));
        let value = |key: &str| {
            yaml.lines()
                .find_map(|l| l.strip_prefix(&format!("{key}: ")))
                .unwrap_or_else(|| panic!("data.yaml has no {key}:\n{yaml}"))
                .trim_matches('"')
                .to_owned()
        };
        assert_eq!(
            Path::new(&value("path")),
            yolo.canonicalize().unwrap(),
            "path must be the export folder, absolute"
        );
        assert_eq!(value("train"), "images/train");
        assert_eq!(
            value("val"),
            "images/train",
            "no val split: train stands in"
        );
        let names: Vec<String> = yaml
            .lines()
            .skip_while(|l| *l != "names:")
            .skip(1)
            .enumerate()
            .map(|(k, l)| {
                let (i, n) = l.trim().split_once(": ").unwrap();
                assert_eq!(i.parse::<usize>().unwrap(), k, "names are numbered from 0");
                n.trim_matches('"').to_owned()
            })
            .collect();
        let categories: Vec<&str> = coco["categories"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c["name"].as_str().unwrap())
            .collect();
        assert_eq!(names, categories);

        for image in coco["images"].as_array().unwrap() {
            let file_name = image["file_name"].as_str().unwrap();
            let stem = Path::new(file_name).file_stem().unwrap().to_str().unwrap();
            let link = yolo.join(format!("images/train/{stem}.png"));
            assert!(std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink());
            assert_eq!(hash_file(&link), hash_file(&dataset.join(file_name)));
            let (w, h) = (f(&image["width"]), f(&image["height"]));
            let text = read_text(&yolo.join(format!("labels/train/{stem}.txt")));
            let lines: Vec<Vec<f64>> = text
                .lines()
                .map(|l| l.split_whitespace().map(|t| t.parse().unwrap()).collect())
                .collect();
            let anns = objects_of(&coco, image["id"].as_u64().unwrap());
            assert_eq!(lines.len(), anns.len(), "{stem}: one line per COCO object");
            for (line, ann) in lines.iter().zip(anns) {
                assert_eq!(line.len(), 5);
                assert_eq!(
                    line[0],
                    f(&ann["category_id"]) - 1.0,
                    "classes count from 0"
                );
                let b = floats(&ann["bbox"]);
                let expected = [
                    (b[0] + b[2] / 2.0) / w,
                    (b[1] + b[3] / 2.0) / h,
                    b[2] / w,
                    b[3] / h,
                ];
                for (got, want) in line[1..].iter().zip(expected) {
                    max_diff = max_diff.max((got - want).abs());
                }
                boxes += 1;
            }
        }
    }
    eprintln!("yolo vs coco: {boxes} boxes, max |difference| {max_diff:.2e}");
    assert!(boxes >= 10);
    assert!(max_diff <= 1e-6, "YOLO differs from COCO by {max_diff}");
}
