//! Integration tests of the `panoconv` command line: exit codes, what is written (and what is
//! not), error reports, accepted input variants, and the conversion of real KITTI frames. This
//! file holds the checks the topics share; each topic is a file of `tests/cli/`.

mod conversion;
mod frame_errors;
mod input_variants;
mod real_kitti;
mod setup_errors;

use crate::common::*;
use std::path::Path;

// ---------------------------------------------------------------------------------------------
// Checks shared by the topics

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
