//! Files of an object dataset that no frame takes: an image that is not a PNG (a `.jpg` in
//! `image_2/`), or a calib or label with no image beside it. A conversion does not fail on them
//! (they are not frames), but it names them in its summary, as `inspect` does, so that a
//! dataset smaller than its folder does not go unnoticed.

use super::{Dataset, Layout};

/// Each such file as `split/folder/name: why`, in name order (every split's, object layout
/// only; hidden files aside).
pub fn list(dataset: &Dataset) -> Vec<String> {
    let mut out = Vec::new();
    for split in &dataset.splits {
        if !matches!(split.layout, Layout::Object) {
            continue;
        }
        let unusable_stems: Vec<&str> = split
            .unusable
            .iter()
            .map(|n| n.rsplit_once('.').map_or(n.as_str(), |(s, _)| s))
            .collect();
        let has_image = |stem: &str| {
            split
                .frames
                .binary_search_by(|f| f.as_str().cmp(stem))
                .is_ok()
                || unusable_stems.contains(&stem)
        };
        for name in names(&split.dir.join("image_2")) {
            let png = name
                .rsplit_once('.')
                .is_some_and(|(_, ext)| ext.eq_ignore_ascii_case("png"));
            if !png {
                let why = if name.rsplit_once('.').is_some_and(|(_, e)| {
                    e.eq_ignore_ascii_case("jpg") || e.eq_ignore_ascii_case("jpeg")
                }) {
                    "the file is a JPEG; KITTI images are PNG"
                } else {
                    "not a .png image"
                };
                out.push(format!("{}/image_2/{name}: {why}", split.name));
            }
        }
        let mut folders = vec!["calib"];
        if split.has_labels {
            folders.push("label_2");
        }
        for folder in folders {
            for name in names(&split.dir.join(folder)) {
                let Some(stem) = name.strip_suffix(".txt") else {
                    continue;
                };
                if !has_image(stem) {
                    out.push(format!(
                        "{}/{folder}/{name}: no image_2/{stem}.png for it",
                        split.name
                    ));
                }
            }
        }
    }
    out.sort();
    out
}

/// The visible file names of a folder (none when it cannot be read).
fn names(dir: &std::path::Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    entries
        .flatten()
        .filter(|e| e.file_type().is_ok_and(|t| !t.is_dir()))
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .collect()
}
