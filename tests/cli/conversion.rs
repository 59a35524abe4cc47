//! Successful conversions of the synthetic dataset (happy paths, identity, determinism), the
//! input never modified, `--help` and `panoconv synth`.

use super::{check_frame, edit_line, set_token, LABEL1};
use crate::common::*;
use std::collections::BTreeSet;

const PROJECTIONS: [&str; 3] = ["equirect", "cylindrical", "perspective"];

/// Converts the synthetic dataset to `projection` with `extra` options and checks everything.
fn synth_happy_path(projection: &str) -> Scratch {
    let s = Scratch::synth();
    let before = tree_hashes(&s.input);
    let run = kitti(projection, &s.input, &s.output, &["--jobs", "2"]);
    assert_success(&run);
    assert!(
        run.stderr
            .contains("panoconv: 4 frames converted, 0 failed in"),
        "summary line: {}",
        run.stderr
    );
    assert_eq!(tree_files(&s.output), expected_files(&SYNTH_FRAMES));
    let literal: BTreeSet<String> = [
        "panoconv.json",
        "testing/calib/000003.txt",
        "testing/image_2/000003.png",
        "training/calib/000000.txt",
        "training/calib/000001.txt",
        "training/calib/000002.txt",
        "training/image_2/000000.png",
        "training/image_2/000001.png",
        "training/image_2/000002.png",
        "training/label_2/000000.txt",
        "training/label_2/000001.txt",
        "training/label_2/000002.txt",
    ]
    .into_iter()
    .map(String::from)
    .collect();
    assert_eq!(tree_files(&s.output), literal);
    let m = check_manifest(&s.input, &s.output, 4, 0);
    assert_eq!(m["parameters"]["output_spec"]["projection"], projection);
    for (split, id) in SYNTH_FRAMES {
        assert_eq!(manifest_frame(&m, split, id)["status"], "ok");
        check_frame(&s.input, &s.output, projection, split, id);
    }
    assert_eq!(before, tree_hashes(&s.input), "the input was modified");
    s
}

#[test]
fn equirect_converts_synthetic_dataset() {
    let s = synth_happy_path("equirect");
    // Equirect compresses the periphery: narrower than the 1242-pixel source at the same focal.
    let img = read_rgb8(&s.output_file("training/image_2/000000.png"));
    assert!(img.width < 1242 && img.width > 900, "{}", img.width);
}

#[test]
fn cylindrical_converts_synthetic_dataset() {
    let s = synth_happy_path("cylindrical");
    // The cylinder keeps the source's vertical extent at the centre column.
    let img = read_rgb8(&s.output_file("training/image_2/000000.png"));
    assert_eq!(img.height, 375);
    assert!(img.width < 1242 && img.width > 900, "{}", img.width);
}

#[test]
fn perspective_without_options_is_identity() {
    let s = synth_happy_path("perspective");
    for (split, id) in SYNTH_FRAMES {
        let a = read_rgb8(&s.input_file(&format!("{split}/image_2/{id}.png")));
        let b = read_rgb8(&s.output_file(&format!("{split}/image_2/{id}.png")));
        assert_eq!(
            (a.width, a.height),
            (b.width, b.height),
            "{split}/{id} size"
        );
        let differing = a.data.iter().zip(&b.data).filter(|(x, y)| x != y).count();
        assert_eq!(differing, 0, "{split}/{id}: pixels changed by an identity");
        let calib_in = read_text(&s.input_file(&format!("{split}/calib/{id}.txt")));
        let calib_out = read_text(&s.output_file(&format!("{split}/calib/{id}.txt")));
        let [fu, fv, cu, cv] = k_of_p(&calib_values(&calib_in, "P2").unwrap());
        assert_eq!(
            calib_values(&calib_out, "K2").unwrap(),
            vec![fu, 0.0, cu, 0.0, fv, cv, 0.0, 0.0, 1.0],
            "{split}/{id}: K2 is P2's K"
        );
        // P2 rewritten as K [I | -C] is the input P2.
        assert_eq!(
            calib_values(&calib_out, "P2"),
            calib_values(&calib_in, "P2")
        );
    }
}

#[test]
fn output_does_not_depend_on_jobs() {
    let s = Scratch::synth();
    for opts in [&[][..], &["--pano-width", "1500"][..]] {
        let mut trees = Vec::new();
        for jobs in ["1", "2", "4"] {
            let out = s.path(&format!("out-{}-{jobs}", opts.len()));
            let mut args = vec!["--jobs", jobs, "--quiet"];
            args.extend_from_slice(opts);
            let run = kitti("equirect", &s.input, &out, &args);
            assert_success(&run);
            assert!(run.stderr.is_empty(), "--quiet printed: {}", run.stderr);
            let tree = tree_hashes(&out);
            assert!(tree.contains_key("panoconv.json"));
            // 12 files (with the manifest) and 7 folders
            assert_eq!(tree.len(), 12 + 7, "files and folders: {tree:?}");
            trees.push((jobs, tree));
        }
        for (jobs, t) in &trees[1..] {
            assert_eq!(
                &trees[0].1, t,
                "--jobs 1 and --jobs {jobs} differ (options {opts:?})"
            );
        }
    }
}

#[test]
fn input_is_never_modified() {
    let s = Scratch::synth();
    let before = tree_hashes(&s.input);
    for (i, to) in PROJECTIONS.iter().enumerate() {
        let out = s.path(&format!("out{i}"));
        assert_success(&kitti(to, &s.input, &out, &[]));
        assert_eq!(
            before,
            tree_hashes(&s.input),
            "--to {to} modified the input"
        );
    }
    // a run with a failing frame, and an --overwrite run
    edit_line(&s.input_file(LABEL1), 1, |l| set_token(l, 3, "?"));
    let before = tree_hashes(&s.input);
    let out = s.path("out0");
    let run = kitti("equirect", &s.input, &out, &["--overwrite"]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert_eq!(
        before,
        tree_hashes(&s.input),
        "a failing run modified the input"
    );
}

#[test]
fn help_shows_examples_and_exit_codes() {
    let run = panoconv(["kitti", "--help"]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert!(run.stdout.contains("Examples:"), "{}", run.stdout);
    assert!(
        run.stdout.contains("panoconv kitti --to equirect"),
        "{}",
        run.stdout
    );
    let run = panoconv(["--help"]);
    assert_eq!(run.code, 0);
    assert!(run.stdout.contains("Exit codes"), "{}", run.stdout);
    let run = panoconv(["kitti"]);
    assert_eq!(run.code, 2, "missing required arguments: {}", run.stderr);
}

#[test]
fn synth_refuses_a_non_empty_output_and_leaves_it_alone() {
    // what `panoconv synth --output DIR` writes is checked by tests/sample.rs (the shared
    // `synth_source()` against the shipped sample) and the README block (a second run)
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("synth");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let run = panoconv([
        std::ffi::OsStr::new("synth"),
        "--output".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("is not empty"), "{}", run.stderr);
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 1);
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "mine"
    );
}
