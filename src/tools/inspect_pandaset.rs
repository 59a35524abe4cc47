//! `panoconv inspect` on a PandaSet sequence (or a folder of them): not a layout the command
//! reads, so one set-up error that says what it is and what reads it (the Python package's
//! adapter, `python -m panoconv pandaset`), instead of "neither training/ nor testing/".

use crate::error::Error;
use std::path::Path;

/// Whether `dir` is a sequence folder in PandaSet's layout: `camera/`, `lidar/` and
/// `annotations/` or `meta/`.
fn is_sequence(dir: &Path) -> bool {
    dir.join("camera").is_dir()
        && dir.join("lidar").is_dir()
        && (dir.join("annotations").is_dir() || dir.join("meta").is_dir())
}

/// Sorted names of the entries of `dir` that `keep` accepts.
fn names(dir: &Path, keep: impl Fn(&Path) -> bool) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.flatten()
                .filter(|e| keep(&e.path()))
                .filter_map(|e| e.file_name().to_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

/// The refusal of `root` when it is a PandaSet sequence or holds some, else None.
pub(crate) fn pandaset_refusal(root: &Path) -> Option<Error> {
    let how = "panoconv reads PandaSet through its Python package (pip install \
               panoconv[pandaset]; docs/python.md, \"PandaSet\")";
    if is_sequence(root) {
        let frames = names(&root.join("lidar"), |p| {
            p.to_str().is_some_and(|n| n.ends_with(".pkl.gz"))
        });
        let cameras = names(&root.join("camera"), Path::is_dir);
        return Some(Error::Setup(format!(
            "{} is a PandaSet sequence ({} frames on disk, cameras {}), not a KITTI, \
             nuScenes or KITTI-360 root; {how}: `python -m panoconv pandaset --input {} --to \
             equirect --output O` converts it, then `panoconv inspect O` checks what it wrote",
            root.display(),
            frames.len(),
            cameras.join(", "),
            root.display()
        )));
    }
    let sequences = names(root, is_sequence);
    let first = sequences.first()?;
    let shown = sequences
        .iter()
        .take(5)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    let more = if sequences.len() > 5 { ", ..." } else { "" };
    Some(Error::Setup(format!(
        "{} holds PandaSet sequences ({shown}{more}), not a KITTI, nuScenes or KITTI-360 \
         root; {how}: `python -m panoconv pandaset --input {} --to equirect --output O` \
         converts one",
        root.display(),
        root.join(first).display()
    )))
}
