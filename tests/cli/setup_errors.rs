//! Set-up errors: exit 2, one `panoconv: error:` line, nothing written.

use super::assert_setup_error;
use crate::common::*;

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
