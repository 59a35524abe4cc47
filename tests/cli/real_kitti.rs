//! Real KITTI frames: the tight canvas, the kept fields, and every unoccluded car's box against
//! its warped source box.

use super::check_frame;
use crate::common::*;
use std::collections::BTreeSet;

/// The output pixel of source pixel (u, v) through the source pinhole `k` and output `k2`.
fn warp_pixel(projection: &str, k: [f64; 4], k2: &[f64], u: f64, v: f64) -> (f64, f64) {
    let [fu, fv, cu, cv] = k;
    let (x, y, z) = ((u - cu) / fu, (v - cv) / fv, 1.0f64);
    let lon = x.atan2(z);
    let b = match projection {
        "equirect" => (y / (x * x + y * y + z * z).sqrt()).asin(),
        "cylindrical" => y / x.hypot(z),
        p => panic!("{p}"),
    };
    (k2[0] * lon + k2[2], k2[4] * b + k2[5])
}

/// The source box mapped into the output: bounds of its warped boundary, clipped to the image.
fn warp_box(projection: &str, k: [f64; 4], k2: &[f64], b: [f64; 4], size: (u32, u32)) -> [f64; 4] {
    let mut out = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    let n = 64;
    for i in 0..=n {
        let t = i as f64 / n as f64;
        let (l, tp, r, bt) = (b[0], b[1], b[2], b[3]);
        for (u, v) in [
            (l + (r - l) * t, tp),
            (l + (r - l) * t, bt),
            (l, tp + (bt - tp) * t),
            (r, tp + (bt - tp) * t),
        ] {
            let (x, y) = warp_pixel(projection, k, k2, u, v);
            out = [out[0].min(x), out[1].min(y), out[2].max(x), out[3].max(y)];
        }
    }
    let (w, h) = (size.0 as f64 - 1.0, size.1 as f64 - 1.0);
    [
        out[0].max(0.0),
        out[1].max(0.0),
        out[2].min(w),
        out[3].min(h),
    ]
}

/// Width and height of the tight canvas of a pinhole image (k, w x h) in the projection at the
/// source focal length: azimuth extremes lie on the side columns, latitude extremes (and the
/// cylinder's height extremes) on the centre column.
fn tight_size(projection: &str, k: [f64; 4], w: f64, h: f64) -> (u32, u32) {
    let [fu, fv, cu, cv] = k;
    let ceil = |x: f64| (x - 1e-6).ceil() as u32;
    let width = ceil(fu * (((w - 0.5 - cu) / fu).atan() + ((cu + 0.5) / fu).atan()));
    let height = match projection {
        "equirect" => ceil(fu * (((h - 0.5 - cv) / fv).atan() + ((cv + 0.5) / fv).atan())),
        _ => ceil(fv * ((h - 0.5 - cv) / fv + (cv + 0.5) / fv)),
    };
    (width, height)
}

#[test]
fn real_kitti_converts_and_boxes_match() {
    let kitti_root = real_kitti();
    assert!(
        kitti_root.join("training/image_2/000000.png").is_file(),
        "the real KITTI frames are missing at {}",
        kitti_root.display()
    );
    let before = tree_hashes(&kitti_root);
    let frames: Vec<(&str, String)> = (0..6)
        .map(|i| ("training", format!("{i:06}")))
        .chain([("testing", "000007".to_owned())])
        .collect();
    let frame_refs: Vec<(&str, &str)> = frames.iter().map(|(s, i)| (*s, i.as_str())).collect();
    let tmp = tempfile::tempdir().unwrap();
    let mut min_iou = (f64::INFINITY, String::new());
    let mut cars = 0;
    for projection in ["equirect", "cylindrical"] {
        let out = tmp.path().join(projection);
        let run = kitti(projection, &kitti_root, &out, &[]);
        assert_success(&run);
        assert!(
            run.stderr
                .contains("panoconv: 7 frames converted, 0 failed"),
            "{}",
            run.stderr
        );
        assert_eq!(tree_files(&out), expected_files(&frame_refs));
        check_manifest(&kitti_root, &out, 7, 0);

        let mut sizes = BTreeSet::new();
        for (split, id) in &frame_refs {
            let size = check_frame(&kitti_root, &out, projection, split, id);
            sizes.insert(size);
            let calib_in = read_text(&kitti_root.join(format!("{split}/calib/{id}.txt")));
            let k = k_of_p(&calib_values(&calib_in, "P2").unwrap());
            let src = read_rgb8(&kitti_root.join(format!("{split}/image_2/{id}.png")));
            assert_eq!(
                size,
                tight_size(projection, k, src.width as f64, src.height as f64),
                "{projection} {split}/{id}: canvas of {}x{} source",
                src.width,
                src.height
            );
            if *split != "training" {
                continue;
            }
            let k2 = calib_values(
                &read_text(&out.join(format!("{split}/calib/{id}.txt"))),
                "K2",
            )
            .unwrap();
            let lin = read_text(&kitti_root.join(format!("{split}/label_2/{id}.txt")));
            let lout = read_text(&out.join(format!("{split}/label_2/{id}.txt")));
            for (a, b) in label_lines(&lin).iter().zip(label_lines(&lout)) {
                let (ta, tb) = (tokens(a), tokens(b));
                if ta[0] != "Car" {
                    continue;
                }
                // 3D fields kept (also covered by check_frame for all tokens)
                assert_eq!(ta[8..15], tb[8..15], "{a} -> {b}");
                if ta[1].parse::<f64>().unwrap() != 0.0 || ta[2] != "0" {
                    continue;
                }
                let mapped = warp_box(projection, k, &k2, bbox_of(&ta), size);
                let v = iou(mapped, bbox_of(&tb));
                cars += 1;
                eprintln!("{projection} {split}/{id} Car IoU {v:.3}: {a} -> {b}");
                if v < min_iou.0 {
                    min_iou = (v, format!("{projection} {split}/{id}: {a} -> {b}"));
                }
            }
        }
        // 000000 has its own calibration: two sizes, one for 000000 and one for the rest
        assert_eq!(sizes.len(), 2, "{projection}: output sizes {sizes:?}");
    }
    println!(
        "real KITTI: minimum Car IoU {:.4} ({})",
        min_iou.0, min_iou.1
    );
    eprintln!(
        "real KITTI: minimum Car IoU {:.4} ({})",
        min_iou.0, min_iou.1
    );
    assert!(
        cars >= 4,
        "only {cars} unoccluded, untruncated cars compared"
    );
    assert!(
        min_iou.0 >= 0.7,
        "minimum IoU {:.3} at {}",
        min_iou.0,
        min_iou.1
    );
    assert_eq!(
        before,
        tree_hashes(&kitti_root),
        "the KITTI input was modified"
    );
}
