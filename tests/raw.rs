//! kitti-raw: the synthetic frames laid out as a raw drive convert exactly as the object
//! dataset does (same images, same depth), with one KITTI-object calib per drive.

use panoconv::kitti::calib::format_sci;
use panoconv::tools::synth::SynthCalib;
use std::path::Path;
use std::process::Command;

const DRIVE: &str = "2011_09_26_drive_0001_sync";

fn row(v: &[f64]) -> String {
    v.iter()
        .map(|&x| format_sci(x))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The shipped synthetic training frames 000000 and 000002 (same calibration) as a raw date folder.
pub(crate) fn raw_date_folder(root: &Path) -> std::path::PathBuf {
    let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synthetic_kitti/training");
    let date = root.join("2011_09_26");
    let drive = date.join(DRIVE);
    for d in ["image_02/data", "image_03/data", "velodyne_points/data"] {
        std::fs::create_dir_all(drive.join(d)).unwrap();
    }
    for (i, id) in ["000000", "000002"].iter().enumerate() {
        let raw_id = format!("{i:010}");
        std::fs::copy(
            sample.join(format!("image_2/{id}.png")),
            drive.join(format!("image_02/data/{raw_id}.png")),
        )
        .unwrap();
        std::fs::copy(
            sample.join(format!("image_3/{id}.png")),
            drive.join(format!("image_03/data/{raw_id}.png")),
        )
        .unwrap();
        std::fs::copy(
            sample.join(format!("velodyne/{id}.bin")),
            drive.join(format!("velodyne_points/data/{raw_id}.bin")),
        )
        .unwrap();
    }
    let c = SynthCalib::standard();
    let p = |centre: nalgebra::Vector3<f64>| row(&c.p(&centre));
    std::fs::write(
        date.join("calib_cam_to_cam.txt"),
        format!(
            "calib_time: 09-Jan-2012 13:57:47\ncorner_dist: 9.950000e-02\nS_rect_00: 1.242000e+03 3.750000e+02\nR_rect_00: {}\nP_rect_00: {}\nP_rect_01: {}\nP_rect_02: {}\nP_rect_03: {}\n",
            row(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]),
            p(nalgebra::Vector3::zeros()),
            p(nalgebra::Vector3::new(0.537, 0.0, 0.0)),
            p(c.centre()),
            p(c.centre3()),
        ),
    )
    .unwrap();
    std::fs::write(
        date.join("calib_velo_to_cam.txt"),
        "calib_time: 15-Mar-2012 11:37:16\nR: 0 -1 0 0 0 -1 1 0 0\nT: 0 -0.08 -0.27\ndelta_f: 0 0\ndelta_c: 0 0\n",
    )
    .unwrap();
    date
}

fn run(args: &[&std::ffi::OsStr]) {
    let o = Command::new(env!("CARGO_BIN_EXE_panoconv"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{:?}: {}",
        args,
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn raw_drive_converts_like_the_object_dataset() {
    let tmp = tempfile::tempdir().unwrap();
    let date = raw_date_folder(tmp.path());
    let (raw_out, obj_out) = (tmp.path().join("raw_out"), tmp.path().join("obj_out"));
    let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synthetic_kitti");
    let common = ["--to", "equirect", "--cameras", "2,3", "--depth", "-q"];
    let mut a: Vec<&std::ffi::OsStr> = vec![
        "kitti-raw".as_ref(),
        "-i".as_ref(),
        date.as_os_str(),
        "-o".as_ref(),
        raw_out.as_os_str(),
    ];
    a.extend(common.iter().map(std::ffi::OsStr::new));
    run(&a);
    let mut b: Vec<&std::ffi::OsStr> = vec![
        "kitti".as_ref(),
        "-i".as_ref(),
        sample.as_os_str(),
        "-o".as_ref(),
        obj_out.as_os_str(),
        "--frames".as_ref(),
        "000000,000002".as_ref(),
    ];
    b.extend(common.iter().map(std::ffi::OsStr::new));
    run(&b);
    let drive = raw_out.join(DRIVE);
    for (i, id) in ["000000", "000002"].iter().enumerate() {
        let raw_id = format!("{i:010}");
        for (raw_rel, obj_rel) in [
            (
                format!("image_02/data/{raw_id}.png"),
                format!("training/image_2/{id}.png"),
            ),
            (
                format!("image_03/data/{raw_id}.png"),
                format!("training/image_3/{id}.png"),
            ),
            (
                format!("depth_02/data/{raw_id}.png"),
                format!("training/depth_2/{id}.png"),
            ),
        ] {
            let (x, y) = (
                std::fs::read(drive.join(&raw_rel)).unwrap(),
                std::fs::read(obj_out.join(&obj_rel)).unwrap(),
            );
            assert!(x == y, "{raw_rel} differs from {obj_rel}");
        }
    }
    // one calib for the drive, in object form, with the output cameras
    let calib = std::fs::read_to_string(drive.join("calib.txt")).unwrap();
    let object_calib = std::fs::read_to_string(obj_out.join("training/calib/000000.txt")).unwrap();
    for key in [
        "P2:",
        "P3:",
        "R0_rect:",
        "Tr_velo_to_cam:",
        "projection: equirect",
        "K2:",
        "C2:",
        "K3:",
        "C3:",
    ] {
        let line = |text: &str| text.lines().find(|l| l.starts_with(key)).map(str::to_owned);
        assert!(line(&calib).is_some(), "{key} missing");
        if key != "Tr_velo_to_cam:" && key != "R0_rect:" {
            assert_eq!(line(&calib), line(&object_calib), "{key}");
        }
    }
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(raw_out.join("panoconv.json")).unwrap()).unwrap();
    assert_eq!(m["command"], "kitti-raw");
    assert_eq!(m["summary"]["converted"], 2);
}

#[test]
fn raw_errors_are_set_up_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let date = raw_date_folder(tmp.path());
    let out = tmp.path().join("o");
    let o = Command::new(env!("CARGO_BIN_EXE_panoconv"))
        .args(["kitti-raw", "--to", "equirect", "--drive", "nope", "-i"])
        .arg(&date)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("drive \"nope\" not found") && err.contains(DRIVE),
        "{err}"
    );
    std::fs::remove_file(date.join("calib_velo_to_cam.txt")).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_panoconv"))
        .args(["kitti-raw", "--to", "equirect", "-i"])
        .arg(&date)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("calib_velo_to_cam.txt"), "{err}");
    assert!(!out.exists());
}

#[test]
fn a_raw_conversion_passes_its_own_verify() {
    let tmp = tempfile::tempdir().unwrap();
    let date = raw_date_folder(tmp.path());
    let out = tmp.path().join("out");
    run(&[
        "kitti-raw".as_ref(),
        "--to".as_ref(),
        "equirect".as_ref(),
        "--cameras".as_ref(),
        "2,3".as_ref(),
        "--input".as_ref(),
        date.as_os_str(),
        "--output".as_ref(),
        out.as_os_str(),
    ]);
    let o = Command::new(env!("CARGO_BIN_EXE_panoconv"))
        .arg("verify")
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{stdout}");
    // The drive's one calib is listed (so a changed calib is caught).
    let calib = out.join(DRIVE).join("calib.txt");
    std::fs::write(&calib, std::fs::read_to_string(&calib).unwrap() + "\n").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_panoconv"))
        .arg("verify")
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(1), "{stdout}");
    assert!(
        stdout.contains(&format!("changed: {DRIVE}/calib.txt")),
        "{stdout}"
    );
}
