//! Frame errors: exit 1, the frame reported (file, line, field) and counted, the others
//! converted, no output left behind for the failed frame.

use super::{check_frame, edit_line, set_token, CALIB1, IMAGE1, LABEL1};
use crate::common::*;

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
