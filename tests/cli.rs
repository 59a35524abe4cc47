//! Integration tests of the `panoconv` command line: exit codes, what is written (and what is
//! not), error reports, accepted input variants, and the conversion of real KITTI frames.

use crate::common::*;
use std::collections::BTreeSet;
use std::path::Path;

const PROJECTIONS: [&str; 3] = ["equirect", "cylindrical", "perspective"];

// ---------------------------------------------------------------------------------------------
// Checks shared by the successful conversions

/// Checks one converted frame's calib, label and image against its input. Returns the output
/// image size.
fn check_frame(input: &Path, output: &Path, projection: &str, split: &str, id: &str) -> (u32, u32) {
    // calib: every input line verbatim, then projection, K2 and C2
    let calib_in = read_text(&input.join(format!("{split}/calib/{id}.txt")));
    let calib_out = read_text(&output.join(format!("{split}/calib/{id}.txt")));
    let mut prefix = calib_in.replace("\r\n", "\n");
    if !prefix.ends_with('\n') {
        prefix.push('\n');
    }
    assert!(
        calib_out.starts_with(&prefix),
        "{split}/{id}: output calib does not keep the input lines:\n{calib_out}"
    );
    let added: Vec<&str> = calib_out[prefix.len()..].lines().collect();
    assert_eq!(added.len(), 3, "{split}/{id}: added calib lines {added:?}");
    assert_eq!(added[0], format!("projection: {projection}"));
    assert!(added[1].starts_with("K2: ") && added[2].starts_with("C2: "));
    let k2 = calib_values(&calib_out, "K2").unwrap();
    let c2 = calib_values(&calib_out, "C2").unwrap();
    assert_eq!(k2.len(), 9, "K2 has 9 numbers");
    assert_eq!(c2.len(), 3, "C2 has 3 numbers");
    assert_eq!(
        [k2[1], k2[3], k2[6], k2[7], k2[8]],
        [0.0, 0.0, 0.0, 0.0, 1.0]
    );
    let p2 = calib_values(&calib_in, "P2").unwrap();
    let [fu, fv, _, _] = k_of_p(&p2);
    // default scale: the source focal length; equirect is square in angle
    assert_eq!(k2[0], fu, "{split}/{id}: K2 fu");
    let want_fv = if projection == "equirect" { fu } else { fv };
    assert!(
        (k2[4] - want_fv).abs() < 1e-9,
        "{split}/{id}: K2 fv {}",
        k2[4]
    );
    let c = centre_of_p(&p2);
    for i in 0..3 {
        assert!(
            (c2[i] - c[i]).abs() < 1e-11,
            "{split}/{id}: C2 {c2:?} vs {c:?}"
        );
    }

    // image: 8-bit RGB, not blank
    let img = read_rgb8(&output.join(format!("{split}/image_2/{id}.png")));
    assert!(
        img.data.iter().any(|&v| v > 16),
        "{split}/{id}: black image"
    );

    // labels: same objects, untouched fields byte-identical, boxes inside the image
    if split == "training" {
        let lin = read_text(&input.join(format!("{split}/label_2/{id}.txt")));
        let lout = read_text(&output.join(format!("{split}/label_2/{id}.txt")));
        let (lin, lout) = (label_lines(&lin), label_lines(&lout));
        assert_eq!(lin.len(), lout.len(), "{split}/{id}: object count");
        for (a, b) in lin.iter().zip(&lout) {
            let (ta, tb) = (tokens(a), tokens(b));
            assert_eq!(ta.len(), tb.len(), "{a} -> {b}");
            for i in (0..ta.len()).filter(|i| !(*i == 1 || (4..8).contains(i))) {
                assert_eq!(ta[i], tb[i], "token {i} changed: {a} -> {b}");
            }
            let tr_in: f64 = ta[1].parse().unwrap();
            if tr_in < 0.0 {
                assert_eq!(ta[1], tb[1], "DontCare truncation changed: {a} -> {b}");
            } else {
                let tr_out: f64 = tb[1].parse().unwrap();
                assert!(
                    (tr_in..=1.0).contains(&tr_out),
                    "truncation {tr_in} -> {tr_out}: {b}"
                );
            }
            let bb = bbox_of(&tb);
            let (w, h) = (img.width as f64, img.height as f64);
            assert!(
                0.0 <= bb[0] && bb[0] <= bb[2] && bb[2] <= w - 1.0,
                "{split}/{id}: box outside the {w}x{h} image: {b}"
            );
            assert!(
                0.0 <= bb[1] && bb[1] <= bb[3] && bb[3] <= h - 1.0,
                "{split}/{id}: box outside the {w}x{h} image: {b}"
            );
        }
    }
    (img.width, img.height)
}

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

// ---------------------------------------------------------------------------------------------
// 1-3: happy paths, identity, determinism

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

// ---------------------------------------------------------------------------------------------
// 4: set-up errors: exit 2, nothing written

/// Asserts a set-up error: exit 2, one `panoconv: error:` line containing `message`, no frame
/// reports, `output` not created, and the input unchanged.
#[track_caller]
fn assert_setup_error(run: &Run, message: &str, output: &Path) {
    assert_eq!(run.code, 2, "expected exit 2; stderr:\n{}", run.stderr);
    assert!(
        run.stderr.starts_with("panoconv: error: ") && run.stderr.contains(message),
        "expected `panoconv: error: ...{message}...`, got:\n{}",
        run.stderr
    );
    assert_eq!(run.stderr.lines().count(), 1, "{}", run.stderr);
    assert!(run.frame_failures().is_empty());
    assert!(!output.exists(), "{} was created", output.display());
}

#[test]
fn setup_error_missing_input() {
    let s = Scratch::synth();
    let missing = s.path("nope");
    let run = kitti("equirect", &missing, &s.output, &[]);
    assert_setup_error(
        &run,
        &format!("input {} is not a directory", missing.display()),
        &s.output,
    );
}

#[test]
fn setup_error_input_without_splits() {
    let s = Scratch::synth();
    let empty = s.path("empty");
    std::fs::create_dir_all(empty.join("velodyne")).unwrap();
    let run = kitti("equirect", &empty, &s.output, &[]);
    assert_setup_error(
        &run,
        &format!(
            "input {} holds neither training/ nor testing/",
            empty.display()
        ),
        &s.output,
    );
    // a training split without labels is refused too
    std::fs::remove_dir_all(s.input_file("training/label_2")).unwrap();
    let run = kitti("equirect", &s.input, &s.output, &[]);
    assert_setup_error(&run, "the training split has no label_2/ folder", &s.output);
}

#[test]
fn setup_error_output_is_input() {
    let s = Scratch::synth();
    let before = tree_hashes(&s.input);
    let run = kitti("equirect", &s.input, &s.input, &["--overwrite"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr.contains(&format!(
            "panoconv: error: output {} is the input dataset",
            s.input.display()
        )),
        "{}",
        run.stderr
    );
    // the same folder spelled differently
    let other = s.input.join("training").join("..");
    let run = kitti("equirect", &s.input, &other, &["--overwrite"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr.contains("is the input dataset"),
        "{}",
        run.stderr
    );
    assert_eq!(before, tree_hashes(&s.input), "the input was modified");
}

#[test]
fn setup_error_output_inside_input() {
    let s = Scratch::synth();
    let before = tree_hashes(&s.input);
    let inside = s.input.join("converted");
    let run = kitti("equirect", &s.input, &inside, &[]);
    assert_setup_error(
        &run,
        &format!(
            "output {} is inside the input dataset {}",
            inside.display(),
            s.input.display()
        ),
        &inside,
    );
    // through a `..` that passes a folder which does not exist: refused (the message is
    // checked by `output_inside_input_through_missing_dotdot_is_named`)
    let sneaky = s.input.join("training/nothing/../converted");
    let run = kitti("equirect", &s.input, &sneaky, &[]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr.starts_with("panoconv: error: "),
        "{}",
        run.stderr
    );
    assert!(!s.input.join("training/nothing").exists());
    assert!(!s.input.join("training/converted").exists());
    // through a symlink to the input
    #[cfg(unix)]
    {
        let link = s.path("link");
        std::os::unix::fs::symlink(&s.input, &link).unwrap();
        let run = kitti("equirect", &s.input, &link.join("converted"), &[]);
        assert_setup_error(&run, "is inside the input dataset", &inside);
        std::fs::remove_file(&link).unwrap();
    }
    assert_eq!(before, tree_hashes(&s.input), "the input was modified");
}

#[test]
fn output_inside_input_through_missing_dotdot_is_named() {
    let s = Scratch::synth();
    let sneaky = s.input.join("training/nothing/../converted");
    let run = kitti("equirect", &s.input, &sneaky, &[]);
    assert_setup_error(
        &run,
        &format!("output {} is inside the input dataset", sneaky.display()),
        &s.input.join("training/converted"),
    );
}

#[test]
fn setup_io_error_is_reported_once() {
    let s = Scratch::synth();
    let list = s.path("no-such-list.txt");
    let run = kitti(
        "equirect",
        &s.input,
        &s.output,
        &["--frames-from", list.to_str().unwrap()],
    );
    assert_setup_error(&run, &format!("{}: ", list.display()), &s.output);
    assert_eq!(
        run.stderr.matches("(os error 2)").count(),
        1,
        "OS error repeated: {}",
        run.stderr
    );
}

#[test]
fn setup_error_missing_frames_from_file() {
    let s = Scratch::synth();
    let list = s.path("no-such-list.txt");
    let run = kitti(
        "equirect",
        &s.input,
        &s.output,
        &["--frames-from", list.to_str().unwrap()],
    );
    assert_setup_error(&run, &format!("{}: ", list.display()), &s.output);
}

#[test]
fn setup_error_output_not_empty_unless_overwrite() {
    let s = Scratch::synth();
    std::fs::create_dir_all(s.output_file("training/image_2")).unwrap();
    write_text(&s.output_file("keep.txt"), "mine\n");
    write_text(&s.output_file("training/image_2/000001.png"), "stale");
    let before = tree_hashes(&s.output);
    let run = kitti("equirect", &s.input, &s.output, &[]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr.starts_with(&format!(
            "panoconv: error: output {} is not empty (use --overwrite",
            s.output.display()
        )),
        "{}",
        run.stderr
    );
    assert_eq!(
        before,
        tree_hashes(&s.output),
        "non-empty output was touched"
    );

    // --overwrite removes only what an earlier run wrote: files no run accounts for are named
    // and nothing is touched
    let run = kitti("equirect", &s.input, &s.output, &["--overwrite"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    for name in ["keep.txt", "training/image_2/000001.png"] {
        assert!(run.stderr.contains(name), "{name}: {}", run.stderr);
    }
    assert_eq!(
        before,
        tree_hashes(&s.output),
        "a refused --overwrite touched the output"
    );
    std::fs::remove_file(s.output_file("keep.txt")).unwrap();
    std::fs::remove_file(s.output_file("training/image_2/000001.png")).unwrap();
    let run = kitti("equirect", &s.input, &s.output, &["--overwrite"]);
    assert_success(&run);
    assert_eq!(tree_files(&s.output), expected_files(&SYNTH_FRAMES));
    check_manifest(&s.input, &s.output, 4, 0);

    // an output that is a file
    let file = s.path("file");
    write_text(&file, "x");
    let run = kitti("equirect", &s.input, &file, &["--overwrite"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr.contains("exists and is not a directory"),
        "{}",
        run.stderr
    );
    assert_eq!(read_text(&file), "x");
}

#[test]
fn setup_error_bogus_split() {
    let s = Scratch::synth();
    let run = kitti("equirect", &s.input, &s.output, &["--split", "bogus"]);
    assert_setup_error(
        &run,
        "unknown split \"bogus\": expected training or testing",
        &s.output,
    );
    // a real split name that the input lacks
    std::fs::remove_dir_all(s.input_file("testing")).unwrap();
    let run = kitti("equirect", &s.input, &s.output, &["--split", "testing"]);
    assert_setup_error(&run, "input has no", &s.output);
}

#[test]
fn setup_error_missing_image_set() {
    let s = Scratch::synth();
    let run = kitti("equirect", &s.input, &s.output, &["--image-set", "missing"]);
    assert_setup_error(
        &run,
        &format!(
            "image set \"missing\": {} does not exist",
            s.input.join("ImageSets").join("missing.txt").display()
        ),
        &s.output,
    );
}

#[test]
fn setup_error_zero_jobs() {
    let s = Scratch::synth();
    let run = kitti("equirect", &s.input, &s.output, &["--jobs", "0"]);
    assert_setup_error(&run, "--jobs must be at least 1", &s.output);
}

#[test]
fn usage_errors_exit_2() {
    let s = Scratch::synth();
    // bad --size, rejected by the argument parser
    let run = kitti("equirect", &s.input, &s.output, &["--size", "10y5"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr.contains("'10y5'") && run.stderr.contains("--size"),
        "{}",
        run.stderr
    );
    assert!(
        run.stderr.contains("expected WIDTHxHEIGHT"),
        "{}",
        run.stderr
    );
    assert!(!s.output.exists());
    for size in ["0x5", "10x", "axb"] {
        let run = kitti("equirect", &s.input, &s.output, &["--size", size]);
        assert_eq!(run.code, 2, "--size {size}: {}", run.stderr);
        assert!(!s.output.exists());
    }
    // unknown projection, zero scales
    let run = kitti("fisheye-ish", &s.input, &s.output, &[]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    let run = kitti("equirect", &s.input, &s.output, &["--pano-width", "0"]);
    assert_setup_error(&run, "--pano-width must be positive", &s.output);
    let run = kitti("equirect", &s.input, &s.output, &["--px-per-deg", "0"]);
    assert_setup_error(&run, "--px-per-deg must be positive", &s.output);
}

// ---------------------------------------------------------------------------------------------
// 5: frame errors: exit 1, reported, the others converted

/// Runs an equirect conversion of the synthetic dataset after `mutate`, expecting exactly frame
/// (split, id) to fail with a message starting with `message` (equal to it when `exact`).
fn assert_frame_fails(
    mutate: impl FnOnce(&Scratch),
    split: &str,
    id: &str,
    message: impl Fn(&Scratch) -> String,
    exact: bool,
) {
    let s = Scratch::synth();
    mutate(&s);
    let before = tree_hashes(&s.input);
    let run = kitti("equirect", &s.input, &s.output, &[]);
    assert_eq!(run.code, 1, "expected exit 1; stderr:\n{}", run.stderr);
    assert!(!run.stderr.contains("panoconv: error:"), "{}", run.stderr);
    let failures = run.frame_failures();
    assert_eq!(failures.len(), 1, "frame reports:\n{}", run.stderr);
    let head = format!("panoconv: frame {split}/{id} failed: ");
    let reported = failures[0]
        .strip_prefix(&head)
        .unwrap_or_else(|| panic!("expected `{head}...`, got {:?}", failures[0]));
    let want = message(&s);
    if exact {
        assert_eq!(reported, want);
    } else {
        assert!(
            reported.starts_with(&want),
            "expected `{want}...`, got `{reported}`"
        );
    }
    assert!(
        run.stderr
            .contains("panoconv: 3 frames converted, 1 failed in"),
        "{}",
        run.stderr
    );

    let ok: Vec<(&str, &str)> = SYNTH_FRAMES
        .iter()
        .copied()
        .filter(|f| *f != (split, id))
        .collect();
    assert_eq!(ok.len(), 3);
    assert_eq!(
        tree_files(&s.output),
        expected_files(&ok),
        "outputs after {split}/{id} failed"
    );
    for rel in frame_outputs(split, id) {
        assert!(
            !s.output_file(&rel).exists(),
            "{rel} written for a failed frame"
        );
    }
    let m = check_manifest(&s.input, &s.output, 3, 1);
    let rec = manifest_frame(&m, split, id);
    assert_eq!(rec["status"], "failed");
    assert_eq!(rec["error"], reported, "manifest error = reported error");
    for (sp, i) in ok {
        assert_eq!(manifest_frame(&m, sp, i)["status"], "ok");
        check_frame(&s.input, &s.output, "equirect", sp, i);
    }
    assert_eq!(before, tree_hashes(&s.input), "the input was modified");
}

/// Replaces line `n` (1-based) of a text file.
fn edit_line(path: &Path, n: usize, f: impl FnOnce(&str) -> String) {
    let text = read_text(path);
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines[n - 1] = f(&lines[n - 1]);
    write_text(path, &(lines.join("\n") + "\n"));
}

fn set_token(line: &str, i: usize, value: &str) -> String {
    let mut t: Vec<&str> = tokens(line);
    t[i] = value;
    t.join(" ")
}

const LABEL1: &str = "training/label_2/000001.txt";
const CALIB1: &str = "training/calib/000001.txt";
const IMAGE1: &str = "training/image_2/000001.png";

#[test]
fn frame_error_label_not_a_number() {
    assert_frame_fails(
        |s| edit_line(&s.input_file(LABEL1), 2, |l| set_token(l, 12, "abc")),
        "training",
        "000001",
        |s| {
            format!(
                "{}:2: location.y: \"abc\" is not a number",
                s.input_file(LABEL1).display()
            )
        },
        true,
    );
}

#[test]
fn frame_error_label_bad_fields_named() {
    // other fields, to check the field names
    for (token, field) in [(5, "bbox.top"), (9, "dimensions.width"), (14, "rotation_y")] {
        assert_frame_fails(
            |s| edit_line(&s.input_file(LABEL1), 3, |l| set_token(l, token, "x1")),
            "training",
            "000001",
            |s| {
                format!(
                    "{}:3: {field}: \"x1\" is not a number",
                    s.input_file(LABEL1).display()
                )
            },
            true,
        );
    }
}

#[test]
fn frame_error_label_with_14_fields() {
    assert_frame_fails(
        |s| {
            edit_line(&s.input_file(LABEL1), 1, |l| {
                let t = tokens(l);
                t[..14].join(" ")
            })
        },
        "training",
        "000001",
        |s| {
            format!(
                "{}:1: fields: expected 15 fields (16 with score), found 14",
                s.input_file(LABEL1).display()
            )
        },
        true,
    );
}

#[test]
fn frame_error_label_nan() {
    assert_frame_fails(
        |s| edit_line(&s.input_file(LABEL1), 2, |l| set_token(l, 13, "NaN")),
        "training",
        "000001",
        |s| {
            format!(
                "{}:2: location.z: \"NaN\" is not finite",
                s.input_file(LABEL1).display()
            )
        },
        true,
    );
}

#[test]
fn frame_error_calib_missing() {
    assert_frame_fails(
        |s| std::fs::remove_file(s.input_file(CALIB1)).unwrap(),
        "training",
        "000001",
        |s| format!("{}: ", s.input_file(CALIB1).display()),
        false,
    );
}

#[test]
fn frame_error_calib_p2_with_11_numbers() {
    assert_frame_fails(
        |s| {
            edit_line(&s.input_file(CALIB1), 3, |l| {
                let t = tokens(l);
                t[..12].join(" ")
            })
        },
        "training",
        "000001",
        |s| {
            format!(
                "{}:3: P2: expected 12 numbers, found 11",
                s.input_file(CALIB1).display()
            )
        },
        true,
    );
}

#[test]
fn frame_error_calib_without_p2() {
    assert_frame_fails(
        |s| {
            let text = read_text(&s.input_file(CALIB1));
            let kept: String = text
                .lines()
                .filter(|l| !l.starts_with("P2:"))
                .map(|l| format!("{l}\n"))
                .collect();
            write_text(&s.input_file(CALIB1), &kept);
        },
        "training",
        "000001",
        |s| format!("{}: no P2 line", s.input_file(CALIB1).display()),
        true,
    );
}

#[test]
fn frame_error_calib_p2_not_a_number() {
    assert_frame_fails(
        |s| edit_line(&s.input_file(CALIB1), 3, |l| set_token(l, 5, "abc")),
        "training",
        "000001",
        |s| {
            format!(
                "{}:3: P2[4]: \"abc\" is not a number",
                s.input_file(CALIB1).display()
            )
        },
        true,
    );
}

#[test]
fn frame_error_png_truncated() {
    assert_frame_fails(
        |s| {
            let p = s.input_file(IMAGE1);
            let bytes = std::fs::read(&p).unwrap();
            std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
        },
        "training",
        "000001",
        |s| format!("{}: cannot decode PNG: ", s.input_file(IMAGE1).display()),
        false,
    );
}

#[test]
fn frame_error_png_garbage() {
    assert_frame_fails(
        |s| std::fs::write(s.input_file(IMAGE1), b"this is not a PNG file at all\n").unwrap(),
        "training",
        "000001",
        |s| format!("{}: cannot decode PNG: ", s.input_file(IMAGE1).display()),
        false,
    );
}

#[test]
fn frame_error_png_empty() {
    assert_frame_fails(
        |s| std::fs::write(s.input_file(IMAGE1), b"").unwrap(),
        "training",
        "000001",
        |s| format!("{}: cannot decode PNG: ", s.input_file(IMAGE1).display()),
        false,
    );
}

#[test]
fn frame_error_in_testing_split() {
    let calib = "testing/calib/000003.txt";
    assert_frame_fails(
        |s| edit_line(&s.input_file(calib), 3, |l| set_token(l, 1, "1e999")),
        "testing",
        "000003",
        |s| {
            format!(
                "{}:3: P2[0]: \"1e999\" is not finite",
                s.input_file(calib).display()
            )
        },
        true,
    );
}

#[test]
fn unknown_frame_id_is_a_setup_error() {
    let s = Scratch::synth();
    let run = kitti(
        "equirect",
        &s.input,
        &s.output,
        &["--frames", "000001,999999"],
    );
    assert_setup_error(
        &run,
        &format!(
            "frame 999999 not found in {} (training: 000000..000002 (3 frames); testing: 000003 (1 frame))",
            s.input.display()
        ),
        &s.output,
    );
}

#[test]
fn frame_files_with_unusable_names_are_reported_not_skipped() {
    use std::os::unix::ffi::OsStrExt;
    let s = Scratch::synth();
    let images = s.input_file("training/image_2");
    std::fs::rename(images.join("000002.png"), images.join("000002.PNG")).unwrap();
    let bad = std::ffi::OsStr::from_bytes(b"0000\xff9.png");
    std::fs::copy(images.join("000001.png"), images.join(bad)).unwrap();
    // not frames at all: other extensions, hidden files
    write_text(&images.join("notes.txt"), "x");
    std::fs::copy(images.join("000001.png"), images.join("._000001.png")).unwrap();

    let run = kitti("equirect", &s.input, &s.output, &[]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    let failures = run.frame_failures();
    assert_eq!(failures.len(), 2, "{}", run.stderr);
    for (failure, name) in failures.iter().zip(["000002.PNG", "0000\u{fffd}9.png"]) {
        assert!(
            failure.contains(&format!("training/image_2/{name}: not a KITTI frame name")),
            "{failure}"
        );
    }
    assert!(
        run.stderr
            .contains("panoconv: 3 frames converted, 2 failed in"),
        "{}",
        run.stderr
    );
    let m = check_manifest(&s.input, &s.output, 3, 2);
    assert_eq!(
        manifest_frame(&m, "training", "000002.PNG")["status"],
        "failed"
    );
    // Asked for by id, other files are not this run's business.
    let out = s.path("selected");
    let run = kitti("equirect", &s.input, &out, &["--frames", "000001"]);
    assert_success(&run);
}

#[test]
fn frame_selection_options() {
    let s = Scratch::synth();
    // --image-set
    std::fs::create_dir_all(s.input_file("ImageSets")).unwrap();
    write_text(&s.input_file("ImageSets/val.txt"), "000002\n\n000003\n");
    let out = s.path("set");
    let run = kitti("equirect", &s.input, &out, &["--image-set", "val"]);
    assert_success(&run);
    let want = [("training", "000002"), ("testing", "000003")];
    assert_eq!(tree_files(&out), expected_files(&want));
    check_manifest(&s.input, &out, 2, 0);
    // --frames-from with a comment
    let list = s.path("ids.txt");
    write_text(&list, "# ids\n000000\n");
    let out = s.path("from");
    let run = kitti(
        "equirect",
        &s.input,
        &out,
        &["--frames-from", list.to_str().unwrap()],
    );
    assert_success(&run);
    assert_eq!(tree_files(&out), expected_files(&[("training", "000000")]));
    // --split testing
    let out = s.path("split");
    let run = kitti("cylindrical", &s.input, &out, &["--split", "testing"]);
    assert_success(&run);
    assert_eq!(tree_files(&out), expected_files(&[("testing", "000003")]));
    check_manifest(&s.input, &out, 1, 0);
}

#[test]
fn overwrite_does_not_leave_stale_outputs_of_a_failed_frame() {
    let s = Scratch::synth();
    assert_success(&kitti("equirect", &s.input, &s.output, &[]));
    edit_line(&s.input_file(LABEL1), 1, |l| set_token(l, 11, "abc"));
    let run = kitti("equirect", &s.input, &s.output, &["--overwrite"]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    let m = check_manifest(&s.input, &s.output, 3, 1);
    assert_eq!(manifest_frame(&m, "training", "000001")["status"], "failed");
    for rel in frame_outputs("training", "000001") {
        assert!(
            !s.output_file(&rel).exists(),
            "{rel}: a stale output of the failed frame is left in the output"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 6: accepted input variants

/// Converts `s.input` (equirect, frames `frames`) into `out`, expecting success.
fn convert_ok(s: &Scratch, out: &str, extra: &[&str]) -> std::path::PathBuf {
    let out = s.path(out);
    let run = kitti("equirect", &s.input, &out, extra);
    assert_success(&run);
    out
}

#[test]
fn crlf_label_and_calib_are_accepted() {
    let s = Scratch::synth();
    let base = convert_ok(&s, "base", &["--frames", "000001"]);
    for rel in [LABEL1, CALIB1] {
        let p = s.input_file(rel);
        write_text(&p, &read_text(&p).replace('\n', "\r\n"));
    }
    let out = convert_ok(&s, "crlf", &["--frames", "000001"]);
    for rel in frame_outputs("training", "000001") {
        assert_eq!(
            hash_file(&base.join(&rel)),
            hash_file(&out.join(&rel)),
            "{rel} differs with CRLF input"
        );
    }
    check_frame(&s.input, &out, "equirect", "training", "000001");
}

#[test]
fn calib_blank_lines_and_unknown_keys_are_kept() {
    let s = Scratch::synth();
    let base = convert_ok(&s, "base", &["--frames", "000001"]);
    let p = s.input_file(CALIB1);
    let text = read_text(&p);
    let edited = format!(
        "\nCustom_key: 1 2 3\n{}\n   \nTr_cam_to_road: 0 0 0 1\nnotes without colon\n",
        text.trim_end().replace("P3:", "\nP3:")
    );
    write_text(&p, &edited);
    let out = convert_ok(&s, "edited", &["--frames", "000001"]);
    let calib = read_text(&out.join(CALIB1));
    assert!(
        calib.starts_with(&edited),
        "lines not kept verbatim:\n{calib}"
    );
    assert_eq!(
        calib[edited.len()..],
        read_text(&base.join(CALIB1))[text.len()..],
        "projection/K2/C2 changed"
    );
    for rel in [IMAGE1, LABEL1] {
        assert_eq!(
            hash_file(&base.join(rel)),
            hash_file(&out.join(rel)),
            "{rel}"
        );
    }
}

/// Replaces image 000002 by `variant` (and optionally the reference by `reference`), converts
/// frame 000002 both ways and expects identical outputs.
fn png_variant_converts_like(variant: impl Fn(&Png) -> (Png, Option<Png>)) {
    let s = Scratch::synth();
    let rel = "training/image_2/000002.png";
    let original = read_rgb8(&s.input_file(rel));
    let (var, reference) = variant(&original);
    if let Some(r) = &reference {
        write_png(&s.input_file(rel), r);
    }
    let base = convert_ok(&s, "base", &["--frames", "000002"]);
    write_png(&s.input_file(rel), &var);
    assert_eq!(read_png(&s.input_file(rel)).color, var.color);
    let out = convert_ok(&s, "variant", &["--frames", "000002"]);
    let a = read_rgb8(&base.join(rel));
    let b = read_rgb8(&out.join(rel));
    assert_eq!((a.width, a.height), (b.width, b.height));
    assert!(
        a.data == b.data,
        "{:?} {:?} input converts differently",
        var.color,
        var.depth
    );
    check_frame(&s.input, &out, "equirect", "training", "000002");
}

#[test]
fn png_16bit_rgb_input() {
    png_variant_converts_like(|p| (p.to_rgb16(), None));
}

#[test]
fn png_rgba_input() {
    png_variant_converts_like(|p| (p.to_rgba8(), None));
}

#[test]
fn png_grey_input() {
    png_variant_converts_like(|p| {
        let (grey, rgb) = p.to_grey8();
        (grey, Some(rgb))
    });
}

#[test]
fn png_palette_input() {
    png_variant_converts_like(|p| {
        let (palette, rgb) = p.to_palette_grey();
        (palette, Some(rgb))
    });
}

#[test]
fn relative_paths() {
    let s = Scratch::synth();
    let cwd = s.dir.path();
    let args = |out: &str| {
        [
            "kitti", "--to", "equirect", "--input", "in", "--output", out, "--frames", "000003",
        ]
        .map(String::from)
    };
    // `in/../out` is beside the input, not inside it
    let run = panoconv_in(cwd, args("in/../out"));
    assert_success(&run);
    assert_eq!(
        tree_files(&s.output),
        expected_files(&[("testing", "000003")])
    );
    let m = check_manifest(&s.input, &s.output, 1, 0);
    assert_eq!(m["parameters"]["input"], "in");
    // `./in/sub` is inside
    let before = tree_hashes(&s.input);
    let run = panoconv_in(cwd, args("./in/sub"));
    assert_setup_error(&run, "is inside the input dataset", &s.input.join("sub"));
    assert_eq!(before, tree_hashes(&s.input));
}

#[test]
fn label_with_score_and_empty_label_file() {
    let s = Scratch::synth();
    let base = convert_ok(&s, "base", &[]);
    let p = s.input_file("training/label_2/000000.txt");
    let with_score: String = read_text(&p)
        .lines()
        .map(|l| format!("{l} 0.87\n"))
        .collect();
    write_text(&p, &with_score);
    write_text(&s.input_file("training/label_2/000002.txt"), "");
    let out = convert_ok(&s, "score", &[]);
    let rel = "training/label_2/000000.txt";
    let want: String = read_text(&base.join(rel))
        .lines()
        .map(|l| format!("{l} 0.87\n"))
        .collect();
    assert_eq!(read_text(&out.join(rel)), want);
    for l in read_text(&out.join(rel)).lines() {
        assert_eq!(tokens(l).len(), 16, "{l}");
    }
    assert_eq!(read_text(&out.join("training/label_2/000002.txt")), "");
    check_manifest(&s.input, &out, 4, 0);
}

// ---------------------------------------------------------------------------------------------
// 7: the input is never modified

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

// ---------------------------------------------------------------------------------------------
// 8: real KITTI frames

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
fn synth_writes_the_cached_dataset_and_refuses_non_empty_output() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("synth");
    let run = panoconv([
        std::ffi::OsStr::new("synth"),
        "--output".as_ref(),
        out.as_os_str(),
    ]);
    assert_success(&run);
    // deterministic: the same bytes as the cached copy the other tests use
    assert_eq!(tree_hashes(&out), tree_hashes(synth_source()));
    let run = panoconv([
        std::ffi::OsStr::new("synth"),
        "--output".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("is not empty"), "{}", run.stderr);
}
