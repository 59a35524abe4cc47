//! Accepted input variants (CRLF, blank lines and unknown calib keys, PNG colour types and
//! depths, relative paths, scores, empty labels) and the frame selection options.

use super::{assert_setup_error, check_frame, CALIB1, IMAGE1, LABEL1};
use crate::common::*;

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
