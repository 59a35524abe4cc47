//! The conversion against the scene rendered directly in the fisheye camera, over the covered
//! area: every model, and camera 3 from its own centre.

use super::*;
use panoconv::kitti::Cam;
use panoconv::tools::synth::{frames, SynthCalib};

#[test]
fn every_model_matches_the_exact_render_over_the_covered_area() {
    let dir = tempfile::tempdir().unwrap();
    let frame = &frames()[0];
    let centre = SynthCalib::standard().centre();
    let mut report = Vec::new();
    for model in MODELS {
        // 10° nose down: the source's field of view lies above the fisheye's centre.
        let size = (1360, 560);
        let json = camera_json(model, fov_of(model), -10.0, size, (679.5, 379.5));
        let cam_path = write_camera(dir.path(), &format!("{model}.json"), &json);
        let out = dir.path().join(model);
        convert(
            &cam_path,
            synth_source(),
            &out,
            &["--frames", "000000", "--mask"],
        );
        let warped = read_image(&out.join("training/image_2/000000.png"));
        let (mw, mh, mask) = read_mask(&out.join("training/mask_2/000000.png"));
        assert_eq!((mw, mh), (size.0, size.1), "{model}: mask size");
        assert_eq!((warped.width(), warped.height()), (size.0, size.1));
        let camera = fisheye_camera(&cam_path);
        let covered = |u: u32, v: u32| mask[(v * mw + u) as usize];
        // `Scene::render` over the covered pixels only
        let exact = render_where(&frame.scene, &camera, &centre, 0.55, 6, covered);
        let (db, n) = psnr(&warped, &exact, covered);
        report.push(format!("{model}: {db:.2} dB over {n} px"));
        assert!(n > 200_000, "{model}: only {n} covered pixels");
        assert!(db >= MIN_PSNR_DB, "{model}: {db:.2} dB < {MIN_PSNR_DB} dB");
        assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
    }
    eprintln!("{}", report.join("\n"));
}

#[test]
fn camera_3_sits_at_its_own_centre() {
    let dir = tempfile::tempdir().unwrap();
    let cam = kb_camera(dir.path());
    let out = dir.path().join("out");
    convert(
        &cam,
        synth_source(),
        &out,
        &["--frames", "000000", "--cameras", "2,3", "--mask"],
    );
    let calib_path = out.join("training/calib/000000.txt");
    let text = read_text(&calib_path);
    for key in ["model3", "D3", "fov3", "R3", "C3", "K3"] {
        assert!(
            text.contains(&format!("\n{key}: ")),
            "no {key} line:\n{text}"
        );
    }
    let calib = panoconv::kitti::Calib::read(&calib_path).unwrap();
    let (camera, centre) = calib
        .output_camera(Cam::C3, panoconv::camera::ImageSize::new(1360, 560))
        .unwrap();
    let truth = SynthCalib::standard().centre3();
    assert!(
        (centre - truth).norm() < 1e-9,
        "C3 {centre:?}, truth {truth:?}"
    );
    // The right image against the scene rendered from camera 3's centre.
    let warped = read_image(&out.join("training/image_3/000000.png"));
    let (mw, _, mask) = read_mask(&out.join("training/mask_3/000000.png"));
    let covered = |u: u32, v: u32| mask[(v * mw + u) as usize];
    let scene = &frames()[0].scene;
    let exact = render_where(scene, camera.as_ref(), &truth, 0.55, 6, covered);
    let (db, n) = psnr(&warped, &exact, covered);
    eprintln!("camera 3: {db:.2} dB over {n} px");
    assert!(
        n > 200_000 && db >= MIN_PSNR_DB,
        "camera 3: {db:.2} dB over {n} px"
    );
    assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
}

/// Lenses 2.5 and 3.5 times coarser than the source at their centre (288.6 and 206.2 px/rad
/// against 721.5), 190°, 10° nose down: their pixels span 2 source pixels or more. Against the
/// exact render over the covered area the conversion's PSNR is the per-tap table's (built here
/// from the same source PNG) within 0.2 dB or better, and its `--mask` is that table's; the
/// coarser lens samples the source's pyramid (its image is not the taps').
#[test]
fn coarse_lenses_through_the_pyramid_match_the_exact_render_as_the_taps_do() {
    use nalgebra::{Matrix3, Vector3};
    use panoconv::camera::Perspective;
    use panoconv::warp::{Footprint, RemapTable, Wrap};
    let dir = tempfile::tempdir().unwrap();
    let frame = &frames()[0];
    let calib = SynthCalib::standard();
    let centre = calib.centre();
    let source = read_image(&synth_source().join("training/image_2/000000.png"));
    let src = Perspective::new(calib.intrinsics(), calib.size);
    let full = format!("{CENTRE_SCALE}");
    for (model, div) in [
        ("equidistant", 2.5),
        ("kannala_brandt", 2.5),
        ("equidistant", 3.5),
    ] {
        let coarse = format!("{}", CENTRE_SCALE / div);
        let size = ((1360.0 / div) as u32, (560.0 / div) as u32);
        let c = (size.0 as f64 / 2.0 - 0.5, 379.5 / div);
        let json = camera_json(model, 190.0, -10.0, size, c).replace(&full, &coarse);
        let cam_path = write_camera(dir.path(), &format!("{model}_{div}.json"), &json);
        let out = dir.path().join(format!("{model}_{div}"));
        convert(
            &cam_path,
            synth_source(),
            &out,
            &["--frames", "000000", "--mask"],
        );
        let warped = read_image(&out.join("training/image_2/000000.png"));
        let (mw, mh, mask) = read_mask(&out.join("training/mask_2/000000.png"));
        assert_eq!((mw, mh), size, "{model}: mask size");
        let camera = fisheye_camera(&cam_path);
        let id = Matrix3::identity();
        let blind = camera.rect_from_camera * -Vector3::z();
        let seen = Footprint::new(&camera, &src, &id, &blind);
        let taps =
            RemapTable::build_within(&camera, &src, &id, Wrap::None, 8, seen.as_ref(), false);
        for v in 0..mh {
            for u in 0..mw {
                let m = mask[(v * mw + u) as usize];
                assert_eq!(
                    m,
                    taps.is_inside(u, v),
                    "{model} x{div}: mask at ({u}, {v})"
                );
            }
        }
        let covered = |u: u32, v: u32| mask[(v * mw + u) as usize];
        let exact = render_where(&frame.scene, &camera, &centre, 0.55, 6, covered);
        let by_taps = taps.apply(&source);
        let (db, n) = psnr(&warped, &exact, covered);
        let (db_taps, _) = psnr(&by_taps, &exact, covered);
        eprintln!(
            "{model} at {div} source px: {db:.2} dB, per-tap table {db_taps:.2} dB over {n} px"
        );
        assert!(n > 10_000, "{model} x{div}: only {n} covered pixels");
        assert!(
            db >= db_taps - 0.2,
            "{model} x{div}: {db:.2} < {db_taps:.2} - 0.2 dB"
        );
        if div > 3.0 {
            assert!(
                warped != by_taps,
                "{model} x{div}: the lens takes taps alone"
            );
        }
    }
}
