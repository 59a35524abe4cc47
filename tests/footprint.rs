//! [`Footprint`]: a fisheye target's table built only within the source's footprint is the
//! table of the full build, for every lens model, turned every way, serial and parallel; and
//! the footprint does skip most of a wide lens's image.

use crate::common::*;
use nalgebra::{Matrix3, Vector3};
use panoconv::camera::{
    rotation_ypr, CameraModel, DoubleSphere, Eucm, Fisheye, FisheyeCamera, ImageSize, Intrinsics,
    Lens, MeiDistortion, Perspective, RadialModel, Unified,
};
use panoconv::warp::{Footprint, RemapTable, Wrap, MAX_SUPERSAMPLE};

/// KITTI's camera 2 (frame 000000's P2) at a third of its size: the same field of view
/// (pixel edges scaled about the image's corner), so the same footprints, with the lenses'
/// pixels (~120 px/rad) 2 times coarser than the source's instead of 6: tables of up to 2×2
/// taps a pixel instead of 6×6, which still puts supersampled taps on the footprint's border.
fn kitti_source() -> Perspective {
    let s = 1.0 / 3.0;
    Perspective::new(
        Intrinsics::new(
            721.5377 * s,
            721.5377 * s,
            (609.5593 + 0.5) * s - 0.5,
            (172.854 + 0.5) * s - 0.5,
        ),
        ImageSize::new(414, 125),
    )
}

/// One lens of each model, `size` pixels, about 120 px per radian at the centre, seeing
/// `fov_deg` degrees (orthographic: at most 180).
fn lenses(size: ImageSize, fov_deg: f64) -> Vec<Lens> {
    let (cu, cv) = (
        size.width as f64 / 2.0 - 0.3,
        size.height as f64 / 2.0 + 0.2,
    );
    let k = Intrinsics::new(120.0, 121.0, cu, cv);
    let fov = fov_deg.to_radians();
    let t = fov / 2.0;
    let radial = |m: RadialModel, k: Intrinsics, fov: f64| {
        Lens::from(Fisheye::new(m, k, size, fov).unwrap())
    };
    vec![
        radial(RadialModel::Equidistant, k, fov),
        radial(RadialModel::Equisolid, k, fov),
        radial(RadialModel::Stereographic, k, fov),
        radial(RadialModel::Orthographic, k, fov.min(std::f64::consts::PI)),
        radial(
            RadialModel::KannalaBrandt([0.04, -0.012, 0.002, -0.0002]),
            k,
            fov,
        ),
        radial(
            RadialModel::Polynomial([120.0, -11.3, 17.0, -2.5]),
            Intrinsics::new(1.0, 1.01, cu, cv),
            fov,
        ),
        Lens::from(
            Unified::new(
                1.2,
                MeiDistortion {
                    k1: -0.08,
                    k2: 0.015,
                    p1: 4e-4,
                    p2: -3e-4,
                },
                Intrinsics::new(264.0, 266.0, cu, cv),
                0.4,
                size,
                t,
            )
            .unwrap(),
        ),
        Lens::from(Eucm::new(0.6, 1.1, k, size, t).unwrap()),
        Lens::from(DoubleSphere::new(-0.2, 0.59, k.scaled(0.8), size, t).unwrap()),
    ]
}

trait Scaled {
    fn scaled(self, s: f64) -> Self;
}

impl Scaled for Intrinsics {
    fn scaled(self, s: f64) -> Self {
        Intrinsics::new(self.fu * s, self.fv * s, self.cu, self.cv)
    }
}

/// The table built within the footprint (when there is one) and the full one, both ways.
fn check(camera: &FisheyeCamera, src: &Perspective) -> Option<f64> {
    let id = Matrix3::identity();
    let blind = camera.rect_from_camera * -Vector3::z();
    let seen = Footprint::new(camera, src, &id, &blind);
    let full = RemapTable::build_with(camera, src, &id, Wrap::None, MAX_SUPERSAMPLE);
    for parallel in [false, true] {
        let within = RemapTable::build_within(
            camera,
            src,
            &id,
            Wrap::None,
            MAX_SUPERSAMPLE,
            seen.as_ref(),
            parallel,
        );
        assert!(
            within == full,
            "{} turned {:?}: the table within the footprint differs (parallel: {parallel})",
            camera.lens.name(),
            camera.rect_from_camera
        );
    }
    seen.map(|s| s.share(camera.size().width))
}

#[test]
fn tables_within_the_footprint_equal_the_full_tables_for_every_lens_and_turn() {
    let src = kitti_source();
    let size = ImageSize::new(260, 200);
    // (yaw, pitch, roll) in degrees and whether the bound can be shown: ahead; turned; turned
    // so far that part of the source's border is beyond the lens's 95° (no bound); looking
    // back, the lens's blind cap inside the source's view (no bound); tilted and rolled.
    let turns = [
        ((0.0, 0.0, 0.0), true),
        ((35.0, -10.0, 5.0), true),
        ((75.0, 0.0, 0.0), false),
        ((180.0, 0.0, 0.0), false),
        ((-20.0, 30.0, 90.0), true),
    ];
    for lens in lenses(size, 190.0) {
        for &((yaw, pitch, roll), bounded) in &turns {
            let camera = FisheyeCamera {
                lens: lens.clone(),
                rect_from_camera: rotation_ypr(
                    f64::to_radians(yaw),
                    f64::to_radians(pitch),
                    f64::to_radians(roll),
                ),
            };
            let share = check(&camera, &src);
            assert_eq!(
                share.is_some(),
                bounded,
                "{} turned {yaw}, {pitch}, {roll}: footprint {share:?}",
                lens.name()
            );
            if let Some(share) = share {
                assert!(
                    share < 0.45,
                    "{} turned {yaw}, {pitch}, {roll}: the footprint keeps {share:.3} of a \
                     190° lens's image",
                    lens.name()
                );
            }
        }
    }
}

#[test]
fn a_lens_narrower_than_the_source_has_no_footprint_and_the_same_table() {
    // 60°: the source's border (82° across) has no image in it, so every pixel is mapped.
    let src = kitti_source();
    for lens in lenses(ImageSize::new(200, 150), 60.0) {
        let camera = FisheyeCamera {
            lens,
            rect_from_camera: Matrix3::identity(),
        };
        assert_eq!(check(&camera, &src), None, "{}", camera.lens.name());
    }
}

/// A one-frame fisheye run with `PANOCONV_PROGRESS=lines` (stderr is not a terminal here).
fn fisheye_run(dir: &std::path::Path, progress: Option<&str>, quiet: bool) -> Run {
    let camera = dir.join("front.json");
    // docs/fisheye.md's 190° Kannala-Brandt camera, at a third of its size.
    write_text(
        &camera,
        r#"{"version": 1, "model": "kannala_brandt", "width": 427, "height": 322,
            "max_fov_deg": 190, "fx": 110.1, "fy": 110.3, "cx": 213.4, "cy": 160.2,
            "k": [0.04, -0.012, 0.002, -0.0002]}"#,
    );
    let out = dir.join(format!("out-{progress:?}-{quiet}"));
    let mut cmd = std::process::Command::new(BIN);
    cmd.args(["kitti", "--to", "fisheye", "--camera"])
        .arg(&camera)
        .arg("--input")
        .arg(synth_source())
        .arg("--output")
        .arg(&out)
        .args(["--frames", "000000"]);
    if quiet {
        cmd.arg("--quiet");
    }
    cmd.env_remove("PANOCONV_PROGRESS");
    if let Some(p) = progress {
        cmd.env("PANOCONV_PROGRESS", p);
    }
    let o = cmd.output().unwrap();
    Run {
        code: o.status.code().unwrap(),
        stdout: String::from_utf8_lossy(&o.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
    }
}

#[test]
fn a_fisheye_run_says_it_is_building_the_camera_table() {
    let dir = tempfile::tempdir().unwrap();
    let run = fisheye_run(dir.path(), Some("lines"), false);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let notes: Vec<&str> = run.stderr.lines().filter(|l| l.contains("table")).collect();
    assert_eq!(
        notes,
        ["panoconv: building the camera table"],
        "stderr: {}",
        run.stderr
    );
    // Logs stay clean without the variable, and --quiet silences the notes.
    for (progress, quiet) in [(None, false), (Some("lines"), true)] {
        let run = fisheye_run(dir.path(), progress, quiet);
        assert_eq!(run.code, 0, "{}", run.stderr);
        assert!(
            !run.stderr.contains("table"),
            "{progress:?} quiet {quiet}: {}",
            run.stderr
        );
    }
}
