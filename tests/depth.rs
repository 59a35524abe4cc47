//! LiDAR depth in the output projection against the exact scene: a synthetic LiDAR mounted
//! like KITTI's (8 cm above, 27 cm behind the camera) scans the synthetic scene; every written
//! depth pixel is compared with the true visible surface seen from the camera centre through
//! that pixel's centre.

use nalgebra::{Point2, Vector3};
use panoconv::camera::{CameraModel, LinearCamera, Perspective, Projection};
use panoconv::geometry::{output_camera, OutputSpec};
use panoconv::kitti::velodyne::rect_from_velo;
use panoconv::kitti::Cam;
use panoconv::reproject::depth::{depth_map, DepthMap, OcclusionFilter};
use panoconv::tools::synth::{frames, SynthCalib};

/// The bars.
const MIN_CORRECT: f64 = 0.995;
const MAX_SEE_THROUGH: f64 = 0.002;
const TOLERANCE: f64 = 0.05;

struct Score {
    pixels: usize,
    correct: usize,
    see_through: usize,
}

fn score(
    map: &DepthMap,
    cam: &dyn CameraModel,
    centre: &Vector3<f64>,
    scene: &panoconv::tools::synth::Scene,
) -> Score {
    let mut s = Score {
        pixels: 0,
        correct: 0,
        see_through: 0,
    };
    for v in 0..map.height {
        for u in 0..map.width {
            let d = map.values[(v * map.width + u) as usize];
            if d <= 0.0 {
                continue;
            }
            s.pixels += 1;
            let ray = cam.unproject(&Point2::new(u as f64, v as f64)).unwrap();
            let Some((t, _)) = scene.first_hit(centre, &ray) else {
                continue;
            };
            let truth = cam.distance(&(ray * t));
            if (d - truth).abs() <= TOLERANCE * truth {
                s.correct += 1;
            } else if d > truth {
                s.see_through += 1;
            }
        }
    }
    s
}

fn run(projection: Projection, frame: usize, filter: Option<&OcclusionFilter>) -> Score {
    let f = &frames()[frame];
    let calib: &SynthCalib = &f.calib;
    let (r, t) = SynthCalib::rect_from_velo();
    let scan = f.scene.lidar_scan(&(r, t));
    let velo: Vec<Vector3<f64>> = scan.iter().map(|(p, _)| *p).collect();
    let mut tr = nalgebra::Matrix3x4::zeros();
    tr.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    tr.set_column(3, &t);
    let rect = rect_from_velo(&velo, &nalgebra::Matrix3::identity(), &tr);
    let src = Perspective::new(calib.intrinsics(), calib.size);
    let out: Box<dyn LinearCamera> =
        output_camera(&OutputSpec::new(projection), calib.intrinsics(), &src).unwrap();
    let (map, _) = depth_map(
        rect.iter().copied(),
        &calib.centre(),
        out.as_ref(),
        &src,
        filter,
    );
    score(&map, out.as_ref(), &calib.centre(), &f.scene)
}

#[test]
fn occlusion_filter_removes_see_through_points() {
    let filter = OcclusionFilter::default();
    for projection in [
        Projection::Equirect,
        Projection::Cylindrical,
        Projection::Perspective,
    ] {
        let (mut raw, mut filt) = ((0, 0, 0), (0, 0, 0));
        for frame in 0..3 {
            let a = run(projection, frame, None);
            let b = run(projection, frame, Some(&filter));
            raw = (raw.0 + a.pixels, raw.1 + a.correct, raw.2 + a.see_through);
            filt = (
                filt.0 + b.pixels,
                filt.1 + b.correct,
                filt.2 + b.see_through,
            );
        }
        let pct = |n: usize, d: usize| 100.0 * n as f64 / d as f64;
        eprintln!(
            "{projection:?}: z-buffer {} px, {:.2} % correct, {:.2} % see-through | filtered {} px, {:.2} % correct, {:.3} % see-through",
            raw.0,
            pct(raw.1, raw.0),
            pct(raw.2, raw.0),
            filt.0,
            pct(filt.1, filt.0),
            pct(filt.2, filt.0)
        );
        assert!(
            filt.1 as f64 >= MIN_CORRECT * filt.0 as f64,
            "{projection:?}: correct {:.3} %",
            pct(filt.1, filt.0)
        );
        assert!(
            filt.2 as f64 <= MAX_SEE_THROUGH * filt.0 as f64,
            "{projection:?}: see-through {:.3} %",
            pct(filt.2, filt.0)
        );
        assert!(
            raw.2 > 3 * filt.2.max(1),
            "the plain z-buffer must be measurably worse"
        );
        assert!(
            filt.0 * 2 > raw.0,
            "the filter keeps most points: {} of {}",
            filt.0,
            raw.0
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Through the binary.

use panoconv::codec::png::{decode_gray16, decode_rgb8};
use panoconv::kitti::{Calib, LabelFile};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_panoconv"))
        .args(args)
        .output()
        .unwrap()
}

/// A fresh copy of the synthetic dataset (the cache the other tests share, then copied).
fn synth_dataset(root: &Path) -> PathBuf {
    let d = root.join("synth");
    copy_tree(crate::common::synth_source(), &d);
    d
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        let target = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy_tree(&p, &target);
        } else {
            std::fs::copy(&p, &target).unwrap();
        }
    }
}

fn convert(input: &Path, output: &Path, extra: &[&str]) -> Output {
    let mut args: Vec<&std::ffi::OsStr> = vec![
        "kitti".as_ref(),
        "-q".as_ref(),
        "-i".as_ref(),
        input.as_os_str(),
        "-o".as_ref(),
        output.as_os_str(),
    ];
    args.extend(extra.iter().map(std::ffi::OsStr::new));
    bin(&args)
}

/// Real KITTI: depth inside each clearly visible car's box is the car's distance, and depth on
/// the road in front of the car follows the ground plane.
#[test]
fn real_kitti_depth_lies_on_cars_and_road() {
    let kitti = crate::common::real_kitti();
    let tmp = tempfile::tempdir().unwrap();
    for to in ["equirect", "cylindrical"] {
        let out = tmp.path().join(to);
        let o = convert(
            &kitti,
            &out,
            &["--to", to, "--depth", "--split", "training"],
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (mut cars, mut road_ok, mut road_n) = (0, 0, 0);
        for id in ["000000", "000001", "000002", "000003", "000004", "000005"] {
            let png = std::fs::read(out.join(format!("training/depth_2/{id}.png"))).unwrap();
            let (w, h, depth) = decode_gray16(&png, Path::new(id)).unwrap();
            let calib = Calib::read(&out.join(format!("training/calib/{id}.txt"))).unwrap();
            let (cam, centre) = calib
                .output_camera(Cam::C2, panoconv::camera::ImageSize::new(w, h))
                .unwrap();
            for l in LabelFile::read(&out.join(format!("training/label_2/{id}.txt")))
                .unwrap()
                .labels
            {
                if l.kind != "Car" || l.occluded != 0 || l.truncated > 0.05 {
                    continue;
                }
                let [x0, y0, x1, y1] = l.bbox;
                let (cx, cy, hw, hh) = (
                    (x0 + x1) / 2.0,
                    (y0 + y1) / 2.0,
                    (x1 - x0) / 4.0,
                    (y1 - y0) / 4.0,
                );
                let mut ds: Vec<f64> = Vec::new();
                for v in (cy - hh) as u32..=(cy + hh) as u32 {
                    for u in (cx - hw) as u32..=(cx + hw) as u32 {
                        let d = depth[(v * w + u) as usize];
                        if d > 0 {
                            ds.push(d as f64 / 256.0);
                        }
                    }
                }
                if ds.len() < 5 {
                    continue;
                }
                ds.sort_by(f64::total_cmp);
                let median = ds[ds.len() / 2];
                let centre_box =
                    l.location - nalgebra::Vector3::new(0.0, l.dimensions[0] / 2.0, 0.0) - centre;
                let expect = cam.distance(&centre_box);
                let reach = l.dimensions[2].max(l.dimensions[1]) / 2.0 + 0.5;
                assert!(
                    (median - expect).abs() <= reach,
                    "{to} {id}: car at {expect:.1} m, depth {median:.1} m"
                );
                cars += 1;
            }
            // the bottom rows at the image centre look at the road just ahead: flat ground at
            // y ≈ 1.65 m below the camera
            for v in h - 12..h - 2 {
                for u in w / 2 - 40..w / 2 + 40 {
                    let d = depth[(v * w + u) as usize];
                    if d == 0 {
                        continue;
                    }
                    let ray = cam.unproject(&Point2::new(u as f64, v as f64)).unwrap();
                    let ground = cam.distance(&(ray * (1.65 / ray.y)));
                    road_n += 1;
                    if ((d as f64 / 256.0) - ground).abs() < 0.1 * ground {
                        road_ok += 1;
                    }
                }
            }
        }
        eprintln!("{to}: {cars} cars matched their depth; road {road_ok}/{road_n} within 10 % of the ground plane");
        assert!(cars >= 4);
        assert!(road_n > 50 && road_ok as f64 >= 0.9 * road_n as f64);
    }
}

#[test]
fn depth_png_contract_and_filter_switch() {
    let tmp = tempfile::tempdir().unwrap();
    let input = synth_dataset(tmp.path());
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    assert!(convert(&input, &a, &["--to", "equirect", "--depth"])
        .status
        .success());
    assert!(convert(
        &input,
        &b,
        &["--to", "equirect", "--depth", "--no-occlusion-filter"]
    )
    .status
    .success());
    let read = |root: &Path| {
        let png = std::fs::read(root.join("training/depth_2/000000.png")).unwrap();
        decode_gray16(&png, Path::new("d")).unwrap()
    };
    let ((w, h, filtered), (_, _, raw)) = (read(&a), read(&b));
    let img = decode_rgb8(
        &std::fs::read(a.join("training/image_2/000000.png")).unwrap(),
        Path::new("i"),
    )
    .unwrap();
    assert_eq!(
        (w, h),
        (img.width(), img.height()),
        "depth map has the image's size"
    );
    let n = |v: &[u16]| v.iter().filter(|&&d| d > 0).count();
    assert!(n(&filtered) < n(&raw), "the filter drops points");
    assert!(
        filtered.iter().zip(&raw).all(|(f, r)| *f == 0 || f == r),
        "kept pixels keep their value"
    );
    // values are round(d * 256) of the projection's distance: the nearest ground pixel at the
    // bottom centre is ~1.65 m / sin(latitude) away
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.join("panoconv.json")).unwrap()).unwrap();
    let record = m["frames"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["split"] == "training" && f["id"] == "000000")
        .unwrap();
    let lidar = &record["lidar"];
    assert!(lidar["dropped_occluded"].as_u64().unwrap() > 0);
    assert_eq!(
        lidar["depth_pixels"].as_u64().unwrap() as usize,
        n(&filtered)
    );
}

#[test]
fn broken_velodyne_fails_its_frame_and_nan_points_are_counted() {
    let tmp = tempfile::tempdir().unwrap();
    let input = synth_dataset(tmp.path());
    let velo = input.join("training/velodyne/000001.bin");
    let mut bytes = std::fs::read(&velo).unwrap();
    bytes.truncate(bytes.len() - 3);
    std::fs::write(&velo, &bytes).unwrap();
    let nan = input.join("training/velodyne/000002.bin");
    let mut bytes = std::fs::read(&nan).unwrap();
    bytes[0..4].copy_from_slice(&f32::NAN.to_le_bytes());
    bytes[16..20].copy_from_slice(&f32::INFINITY.to_le_bytes());
    std::fs::write(&nan, &bytes).unwrap();
    let out = tmp.path().join("o");
    let o = convert(&input, &out, &["--to", "cylindrical", "--depth"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("frame training/000001 failed")
            && err.contains("000001.bin: ")
            && err.contains("not a whole number of 16-byte points"),
        "{err}"
    );
    assert!(!out.join("training/depth_2/000001.png").exists());
    assert!(out.join("training/depth_2/000002.png").exists());
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("panoconv.json")).unwrap()).unwrap();
    let f2 = m["frames"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["id"] == "000002")
        .unwrap();
    assert_eq!(f2["lidar"]["dropped_non_finite"], 2);
}

/// image_3 is converted about its own centre C3 and matches the exact render from there.
#[test]
fn right_camera_matches_the_exact_render_from_c3() {
    let tmp = tempfile::tempdir().unwrap();
    let input = synth_dataset(tmp.path());
    let out = tmp.path().join("o");
    let o = convert(
        &input,
        &out,
        &["--to", "equirect", "--cameras", "2,3", "--frames", "000000"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let calib = Calib::read(&out.join("training/calib/000000.txt")).unwrap();
    let truth = &frames()[0];
    let c3 = calib.c_out[3].expect("C3 line");
    assert!((c3 - truth.calib.centre3()).norm() < 1e-3, "C3 {c3:?}");
    let img = decode_rgb8(
        &std::fs::read(out.join("training/image_3/000000.png")).unwrap(),
        Path::new("i"),
    )
    .unwrap();
    let (cam, centre) = calib
        .output_camera(
            Cam::C3,
            panoconv::camera::ImageSize::new(img.width(), img.height()),
        )
        .unwrap();
    let src = Perspective::new(truth.calib.intrinsics(), truth.calib.size);
    let (w, h) = (img.width(), img.height());
    // inside the source view, a pixel away from its border
    let inside = |u: u32, v: u32| {
        (1..w - 1).contains(&u)
            && (1..h - 1).contains(&v)
            && [(-1.0, 0.0), (1.0, 0.0), (0.0, -1.0), (0.0, 1.0)]
                .iter()
                .all(|(du, dv)| {
                    cam.unproject(&Point2::new(u as f64 + du, v as f64 + dv))
                        .ok()
                        .and_then(|d| src.project(&d).ok())
                        .is_some_and(|p| src.contains(&p))
                })
    };
    // `Scene::render` where compared
    let exact = crate::common::render_where(&truth.scene, cam.as_ref(), &centre, 0.55, 6, inside);
    let (mut se, mut n) = (0.0, 0usize);
    for v in 0..h {
        for u in 0..w {
            if inside(u, v) {
                let (p, q) = (img.pixel(u, v), exact.pixel(u, v));
                se += (0..3)
                    .map(|c| (p[c] as f64 - q[c] as f64).powi(2))
                    .sum::<f64>();
                n += 3;
            }
        }
    }
    let psnr = 10.0 * (255.0f64.powi(2) / (se / n as f64)).log10();
    eprintln!("image_3 vs exact render from C3: PSNR {psnr:.2} dB");
    assert!(psnr >= 50.0, "{psnr}");
}
