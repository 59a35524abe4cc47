//! The file checks of `panoconv inspect` that need no parser: a PNG whole through IEND, a
//! velodyne scan a whole number of points, and the per-frame files a split has for some
//! frames but not others. Cheap on purpose: a PNG's chunks are walked by their lengths
//! (a few dozen 8-byte reads, no decode) and a scan is only its length, so a 7 481-frame
//! split is checked in the time its directory listings take.

use crate::kitti::{Cam, Split};
use std::fs::File;
use std::path::Path;

/// What is wrong with the PNG at `path` past its header, or None when its chunks run whole
/// through IEND. The header itself is read (and reported) by the size check; unreadable files
/// are reported there too.
pub(crate) fn png_incomplete(path: &Path) -> Option<String> {
    let mut f = File::open(path).ok()?;
    let len = f.metadata().ok()?.len();
    // after the 8-byte signature: length (4), type (4), data, CRC (4) per chunk
    let mut pos = 8u64;
    let mut last = String::from("signature");
    loop {
        if pos + 12 > len {
            return Some(format!(
                "truncated: {len} bytes, ending after the {last} chunk at byte {pos} without the IEND chunk"
            ));
        }
        let mut head = [0u8; 8];
        read_at(&mut f, pos, &mut head).ok()?;
        let n = u64::from(u32::from_be_bytes([head[0], head[1], head[2], head[3]]));
        let kind = &head[4..8];
        if !kind.iter().all(u8::is_ascii_alphabetic) {
            return Some(format!(
                "corrupt: no PNG chunk at byte {pos} (after the {last} chunk): the bytes there are not a chunk type"
            ));
        }
        let kind = String::from_utf8_lossy(kind).into_owned();
        let end = pos + 12 + n;
        if end > len {
            return Some(format!(
                "truncated: the {kind} chunk at byte {pos} holds {n} bytes but the file ends at byte {len}"
            ));
        }
        if kind == "IEND" {
            return None;
        }
        pos = end;
        last = kind;
    }
}

/// Fills `buf` from byte `pos`: one positional read where the platform has it (a KITTI PNG
/// has about 90 chunks, so this halves inspect's system time against seek + read).
#[cfg(unix)]
fn read_at(f: &mut File, pos: u64, buf: &mut [u8]) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(f, buf, pos)
}

#[cfg(not(unix))]
fn read_at(f: &mut File, pos: u64, buf: &mut [u8]) -> std::io::Result<()> {
    use std::io::{Read, Seek, SeekFrom};
    f.seek(SeekFrom::Start(pos))?;
    f.read_exact(buf)
}

/// What is wrong with the velodyne scan at `path` by its length alone (the conversion's
/// parser refuses the same), or None.
pub(crate) fn scan_incomplete(path: &Path) -> Option<String> {
    crate::kitti::velodyne::length_problem(std::fs::metadata(path).ok()?.len())
}

/// `split/…`, a file of the split relative to the dataset root.
fn rel(split: &Split, path: &Path) -> String {
    let inner = path.strip_prefix(&split.dir).unwrap_or(path);
    format!("{}/{}", split.name, inner.display())
}

/// The files a frame may have beyond image_2, calib and labels: each is checked where the
/// split has it for at least one frame (none at all is a split without that data).
struct Companion {
    folder: &'static str,
    ext: &'static str,
    path: fn(&Split, &str) -> std::path::PathBuf,
    check: fn(&Path) -> Option<String>,
}

const COMPANIONS: [Companion; 2] = [
    Companion {
        folder: "image_3",
        ext: ".png",
        path: |s, id| s.image_path(Cam::C3, id),
        check: png_incomplete,
    },
    Companion {
        folder: "velodyne",
        ext: ".bin",
        path: |s, id| s.velodyne_path(id),
        check: scan_incomplete,
    },
];

/// A file's problem: its path within the dataset and the message.
pub(crate) type FileProblem = (String, String);

/// The image_2 PNG's problem past its header.
pub(crate) fn image_problem(split: &Split, id: &str) -> Option<FileProblem> {
    let path = split.image_path(Cam::C2, id);
    png_incomplete(&path).map(|m| (rel(split, &path), m))
}

/// Missing and broken image_3 PNGs and velodyne scans of the split's frames.
pub(crate) fn companion_problems(split: &Split) -> Vec<FileProblem> {
    let mut problems = Vec::new();
    for c in &COMPANIONS {
        let Some(first) = split.frames.first() else {
            break;
        };
        let dir = (c.path)(split, first)
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        let have = crate::fs::file_stems(&dir, c.ext).unwrap_or_default();
        let some = split
            .frames
            .iter()
            .filter(|id| have.binary_search(id).is_ok())
            .count();
        if some == 0 {
            continue;
        }
        for id in &split.frames {
            let path = (c.path)(split, id);
            let file = rel(split, &path);
            if have.binary_search(id).is_err() {
                problems.push((
                    file,
                    format!(
                        "missing ({some} of the split's {} frames have a {} file)",
                        split.frames.len(),
                        c.folder
                    ),
                ));
            } else if let Some(m) = (c.check)(&path) {
                problems.push((file, m));
            }
        }
    }
    problems
}
