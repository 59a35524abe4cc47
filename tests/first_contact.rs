//! What a first user meets: `verify` fails a run with failed frames, a missing folder is one
//! set-up error, YOLO's stand-in val split is said, a slow run's speed, `eval-depth` on float
//! predictions, and help texts that name the right commands. Each test drives the real binary
//! on copies of the synthetic sample.

use crate::common::*;
use std::ffi::OsStr;
use std::path::Path;

fn verify(output: &Path, extra: &[&str]) -> Run {
    let mut args = vec![OsStr::new("verify")];
    args.extend(extra.iter().map(OsStr::new));
    args.push(output.as_os_str());
    panoconv(args)
}

#[test]
fn verify_fails_a_dataset_whose_run_recorded_failed_frames_unless_allowed() {
    let s = Scratch::synth();
    std::fs::remove_file(s.input_file("training/calib/000001.txt")).unwrap();
    let run = kitti("equirect", &s.input, &s.output, &[]);
    assert_eq!(run.code, 1, "{}", run.stderr);

    let checked = verify(&s.output, &[]);
    assert_eq!(checked.code, 1, "{}{}", checked.stdout, checked.stderr);
    assert!(
        checked
            .stdout
            .contains("failed: 1 frame failed in the run that wrote the folder (training/000001: "),
        "{}",
        checked.stdout
    );
    assert!(
        checked.stdout.contains("--allow-failed"),
        "{}",
        checked.stdout
    );
    let last = checked.stdout.lines().last().unwrap();
    assert!(
        last.starts_with("panoconv verify: FAILED: ") && last.contains(", 1 failed frames ("),
        "{last}"
    );

    let allowed = verify(&s.output, &["--allow-failed"]);
    assert_eq!(allowed.code, 0, "{}", allowed.stdout);
    assert!(
        allowed.stdout.starts_with("panoconv verify: OK: ")
            && allowed.stdout.contains("1 failed frames (allowed)"),
        "{}",
        allowed.stdout
    );
    // --allow-failed accepts failed frames, not changed files.
    let label = s.output_file("training/label_2/000000.txt");
    std::fs::write(&label, "changed\n").unwrap();
    assert_eq!(verify(&s.output, &["--allow-failed"]).code, 1);
}

#[test]
fn verify_names_the_first_failures_and_counts_the_rest() {
    let s = Scratch::synth();
    for id in ["000000", "000001", "000002"] {
        std::fs::write(s.input_file(&format!("training/calib/{id}.txt")), "P2: 1\n").unwrap();
    }
    std::fs::write(s.input_file("testing/calib/000003.txt"), "P2: 1\n").unwrap();
    let run = kitti("equirect", &s.input, &s.output, &[]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    let checked = verify(&s.output, &["--quiet"]);
    assert_eq!(checked.code, 1);
    let line = checked.stdout.lines().next().unwrap();
    assert!(line.starts_with("failed: 4 frames failed"), "{line}");
    assert!(line.contains("; and 1 more)"), "{line}");
    // The first three in the manifest's order (by split, then id).
    for named in ["testing/000003: ", "training/000000: ", "training/000001: "] {
        assert!(line.contains(named), "{named} not in {line}");
    }
    assert!(!line.contains("training/000002"), "{line}");
}

#[test]
fn a_split_without_calib_or_image_2_is_a_setup_error_not_frame_failures() {
    for (folder, wanted) in [
        (
            "training/calib",
            "training/calib, which does not exist in split training",
        ),
        (
            "testing/calib",
            "testing/calib, which does not exist in split testing",
        ),
        ("training/image_2", "a KITTI split needs image_2/"),
    ] {
        let s = Scratch::synth();
        std::fs::remove_dir_all(s.input_file(folder)).unwrap();
        let run = kitti("equirect", &s.input, &s.output, &[]);
        assert_eq!(run.code, 2, "{folder}: {}", run.stderr);
        assert_eq!(run.stderr.lines().count(), 1, "{folder}: {}", run.stderr);
        assert!(run.stderr.contains(wanted), "{folder}: {}", run.stderr);
        assert!(!s.output.exists(), "{folder}: a set-up error wrote output");
    }
    // One missing calib file stays one frame's failure.
    let s = Scratch::synth();
    std::fs::remove_file(s.input_file("testing/calib/000003.txt")).unwrap();
    let run = kitti("equirect", &s.input, &s.output, &[]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert_eq!(run.frame_failures().len(), 1, "{}", run.stderr);
}

#[test]
fn yolo_without_a_val_split_says_that_val_is_the_training_images() {
    let s = Scratch::synth();
    assert_success(&kitti("perspective", &s.input, &s.output, &[]));
    let yolo = s.path("yolo");
    let export = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            OsStr::new("export"),
            s.output.as_os_str(),
            OsStr::new("--format"),
            OsStr::new("yolo"),
            OsStr::new("--output"),
            out.as_os_str(),
        ];
        args.extend(extra.iter().map(OsStr::new));
        panoconv(args)
    };
    let run = export(&yolo, &[]);
    assert_success(&run);
    assert!(read_text(&yolo.join("data.yaml")).contains("val: images/train\n"));
    let said: Vec<&str> = run
        .stderr
        .lines()
        .filter(|l| l.contains("val: images/train"))
        .collect();
    assert_eq!(said.len(), 1, "{}", run.stderr);
    assert!(said[0].contains("--val-fraction"), "{}", said[0]);

    let held_out = s.path("yolo_val");
    let run = export(&held_out, &["--val-fraction", "0.5", "--seed", "1"]);
    assert_success(&run);
    assert!(read_text(&held_out.join("data.yaml")).contains("val: images/val\n"));
    assert!(!run.stderr.contains("val: images/train"), "{}", run.stderr);
}

#[test]
fn kitti360_help_offers_fisheye_without_naming_other_commands() {
    let help = panoconv(["kitti360", "--help"]);
    assert_eq!(help.code, 0);
    let line = help
        .stdout
        .lines()
        .find(|l| l.trim_start().starts_with("- fisheye:"))
        .unwrap_or_else(|| panic!("no fisheye value in:\n{}", help.stdout));
    assert!(!line.contains("kitti-raw"), "{line}");
}

/// Writes `script` to a file and runs it with the test Python (numpy), failing on error.
fn python(dir: &Path, script: &str) {
    let file = dir.join("write.py");
    write_text(&file, script);
    let out = std::process::Command::new(crate::export::python())
        .arg(&file)
        .output()
        .expect("start the test Python");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn eval_depth_reads_float_npy_and_npz_predictions_as_metres() {
    let tmp = tempfile::tempdir().unwrap();
    let (gt, pred) = (tmp.path().join("gt"), tmp.path().join("pred"));
    std::fs::create_dir_all(&gt).unwrap();
    std::fs::create_dir_all(&pred).unwrap();
    let gt_map = |name: &str, metres: &[f64]| {
        let v: Vec<u16> = metres.iter().map(|d| (d * 256.0).round() as u16).collect();
        let png = panoconv::codec::png::encode_gray16(
            2,
            2,
            &v,
            panoconv::codec::png::PngCompression::Fast,
        );
        std::fs::write(gt.join(name), png).unwrap();
    };
    // a: pred 12 for gt 10 everywhere; b: pred 20 for gt 20 (the zero is no depth).
    gt_map("a.png", &[10.0, 10.0, 10.0, 10.0]);
    gt_map("b.png", &[20.0, 20.0, 0.0, 20.0]);
    python(
        tmp.path(),
        &format!(
            "import numpy as np\n\
             np.save({a:?}, np.full((2, 2), 12.0, dtype=np.float32))\n\
             np.savez_compressed({b:?}, np.full((1, 2, 2), 20.0))\n",
            a = pred.join("a.npy").to_str().unwrap(),
            b = pred.join("b.npz").to_str().unwrap(),
        ),
    );
    let run = panoconv([
        OsStr::new("eval-depth"),
        OsStr::new("--json"),
        OsStr::new("--pred"),
        pred.as_os_str(),
        OsStr::new("--gt"),
        gt.as_os_str(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let j: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    assert_eq!(j["images"], 2);
    assert_eq!(j["mean"]["pixels"], 7);
    // abs rel: a 0.2, b 0: mean 0.1; δ1: a 1 (1.2 < 1.25), b 1.
    let abs_rel = j["mean"]["abs_rel"].as_f64().unwrap();
    assert!((abs_rel - 0.1).abs() < 1e-12, "{abs_rel}");
    assert_eq!(j["mean"]["delta_1"].as_f64().unwrap(), 1.0);

    // An integer array is refused by name, as a failed image.
    python(
        tmp.path(),
        &format!(
            "import numpy as np\nnp.save({a:?}, np.zeros((2, 2), dtype=np.uint16))\n",
            a = pred.join("a.npy").to_str().unwrap()
        ),
    );
    let run = panoconv([
        OsStr::new("eval-depth"),
        OsStr::new("--pred"),
        pred.as_os_str(),
        OsStr::new("--gt"),
        gt.as_os_str(),
    ]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert!(
        run.stderr.contains("a.npy") && run.stderr.contains("dtype <u2"),
        "{}",
        run.stderr
    );
}

/// `scripts/shared_skips.sh` with the shared data at `shared` and the variables `vars`.
fn shared_skips(shared: &Path, vars: &[(&str, &str)]) -> std::process::Output {
    let mut cmd = std::process::Command::new(repo().join("scripts/shared_skips.sh"));
    cmd.env("PANOCONV_SHARED", shared)
        .env_remove("PANOCONV_KITTI")
        .env_remove("CI")
        .env_remove("PANOCONV_REQUIRE_SHARED")
        .envs(vars.iter().copied());
    cmd.output().expect("run scripts/shared_skips.sh")
}

/// The entries of tests/needs_shared.txt: (test name, data).
fn needs_shared() -> Vec<(String, String)> {
    read_text(&repo().join("tests/needs_shared.txt"))
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| {
            let (name, data) = l.split_once(' ').expect("NAME DATA");
            (name.to_owned(), data.trim().to_owned())
        })
        .collect()
}

#[test]
fn every_test_listed_as_needing_shared_data_is_a_test() {
    let listed = needs_shared();
    assert!(listed.len() >= 20, "{listed:?}");
    for (name, data) in &listed {
        assert!(
            ["kitti", "pano", "pandaset"].contains(&data.as_str()),
            "{name}: {data}"
        );
        let parts: Vec<&str> = name.split("::").collect();
        let (test, module) = parts.split_last().unwrap();
        let file = repo().join("tests").join(module.join("/") + ".rs");
        let source = read_text(&file);
        let at = source
            .find(&format!("fn {test}()"))
            .unwrap_or_else(|| panic!("{name}: no fn {test} in {}", file.display()));
        assert!(
            source[..at].trim_end().ends_with("#[test]")
                || source[..at].rsplit("#[test]").next().unwrap().len() < 80,
            "{name} is not a #[test]"
        );
    }
}

#[test]
fn without_shared_data_its_tests_are_skipped_by_name_and_required_in_ci() {
    let tmp = tempfile::tempdir().unwrap();
    let listed = needs_shared();

    let absent = shared_skips(&tmp.path().join("nothing"), &[]);
    assert!(absent.status.success());
    let args = String::from_utf8(absent.stdout).unwrap();
    let skip_args: Vec<&str> = args.lines().collect();
    let expected: Vec<&str> = listed
        .iter()
        .flat_map(|(n, _)| ["--skip", n.as_str()])
        .collect();
    assert_eq!(skip_args, expected);
    let report = String::from_utf8(absent.stderr).unwrap();
    for (name, data) in &listed {
        assert!(
            report.contains(&format!("skipped: {name} (needs {data}: ")),
            "{name} not named in:\n{report}"
        );
    }
    assert_eq!(
        report.lines().last().unwrap(),
        format!(
            "{} tests skipped: their shared data is absent (tests/needs_shared.txt)",
            listed.len()
        )
    );

    // Only the data that is absent skips its tests.
    std::fs::create_dir_all(tmp.path().join("half/kitti")).unwrap();
    let half = shared_skips(&tmp.path().join("half"), &[]);
    let other_tests = listed.iter().filter(|(_, d)| d != "kitti").count();
    assert_eq!(
        String::from_utf8(half.stdout).unwrap().lines().count(),
        2 * other_tests
    );

    for vars in [[("CI", "true")], [("PANOCONV_REQUIRE_SHARED", "1")]] {
        let required = shared_skips(&tmp.path().join("half"), &vars);
        assert_eq!(required.status.code(), Some(1), "{vars:?}");
        assert!(required.stdout.is_empty());
        let said = String::from_utf8(required.stderr).unwrap();
        assert!(
            said.starts_with("shared data missing: pano is not at "),
            "{said}"
        );
    }

    std::fs::create_dir_all(tmp.path().join("half/pano")).unwrap();
    std::fs::create_dir_all(tmp.path().join("half/pandaset/002")).unwrap();
    let present = shared_skips(&tmp.path().join("half"), &[("CI", "true")]);
    assert!(present.status.success());
    assert!(present.stdout.is_empty() && present.stderr.is_empty());
}

/// A copy of fixtures/kitti360 whose poses file also lists frames 253 and 260, which have no
/// images (a partial download).
fn kitti360_with_extra_poses(dir: &Path) -> std::path::PathBuf {
    let root = dir.join("in");
    copy_tree(&repo().join("fixtures/kitti360"), &root);
    let poses = root.join("data_poses/2013_05_28_drive_0000_sync/poses.txt");
    let text = read_text(&poses);
    let last = text.lines().last().unwrap();
    let rest = last.split_once(' ').unwrap().1;
    write_text(&poses, &format!("{text}253 {rest}\n260 {rest}\n"));
    root
}

fn kitti360_run(root: &Path, output: &Path, extra: &[&str]) -> Run {
    let mut args = vec![
        "kitti360",
        "--input",
        root.to_str().unwrap(),
        "--sequence",
        "2013_05_28_drive_0000_sync",
        "--output",
        output.to_str().unwrap(),
        "--to",
        "equirect",
        "--pano-width",
        "256",
    ];
    args.extend(extra);
    panoconv(args)
}

#[test]
fn kitti360_poses_without_images_are_not_frames_and_are_named() {
    let tmp = tempfile::tempdir().unwrap();
    let root = kitti360_with_extra_poses(tmp.path());
    let input_before = tree_hashes(&root);

    let out = tmp.path().join("out");
    let run = kitti360_run(&root, &out, &[]);
    assert_success(&run);
    assert!(
        run.stderr.contains(
            "panoconv: 2 poses without an image of every chosen camera (--cameras, default \
             all) not converted (not frames): 2013_05_28_drive_0000_sync/0000000253, \
             2013_05_28_drive_0000_sync/0000000260\n"
        ),
        "{}",
        run.stderr
    );
    assert!(run
        .stderr
        .contains("panoconv: 3 frames converted, 0 failed"));
    let manifest = read_manifest(&out);
    assert_eq!(manifest["frames"].as_array().unwrap().len(), 3);
    assert_eq!(
        panoconv(["verify", out.to_str().unwrap()]).code,
        0,
        "the run is complete"
    );

    // Naming one in --frames is a set-up error that writes nothing.
    let named = tmp.path().join("named");
    let run = kitti360_run(&root, &named, &["--frames", "252,253"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert_eq!(run.stderr.lines().count(), 1, "{}", run.stderr);
    assert!(
        run.stderr.contains("--frames 253: ")
            && run.stderr.contains("0000000253.png does not exist"),
        "{}",
        run.stderr
    );
    assert!(!named.exists());

    // A frame with images but no scan under --depth still fails.
    std::fs::remove_file(
        root.join("data_3d_raw/2013_05_28_drive_0000_sync/velodyne_points/data/0000000252.bin"),
    )
    .unwrap();
    let depth = tmp.path().join("depth");
    let run = kitti360_run(&root, &depth, &["--depth"]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert_eq!(run.frame_failures().len(), 1, "{}", run.stderr);
    assert!(run.stderr.contains("0000000252.bin"), "{}", run.stderr);
    let mut input_after = tree_hashes(&root);
    input_after.insert(
        "data_3d_raw/2013_05_28_drive_0000_sync/velodyne_points/data/0000000252.bin".into(),
        input_before["data_3d_raw/2013_05_28_drive_0000_sync/velodyne_points/data/0000000252.bin"]
            .clone(),
    );
    assert_eq!(input_after, input_before, "the input is never written");
}

#[test]
fn inspect_says_p2_is_not_the_camera_and_the_documented_targets_match_the_labels() {
    let s = Scratch::synth();
    assert_success(&kitti("equirect", &s.input, &s.output, &[]));
    let inspect = panoconv([OsStr::new("inspect"), s.output.as_os_str()]);
    assert_eq!(inspect.code, 0, "{}", inspect.stderr);
    let line = inspect
        .stdout
        .lines()
        .find(|l| l.starts_with("P2: "))
        .unwrap_or_else(|| panic!("no P2 line in:\n{}", inspect.stdout));
    assert!(
        line.starts_with("P2: not the camera of these images (equirect 4)")
            && line.contains("K2: and C2:")
            && line.contains("labels-to-pixels"),
        "{line}"
    );
    let persp = s.path("persp");
    assert_success(&kitti("perspective", &s.input, &persp, &[]));
    let inspect = panoconv([OsStr::new("inspect"), persp.as_os_str()]);
    assert!(!inspect.stdout.contains("P2: "), "{}", inspect.stdout);

    // The function of docs/formats.md, run on labels-to-pixels' output.
    let pixels = s.output_file("training/pixels");
    assert_success(&panoconv([
        OsStr::new("labels-to-pixels"),
        OsStr::new("--input"),
        s.output.as_os_str(),
        OsStr::new("--output"),
        pixels.as_os_str(),
    ]));
    let doc = read_text(&repo().join("docs/formats.md"));
    let code = doc
        .split("<!-- mono3d-targets-begin -->\n```python\n")
        .nth(1)
        .and_then(|r| r.split("```\n<!-- mono3d-targets-end -->").next())
        .expect("the mono3d-targets block of docs/formats.md");
    let tmp = tempfile::tempdir().unwrap();
    let script = tmp.path().join("targets.py");
    write_text(
        &script,
        &format!(
            "import json, sys\n{code}\nprint(json.dumps({{f: mono3d_targets(sys.argv[1], f) for f in sys.argv[2:]}}))\n"
        ),
    );
    let frames = ["000000", "000001", "000002"];
    let out = std::process::Command::new(crate::export::python())
        .arg(&script)
        .arg(&s.output)
        .args(frames)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let targets: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let (mut checked, mut p2_off) = (0, 0.0f64);
    for frame in frames {
        let calib = read_text(&s.output_file(&format!("training/calib/{frame}.txt")));
        let k = calib_values(&calib, "K2").unwrap();
        let c = calib_values(&calib, "C2").unwrap();
        let p2 = calib_values(&calib, "P2").unwrap();
        let labels = read_text(&s.output_file(&format!("training/label_2/{frame}.txt")));
        let objects: Vec<Vec<&str>> = label_lines(&labels)
            .into_iter()
            .filter(|l| !l.starts_with("DontCare"))
            .map(tokens)
            .collect();
        let got = targets[frame].as_array().unwrap();
        assert_eq!(got.len(), objects.len(), "{frame}");
        for (t, o) in got.iter().zip(&objects) {
            let v = |i: usize| o[i].parse::<f64>().unwrap();
            // The 3D centre (location is the bottom face's centre) from camera 2's centre.
            let centre = [v(11), v(12) - v(8) / 2.0, v(13)];
            let d = [centre[0] - c[0], centre[1] - c[1], centre[2] - c[2]];
            let range = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let u = k[0] * d[0].atan2(d[2]) + k[2];
            let vv = k[4] * (d[1] / range).asin() + k[5];
            assert_eq!(t[0], o[0], "{frame}");
            let f = |i: usize| t[i].as_f64().unwrap();
            assert!(
                (f(1) - u).abs() < 1e-3,
                "{frame} {}: u {} vs {u}",
                o[0],
                f(1)
            );
            assert!(
                (f(2) - vv).abs() < 1e-3,
                "{frame} {}: v {} vs {vv}",
                o[0],
                f(2)
            );
            assert!((f(3) - range).abs() < 1e-5, "{frame}: distance");
            let bbox: Vec<f64> = t[4]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            assert_eq!(bbox, bbox_of(o).to_vec(), "{frame}: the label's box");
            // What a loader using P2 would take instead is another pixel altogether.
            let h = p2[8] * centre[0] + p2[9] * centre[1] + p2[10] * centre[2] + p2[11];
            let pu = (p2[0] * centre[0] + p2[1] * centre[1] + p2[2] * centre[2] + p2[3]) / h;
            let pv = (p2[4] * centre[0] + p2[5] * centre[1] + p2[6] * centre[2] + p2[7]) / h;
            p2_off = p2_off.max((pu - u).hypot(pv - vv));
            checked += 1;
        }
    }
    assert!(checked >= 3, "{checked} objects checked");
    assert!(p2_off > 5.0, "P2 lands within {p2_off} px of every target");
}

/// (objects, DontCare regions, objects failing the default rule) over a converted split.
fn object_census(output: &Path) -> (usize, usize, usize) {
    let (mut objects, mut regions, mut slivers) = (0, 0, 0);
    for e in std::fs::read_dir(output.join("training/label_2")).unwrap() {
        let text = read_text(&e.unwrap().path());
        for line in label_lines(&text) {
            let t = tokens(line);
            if t[0] == "DontCare" {
                regions += 1;
                continue;
            }
            objects += 1;
            let b = bbox_of(&t);
            let truncation: f64 = t[1].parse().unwrap();
            if b[2] - b[0] < 2.0 || b[3] - b[1] < 2.0 || truncation > 0.9 {
                slivers += 1;
            }
        }
    }
    (objects, regions, slivers)
}

#[test]
fn barely_visible_objects_become_dont_care_regions_and_do_not_count() {
    let s = Scratch::synth();
    let args = [
        "--augment",
        "8",
        "--seed",
        "3",
        "--scale-range",
        "1.5,2.5",
        "--crop-size",
        "160x96",
        "--min-objects",
        "1",
    ];
    let all = s.path("all");
    let mut off = args.to_vec();
    off.extend(["--min-visible", "0,0"]);
    assert_success(&kitti("equirect", &s.input, &all, &off));
    let (objects_off, regions_off, slivers_off) = object_census(&all);
    assert!(slivers_off >= 3, "the test needs slivers: {slivers_off}");

    let run = kitti("equirect", &s.input, &s.output, &args);
    assert_success(&run);
    let (objects, regions, slivers) = object_census(&s.output);
    assert_eq!(
        slivers, 0,
        "objects failing the rule were written as objects"
    );
    assert!(objects > 0);
    // The rule changes what views are drawn (they hold fewer objects), so compare the rule's
    // own counts: everything written is an object or a region.
    assert!(regions > 0 && objects + regions > 0);
    assert!(objects_off > slivers_off && regions_off > 0);
    // No view that holds only DontCare regions is counted as holding an object.
    let empty = label_files_without_objects(&s.output);
    let said = run
        .stderr
        .lines()
        .find(|l| l.contains("augmented view"))
        .map_or(0, |l| l.split_whitespace().nth(1).unwrap().parse().unwrap());
    assert_eq!(empty, said, "{}", run.stderr);
    // The manifest records a rule the options do not imply, so --resume cannot mix them.
    assert!(read_manifest(&s.output)["parameters"]
        .get("visibility")
        .is_none());
    let strict = s.path("strict");
    let mut three = args.to_vec();
    three.extend(["--min-visible", "3,0.2"]);
    assert_success(&kitti("equirect", &s.input, &strict, &three));
    assert_eq!(
        read_manifest(&strict)["parameters"]["visibility"]["min_side_px"],
        3.0
    );

    // The exports apply the same rule to a dataset written without it.
    let coco = |extra: &[&str], out: &Path| -> serde_json::Value {
        let mut a = vec![
            OsStr::new("export"),
            all.as_os_str(),
            OsStr::new("--format"),
            OsStr::new("coco"),
            OsStr::new("--output"),
            out.as_os_str(),
        ];
        a.extend(extra.iter().map(OsStr::new));
        assert_success(&panoconv(a));
        serde_json::from_str(&read_text(&out.join("instances_train.json"))).unwrap()
    };
    let count = |j: &serde_json::Value, crowd: u64| {
        j["annotations"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|a| a["iscrowd"] == crowd)
            .count()
    };
    let ruled = coco(&["--min-visible", "2,0.1"], &s.path("coco"));
    let every = coco(&["--min-visible", "0,0"], &s.path("coco_all"));
    assert_eq!(count(&every, 0), objects_off);
    assert_eq!(count(&ruled, 0), objects_off - slivers_off);
}

fn label_files_without_objects(output: &Path) -> usize {
    std::fs::read_dir(output.join("training/label_2"))
        .unwrap()
        .filter(|e| {
            let text = read_text(&e.as_ref().unwrap().path());
            label_lines(&text).iter().all(|l| l.starts_with("DontCare"))
        })
        .count()
}
