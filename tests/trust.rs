//! Exit codes and `verify` tell the truth: a run that selects nothing fails before writing, every
//! output a command writes passes `verify`, missing folders are set-up errors, a full output
//! device stops the run with one line, and impossible labels are frame errors. Each test drives
//! the real binary on copies of the synthetic sample or of the real frames in ../shared/kitti.

use crate::common::*;
use std::ffi::OsStr;
use std::path::Path;
use std::process::Command;

/// `verify OUT`, which must pass.
#[track_caller]
fn assert_verifies(output: &Path) {
    let run = panoconv([OsStr::new("verify"), output.as_os_str()]);
    assert_eq!(
        run.code,
        0,
        "verify {} failed:\n{}{}",
        output.display(),
        run.stdout,
        run.stderr
    );
    assert!(run.stdout.contains("verify: OK"), "{}", run.stdout);
}

#[track_caller]
fn assert_setup_error(run: &Run, output: &Path, wanted: &[&str]) {
    assert_eq!(
        run.code, 2,
        "expected a set-up error; stderr:\n{}",
        run.stderr
    );
    assert_eq!(run.stderr.lines().count(), 1, "one line:\n{}", run.stderr);
    for w in wanted {
        assert!(run.stderr.contains(w), "{w:?} not in:\n{}", run.stderr);
    }
    assert!(
        !output.exists(),
        "a set-up error must write nothing, yet {} exists",
        output.display()
    );
}

#[test]
fn a_split_of_jpegs_or_nothing_is_a_setup_error_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("in");
    let images = input.join("training/image_2");
    std::fs::create_dir_all(&images).unwrap();
    std::fs::create_dir_all(input.join("training/label_2")).unwrap();
    let output = tmp.path().join("out");

    let run = kitti("equirect", &input, &output, &[]);
    assert_setup_error(
        &run,
        &output,
        &["image_2/*.png: no frames", "the folder is empty"],
    );

    for i in 0..12 {
        std::fs::write(images.join(format!("{i:06}.jpg")), b"\xFF\xD8\xFF").unwrap();
    }
    let run = kitti("equirect", &input, &output, &[]);
    assert_setup_error(
        &run,
        &output,
        &[
            &format!("{}: no frames", images.join("*.png").display()),
            "12 .jpg files there: KITTI images are PNG",
        ],
    );
}

#[test]
fn a_selection_that_names_absent_or_no_frames_is_a_setup_error() {
    let s = Scratch::synth();
    let run = kitti("equirect", &s.input, &s.output, &["--frames", "123456"]);
    assert_setup_error(
        &run,
        &s.output,
        &[
            "frame 123456 not found",
            "training: 000000..000002 (3 frames)",
            "testing: 000003 (1 frame)",
        ],
    );
    let run = kitti(
        "equirect",
        &s.input,
        &s.output,
        &["--frames", "000001,999998,999999"],
    );
    assert_setup_error(&run, &s.output, &["frames 999998, 999999 not found"]);

    let list = s.path("empty.txt");
    write_text(&list, "# nothing here\n\n");
    let run = kitti(
        "equirect",
        &s.input,
        &s.output,
        &["--frames-from", list.to_str().unwrap()],
    );
    assert_setup_error(&run, &s.output, &["empty.txt: lists no frame id"]);

    std::fs::create_dir_all(s.input_file("ImageSets")).unwrap();
    write_text(&s.input_file("ImageSets/val.txt"), "");
    let run = kitti("equirect", &s.input, &s.output, &["--image-set", "val"]);
    assert_setup_error(&run, &s.output, &["val.txt: lists no frame id"]);
}

#[test]
fn a_shard_that_owns_no_frame_is_not_an_error() {
    // 4 frames over 64 shards: most shards own none, and must still finish (merge needs them).
    let s = Scratch::synth();
    let owners: Vec<i32> = (0..64)
        .map(|k| {
            let shard = format!("{k}/64");
            let out = s.path(&format!("out{k}"));
            kitti("equirect", &s.input, &out, &["--shard", &shard, "--quiet"]).code
        })
        .collect();
    assert!(owners.iter().all(|&c| c == 0), "{owners:?}");
}

#[test]
fn the_right_camera_or_lidar_missing_for_a_split_is_a_setup_error() {
    let s = Scratch::synth();
    std::fs::remove_dir_all(s.input_file("training/image_3")).unwrap();
    let run = kitti("equirect", &s.input, &s.output, &["--cameras", "2,3"]);
    assert_setup_error(&run, &s.output, &["--cameras 2,3 reads", "image_3"]);

    let s = Scratch::synth();
    std::fs::remove_dir_all(s.input_file("testing/velodyne")).unwrap();
    let run = kitti("cylindrical", &s.input, &s.output, &["--depth"]);
    assert_setup_error(&run, &s.output, &["--depth reads", "testing/velodyne"]);
}

#[test]
fn impossible_dimensions_fail_their_frame_and_name_the_field() {
    let s = Scratch::synth();
    let path = s.input_file("training/label_2/000002.txt");
    let text = read_text(&path);
    let first = text.lines().next().unwrap().to_owned();
    let mut t: Vec<&str> = first.split_whitespace().collect();
    assert_ne!(t[0], "DontCare");
    t[8] = "-1.50";
    let flipped = t.join(" ");
    write_text(&path, &text.replacen(&first, &flipped, 1));
    let run = kitti("equirect", &s.input, &s.output, &[]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    let failures = run.frame_failures();
    assert_eq!(failures.len(), 1, "{}", run.stderr);
    assert!(
        failures[0].contains("label_2/000002.txt:1: dimensions.height: \"-1.50\" must be positive"),
        "{}",
        failures[0]
    );
    assert!(!s.output_file("training/image_2/000002.png").exists());
    // DontCare's -1 placeholders stay valid: the sample's DontCare row converts.
    assert!(read_text(&s.input_file("training/label_2/000001.txt")).contains("DontCare -1 -1"));
    assert!(read_text(&s.output_file("training/label_2/000001.txt")).contains("DontCare"));
    let checked = panoconv([
        OsStr::new("verify"),
        OsStr::new("--allow-failed"),
        s.output.as_os_str(),
    ]);
    assert_eq!(checked.code, 0, "{}", checked.stdout);
}

#[test]
fn labels_to_pixels_inside_a_dataset_is_recorded_and_verified() {
    let s = Scratch::synth();
    assert_success(&kitti("equirect", &s.input, &s.output, &[]));
    let pixels = s.output.join("training/pixels");
    let run = panoconv([
        OsStr::new("labels-to-pixels"),
        OsStr::new("--input"),
        s.output.as_os_str(),
        OsStr::new("--output"),
        pixels.as_os_str(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert_verifies(&s.output);
    // A preview written into the dataset is recorded too.
    let preview = s.output.join("preview.png");
    let run = panoconv([
        OsStr::new("preview"),
        s.output.as_os_str(),
        OsStr::new("--frame"),
        OsStr::new("1"),
        OsStr::new("--output"),
        preview.as_os_str(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert_verifies(&s.output);
    // ... and checked: a changed pixel file is caught, not waved through.
    let file = pixels.join("000001.txt");
    write_text(&file, &(read_text(&file) + "Car 1 2 3 4 5 6 7 8\n"));
    let run = panoconv([OsStr::new("verify"), s.output.as_os_str()]);
    assert_eq!(run.code, 1, "{}", run.stdout);
    assert!(
        run.stdout.contains("changed: training/pixels/000001.txt"),
        "{}",
        run.stdout
    );
    // Running it again replaces the record (no stale entry, no double listing).
    let run = panoconv([
        OsStr::new("labels-to-pixels"),
        OsStr::new("--input"),
        s.output.as_os_str(),
        OsStr::new("--output"),
        pixels.as_os_str(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert_verifies(&s.output);
    let manifest = read_manifest(&s.output);
    assert_eq!(
        manifest["derived"].as_array().unwrap().len(),
        2,
        "{manifest}"
    );
}

/// Runs `script` (sh) in a private user and mount namespace, where it may mount a tmpfs.
fn in_mount_namespace(script: &str) -> std::process::Output {
    let out = Command::new("unshare")
        .args(["--user", "--map-root-user", "--mount", "sh", "-euc", script])
        .output()
        .expect("the test needs unshare (util-linux)");
    out
}

#[test]
fn a_full_output_device_stops_the_run_with_one_line_and_resume_completes_it() {
    // 36 real KITTI frames (the sample's, under more ids) into a 3 MB file system.
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("in");
    let real = real_kitti().join("training");
    for sub in ["image_2", "label_2", "calib"] {
        std::fs::create_dir_all(input.join("training").join(sub)).unwrap();
    }
    let mut ids: Vec<String> = std::fs::read_dir(real.join("image_2"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().replace(".png", ""))
        .collect();
    ids.sort();
    for n in 0..36 {
        let src = &ids[n % ids.len()];
        let dst = format!("{:06}", 100 + n);
        for (sub, ext) in [("image_2", "png"), ("label_2", "txt"), ("calib", "txt")] {
            std::fs::copy(
                real.join(sub).join(format!("{src}.{ext}")),
                input
                    .join("training")
                    .join(sub)
                    .join(format!("{dst}.{ext}")),
            )
            .unwrap();
        }
    }
    let reference = tmp.path().join("reference");
    assert_success(&kitti("equirect", &input, &reference, &["--quiet"]));

    let small = tmp.path().join("small");
    std::fs::create_dir_all(&small).unwrap();
    let log = tmp.path().join("log");
    let script = format!(
        r#"mount -t tmpfs -o size=3m tmpfs "{small}"
set +e
"{bin}" kitti --to equirect --input "{input}" --output "{small}/out" --jobs 2 2>"{log}/full.err"
echo $? >"{log}/full.code"
cp "{small}/out/panoconv.json" "{log}/full.json" 2>/dev/null
mount -o remount,size=200m "{small}"
"{bin}" kitti --to equirect --input "{input}" --output "{small}/out" --resume --jobs 2 2>"{log}/resume.err"
echo $? >"{log}/resume.code"
diff -r "{reference}" "{small}/out" >"{log}/diff" 2>&1
echo $? >"{log}/diff.code"
"#,
        small = small.display(),
        bin = BIN,
        input = input.display(),
        log = log.display(),
        reference = reference.display(),
    );
    std::fs::create_dir_all(&log).unwrap();
    let out = in_mount_namespace(&script);
    assert!(
        out.status.success(),
        "the namespace script failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let read = |name: &str| read_text(&log.join(name));
    let err = read("full.err");
    assert_eq!(read("full.code").trim(), "1", "{err}");
    let full_lines: Vec<&str> = err.lines().filter(|l| l.contains("No space")).collect();
    assert_eq!(
        full_lines.len(),
        1,
        "one line about the full device:\n{err}"
    );
    assert!(
        full_lines[0].contains("output device full after")
            && full_lines[0].contains("of 36 frames")
            && full_lines[0].contains("run again with --resume"),
        "{err}"
    );
    assert!(
        err.lines().all(|l| !l.starts_with("panoconv: frame ")),
        "{err}"
    );
    let manifest: serde_json::Value = serde_json::from_str(&read("full.json")).unwrap();
    assert_eq!(manifest["complete"], false);
    let kept = manifest["frames"].as_array().unwrap().len();
    assert!(kept > 0 && kept < 36, "{kept} frames in the manifest");
    assert_eq!(read("resume.code").trim(), "0", "{}", read("resume.err"));
    assert!(
        read("resume.err").contains(&format!("({kept} kept from the previous run)")),
        "{}",
        read("resume.err")
    );
    assert_eq!(read("diff.code").trim(), "0", "{}", read("diff"));
}

#[test]
fn a_read_only_output_is_a_setup_error() {
    let s = Scratch::synth();
    let ro = s.path("ro");
    std::fs::create_dir_all(&ro).unwrap();
    let script = format!(
        r#"mount -t tmpfs -o ro tmpfs "{ro}"
set +e
"{bin}" kitti --to equirect --input "{input}" --output "{ro}/out" 2>"{dir}/err"
echo $? >"{dir}/code"
"#,
        ro = ro.display(),
        bin = BIN,
        input = s.input.display(),
        dir = s.dir.path().display(),
    );
    let out = in_mount_namespace(&script);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = read_text(&s.path("err"));
    assert_eq!(read_text(&s.path("code")).trim(), "2", "{err}");
    assert!(err.contains("Read-only file system"), "{err}");
}

#[test]
fn wrong_layouts_say_what_to_do() {
    let tmp = tempfile::tempdir().unwrap();
    let flat = tmp.path().join("flat");
    std::fs::create_dir_all(flat.join("image_2")).unwrap();
    let out = tmp.path().join("out");
    let run = kitti("equirect", &flat, &out, &[]);
    assert_setup_error(
        &run,
        &out,
        &[
            "image_2/ is at its top",
            "training/",
            "(expected INPUT/training/{image_2/000000.png",
        ],
    );

    let date = tmp.path().join("2011_09_26");
    std::fs::create_dir_all(date.join("2011_09_26_drive_0001_sync")).unwrap();
    std::fs::write(date.join("calib_cam_to_cam.txt"), "").unwrap();
    let run = kitti("equirect", &date, &out, &[]);
    assert_setup_error(&run, &out, &["KITTI raw date folder", "panoconv kitti-raw"]);

    let s = Scratch::synth();
    let run = kitti("fisheye", &s.input, &s.output, &[]);
    assert_setup_error(&run, &s.output, &["--to fisheye needs --camera FILE"]);
    let run = panoconv([
        OsStr::new("pano"),
        OsStr::new("--to"),
        OsStr::new("fisheye"),
        OsStr::new("--input"),
        s.input.as_os_str(),
        OsStr::new("--output"),
        s.output.as_os_str(),
    ]);
    // a folder conversion does not offer a fisheye target: clap refuses it, listing those it has
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr.contains("invalid value 'fisheye'")
            && run
                .stderr
                .contains("[possible values: equirect, cylindrical, perspective]"),
        "{}",
        run.stderr
    );
    assert!(!s.output.exists());

    // JPEG bytes under a .png name are named as such.
    std::fs::copy(
        real_panos().join("street_pano_512x256.jpg"),
        s.input_file("training/image_2/000001.png"),
    )
    .unwrap();
    let run = kitti("equirect", &s.input, &s.output, &[]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert!(
        run.stderr
            .contains("000001.png: cannot decode PNG: the file is a JPEG"),
        "{}",
        run.stderr
    );
}

#[test]
fn each_subcommands_help_lists_only_what_it_accepts() {
    let help = |cmd: &str| panoconv([cmd, "--help"]).stdout;
    let raw = help("kitti-raw");
    for absent in ["--split", "--image-set", "--augment", "object root"] {
        assert!(
            !raw.contains(absent),
            "kitti-raw --help shows {absent}:\n{raw}"
        );
    }
    assert!(
        raw.contains("--drive") && raw.contains("date folder"),
        "{raw}"
    );
    let kitti = help("kitti");
    assert!(!kitti.contains("--drive"), "{kitti}");
    for cmd in ["pano", "fisheye"] {
        let h = help(cmd);
        assert!(
            !h.contains("PNG input only") && !h.contains("JPEG is not read"),
            "{h}"
        );
    }
}

#[test]
fn preview_finds_a_testing_frame_by_its_short_id() {
    let s = Scratch::synth();
    assert_success(&kitti("equirect", &s.input, &s.output, &[]));
    let png = s.path("p.png");
    let run = panoconv([
        OsStr::new("preview"),
        s.output.as_os_str(),
        OsStr::new("--frame"),
        OsStr::new("3"),
        OsStr::new("--output"),
        png.as_os_str(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let img = read_png(&png);
    let warped = read_png(&s.output_file("testing/image_2/000003.png"));
    assert_eq!((img.width, img.height), (warped.width, warped.height));
    let run = panoconv([
        OsStr::new("preview"),
        s.output.as_os_str(),
        OsStr::new("--frame"),
        OsStr::new("000042"),
        OsStr::new("--output"),
        png.as_os_str(),
    ]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr.contains("frame 000042 not found"),
        "{}",
        run.stderr
    );
}

#[test]
fn inspect_describes_a_converted_dataset_by_its_written_camera() {
    let s = Scratch::synth();
    assert_success(&kitti("equirect", &s.input, &s.output, &["--depth"]));
    let calib = read_text(&s.output_file("training/calib/000000.txt"));
    let k2 = calib_values(&calib, "K2").unwrap();
    let run = panoconv([OsStr::new("inspect"), s.output.as_os_str()]);
    assert_eq!(run.code, 0, "{}", run.stdout);
    assert!(
        run.stdout
            .contains(&format!("equirect K2 fu {:.4} fv {:.4}", k2[0], k2[4])),
        "{}",
        run.stdout
    );
    assert!(
        run.stdout
            .contains("training: image_2 label_2 depth_2 calib (no image_3, no velodyne)"),
        "{}",
        run.stdout
    );
}

#[test]
fn eval_depth_with_nothing_evaluated_is_exit_2_not_numbers() {
    let tmp = tempfile::tempdir().unwrap();
    let (pred, gt) = (tmp.path().join("pred"), tmp.path().join("gt"));
    std::fs::create_dir_all(&pred).unwrap();
    std::fs::create_dir_all(&gt).unwrap();
    let s = Scratch::synth();
    assert_success(&kitti("cylindrical", &s.input, &s.output, &["--depth"]));
    std::fs::copy(
        s.output_file("training/depth_2/000000.png"),
        gt.join("000000.png"),
    )
    .unwrap();
    let run = panoconv([
        OsStr::new("eval-depth"),
        OsStr::new("--pred"),
        pred.as_os_str(),
        OsStr::new("--gt"),
        gt.as_os_str(),
    ]);
    assert_eq!(run.code, 2, "{}{}", run.stdout, run.stderr);
    assert!(!run.stdout.contains("-0.0000"), "{}", run.stdout);
    assert!(
        run.stderr.contains("no image could be evaluated"),
        "{}",
        run.stderr
    );
}

#[test]
fn one_frame_is_one_frame() {
    let s = Scratch::synth();
    let run = kitti("equirect", &s.input, &s.output, &["--frames", "000001"]);
    assert_success(&run);
    assert!(
        run.stderr.contains("panoconv: 1 frame converted,"),
        "{}",
        run.stderr
    );
}

#[test]
fn augment_min_objects_redraws_empty_views_and_the_summary_counts_the_rest() {
    let s = Scratch::synth();
    let args = [
        "--augment",
        "6",
        "--seed",
        "3",
        "--scale-range",
        "1.5,2.5",
        "--crop-size",
        "160x96",
    ];
    let plain = kitti("equirect", &s.input, &s.output, &args);
    assert_success(&plain);
    let count = |stderr: &str| -> usize {
        let line = stderr
            .lines()
            .find(|l| l.contains("augmented view"))
            .unwrap_or_else(|| panic!("no view count in:\n{stderr}"));
        line.split_whitespace().nth(1).unwrap().parse().unwrap()
    };
    let empty_plain = count(&plain.stderr);
    assert!(
        empty_plain > 0,
        "the test needs empty views: {}",
        plain.stderr
    );
    let objects_in = |out: &Path| -> Vec<usize> {
        let mut n = Vec::new();
        for e in std::fs::read_dir(out.join("training/label_2")).unwrap() {
            let text = read_text(&e.unwrap().path());
            n.push(
                label_lines(&text)
                    .iter()
                    .filter(|l| !l.starts_with("DontCare"))
                    .count(),
            );
        }
        n
    };
    assert_eq!(
        objects_in(&s.output).iter().filter(|&&n| n == 0).count(),
        empty_plain
    );
    let out2 = s.path("out2");
    let mut with_min: Vec<&str> = args.to_vec();
    with_min.extend(["--min-objects", "1"]);
    let run = kitti("equirect", &s.input, &out2, &with_min);
    assert_success(&run);
    let empty_min = count(&run.stderr);
    let counted = objects_in(&out2).iter().filter(|&&n| n == 0).count();
    assert_eq!(counted, empty_min);
    assert!(empty_min < empty_plain, "{empty_min} vs {empty_plain}");
    assert_verifies(&out2);
    // Reproducible: the same options give the same bytes.
    let out3 = s.path("out3");
    assert_success(&kitti("equirect", &s.input, &out3, &with_min));
    assert_eq!(tree_hashes(&out2), tree_hashes(&out3));
}

#[test]
fn a_turning_radial_function_is_reported_at_its_exact_angle() {
    use panoconv::camera::{Fisheye, ImageSize, Intrinsics, RadialModel};
    // r = θ + k1·θ³ turns where r' = 1 + 3·k1·θ² = 0, at 59.0397°.
    let turn = 59.0397f64.to_radians();
    let k1 = -1.0 / (3.0 * turn * turn);
    let err = Fisheye::new(
        RadialModel::KannalaBrandt([k1, 0.0, 0.0, 0.0]),
        Intrinsics::new(300.0, 300.0, 640.0, 400.0),
        ImageSize::new(1280, 800),
        150f64.to_radians(),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("stops increasing at θ = 59.0397°"), "{err}");
    assert!(err.contains("lower max_fov_deg below 118.0794"), "{err}");
}
