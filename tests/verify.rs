//! `panoconv verify`: a fresh conversion of `fixtures/synthetic_kitti` verifies; a flipped byte in
//! each kind of output, a deleted file, an added file and a broken manifest are each caught and
//! named, with the documented exit codes (0 match, 1 problems, 2 manifest unusable).

use panoconv::tools::verify::{verify, Problem};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

const BIN: &str = env!("CARGO_BIN_EXE_panoconv");

struct Run {
    code: i32,
    stdout: String,
    stderr: String,
}

fn panoconv(args: &[&std::ffi::OsStr]) -> Run {
    let out = Command::new(BIN).args(args).output().unwrap();
    Run {
        code: out.status.code().expect("exit code"),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

fn run_verify(dir: &Path) -> Run {
    panoconv(&["verify".as_ref(), dir.as_os_str()])
}

/// `fixtures/synthetic_kitti` converted once to equirect; tests work on copies.
fn converted() -> &'static Path {
    static DIR: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    &DIR.get_or_init(|| {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        let input = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synthetic_kitti");
        let run = panoconv(&[
            "kitti".as_ref(),
            "--to".as_ref(),
            "equirect".as_ref(),
            "--quiet".as_ref(),
            "--input".as_ref(),
            input.as_os_str(),
            "--output".as_ref(),
            out.as_os_str(),
        ]);
        assert_eq!(run.code, 0, "{}", run.stderr);
        (tmp, out)
    })
    .1
}

fn copy_tree(src: &Path, dst: &Path) {
    std::fs::create_dir_all(dst).unwrap();
    for e in std::fs::read_dir(src).unwrap() {
        let e = e.unwrap();
        let to = dst.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_tree(&e.path(), &to);
        } else {
            std::fs::copy(e.path(), &to).unwrap();
        }
    }
}

fn fresh_copy() -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("out");
    copy_tree(converted(), &dir);
    (tmp, dir)
}

const FILES: usize = 11; // 3 training frames × (image, label, calib) + 1 testing × (image, calib)

#[test]
fn a_fresh_conversion_verifies() {
    let (_tmp, dir) = fresh_copy();
    let report = verify(&dir).unwrap();
    assert!(report.is_ok(), "{:?}", report.problems);
    assert_eq!((report.listed, report.matched), (FILES, FILES));
    let run = run_verify(&dir);
    assert_eq!(run.code, 0, "{}{}", run.stdout, run.stderr);
    assert_eq!(
        run.stdout,
        format!(
            "panoconv verify: OK: {FILES} files listed, {FILES} match, 0 missing, 0 changed, 0 extra ({})\n",
            dir.display()
        )
    );
    // manifest parts are not extra files
    std::fs::write(dir.join("panoconv.part-0.json"), "{}").unwrap();
    assert_eq!(run_verify(&dir).code, 0);
}

#[test]
fn one_flipped_byte_in_any_kind_of_output_is_caught_and_named() {
    for rel in [
        "training/image_2/000001.png",
        "training/label_2/000001.txt",
        "training/calib/000001.txt",
        "testing/image_2/000003.png",
    ] {
        let (_tmp, dir) = fresh_copy();
        let path = dir.join(rel);
        let mut bytes = std::fs::read(&path).unwrap();
        let expected = blake3::hash(&bytes).to_hex().to_string();
        let i = bytes.len() / 2;
        bytes[i] ^= 0x01;
        std::fs::write(&path, &bytes).unwrap();
        let actual = blake3::hash(&bytes).to_hex().to_string();

        let report = verify(&dir).unwrap();
        assert_eq!(
            report.problems,
            vec![Problem::Changed {
                path: rel.into(),
                expected: expected.clone(),
                actual: actual.clone()
            }],
            "{rel}"
        );
        assert_eq!((report.changed(), report.matched), (1, FILES - 1));
        let run = run_verify(&dir);
        assert_eq!(run.code, 1, "{rel}: {}", run.stdout);
        let lines: Vec<&str> = run.stdout.lines().collect();
        assert_eq!(
            lines[0],
            format!("changed: {rel} (manifest blake3 {expected}, file {actual})")
        );
        assert_eq!(
            lines[1],
            format!(
                "panoconv verify: FAILED: {FILES} files listed, {} match, 0 missing, 1 changed, 0 extra ({})",
                FILES - 1,
                dir.display()
            )
        );
        assert_eq!(lines.len(), 2);
    }
}

#[test]
fn a_deleted_file_is_missing() {
    let (_tmp, dir) = fresh_copy();
    std::fs::remove_file(dir.join("training/label_2/000002.txt")).unwrap();
    let run = run_verify(&dir);
    assert_eq!(run.code, 1);
    assert!(
        run.stdout
            .starts_with("missing: training/label_2/000002.txt\npanoconv verify: FAILED: 11 files listed, 10 match, 1 missing, 0 changed, 0 extra"),
        "{}",
        run.stdout
    );
}

#[test]
fn an_added_file_is_extra() {
    let (_tmp, dir) = fresh_copy();
    std::fs::copy(
        dir.join("training/image_2/000000.png"),
        dir.join("training/image_2/000009.png"),
    )
    .unwrap();
    std::fs::create_dir_all(dir.join("notes")).unwrap();
    std::fs::write(dir.join("notes/readme.txt"), "hand-written").unwrap();
    // a leftover temporary of an interrupted atomic write
    std::fs::write(dir.join("training/calib/.000000.txt.tmp-1234"), "").unwrap();
    let report = verify(&dir).unwrap();
    assert_eq!(report.extra(), 3);
    let run = run_verify(&dir);
    assert_eq!(run.code, 1);
    assert_eq!(
        run.stdout.lines().take(3).collect::<Vec<_>>(),
        [
            "extra: notes/readme.txt (not in the manifest)",
            "extra: training/calib/.000000.txt.tmp-1234 (not in the manifest)",
            "extra: training/image_2/000009.png (not in the manifest)",
        ]
    );
    assert!(run.stdout.contains(", 0 missing, 0 changed, 3 extra"));
}

#[test]
fn several_problems_are_all_reported_in_order() {
    let (_tmp, dir) = fresh_copy();
    std::fs::remove_file(dir.join("testing/calib/000003.txt")).unwrap();
    std::fs::write(dir.join("training/calib/000000.txt"), "P2: changed\n").unwrap();
    std::fs::write(dir.join("extra.png"), "x").unwrap();
    let run = run_verify(&dir);
    assert_eq!(run.code, 1);
    let kinds: Vec<&str> = run
        .stdout
        .lines()
        .map(|l| l.split(':').next().unwrap())
        .collect();
    assert_eq!(kinds, ["missing", "changed", "extra", "panoconv verify"]);
}

#[test]
fn a_corrupt_manifest_is_exit_2_with_line_and_column() {
    let (_tmp, dir) = fresh_copy();
    let manifest = dir.join("panoconv.json");
    let text = std::fs::read_to_string(&manifest).unwrap();
    // cut it in the middle of the frames
    let cut = text.find("\"frames\"").unwrap() + 40;
    std::fs::write(&manifest, &text[..cut]).unwrap();
    let run = run_verify(&dir);
    assert_eq!(run.code, 2, "{}", run.stdout);
    assert!(run.stdout.is_empty());
    let line = text[..cut].lines().count();
    let column = text[..cut].lines().last().unwrap().len();
    assert_eq!(
        run.stderr,
        format!(
            "panoconv: error: {}:{line}: column {column}: not a panoconv manifest: EOF while parsing a string\n",
            manifest.display()
        )
    );

    // valid JSON, not a manifest
    std::fs::write(&manifest, "{\n  \"frames\": 3\n}\n").unwrap();
    let run = run_verify(&dir);
    assert_eq!(run.code, 2);
    assert_eq!(
        run.stderr,
        format!(
            "panoconv: error: {}:2: column 13: not a panoconv manifest: invalid type: integer `3`, expected a sequence\n",
            manifest.display()
        )
    );

    // not UTF-8 at all
    std::fs::write(&manifest, b"\xff\xfe{}").unwrap();
    let run = run_verify(&dir);
    assert_eq!(run.code, 2);
    assert!(run
        .stderr
        .contains("panoconv.json:1: column 1: not a panoconv manifest"));
}

#[test]
fn a_missing_manifest_is_exit_2_and_named() {
    let tmp = tempfile::tempdir().unwrap();
    let run = run_verify(tmp.path());
    assert_eq!(run.code, 2);
    assert_eq!(
        run.stderr,
        format!(
            "panoconv: error: {}/panoconv.json: No such file or directory (os error 2)\n",
            tmp.path().display()
        )
    );
    let run = run_verify(&tmp.path().join("nope"));
    assert_eq!(run.code, 2);
    assert!(run.stderr.contains("nope/panoconv.json: No such file"));
}

#[test]
fn a_manifest_path_outside_the_folder_is_not_opened() {
    let (_tmp, dir) = fresh_copy();
    let manifest = dir.join("panoconv.json");
    let mut json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&manifest).unwrap()).unwrap();
    let outputs = json["frames"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .flat_map(|f| f["outputs"].as_array_mut().unwrap().iter_mut());
    let mut replaced = 0;
    for pair in outputs {
        if pair[0] == "training/calib/000000.txt" {
            pair[0] = "../../etc/passwd".into();
            replaced += 1;
        }
    }
    assert_eq!(replaced, 1);
    std::fs::write(&manifest, serde_json::to_vec_pretty(&json).unwrap()).unwrap();
    let report = verify(&dir).unwrap();
    assert_eq!(
        report.problems,
        vec![
            Problem::BadPath {
                path: "../../etc/passwd".into()
            },
            Problem::Extra {
                path: "training/calib/000000.txt".into()
            }
        ]
    );
    assert_eq!(run_verify(&dir).code, 1);
}

#[test]
fn a_failed_frame_leaves_a_folder_whose_files_verify_and_whose_failure_is_reported() {
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("in");
    copy_tree(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synthetic_kitti"),
        &input,
    );
    std::fs::write(input.join("training/label_2/000001.txt"), "Car 1 2 3\n").unwrap();
    let out = tmp.path().join("out");
    let run = panoconv(&[
        "kitti".as_ref(),
        "--to".as_ref(),
        "cylindrical".as_ref(),
        "--quiet".as_ref(),
        "--input".as_ref(),
        input.as_os_str(),
        "--output".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    let report = verify(&out).unwrap();
    // The files agree with the manifest; the failed frame is reported, not hidden.
    assert!(report.problems.is_empty(), "{:?}", report.problems);
    assert!(report.is_ok_allowing_failed(true));
    assert!(!report.is_ok());
    assert_eq!(report.failed.len(), 1);
    assert_eq!(report.failed[0].frame, "training/000001");
    assert_eq!(report.listed, 8);
}
