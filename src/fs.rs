//! File-system access with the error tagging of `error.rs`: reading whole files and lines,
//! atomic writes, the output-folder checks and content hashes.

use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Component, Path, PathBuf};

/// Reads a whole file, tagging failures with its path.
pub fn read_file(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| Error::io(path, e))
}

/// Reads a whole file into `buf` (cleared first), reusing its allocation.
pub fn read_file_into(path: &Path, buf: &mut Vec<u8>) -> Result<()> {
    use std::io::Read;
    buf.clear();
    let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    if let Ok(meta) = file.metadata() {
        buf.reserve(meta.len() as usize);
    }
    file.read_to_end(buf).map_err(|e| Error::io(path, e))?;
    Ok(())
}

/// The stems of the files named `*{ext}` in `dir` (`ext` with its dot), sorted; hidden files
/// and names that are not UTF-8 are left out.
pub fn file_stems(dir: &Path, ext: &str) -> std::io::Result<Vec<String>> {
    let mut stems = Vec::new();
    for entry in std::fs::read_dir(dir)? {
        let name = entry?.file_name();
        if let Some(stem) = name.to_str().and_then(|n| n.strip_suffix(ext)) {
            if !stem.starts_with('.') {
                stems.push(stem.to_owned());
            }
        }
    }
    stems.sort();
    Ok(stems)
}

/// The names of the folders in `dir` that hold a file `name`, sorted (none when `dir` cannot
/// be read).
pub fn folders_holding(dir: &Path, name: &str) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| e.path().join(name).is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Reads a text file as lines (LF or CRLF), tagging a non-UTF-8 line with its number.
pub fn read_lines(path: &Path) -> Result<Vec<String>> {
    split_lines(&read_file(path)?, path)
}

/// The lines of a text file already read (LF or CRLF); `path` tags a non-UTF-8 line.
pub fn split_lines(bytes: &[u8], path: &Path) -> Result<Vec<String>> {
    bytes
        .split(|&b| b == b'\n')
        .enumerate()
        .map(|(i, raw)| {
            let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
            String::from_utf8(raw.to_vec())
                .map_err(|_| Error::parse(path, i + 1, "text", "line is not valid UTF-8"))
        })
        .collect::<Result<Vec<_>>>()
        .map(|mut lines| {
            // A final newline leaves one empty element behind, not a line.
            if lines.last().is_some_and(|l| l.is_empty()) {
                lines.pop();
            }
            lines
        })
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so a
/// reader (or a killed process) never sees a half-written file. Not fsynced: a frame's files
/// are many and small, and after an OS crash `--resume` re-hashes every output anyway; the
/// manifest, the commit point, goes through [`write_atomic_durable`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_via_temporary(path, bytes, false)
}

/// As [`write_atomic`], and on disk before the rename.
pub fn write_atomic_durable(path: &Path, bytes: &[u8]) -> Result<()> {
    write_via_temporary(path, bytes, true)
}

/// The temporary file beside `path` that an atomic write of it goes through (hidden, named
/// by the process, so that `--resume` can find and remove what a killed run left).
pub fn temporary_path(path: &Path) -> PathBuf {
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    dir.join(format!(".{name}.tmp-{}", std::process::id()))
}

fn write_via_temporary(path: &Path, bytes: &[u8], durable: bool) -> Result<()> {
    let tmp = temporary_path(path);
    let write = || -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        if durable {
            f.sync_data()?;
        }
        std::fs::rename(&tmp, path)
    };
    write().map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}

/// `path` made absolute and free of `.`/`..`, resolving symlinks as far as the path exists.
pub(crate) fn resolve(path: &Path) -> Result<PathBuf> {
    let joined = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()
            .map_err(|e| Error::io(Path::new("."), e))?
            .join(path)
    };
    // `..` after a folder that does not exist yet can only be resolved lexically.
    let mut abs = PathBuf::new();
    for c in joined.components() {
        match c {
            Component::ParentDir if !abs.exists() => {
                abs.pop();
            }
            Component::CurDir => {}
            c => abs.push(c),
        }
    }
    let mut existing = abs.clone();
    let mut rest = Vec::new();
    while !existing.exists() {
        match (existing.file_name(), existing.parent()) {
            (Some(n), Some(p)) => {
                rest.push(n.to_owned());
                existing = p.to_path_buf();
            }
            _ => break,
        }
    }
    let mut out = existing
        .canonicalize()
        .map_err(|e| Error::io(&existing, e))?;
    for c in rest.iter().rev() {
        match Path::new(c).components().next() {
            Some(Component::ParentDir) => {
                out.pop();
            }
            Some(Component::CurDir) | None => {}
            _ => out.push(c),
        }
    }
    Ok(out)
}

/// Checks, before anything is written, that the output is usable: not the input, not inside it,
/// and empty unless `overwrite`.
pub fn check_output_dir(input: &Path, output: &Path, overwrite: bool) -> Result<()> {
    let (i, o) = (resolve(input)?, resolve(output)?);
    if o == i {
        return Err(Error::Setup(format!(
            "output {} is the input dataset",
            output.display()
        )));
    }
    if o.starts_with(&i) {
        return Err(Error::Setup(format!(
            "output {} is inside the input dataset {}; panoconv never writes into its input",
            output.display(),
            input.display()
        )));
    }
    if output.exists() {
        if !output.is_dir() {
            return Err(Error::Setup(format!(
                "output {} exists and is not a directory",
                output.display()
            )));
        }
        let mut entries = std::fs::read_dir(output).map_err(|e| Error::io(output, e))?;
        if entries.next().is_some() && !overwrite {
            return Err(Error::OutputNotEmpty {
                output: output.to_path_buf(),
                advice: "use --overwrite to write into it",
            });
        }
    }
    Ok(())
}

/// The BLAKE3 hash of `bytes` as 64 lowercase hex digits (the hashes in manifests).
pub fn hash_hex(bytes: &[u8]) -> String {
    blake3::hash(bytes).to_hex().to_string()
}

/// The tree under `root`, without following symlinks (no loops, and nothing outside `root` is
/// reached): every non-folder entry (files, symlinks, others) relative to `root` with `/`
/// separators, and every folder below `root`, each listed after its contents.
pub fn walk_tree(root: &Path) -> Result<(Vec<String>, Vec<PathBuf>)> {
    fn walk(
        root: &Path,
        dir: &Path,
        files: &mut Vec<String>,
        dirs: &mut Vec<PathBuf>,
    ) -> Result<()> {
        for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
            let entry = entry.map_err(|e| Error::io(dir, e))?;
            let path = entry.path();
            let kind = entry.file_type().map_err(|e| Error::io(&path, e))?;
            if kind.is_dir() {
                walk(root, &path, files, dirs)?;
                dirs.push(path);
            } else {
                let rel = path.strip_prefix(root).unwrap_or(&path);
                let parts: Vec<String> = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                files.push(parts.join("/"));
            }
        }
        Ok(())
    }
    let (mut files, mut dirs) = (Vec::new(), Vec::new());
    walk(root, root, &mut files, &mut dirs)?;
    Ok((files, dirs))
}
