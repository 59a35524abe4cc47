//! Helpers for the CLI integration tests: running the binary, the synthetic dataset (cached),
//! tree hashing, PNG reading and writing, calib/label/manifest parsing.

#![allow(dead_code)]

use std::collections::{BTreeMap, BTreeSet};
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

pub const BIN: &str = env!("CARGO_BIN_EXE_panoconv");

mod jpeg;
pub use jpeg::jpeg_blocks;
mod paths;
pub use paths::*;
mod render;
pub use render::{psnr, render_where, Window};
mod stitch_figures;
pub use stitch_figures::Truth;

/// The outcome of one run of the binary.
#[derive(Debug)]
pub struct Run {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

impl Run {
    /// Lines of stderr that report a failed frame (a folder conversion's image).
    pub fn frame_failures(&self) -> Vec<&str> {
        self.stderr
            .lines()
            .filter(|l| l.starts_with("panoconv: frame ") || l.starts_with("panoconv: image "))
            .collect()
    }
}

pub fn panoconv<I, S>(args: I) -> Run
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    panoconv_in(Path::new("."), args)
}

/// Runs the binary with working directory `cwd`.
pub fn panoconv_in<I, S>(cwd: &Path, args: I) -> Run
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let out = Command::new(BIN)
        .current_dir(cwd)
        .args(args)
        .output()
        .expect("cannot start the panoconv binary");
    Run {
        code: out
            .status
            .code()
            .unwrap_or_else(|| panic!("panoconv was killed by a signal: {:?}", out.status)),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// `panoconv kitti --to TO --input IN --output OUT EXTRA...`
pub fn kitti(to: &str, input: &Path, output: &Path, extra: &[&str]) -> Run {
    let mut args: Vec<&OsStr> = vec![
        OsStr::new("kitti"),
        OsStr::new("--to"),
        OsStr::new(to),
        OsStr::new("--input"),
        input.as_os_str(),
        OsStr::new("--output"),
        output.as_os_str(),
    ];
    args.extend(extra.iter().map(OsStr::new));
    panoconv(args)
}

/// Asserts exit code 0, showing stderr otherwise.
#[track_caller]
pub fn assert_success(run: &Run) {
    assert_eq!(run.code, 0, "expected success; stderr:\n{}", run.stderr);
    assert!(
        run.frame_failures().is_empty() && !run.stderr.contains("panoconv: error:"),
        "a successful run reported errors:\n{}",
        run.stderr
    );
}

/// The synthetic dataset written by `panoconv synth`, generated once per binary build and cached
/// under the target's test tmp dir (rendering takes seconds). Treat as read only: tests copy it.
pub fn synth_source() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let bin = std::fs::read(BIN).expect("read the panoconv binary");
        let key = &blake3::hash(&bin).to_hex()[..16];
        let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("panoconv-cli");
        std::fs::create_dir_all(&root).unwrap();
        let dir = root.join(format!("synth-{key}"));
        if dir.is_dir() {
            return dir;
        }
        // Older caches belong to older binaries.
        for e in std::fs::read_dir(&root).unwrap().flatten() {
            if e.file_name().to_string_lossy().starts_with("synth-") {
                let _ = std::fs::remove_dir_all(e.path());
            }
        }
        let tmp = root.join(format!("tmp-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&tmp);
        // on one thread, as `synth_cache` (the tests keep the other core busy); tests/sample.rs
        // compares it with the shipped sample, and the README block runs the command again
        let status = Command::new(BIN)
            .args([OsStr::new("synth"), OsStr::new("--output"), tmp.as_os_str()])
            .env("RAYON_NUM_THREADS", "1")
            .status()
            .unwrap();
        assert!(status.success(), "panoconv synth failed");
        if std::fs::rename(&tmp, &dir).is_err() {
            let _ = std::fs::remove_dir_all(&tmp);
            assert!(dir.is_dir(), "synthetic dataset cache missing");
        }
        dir
    })
}

/// The frames of the synthetic dataset: (split, id).
pub const SYNTH_FRAMES: [(&str, &str); 4] = [
    ("training", "000000"),
    ("training", "000001"),
    ("training", "000002"),
    ("testing", "000003"),
];

/// A scratch dir holding a private copy of the synthetic dataset at `in/`; outputs go to `out/`.
pub struct Scratch {
    pub dir: tempfile::TempDir,
    pub input: PathBuf,
    pub output: PathBuf,
}

impl Scratch {
    pub fn synth() -> Scratch {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in");
        copy_tree(synth_source(), &input);
        let output = dir.path().join("out");
        Scratch { dir, input, output }
    }

    pub fn path(&self, rel: &str) -> PathBuf {
        self.dir.path().join(rel)
    }

    pub fn input_file(&self, rel: &str) -> PathBuf {
        self.input.join(rel)
    }

    pub fn output_file(&self, rel: &str) -> PathBuf {
        self.output.join(rel)
    }
}

pub fn copy_tree(src: &Path, dst: &Path) {
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

/// Every entry under `dir` (depth first, by name): path relative to `root` with `/`
/// separators, full path, and whether it is a directory.
fn walk(root: &Path, dir: &Path, out: &mut Vec<(String, PathBuf, bool)>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap())
        .collect();
    entries.sort_by_key(|e| e.file_name());
    for e in entries {
        let path = e.path();
        let rel = path
            .strip_prefix(root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        let is_dir = e.file_type().unwrap().is_dir();
        out.push((rel, path.clone(), is_dir));
        if is_dir {
            walk(root, &path, out);
        }
    }
}

fn entries(root: &Path) -> Vec<(String, PathBuf, bool)> {
    let mut out = Vec::new();
    walk(root, root, &mut out);
    out
}

/// Every entry under `root` (relative path → blake3 hex; directories end in `/` and map to
/// "dir").
pub fn tree_hashes(root: &Path) -> BTreeMap<String, String> {
    entries(root)
        .into_iter()
        .map(|(rel, path, is_dir)| match is_dir {
            true => (format!("{rel}/"), "dir".to_owned()),
            false => (rel, hash_file(&path)),
        })
        .collect()
}

/// Every file under `root` (relative path with `/` separators → its bytes), for comparing
/// whole output trees byte for byte.
pub fn tree_bytes(root: &Path) -> BTreeMap<String, Vec<u8>> {
    entries(root)
        .into_iter()
        .filter(|(_, _, is_dir)| !is_dir)
        .map(|(rel, path, _)| (rel, std::fs::read(path).unwrap()))
        .collect()
}

/// The files (not directories) under `root`, relative.
pub fn tree_files(root: &Path) -> BTreeSet<String> {
    entries(root)
        .into_iter()
        .filter(|(_, _, is_dir)| !is_dir)
        .map(|(rel, _, _)| rel)
        .collect()
}

pub fn hash_file(path: &Path) -> String {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    blake3::hash(&bytes).to_hex().to_string()
}

pub fn read_text(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

pub fn write_text(path: &Path, text: &str) {
    std::fs::write(path, text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The output files a converted frame must have.
pub fn frame_outputs(split: &str, id: &str) -> Vec<String> {
    let mut v = vec![
        format!("{split}/image_2/{id}.png"),
        format!("{split}/calib/{id}.txt"),
    ];
    if split == "training" {
        v.push(format!("{split}/label_2/{id}.txt"));
    }
    v
}

/// The expected output file set for the given converted frames (plus the manifest).
pub fn expected_files(frames: &[(&str, &str)]) -> BTreeSet<String> {
    let mut set: BTreeSet<String> = frames
        .iter()
        .flat_map(|(s, i)| frame_outputs(s, i))
        .collect();
    set.insert("panoconv.json".into());
    set
}

// ---------------------------------------------------------------------------------------------
// PNG

#[derive(Debug, Clone, PartialEq)]
pub struct Png {
    pub width: u32,
    pub height: u32,
    pub color: png::ColorType,
    pub depth: png::BitDepth,
    /// Raw samples as stored (16-bit big-endian).
    pub data: Vec<u8>,
}

pub fn decode_png(bytes: &[u8]) -> Png {
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().expect("PNG header");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("PNG data");
    buf.truncate(info.buffer_size());
    Png {
        width: info.width,
        height: info.height,
        color: info.color_type,
        depth: info.bit_depth,
        data: buf,
    }
}

pub fn read_png(path: &Path) -> Png {
    decode_png(&std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
}

/// Reads a PNG that must be 8-bit RGB.
#[track_caller]
pub fn read_rgb8(path: &Path) -> Png {
    let p = read_png(path);
    assert_eq!(
        (p.color, p.depth),
        (png::ColorType::Rgb, png::BitDepth::Eight),
        "{} is not 8-bit RGB",
        path.display()
    );
    assert_eq!(p.data.len(), (p.width * p.height * 3) as usize);
    p
}

pub fn write_png(path: &Path, img: &Png) {
    let file = std::fs::File::create(path).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), img.width, img.height);
    enc.set_color(img.color);
    enc.set_depth(img.depth);
    if img.color == png::ColorType::Indexed {
        let palette: Vec<u8> = (0..=255u8).flat_map(|i| [i, i, i]).collect();
        enc.set_palette(palette);
    }
    let mut w = enc.write_header().unwrap();
    w.write_image_data(&img.data).unwrap();
    w.finish().unwrap();
}

impl Png {
    /// An 8-bit RGB image as 16-bit RGB with the same values (v·257, exact in 8 bits).
    pub fn to_rgb16(&self) -> Png {
        assert_eq!(self.color, png::ColorType::Rgb);
        Png {
            data: self
                .data
                .iter()
                .flat_map(|&v| (v as u16 * 257).to_be_bytes())
                .collect(),
            depth: png::BitDepth::Sixteen,
            ..self.clone()
        }
    }

    /// An 8-bit RGB image with an alpha channel (varying, so it would show if not dropped).
    pub fn to_rgba8(&self) -> Png {
        let data = self
            .data
            .chunks_exact(3)
            .enumerate()
            .flat_map(|(i, c)| [c[0], c[1], c[2], (i * 7 % 256) as u8])
            .collect();
        Png {
            data,
            color: png::ColorType::Rgba,
            ..self.clone()
        }
    }

    /// An 8-bit palette image of greys (index i is grey i) and the same image as RGB.
    pub fn to_palette_grey(&self) -> (Png, Png) {
        let (grey, rgb) = self.to_grey8();
        (
            Png {
                color: png::ColorType::Indexed,
                ..grey
            },
            rgb,
        )
    }

    /// Luma of an 8-bit RGB image: (8-bit greyscale, the same grey as RGB).
    pub fn to_grey8(&self) -> (Png, Png) {
        let grey: Vec<u8> = self
            .data
            .chunks_exact(3)
            .map(|c| ((c[0] as u32 * 2 + c[1] as u32 * 5 + c[2] as u32) / 8) as u8)
            .collect();
        let rgb = grey.iter().flat_map(|&g| [g, g, g]).collect();
        (
            Png {
                data: grey,
                color: png::ColorType::Grayscale,
                ..self.clone()
            },
            Png {
                data: rgb,
                ..self.clone()
            },
        )
    }
}

// ---------------------------------------------------------------------------------------------
// Calib and labels

/// The numbers of the line `KEY: ...` of a calib text, if present.
pub fn calib_values(text: &str, key: &str) -> Option<Vec<f64>> {
    text.lines().find_map(|l| {
        let rest = l.strip_prefix(key)?.strip_prefix(':')?;
        Some(
            rest.split_whitespace()
                .map(|t| {
                    t.parse::<f64>()
                        .unwrap_or_else(|_| panic!("{key}: {t:?} is not a number"))
                })
                .collect(),
        )
    })
}

/// fu, fv, cu, cv of a KITTI P matrix (P[2][2] = 1 in KITTI files).
pub fn k_of_p(p: &[f64]) -> [f64; 4] {
    assert_eq!(p.len(), 12);
    assert_eq!(p[10], 1.0);
    [p[0], p[5], p[2], p[6]]
}

/// Camera centre in rect: C = -K⁻¹ P[:, 3].
pub fn centre_of_p(p: &[f64]) -> [f64; 3] {
    let [fu, fv, cu, cv] = k_of_p(p);
    let tz = p[11];
    [-(p[3] - cu * tz) / fu, -(p[7] - cv * tz) / fv, -tz]
}

pub fn tokens(line: &str) -> Vec<&str> {
    line.split_whitespace().collect()
}

pub fn label_lines(text: &str) -> Vec<&str> {
    text.lines().filter(|l| !l.trim().is_empty()).collect()
}

pub fn bbox_of(tokens: &[&str]) -> [f64; 4] {
    std::array::from_fn(|i| tokens[4 + i].parse::<f64>().unwrap())
}

pub fn iou(a: [f64; 4], b: [f64; 4]) -> f64 {
    let area = |r: [f64; 4]| (r[2] - r[0]).max(0.0) * (r[3] - r[1]).max(0.0);
    let inter = area([
        a[0].max(b[0]),
        a[1].max(b[1]),
        a[2].min(b[2]),
        a[3].min(b[3]),
    ]);
    inter / (area(a) + area(b) - inter)
}

// ---------------------------------------------------------------------------------------------
// Manifest

pub fn read_manifest(output: &Path) -> serde_json::Value {
    let text = read_text(&output.join("panoconv.json"));
    serde_json::from_str(&text).expect("panoconv.json is JSON")
}

/// The manifest's record of frame (split, id).
#[track_caller]
pub fn manifest_frame<'a>(
    m: &'a serde_json::Value,
    split: &str,
    id: &str,
) -> &'a serde_json::Value {
    let frames = m["frames"].as_array().expect("frames array");
    let found: Vec<_> = frames
        .iter()
        .filter(|f| f["split"] == split && f["id"] == id)
        .collect();
    assert_eq!(found.len(), 1, "frame {split}/{id} in manifest: {m:#}");
    found[0]
}

/// Checks the manifest's summary and that every ok frame's input and output hashes are those
/// of the files on disk, and that its outputs are exactly the frame's output files.
#[track_caller]
pub fn check_manifest(
    input: &Path,
    output: &Path,
    converted: usize,
    failed: usize,
) -> serde_json::Value {
    let m = read_manifest(output);
    assert_eq!(m["tool"], "panoconv");
    assert_eq!(m["command"], "kitti");
    assert_eq!(m["summary"]["frames"], converted + failed);
    assert_eq!(m["summary"]["converted"], converted);
    assert_eq!(m["summary"]["failed"], failed);
    let frames = m["frames"].as_array().expect("frames array");
    assert_eq!(frames.len(), converted + failed);
    let mut ok = 0;
    for f in frames {
        let split = f["split"].as_str().unwrap();
        let id = f["id"].as_str().unwrap();
        match f["status"].as_str().unwrap() {
            "ok" => {
                ok += 1;
                assert!(f.get("error").is_none(), "ok frame with an error: {f}");
                let mut outs = BTreeSet::new();
                for pair in f["outputs"].as_array().unwrap() {
                    let rel = pair[0].as_str().unwrap();
                    assert_eq!(
                        pair[1].as_str().unwrap(),
                        hash_file(&output.join(rel)),
                        "manifest hash of output {rel}"
                    );
                    outs.insert(rel.to_owned());
                }
                let want: BTreeSet<String> = frame_outputs(split, id).into_iter().collect();
                assert_eq!(outs, want, "outputs of {split}/{id} in the manifest");
                let mut ins = BTreeSet::new();
                for pair in f["inputs"].as_array().unwrap() {
                    let rel = pair[0].as_str().unwrap();
                    assert_eq!(
                        pair[1].as_str().unwrap(),
                        hash_file(&input.join(rel)),
                        "manifest hash of input {rel}"
                    );
                    ins.insert(rel.to_owned());
                }
                let want: BTreeSet<String> = frame_outputs(split, id).into_iter().collect();
                assert_eq!(ins, want, "inputs of {split}/{id} in the manifest");
            }
            "failed" => {
                assert!(f["error"].is_string(), "failed frame without error: {f}");
                assert_eq!(f["outputs"].as_array().unwrap().len(), 0);
            }
            s => panic!("unknown status {s:?}"),
        }
    }
    assert_eq!(ok, converted);
    m
}

/// CRC-32 as PNG chunks use it, bit by bit (independent of the crates panoconv decodes with),
/// for hand-made chunks.
pub fn png_crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xffff_ffffu32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// A dataset `panoconv synth ARGS --output DIR` writes, made once per binary build under
/// `CARGO_TARGET_TMPDIR/GROUP/NAME-KEY` (KEY: the binary's hash; older copies removed): the
/// synthetic sequences and scenes the rig tests share. Made on one thread, so that the
/// shipped fixtures (made on several) are checked against these copies: the generator's
/// bytes must not depend on the thread count.
pub fn synth_cache(group: &str, name: &str, args: &[&str]) -> PathBuf {
    let bin = std::fs::read(BIN).expect("read the panoconv binary");
    let key = &blake3::hash(&bin).to_hex()[..16];
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join(group);
    std::fs::create_dir_all(&root).unwrap();
    let dir = root.join(format!("{name}-{key}"));
    if dir.is_dir() {
        return dir;
    }
    for e in std::fs::read_dir(&root).unwrap().flatten() {
        if e.file_name()
            .to_string_lossy()
            .starts_with(&format!("{name}-"))
        {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
    let tmp = root.join(format!("tmp-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    let tmp_s = tmp.to_str().unwrap().to_owned();
    let mut all = vec!["synth"];
    all.extend(args);
    all.extend(["--output", &tmp_s]);
    let status = Command::new(BIN)
        .args(&all)
        .env("RAYON_NUM_THREADS", "1")
        .status()
        .expect("cannot start the panoconv binary");
    assert!(status.success(), "panoconv {all:?}: {status}");
    if std::fs::rename(&tmp, &dir).is_err() {
        let _ = std::fs::remove_dir_all(&tmp);
        assert!(dir.is_dir(), "synthetic data cache missing");
    }
    dir
}
