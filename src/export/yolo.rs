//! The Ultralytics YOLO detection layout:
//!
//! ```text
//! OUT/data.yaml                 path (absolute), train/val/test image folders, names
//! OUT/images/<split>/ID.png     symbolic link to the dataset's image (relative target)
//! OUT/labels/<split>/ID.txt     `class cx cy w h`, normalised to the image size
//! ```
//!
//! The boxes are the COCO export's (same pixel convention: cx = (left + right)/2 + 0.5 over
//! the width). YOLO has no ignore regions: DontCare is left out. The folder is built beside
//! OUT and moved into place at the end, so OUT is either the old export or the new one.

use crate::error::{Error, Result};
use crate::export::coco::{frame_boxes, COCO_FROM_KITTI_PIXEL};
use crate::export::{exported_file, ExportData, ExportOptions, ExportSplit, ExportedFile, Frame};
use crate::fs::resolve;
use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

/// One frame's label file.
pub fn label_text(frame: &Frame) -> String {
    let (w, h) = (frame.size.width as f64, frame.size.height as f64);
    let mut text = String::new();
    for (category, b, _, _) in frame_boxes(frame) {
        let cx = ((b[0] + b[2]) / 2.0 + COCO_FROM_KITTI_PIXEL) / w;
        let cy = ((b[1] + b[3]) / 2.0 + COCO_FROM_KITTI_PIXEL) / h;
        let bw = (b[2] - b[0]) / w;
        let bh = (b[3] - b[1]) / h;
        let _ = writeln!(text, "{category} {cx:.7} {cy:.7} {bw:.7} {bh:.7}");
    }
    text
}

/// A YAML double-quoted scalar (JSON's string syntax is valid YAML).
fn quoted(s: &str) -> String {
    serde_json::to_string(s).expect("a string serialises")
}

fn data_yaml(data: &ExportData, root: &Path, splits: &[ExportSplit]) -> String {
    let mut y = String::from("# Ultralytics dataset written by panoconv export\n");
    let _ = writeln!(y, "path: {}", quoted(&root.to_string_lossy()));
    let has = |s: ExportSplit| splits.contains(&s);
    let _ = writeln!(y, "train: images/{}", ExportSplit::Train);
    // Ultralytics needs a val entry: without a val split, training images stand in.
    let val = if has(ExportSplit::Val) {
        ExportSplit::Val
    } else {
        ExportSplit::Train
    };
    let _ = writeln!(y, "val: images/{val}");
    if has(ExportSplit::Test) {
        let _ = writeln!(y, "test: images/{}", ExportSplit::Test);
    }
    y.push_str("names:\n");
    for (i, name) in data.categories.iter().enumerate() {
        let _ = writeln!(y, "  {i}: {}", quoted(name));
    }
    y
}

/// `target` relative to the folder `from` (both absolute and resolved).
fn relative_path(from: &Path, target: &Path) -> PathBuf {
    let from: Vec<Component> = from.components().collect();
    let to: Vec<Component> = target.components().collect();
    let common = from.iter().zip(&to).take_while(|(a, b)| a == b).count();
    let mut rel = PathBuf::new();
    for _ in common..from.len() {
        rel.push("..");
    }
    for c in &to[common..] {
        rel.push(c);
    }
    rel
}

#[cfg(unix)]
fn link(target: &Path, link: &Path) -> std::io::Result<()> {
    std::os::unix::fs::symlink(target, link)
}

#[cfg(not(unix))]
fn link(target: &Path, link: &Path) -> std::io::Result<()> {
    let resolved = link.parent().unwrap_or(Path::new(".")).join(target);
    std::fs::copy(resolved, link).map(|_| ())
}

/// Writes the YOLO layout into `output`, which must lie outside the dataset and be empty unless
/// `options.overwrite` (then it is replaced whole); returns the label files and `data.yaml`.
pub fn write(
    data: &ExportData,
    output: &Path,
    options: &ExportOptions,
) -> Result<Vec<ExportedFile>> {
    let root = resolve(&data.root)?;
    let out = resolve(output)?;
    if out.starts_with(&root) {
        return Err(Error::Setup(format!(
            "YOLO output {} is inside the dataset {}: its images/ are links into the dataset, put it beside it (e.g. {}_yolo)",
            output.display(),
            data.root.display(),
            data.root.display()
        )));
    }
    let splits = data.splits();
    if splits.is_empty() {
        return Err(Error::Setup(format!(
            "{}: no frame to export",
            data.root.display()
        )));
    }
    if out.exists() {
        let mut entries = std::fs::read_dir(&out).map_err(|e| Error::io(&out, e))?;
        if entries.next().is_some() && !options.overwrite {
            return Err(Error::OutputNotEmpty {
                output: output.to_path_buf(),
                advice: "use --overwrite to replace it",
            });
        }
    }
    let parent = out.parent().unwrap_or(Path::new("/")).to_path_buf();
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    std::fs::create_dir_all(&parent).map_err(|e| Error::io(&parent, e))?;
    let staging = parent.join(format!(".{name}.partial-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&staging);
    let result = fill(data, &out, &staging, &splits);
    let files = match result {
        Ok(files) => files,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&staging);
            return Err(e);
        }
    };
    // Swap: the old export (if any) is moved aside, then removed once the new one is in place.
    let old = parent.join(format!(".{name}.old-{}", std::process::id()));
    if out.exists() {
        std::fs::rename(&out, &old).map_err(|e| Error::io(&out, e))?;
    }
    if let Err(e) = std::fs::rename(&staging, &out) {
        let _ = std::fs::rename(&old, &out);
        let _ = std::fs::remove_dir_all(&staging);
        return Err(Error::io(&out, e));
    }
    let _ = std::fs::remove_dir_all(&old);
    files
        .into_iter()
        .map(|(rel, bytes)| exported_file(&data.root, out.join(rel), &bytes))
        .collect()
}

/// Writes the export into `staging` (as it will be at `out`); returns (path relative to the
/// export folder, bytes) of each regular file.
fn fill(
    data: &ExportData,
    out: &Path,
    staging: &Path,
    splits: &[(ExportSplit, Vec<&Frame>)],
) -> Result<Vec<(String, Vec<u8>)>> {
    let mut files = Vec::new();
    for (split, frames) in splits {
        let (images, labels) = (
            staging.join("images").join(split.name()),
            staging.join("labels").join(split.name()),
        );
        for dir in [&images, &labels] {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
        let final_images = out.join("images").join(split.name());
        for f in frames {
            let image = resolve(&f.image)?;
            let target = relative_path(&final_images, &image);
            let name = format!("{}.png", f.id);
            link(&target, &images.join(&name)).map_err(|e| Error::io(&images.join(&name), e))?;
            let rel = format!("labels/{split}/{}.txt", f.id);
            let text = label_text(f).into_bytes();
            std::fs::write(staging.join(&rel), &text)
                .map_err(|e| Error::io(&staging.join(&rel), e))?;
            files.push((rel, text));
        }
    }
    let names: Vec<ExportSplit> = splits.iter().map(|(s, _)| *s).collect();
    let yaml = data_yaml(data, out, &names).into_bytes();
    std::fs::write(staging.join("data.yaml"), &yaml)
        .map_err(|e| Error::io(&staging.join("data.yaml"), e))?;
    files.push(("data.yaml".to_owned(), yaml));
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_between_folders() {
        assert_eq!(
            relative_path(
                Path::new("/a/o_yolo/images/train"),
                Path::new("/a/o/training/image_2/1.png")
            ),
            PathBuf::from("../../../o/training/image_2/1.png")
        );
    }
}
