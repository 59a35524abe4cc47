//! The malformed-input corpus: small KITTI datasets, each broken in one way, generated at run
//! time from the table in `cases()` (tiny 16×8 PNGs; nothing binary is committed). Every case
//! states its exact outcome: the exit code, which frames fail and with which message (file,
//! line, field), that a failed frame leaves no outputs and the others are converted, that a
//! set-up error writes nothing, and that the input is never modified. The list with outcomes is
//! in `tests/corpus/README.md`; a test keeps the two in step.
//!
//! Cases that expose a bug carry `bug: Some(..)`: the main test skips them and an `#[ignore]`d
//! test of the same name runs them (`cargo test --test tests corpus:: -- --ignored`).
//!
//! This file holds the base dataset, what a case is, and the tests over the table; the table is
//! `tests/corpus/cases.rs`, running one case `tests/corpus/run.rs`.

mod cases;
mod run;
mod velodyne;

use cases::cases;
use run::run_case;
use std::path::{Path, PathBuf};

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
