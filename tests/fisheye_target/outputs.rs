//! Crops, resizes, augmentation, pixel objects, depth, verify and determinism on a fisheye
//! output.

use super::boxes::check_boxes;
use super::*;
use nalgebra::Point2;
use panoconv::kitti::Cam;
use panoconv::tools::synth::{frames, SynthCalib};

#[test]
fn crop_and_resize_move_the_intrinsics_by_the_half_pixel_rule() {
    let dir = tempfile::tempdir().unwrap();
    let cam = kb_camera(dir.path());
    let out = dir.path().join("out");
    // A 600×240 window, enlarged 1.5 times.
    convert(
        &cam,
        synth_source(),
        &out,
        &[
            "--frames",
            "000000",
            "--mask",
            "--crop",
            "380,120,600,240",
            "--resize",
            "900x360",
        ],
    );
    let s = 1.5;
    let (cu, cv) = (679.5 - 380.0, 379.5 - 120.0);
    let want = [
        CENTRE_SCALE * s,
        CENTRE_SCALE * s,
        s * (cu + 0.5) - 0.5,
        s * (cv + 0.5) - 0.5,
    ];
    assert_k_close(
        "crop + resize",
        k2_of(&read_text(&out.join("training/calib/000000.txt"))),
        want,
    );
    // The image agrees with the scene rendered in that camera (blurred like the source,
    // whose blur the enlargement scales).
    let lens = fisheye_camera(&cam);
    let camera = FisheyeCamera {
        lens: lens
            .lens
            .with_intrinsics(
                panoconv::camera::Intrinsics::new(want[0], want[1], want[2], want[3]),
                panoconv::camera::ImageSize::new(900, 360),
            )
            .unwrap(),
        rect_from_camera: lens.rect_from_camera,
    };
    let warped = read_image(&out.join("training/image_2/000000.png"));
    let (mw, _, mask) = read_mask(&out.join("training/mask_2/000000.png"));
    let covered = |u: u32, v: u32| mask[(v * mw + u) as usize];
    let (scene, centre) = (&frames()[0].scene, SynthCalib::standard().centre());
    let exact = render_where(scene, &camera, &centre, 0.55 * s, 8, covered);
    let (db, n) = psnr(&warped, &exact, covered);
    eprintln!("crop + resize: {db:.2} dB over {n} px");
    assert!(n > 100_000, "only {n} covered pixels");
    assert!(db >= MIN_PSNR_DB, "crop + resize: {db:.2} dB");
    assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
}

#[test]
fn augmented_fisheye_views_keep_exact_intrinsics_and_boxes() {
    let dir = tempfile::tempdir().unwrap();
    let cam = kb_camera(dir.path());
    let out = dir.path().join("out");
    convert(
        &cam,
        synth_source(),
        &out,
        &[
            "--split",
            "training",
            "--augment",
            "2",
            "--seed",
            "7",
            "--scale-range",
            "0.6,0.9",
            "--crop-size",
            "640x320",
        ],
    );
    let manifest = read_manifest(&out);
    let mut views = 0;
    for frame in manifest["frames"].as_array().unwrap() {
        for view in frame["views"].as_array().expect("views in the manifest") {
            let id = view["id"].as_str().unwrap();
            let v = view;
            let (scale_w, scale_h) = (
                v["scaled"]["width"].as_f64().unwrap() / 1360.0,
                v["scaled"]["height"].as_f64().unwrap() / 560.0,
            );
            let (x, y) = (
                v["crop"]["x"].as_f64().unwrap(),
                v["crop"]["y"].as_f64().unwrap(),
            );
            let want = [
                CENTRE_SCALE * scale_w,
                CENTRE_SCALE * scale_h,
                scale_w * (679.5 + 0.5) - 0.5 - x,
                scale_h * (379.5 + 0.5) - 0.5 - y,
            ];
            let calib_path = out.join(format!("training/calib/{id}.txt"));
            assert_k_close(id, k2_of(&read_text(&calib_path)), want);
            let image = read_rgb8(&out.join(format!("training/image_2/{id}.png")));
            assert_eq!((image.width, image.height), (640, 320));
            let calib = panoconv::kitti::Calib::read(&calib_path).unwrap();
            let (camera, centre) = calib
                .output_camera(Cam::C2, panoconv::camera::ImageSize::new(640, 320))
                .unwrap();
            let written: Vec<String> =
                label_lines(&read_text(&out.join(format!("training/label_2/{id}.txt"))))
                    .into_iter()
                    .map(str::to_owned)
                    .collect();
            check_boxes(id, &written, camera.as_ref(), &centre);
            views += 1;
        }
    }
    assert_eq!(views, 6, "2 views of 3 frames");
    assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
}

#[test]
fn depth_pixel_objects_verify_and_jobs_on_a_fisheye_output() {
    let dir = tempfile::tempdir().unwrap();
    let cam = kb_camera(dir.path());
    let run = |jobs: &str| {
        let out = dir.path().join(format!("jobs{jobs}"));
        convert(
            &cam,
            synth_source(),
            &out,
            &["--split", "training", "--depth", "--mask", "--jobs", jobs],
        );
        out
    };
    let out = run("1");
    let out2 = run("2");
    assert_eq!(
        tree_hashes(&out),
        tree_hashes(&out2),
        "--jobs 1 and --jobs 2 differ"
    );

    // Depth: the range along the pixel's ray to the surface the scene shows there.
    let (mut pixels, mut correct) = (0usize, 0usize);
    for f in frames().iter().filter(|f| f.split == "training") {
        let id = f.id;
        let calib =
            panoconv::kitti::Calib::read(&out.join(format!("training/calib/{id}.txt"))).unwrap();
        let (camera, centre) = calib
            .output_camera(Cam::C2, panoconv::camera::ImageSize::new(1360, 560))
            .unwrap();
        let png = read_png(&out.join(format!("training/depth_2/{id}.png")));
        assert_eq!(png.depth, png::BitDepth::Sixteen);
        for v in 0..png.height {
            for u in 0..png.width {
                let i = 2 * (v * png.width + u) as usize;
                let raw = u16::from_be_bytes([png.data[i], png.data[i + 1]]);
                if raw == 0 {
                    continue;
                }
                pixels += 1;
                let d = raw as f64 / 256.0;
                let ray = camera.unproject(&Point2::new(u as f64, v as f64)).unwrap();
                if let Some((t, _)) = f.scene.first_hit(&centre, &ray) {
                    if (d - t).abs() <= 0.05 * t {
                        correct += 1;
                    }
                }
            }
        }
    }
    let share = correct as f64 / pixels as f64;
    eprintln!(
        "depth: {pixels} px, {:.2} % within 5 % of the range along the ray",
        100.0 * share
    );
    assert!(pixels > 5000, "only {pixels} depth pixels");
    assert!(share >= 0.995, "{:.3} % correct", 100.0 * share);

    // labels → pixel objects → unproject returns the locations.
    let pixels_dir = out.join("training/pixels");
    assert_success(&panoconv([
        "labels-to-pixels".as_ref(),
        "--input".as_ref(),
        out.as_os_str(),
        "--output".as_ref(),
        pixels_dir.as_os_str(),
    ]));
    let results = out.join("training/results");
    assert_success(&panoconv([
        "unproject".as_ref(),
        "--calib".as_ref(),
        out.join("training/calib").as_os_str(),
        "--input".as_ref(),
        pixels_dir.as_os_str(),
        "--output".as_ref(),
        results.as_os_str(),
    ]));
    let (mut worst, mut n) = (0.0f64, 0);
    for (_, id) in SYNTH_FRAMES.iter().filter(|(s, _)| *s == "training") {
        let labels = read_text(&out.join(format!("training/label_2/{id}.txt")));
        let back = read_text(&results.join(format!("{id}.txt")));
        let want: Vec<Vec<f64>> = label_lines(&labels)
            .iter()
            .filter(|l| !l.starts_with("DontCare"))
            .map(|l| {
                tokens(l)[11..14]
                    .iter()
                    .map(|v| v.parse().unwrap())
                    .collect()
            })
            .collect();
        let got: Vec<Vec<f64>> = label_lines(&back)
            .iter()
            .map(|l| {
                tokens(l)[11..14]
                    .iter()
                    .map(|v| v.parse().unwrap())
                    .collect()
            })
            .collect();
        assert_eq!(want.len(), got.len(), "{id}: objects");
        for (a, b) in want.iter().zip(&got) {
            let e = (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt();
            worst = worst.max(e);
            n += 1;
        }
    }
    eprintln!("unproject: {n} objects, worst location error {worst:.2e} m");
    assert!(n >= 8 && worst <= 1e-3, "{n} objects, worst {worst} m");
    assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
}
