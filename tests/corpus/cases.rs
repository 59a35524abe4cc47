//! The table of cases: labels, calib, images and set-up errors, each with its exact outcome.

use super::*;
use crate::common;

fn no_check(_: &Env) {}

const VICTIM: &[(&str, &str)] = &[("training", "000001")];

fn victim_label(env: &Env) -> String {
    std::fs::read_to_string(env.output.join("training/label_2/000001.txt")).unwrap()
}

/// Whether this process can write into a folder with mode 555 (root can).
fn chmod_blocks_writes(dir: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    let probe = dir.join("chmod-probe");
    std::fs::create_dir(&probe).unwrap();
    std::fs::set_permissions(&probe, std::fs::Permissions::from_mode(0o555)).unwrap();
    let blocked = std::fs::write(probe.join("x"), b"x").is_err();
    std::fs::set_permissions(&probe, std::fs::Permissions::from_mode(0o755)).unwrap();
    std::fs::remove_dir_all(&probe).unwrap();
    blocked
}

pub(super) fn cases() -> Vec<Case> {
    use png::{BitDepth, ColorType};
    vec![
        // ---- labels
        case(
            "label_too_few_fields",
            |e| e.label(format!("{CAR}\n{}\n", &CAR[..CAR.len() - 5])),
            Expect::Fails(
                VICTIM,
                "{IN}/training/label_2/000001.txt:2: fields: expected 15 fields (16 with score), found 14",
            ),
        ),
        case(
            "label_too_many_fields",
            |e| e.label(format!("{CAR} 0.9 7\n")),
            Expect::Fails(
                VICTIM,
                "{IN}/training/label_2/000001.txt:1: fields: expected 15 fields (16 with score), found 17",
            ),
        ),
        case(
            "label_with_score",
            |e| e.label(format!("{CAR} 0.87\n")),
            Expect::Ok(|e| {
                let line = victim_label(e);
                assert_eq!(line.split_whitespace().count(), 16, "{line}");
                assert!(line.trim_end().ends_with(" 0.87"), "{line}");
            }),
        ),
        case(
            "label_nan",
            |e| e.label(format!("{CAR}\n{}\n", CAR.replace(" 0.00 1.00 10.00", " nan 1.00 10.00"))),
            Expect::Fails(
                VICTIM,
                "{IN}/training/label_2/000001.txt:2: location.x: \"nan\" is not finite",
            ),
        ),
        case(
            "label_inf",
            |e| e.label(CAR.replace("1.50 1.60", "-inf 1.60")),
            Expect::Fails(
                VICTIM,
                "{IN}/training/label_2/000001.txt:1: dimensions.height: \"-inf\" is not finite",
            ),
        ),
        case(
            "label_not_a_number",
            |e| e.label(CAR.replace(" 1.00 10.00", " abc 10.00")),
            Expect::Fails(
                VICTIM,
                "{IN}/training/label_2/000001.txt:1: location.y: \"abc\" is not a number",
            ),
        ),
        case(
            "label_comma_decimal",
            |e| e.label(CAR.replace("3.90", "3,90")),
            Expect::Fails(
                VICTIM,
                "{IN}/training/label_2/000001.txt:1: dimensions.length: \"3,90\" is not a number",
            ),
        ),
        case(
            "label_occluded_not_integer",
            |e| e.label(CAR.replace("Car 0.00 0 ", "Car 0.00 0.5 ")),
            Expect::Fails(
                VICTIM,
                "{IN}/training/label_2/000001.txt:1: occluded: \"0.5\" is not an integer",
            ),
        ),
        case(
            "label_non_utf8",
            |e| {
                let mut bytes = format!("{CAR}\n").into_bytes();
                bytes.extend_from_slice(b"Caf\xe9 ");
                bytes.extend_from_slice(&CAR.as_bytes()[4..]);
                bytes.push(b'\n');
                e.label(bytes)
            },
            Expect::Fails(
                VICTIM,
                "{IN}/training/label_2/000001.txt:2: text: line is not valid UTF-8",
            ),
        ),
        case(
            "label_crlf",
            |e| e.label(format!("{CAR}\r\n{DONTCARE}\r\n")),
            Expect::Ok(|e| {
                let text = victim_label(e);
                assert!(!text.contains('\r'), "{text:?}");
                assert_eq!(text.lines().count(), 2, "{text}");
            }),
        ),
        case(
            "label_empty",
            |e| e.label(""),
            Expect::Ok(|e| assert_eq!(victim_label(e), "")),
        ),
        case(
            "label_blank_lines_and_tabs",
            |e| e.label(format!("\n  \n{}\n\n", CAR.replace(' ', "\t"))),
            Expect::Ok(|e| assert_eq!(victim_label(e).lines().count(), 1)),
        ),
        case(
            "label_missing",
            |e| e.remove("training/label_2/000001.txt"),
            Expect::Fails(
                VICTIM,
                "{IN}/training/label_2/000001.txt: No such file or directory (os error 2)",
            ),
        ),
        case(
            "label_object_at_camera_centre",
            |e| e.label("Car 0.00 0 0.00 5.00 2.00 10.00 6.00 1.50 1.60 3.90 -0.06 0.00 0.00 0.00\n"),
            Expect::Ok(no_check),
        ),
        case(
            "label_object_behind_camera",
            |e| e.label("Car 0.00 0 0.00 5.00 2.00 10.00 6.00 1.50 1.60 3.90 0.00 1.00 -10.00 0.00\n"),
            // wholly outside the output image: dropped
            Expect::Ok(|e| assert_eq!(victim_label(e), "")),
        ),
        case(
            "label_huge_values",
            |e| e.label("Car 0.00 0 0.00 5.00 2.00 10.00 6.00 1e300 1e300 1e300 1e300 1e300 1e300 1e300\n"),
            Expect::Ok(no_check),
        ),
        // ---- calib
        case(
            "calib_empty",
            |e| e.calib(""),
            Expect::Fails(VICTIM, "{IN}/training/calib/000001.txt: no P2 line"),
        ),
        case(
            "calib_missing_p2",
            |e| {
                let text: String = calib_text()
                    .lines()
                    .filter(|l| !l.starts_with("P2"))
                    .map(|l| format!("{l}\n"))
                    .collect();
                e.calib(text)
            },
            Expect::Fails(VICTIM, "{IN}/training/calib/000001.txt: no P2 line"),
        ),
        case(
            "calib_p2_zero_focal",
            |e| e.calib_with_p2("0 0 7.5 0 0 0 3.5 0 0 0 1 0"),
            Expect::Fails(
                VICTIM,
                "{IN}/training/calib/000001.txt: P2: focal lengths must be positive (singular K)",
            ),
        ),
        case(
            "calib_p2_all_zero",
            |e| e.calib_with_p2("0 0 0 0 0 0 0 0 0 0 0 0"),
            Expect::Fails(
                VICTIM,
                "{IN}/training/calib/000001.txt: P2: P[2][2] must be positive (P = K [I | t])",
            ),
        ),
        case(
            "calib_p2_skewed",
            |e| e.calib_with_p2("20 3 7.5 0 0 20 3.5 0 0 0 1 0"),
            Expect::Fails(
                VICTIM,
                "{IN}/training/calib/000001.txt: P2: a skewed K is not supported",
            ),
        ),
        case(
            "calib_p2_focal_overflows",
            // P[2][2] = 1e-300: P / P[2][2] has infinite focal lengths, which Calib::camera
            // accepts; the output camera refuses the scale (no field named)
            |e| e.calib_with_p2("1e10 0 7.5e-300 0 0 1e10 3.5e-300 0 0 0 1e-300 0"),
            Expect::Fails(
                VICTIM,
                "{IN}/training/calib/000001.txt: P2: not finite once divided by P[2][2]",
            ),
        ),
        case(
            "calib_p2_tiny_focal",
            // f = 1e-9 px: accepted; a 1×1 output image, the car becomes a zero-area box at
            // (0, 0) with truncation 1.00 (pinned as it is; a plausibility check would refuse it)
            |e| e.calib_with_p2("1e-9 0 7.5 0 0 1e-9 3.5 0 0 0 1 0"),
            Expect::Ok(|e| {
                let png = std::fs::read(e.output.join("training/image_2/000001.png")).unwrap();
                assert_eq!(&png[16..24], &[0, 0, 0, 1, 0, 0, 0, 1]);
                assert_eq!(
                    victim_label(e),
                    "Car 1.00 0 0.00 0.00 0.00 0.00 0.00 1.50 1.60 3.90 0.00 1.00 10.00 0.00\n"
                );
            }),
        ),
        Case {
            bug: Some("calib.rs format_sci panics on a non-finite K2: the whole run dies"),
            ..case(
                "calib_p2_huge_focal",
                |e| e.calib_with_p2("1e300 0 7.5 0 0 1e300 3.5 0 0 0 1 0"),
                Expect::Fails(VICTIM, "{IN}/training/calib/000001.txt: …"),
            )
        },
        case(
            "calib_p2_nan",
            |e| e.calib_with_p2("NaN 0 7.5 0 0 20 3.5 0 0 0 1 0"),
            Expect::Fails(
                VICTIM,
                "{IN}/training/calib/000001.txt:3: P2[0]: \"NaN\" is not finite",
            ),
        ),
        case(
            "calib_p2_too_short",
            |e| e.calib_with_p2("20 0 7.5 0 0 20 3.5 0 0 0 1"),
            Expect::Fails(
                VICTIM,
                "{IN}/training/calib/000001.txt:3: P2: expected 12 numbers, found 11",
            ),
        ),
        case(
            "calib_not_a_number",
            |e| e.calib_with_p2("20 0 7.5 0 0 twenty 3.5 0 0 0 1 0"),
            Expect::Fails(
                VICTIM,
                "{IN}/training/calib/000001.txt:3: P2[5]: \"twenty\" is not a number",
            ),
        ),
        case(
            "calib_non_utf8",
            |e| {
                let mut bytes = b"# calibration \xff\xfe\n".to_vec();
                bytes.extend_from_slice(calib_text().as_bytes());
                e.calib(bytes)
            },
            Expect::Fails(
                VICTIM,
                "{IN}/training/calib/000001.txt:1: text: line is not valid UTF-8",
            ),
        ),
        case(
            "calib_crlf",
            |e| e.calib(calib_text().replace('\n', "\r\n")),
            Expect::Ok(|e| {
                let text =
                    std::fs::read_to_string(e.output.join("training/calib/000001.txt")).unwrap();
                assert!(!text.contains('\r'), "{text:?}");
                assert!(text.starts_with(&calib_text()), "{text}");
            }),
        ),
        case(
            "calib_tracking_spellings",
            |e| {
                e.calib(
                    calib_text()
                        .replace("P2: ", "P2 ")
                        .replace("R0_rect:", "R_rect")
                        .replace("Tr_velo_to_cam:", "Tr_velo_cam")
                        .replace("Tr_imu_to_velo:", "Tr_imu_velo"),
                )
            },
            Expect::Ok(no_check),
        ),
        case(
            "calib_missing",
            |e| e.remove("training/calib/000001.txt"),
            Expect::Fails(
                VICTIM,
                "{IN}/training/calib/000001.txt: No such file or directory (os error 2)",
            ),
        ),
        case(
            "calib_written_by_panoconv",
            |e| e.calib(format!("{}projection: equirect\n", calib_text())),
            Expect::Fails(
                VICTIM,
                "{IN}/training/calib/000001.txt: this calib was written by panoconv (it has a projection: line): convert the original dataset",
            ),
        ),
        // ---- images
        case(
            "png_truncated",
            |e| {
                let png = rgb();
                e.image(&png[..png.len() / 2])
            },
            Expect::Fails(
                VICTIM,
                "{IN}/training/image_2/000001.png: cannot decode PNG: …",
            ),
        ),
        case(
            "png_fake_text",
            |e| e.image("this is not a PNG, just text renamed\n"),
            Expect::Fails(
                VICTIM,
                "{IN}/training/image_2/000001.png: cannot decode PNG: …",
            ),
        ),
        case(
            "png_empty_file",
            |e| e.image(""),
            Expect::Fails(
                VICTIM,
                "{IN}/training/image_2/000001.png: cannot decode PNG: …",
            ),
        ),
        case(
            "png_header_claims_more_rows",
            |e| e.image(with_size(&rgb(), W, 4000)),
            Expect::Fails(
                VICTIM,
                "{IN}/training/image_2/000001.png: cannot decode PNG: …",
            ),
        ),
        Case {
            bug: Some("decode_rgb8 allocates width×height from the header unchecked: abort"),
            ..case(
                "png_huge_dimensions_in_header",
                // a valid 16×8 PNG whose header claims 1,000,000 × 1,000,000 pixels (3 TB)
                |e| e.image(with_size(&rgb(), 1_000_000, 1_000_000)),
                Expect::Fails(
                    VICTIM,
                    "{IN}/training/image_2/000001.png: cannot decode PNG: …",
                ),
            )
        },
        case(
            "png_grey8",
            |e| e.image(image(ColorType::Grayscale, BitDepth::Eight)),
            Expect::Ok(no_check),
        ),
        case(
            "png_grey_alpha8",
            |e| e.image(image(ColorType::GrayscaleAlpha, BitDepth::Eight)),
            Expect::Ok(no_check),
        ),
        case(
            "png_rgba8",
            |e| e.image(image(ColorType::Rgba, BitDepth::Eight)),
            Expect::Ok(no_check),
        ),
        case(
            "png_rgb16",
            |e| e.image(image(ColorType::Rgb, BitDepth::Sixteen)),
            Expect::Ok(no_check),
        ),
        case(
            "png_grey16",
            |e| e.image(image(ColorType::Grayscale, BitDepth::Sixteen)),
            Expect::Ok(no_check),
        ),
        case(
            "png_palette",
            |e| e.image(image(ColorType::Indexed, BitDepth::Eight)),
            Expect::Ok(no_check),
        ),
        case(
            "image_symlink_loop",
            |e| {
                for id in ["a", "b"] {
                    e.put(&format!("training/calib/{id}.txt"), calib_text());
                    e.put(&format!("training/label_2/{id}.txt"), label_text());
                    e.frames.push(("training".into(), id.into()));
                }
                let dir = e.file("training/image_2");
                std::os::unix::fs::symlink("b.png", dir.join("a.png")).unwrap();
                std::os::unix::fs::symlink("a.png", dir.join("b.png")).unwrap();
            },
            Expect::Fails(
                &[("training", "a"), ("training", "b")],
                "{IN}/training/image_2/{ID}.png: Too many levels of symbolic links (os error 40)",
            ),
        ),
        case(
            "image_dangling_symlink",
            |e| {
                e.remove("training/image_2/000001.png");
                std::os::unix::fs::symlink("gone.png", e.file("training/image_2/000001.png"))
                    .unwrap();
            },
            Expect::Fails(
                VICTIM,
                "{IN}/training/image_2/000001.png: No such file or directory (os error 2)",
            ),
        ),
        case(
            "image_is_a_directory",
            |e| {
                e.remove("training/image_2/000001.png");
                std::fs::create_dir(e.file("training/image_2/000001.png")).unwrap();
            },
            Expect::Fails(
                VICTIM,
                "{IN}/training/image_2/000001.png: Is a directory (os error 21)",
            ),
        ),
        case(
            "velodyne_wrong_size_is_ignored_by_kitti",
            |e| e.put("training/velodyne/000001.bin", [0u8; 17]),
            Expect::Ok(no_check),
        ),
        case(
            "frames_unknown_id",
            |e| e.args = vec!["--frames".into(), "000000,000001,999999".into()],
            Expect::Setup(
                "frame 999999 not found in {IN} (training: 000000..000001 (2 frames); testing: 000002 (1 frame))",
            ),
        ),
        // ---- set-up errors
        case(
            "input_missing",
            |e| e.input = e.root.join("nope"),
            Expect::Setup("input {ROOT}/nope is not a directory"),
        ),
        case(
            "input_is_a_file",
            |e| {
                e.input = e.root.join("file");
                write(&e.input, "x");
            },
            Expect::Setup("input {ROOT}/file is not a directory"),
        ),
        case(
            "input_without_splits",
            |e| e.input = e.file("training/calib"),
            Expect::Setup(
                "input {ROOT}/in/training/calib holds neither training/ nor testing/ (expected a KITTI object root: INPUT/training/{image_2/000000.png, label_2/000000.txt, calib/000000.txt}, and INPUT/testing/ likewise without label_2/)",
            ),
        ),
        case(
            "training_without_label_dir",
            |e| std::fs::remove_dir_all(e.file("training/label_2")).unwrap(),
            Expect::Setup("{IN}/training: the training split has no label_2/ folder"),
        ),
        case(
            "split_without_image_dir",
            |e| std::fs::remove_dir_all(e.file("testing/image_2")).unwrap(),
            Expect::Setup(
                "{IN}/testing/image_2: No such file or directory (os error 2) (a KITTI split needs image_2/)",
            ),
        ),
        case(
            "output_inside_input",
            |e| e.output = e.file("converted"),
            Expect::Setup(
                "output {IN}/converted is inside the input dataset {IN}; panoconv never writes into its input",
            ),
        ),
        case(
            "output_inside_input_via_dotdot",
            |e| e.output = e.root.join("elsewhere/../in/training/out"),
            Expect::Setup(
                "output {ROOT}/elsewhere/../in/training/out is inside the input dataset {IN}; panoconv never writes into its input",
            ),
        ),
        case(
            "output_is_input",
            |e| e.output = e.input.clone(),
            Expect::Setup("output {IN} is the input dataset"),
        ),
        case(
            "output_not_empty",
            |e| write(&e.output.join("old.txt"), "old"),
            Expect::Setup("output {OUT} is not empty (use --overwrite to write into it)"),
        ),
        case(
            "output_is_a_file",
            |e| write(&e.output, "x"),
            Expect::Setup("output {OUT} exists and is not a directory"),
        ),
        case(
            "output_under_a_file",
            |e| {
                write(&e.root.join("file"), "x");
                e.output = e.root.join("file/out");
            },
            Expect::Setup("{ROOT}/file/out: Not a directory (os error 20)"),
        ),
        case(
            "output_unwritable",
            |e| {
                use std::os::unix::fs::PermissionsExt;
                if chmod_blocks_writes(&e.root) {
                    std::fs::create_dir(&e.output).unwrap();
                    std::fs::set_permissions(&e.output, std::fs::Permissions::from_mode(0o555))
                        .unwrap();
                } else {
                    // root ignores the mode bits: make the output's parent a file instead
                    write(&e.root.join("ro"), "x");
                    e.output = e.root.join("ro/out");
                }
            },
            // the lock file is the first thing written: `OUT/panoconv.lock: Permission denied`
            // (root: `OUT: Not a directory`)
            Expect::Setup("{OUT}…"),
        ),
    ]
}

/// A PNG with the size in its header replaced (and the header's CRC fixed); the data stays.
fn with_size(png: &[u8], width: u32, height: u32) -> Vec<u8> {
    let mut png = png.to_vec();
    assert_eq!(&png[12..16], b"IHDR");
    png[16..20].copy_from_slice(&width.to_be_bytes());
    png[20..24].copy_from_slice(&height.to_be_bytes());
    let crc = common::png_crc32(&png[12..29]);
    png[29..33].copy_from_slice(&crc.to_be_bytes());
    png
}
