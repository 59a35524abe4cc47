//! The malformed-input corpus: small KITTI datasets, each broken in one way, generated at run
//! time from the table in `cases()` (tiny 16×8 PNGs; nothing binary is committed). Every case
//! states its exact outcome: the exit code, which frames fail and with which message (file,
//! line, field), that a failed frame leaves no outputs and the others are converted, that a
//! set-up error writes nothing, and that the input is never modified. The list with outcomes is
//! in `tests/corpus/README.md`; a test keeps the two in step.
//!
//! Cases that expose a bug carry `bug: Some(..)`: the main test skips them and an `#[ignore]`d
//! test of the same name runs them (`cargo test --test tests corpus:: -- --ignored`).

use crate::common;

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_panoconv");

// ---------------------------------------------------------------------------------------------
// The base dataset: training/000000, training/000001 (the usual victim), testing/000002.

const W: u32 = 16;
const H: u32 = 8;

/// f = 20 px, principal point at the image centre, camera 2 about 6 cm left of camera 0.
fn calib_text() -> String {
    let p = |tx: f64| {
        format!(
            "2.000000000000e+01 0.000000000000e+00 7.500000000000e+00 {tx:.12e} 0.000000000000e+00 2.000000000000e+01 3.500000000000e+00 0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 0.000000000000e+00"
        )
    };
    let id3 = "1.0 0.0 0.0 0.0 1.0 0.0 0.0 0.0 1.0";
    let tr = "0.0 -1.0 0.0 0.0 0.0 0.0 -1.0 -0.08 1.0 0.0 0.0 -0.27";
    let imu = "1.0 0.0 0.0 -0.81 0.0 1.0 0.0 0.32 0.0 0.0 1.0 -0.8";
    format!(
        "P0: {}\nP1: {}\nP2: {}\nP3: {}\nR0_rect: {id3}\nTr_velo_to_cam: {tr}\nTr_imu_to_velo: {imu}\n",
        p(0.0),
        p(-10.8),
        p(1.2),
        p(-9.6)
    )
}

/// A car 10 m ahead and a DontCare rectangle.
const CAR: &str = "Car 0.00 0 0.00 5.00 2.00 10.00 6.00 1.50 1.60 3.90 0.00 1.00 10.00 0.00";
const DONTCARE: &str = "DontCare -1 -1 -10 1.00 1.00 3.00 3.00 -1 -1 -1 -1000 -1000 -1000 -10";

fn label_text() -> String {
    format!("{CAR}\n{DONTCARE}\n")
}

fn encode_png(color: png::ColorType, depth: png::BitDepth, data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, W, H);
        enc.set_color(color);
        enc.set_depth(depth);
        if color == png::ColorType::Indexed {
            enc.set_palette(
                (0..=255u8)
                    .flat_map(|i| [i, 255 - i, i / 2])
                    .collect::<Vec<_>>(),
            );
        }
        let mut w = enc.write_header().unwrap();
        w.write_image_data(data).unwrap();
    }
    out
}

/// A 16×8 image in the given colour type and depth (a gradient, so the warp has something).
fn image(color: png::ColorType, depth: png::BitDepth) -> Vec<u8> {
    let samples = color.samples();
    let wide = depth == png::BitDepth::Sixteen;
    let mut data = Vec::new();
    for y in 0..H {
        for x in 0..W {
            for c in 0..samples {
                let v = ((x * 13 + y * 29 + c as u32 * 71) % 256) as u16;
                if wide {
                    data.extend_from_slice(&(v * 257).to_be_bytes());
                } else {
                    data.push(v as u8);
                }
            }
        }
    }
    encode_png(color, depth, &data)
}

fn rgb() -> Vec<u8> {
    image(png::ColorType::Rgb, png::BitDepth::Eight)
}

fn write(path: &Path, bytes: impl AsRef<[u8]>) {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).unwrap();
    }
    std::fs::write(path, bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

fn write_frame(input: &Path, split: &str, id: &str) {
    write(&input.join(format!("{split}/image_2/{id}.png")), rgb());
    write(&input.join(format!("{split}/calib/{id}.txt")), calib_text());
    if split == "training" {
        write(
            &input.join(format!("{split}/label_2/{id}.txt")),
            label_text(),
        );
    }
}

const BASE_FRAMES: [(&str, &str); 3] = [
    ("training", "000000"),
    ("training", "000001"),
    ("testing", "000002"),
];

// ---------------------------------------------------------------------------------------------
// Cases

/// Where a case runs: a scratch dir with the base dataset at `input`, output to `output`.
struct Env {
    root: PathBuf,
    input: PathBuf,
    output: PathBuf,
    /// Arguments after `kitti --to equirect --input IN --output OUT`.
    args: Vec<String>,
    /// The frames the dataset holds (split, id), for the checks of the converted ones.
    frames: Vec<(String, String)>,
}

impl Env {
    fn file(&self, rel: &str) -> PathBuf {
        self.input.join(rel)
    }
    fn put(&self, rel: &str, bytes: impl AsRef<[u8]>) {
        write(&self.file(rel), bytes);
    }
    fn remove(&self, rel: &str) {
        std::fs::remove_file(self.file(rel)).unwrap();
    }
    /// Replaces the victim's label (training/000001).
    fn label(&self, text: impl AsRef<[u8]>) {
        self.put("training/label_2/000001.txt", text);
    }
    fn calib(&self, text: impl AsRef<[u8]>) {
        self.put("training/calib/000001.txt", text);
    }
    fn image(&self, bytes: impl AsRef<[u8]>) {
        self.put("training/image_2/000001.png", bytes);
    }
    fn calib_with_p2(&self, p2: &str) {
        let text: String = calib_text()
            .lines()
            .map(|l| {
                if l.starts_with("P2:") {
                    format!("P2: {p2}\n")
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        self.calib(text);
    }
}

enum Expect {
    /// Exit 0, every frame converted. The check runs on the output folder.
    Ok(fn(&Env)),
    /// Exit 1: these frames fail with this message (`{IN}`, `{OUT}`, `{ROOT}` are replaced); the
    /// others convert. A message ending in `…` is a prefix (the rest comes from the PNG decoder).
    Fails(&'static [(&'static str, &'static str)], &'static str),
    /// Exit 2 with `panoconv: error: MESSAGE`; nothing written.
    Setup(&'static str),
}

struct Case {
    name: &'static str,
    setup: fn(&mut Env),
    expect: Expect,
    /// Set when the case exposes a bug: skipped by `corpus`, run by an ignored test.
    bug: Option<&'static str>,
}

fn case(name: &'static str, setup: fn(&mut Env), expect: Expect) -> Case {
    Case {
        name,
        setup,
        expect,
        bug: None,
    }
}

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

fn cases() -> Vec<Case> {
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

// ---------------------------------------------------------------------------------------------
// Running a case

struct Outcome {
    code: i32,
    stderr: String,
}

fn panoconv(args: &[OsString]) -> Outcome {
    let out = Command::new(BIN)
        .args(args)
        .output()
        .expect("cannot start panoconv");
    Outcome {
        // killed by a signal: reported as a mismatch of the exit code
        code: out.status.code().unwrap_or(-1),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// Every entry under `root`: files by hash, symlinks by target, folders as `dir`. Missing root:
/// empty.
fn snapshot(root: &Path) -> BTreeMap<String, String> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, String>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.map(Result::unwrap) {
            let path = e.path();
            let rel = path
                .strip_prefix(root)
                .unwrap()
                .to_string_lossy()
                .into_owned();
            let kind = e.file_type().unwrap();
            if kind.is_symlink() {
                let target = std::fs::read_link(&path).unwrap();
                out.insert(rel, format!("-> {}", target.display()));
            } else if kind.is_dir() {
                out.insert(format!("{rel}/"), "dir".into());
                walk(root, &path, out);
            } else {
                let bytes = std::fs::read(&path).unwrap();
                out.insert(rel, blake3::hash(&bytes).to_hex().to_string());
            }
        }
    }
    let mut out = BTreeMap::new();
    if root.is_file() {
        out.insert(
            String::new(),
            blake3::hash(&std::fs::read(root).unwrap())
                .to_hex()
                .to_string(),
        );
    }
    walk(root, root, &mut out);
    out
}

fn outputs_of(split: &str, id: &str) -> Vec<String> {
    let mut v = vec![
        format!("{split}/image_2/{id}.png"),
        format!("{split}/calib/{id}.txt"),
    ];
    if split == "training" {
        v.push(format!("{split}/label_2/{id}.txt"));
    }
    v
}

/// Runs one case; `Err` describes the first mismatch.
fn run_case(case: &Case) -> Result<(), String> {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().canonicalize().unwrap();
    let input = root.join("in");
    for (split, id) in BASE_FRAMES {
        write_frame(&input, split, id);
    }
    let mut env = Env {
        output: root.join("out"),
        input,
        root: root.clone(),
        args: Vec::new(),
        frames: BASE_FRAMES
            .iter()
            .map(|(s, i)| (s.to_string(), i.to_string()))
            .collect(),
    };
    (case.setup)(&mut env);
    let fill = |m: &str| {
        m.replace("{IN}", &env.input.display().to_string())
            .replace("{OUT}", &env.output.display().to_string())
            .replace("{ROOT}", &root.display().to_string())
    };
    let input_before = snapshot(&root.join("in"));
    let output_before = snapshot(&env.output);

    let mut args: Vec<OsString> = ["kitti", "--to", "equirect", "--quiet", "--input"]
        .iter()
        .map(OsString::from)
        .collect();
    args.push(env.input.clone().into());
    args.push("--output".into());
    args.push(env.output.clone().into());
    args.extend(env.args.iter().map(OsString::from));
    let run = panoconv(&args);

    // the input is never touched
    let input_after = snapshot(&root.join("in"));
    if input_after != input_before {
        return Err(format!(
            "the input was modified:\nbefore {input_before:#?}\nafter {input_after:#?}"
        ));
    }
    let err = |what: String| {
        let code = match run.code {
            -1 => "killed by a signal".to_owned(),
            c => format!("exit {c}"),
        };
        Err(format!("{what}\n{code}; stderr:\n{}", run.stderr))
    };

    let failed: Vec<(String, String, String)> = match &case.expect {
        Expect::Setup(message) => {
            if run.code != 2 {
                return err("expected exit 2".into());
            }
            let line = run.stderr.trim_end();
            let want = format!("panoconv: error: {}", fill(message));
            let ok = match want.strip_suffix('…') {
                Some(prefix) => line.starts_with(prefix) && !line.contains('\n'),
                None => line == want,
            };
            if !ok {
                return err(format!("expected stderr {want:?}"));
            }
            let output_after = snapshot(&env.output);
            if output_after != output_before {
                return err(format!(
                    "a set-up error wrote into the output: {output_after:#?}"
                ));
            }
            return Ok(());
        }
        Expect::Ok(_) => Vec::new(),
        Expect::Fails(frames, message) => frames
            .iter()
            .map(|(s, i)| {
                (
                    s.to_string(),
                    i.to_string(),
                    fill(&message.replace("{ID}", i)),
                )
            })
            .collect(),
    };
    let want_code = if failed.is_empty() { 0 } else { 1 };
    if run.code != want_code {
        return err(format!("expected exit {want_code}"));
    }

    // stderr: exactly one line per failed frame, with the message
    let reported: Vec<&str> = run.stderr.lines().collect();
    if reported.len() != failed.len() {
        return err(format!("expected {} failure lines", failed.len()));
    }
    let matches = |got: &str, want: &str| match want.strip_suffix('…') {
        Some(prefix) => got.starts_with(prefix) && got.len() > prefix.len(),
        None => got == want,
    };
    for (split, id, message) in &failed {
        let who = if split.is_empty() {
            format!("frame {id}")
        } else {
            format!("frame {split}/{id}")
        };
        let prefix = format!("panoconv: {who} failed: ");
        let Some(line) = reported.iter().find(|l| l.starts_with(&prefix)) else {
            return err(format!("no failure reported for {who}"));
        };
        if !matches(&line[prefix.len()..], message) {
            return err(format!("{who}: expected {message:?}"));
        }
    }

    // the manifest: one record per frame, failed ones with the message and no outputs
    let manifest: serde_json::Value = match std::fs::read(env.output.join("panoconv.json")) {
        Ok(b) => serde_json::from_slice(&b).map_err(|e| e.to_string())?,
        Err(e) => return err(format!("no manifest: {e}")),
    };
    let records = manifest["frames"].as_array().cloned().unwrap_or_default();
    let mut expected_files: Vec<String> = vec!["panoconv.json".into()];
    let mut all: Vec<(String, String)> = env.frames.clone();
    all.extend(
        failed
            .iter()
            .filter(|(s, i, _)| !env.frames.contains(&(s.clone(), i.clone())))
            .map(|(s, i, _)| (s.clone(), i.clone())),
    );
    if let Some(pos) = env.args.iter().position(|a| a == "--frames") {
        let ids: Vec<&str> = env.args[pos + 1].split(',').collect();
        all.retain(|(s, i)| ids.contains(&i.as_str()) || s.is_empty());
    }
    if records.len() != all.len() {
        return err(format!(
            "manifest has {} frames, expected {:?}",
            records.len(),
            all
        ));
    }
    for (split, id) in &all {
        let rec = records
            .iter()
            .find(|r| r["split"] == split.as_str() && r["id"] == id.as_str())
            .ok_or(format!("no manifest record for {split}/{id}"))?;
        match failed.iter().find(|(s, i, _)| s == split && i == id) {
            Some((_, _, message)) => {
                let got = rec["error"].as_str().unwrap_or("");
                if rec["status"] != "failed" || !matches(got, message) {
                    return err(format!("manifest record of {split}/{id}: {rec}"));
                }
                if rec["outputs"].as_array().is_none_or(|o| !o.is_empty()) {
                    return err(format!("failed frame {split}/{id} lists outputs: {rec}"));
                }
            }
            None => {
                if rec["status"] != "ok" {
                    return err(format!("manifest record of {split}/{id}: {rec}"));
                }
                expected_files.extend(outputs_of(split, id));
            }
        }
    }
    // exactly the converted frames' outputs exist (a failed frame leaves nothing behind)
    let mut files: Vec<String> = snapshot(&env.output)
        .into_iter()
        .filter(|(_, v)| v != "dir")
        .map(|(k, _)| k)
        .collect();
    files.sort();
    expected_files.sort();
    if files != expected_files {
        return err(format!(
            "output files {files:?}, expected {expected_files:?}"
        ));
    }
    // every label written is well formed: 15/16 fields, finite numbers
    for f in files.iter().filter(|f| f.contains("/label_2/")) {
        let text = std::fs::read_to_string(env.output.join(f)).unwrap();
        for line in text.lines() {
            let t: Vec<&str> = line.split_whitespace().collect();
            let finite = t[1..]
                .iter()
                .all(|v| v.parse::<f64>().is_ok_and(f64::is_finite));
            if !(t.len() == 15 || t.len() == 16) || !finite {
                return err(format!("{f}: malformed output label {line:?}"));
            }
        }
    }
    // and the folder verifies against its manifest
    let verify = panoconv(&["verify".into(), env.output.clone().into()]);
    if verify.code != 0 {
        return err(format!("verify failed: {}", verify.stderr));
    }
    if let Expect::Ok(check) = &case.expect {
        check(&env);
    }
    Ok(())
}

fn find(name: &str) -> Case {
    cases()
        .into_iter()
        .find(|c| c.name == name)
        .unwrap_or_else(|| panic!("no case {name}"))
}

#[test]
fn corpus() {
    let cases = cases();
    assert!(cases.len() >= 25, "{} cases", cases.len());
    let mut names: Vec<&str> = cases.iter().map(|c| c.name).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), cases.len(), "duplicate case names");
    let failures: Vec<String> = cases
        .iter()
        .filter(|c| c.bug.is_none())
        .filter_map(|c| run_case(c).err().map(|e| format!("--- {}: {e}", c.name)))
        .collect();
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

#[test]
fn png_huge_dimensions_in_header() {
    if let Err(e) = run_case(&find("png_huge_dimensions_in_header")) {
        panic!("{e}");
    }
}

#[test]
fn calib_p2_huge_focal() {
    if let Err(e) = run_case(&find("calib_p2_huge_focal")) {
        panic!("{e}");
    }
}

#[test]
fn readme_lists_every_case() {
    let readme = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/corpus/README.md"
    ))
    .unwrap();
    for c in cases() {
        assert!(
            readme.contains(&format!("`{}`", c.name)),
            "tests/corpus/README.md does not list `{}`",
            c.name
        );
    }
}

// ---------------------------------------------------------------------------------------------
// The velodyne parser (the conversion does not read scans yet).

#[test]
fn velodyne_wrong_size_is_refused_with_the_exact_message() {
    use panoconv::kitti::velodyne;
    let path = Path::new("training/velodyne/000001.bin");
    for len in [1usize, 15, 17, 33, 16 * 1000 + 4] {
        let err = velodyne::parse(&vec![0u8; len], path)
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            format!(
                "training/velodyne/000001.bin: {len} bytes is not a whole number of 16-byte points (x, y, z, reflectance as float32): truncated or not a velodyne scan"
            )
        );
    }
    let scan = velodyne::parse(&[], path).unwrap();
    assert!(scan.points.is_empty() && scan.dropped_non_finite == 0);
}

#[test]
fn velodyne_non_finite_points_are_dropped_and_counted() {
    use panoconv::kitti::velodyne;
    let mut bytes = Vec::new();
    for p in [
        [1.0f32, 2.0, 3.0, 0.5],
        [f32::NAN, 0.0, 0.0, 0.1],
        [0.0, f32::INFINITY, 0.0, 0.1],
        [4.0, 5.0, 6.0, f32::NAN],
    ] {
        for v in p {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    let scan = velodyne::parse(&bytes, Path::new("v.bin")).unwrap();
    assert_eq!(scan.dropped_non_finite, 2);
    assert_eq!(scan.points.len(), 2);
    assert_eq!(scan.points[1].z, 6.0);
    // a NaN reflectance is kept as it is (only coordinates are checked)
    assert!(scan.reflectance[1].is_nan());
}
