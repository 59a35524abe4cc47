//! The KITTI object layout: `ROOT/{training,testing}/{image_2,calib,label_2}/NNNNNN.*`.

use crate::error::{Error, Result};
use crate::kitti::Cam;
use std::path::{Path, PathBuf};

/// One split of a dataset: an object split (`training`, `testing`) or a raw drive.
#[derive(Debug, Clone)]
pub struct Split {
    /// `training`, `testing`, or the drive folder's name; also its output folder's name.
    pub name: String,
    /// The split's folder in the input.
    pub dir: PathBuf,
    /// Whether `label_2/` exists (testing and raw drives have no labels).
    pub has_labels: bool,
    /// Frame ids (file stems of image_2/*.png), sorted.
    pub frames: Vec<String>,
    /// Image file names that look like frames but cannot be (`.PNG`, a name that is not
    /// UTF-8), sorted: each is reported as a failed frame rather than silently left out.
    pub unusable: Vec<String>,
    /// Where the split keeps its files.
    pub layout: Layout,
}

/// Where a split keeps its files.
#[derive(Debug, Clone)]
pub enum Layout {
    /// KITTI object: `image_2/ID.png`, `calib/ID.txt`, `velodyne/ID.bin`, `label_2/ID.txt`.
    Object,
    /// A KITTI raw drive: `image_02/data/ID.png`, `velodyne_points/data/ID.bin`, and one
    /// calibration for the whole drive (composed from the date folder's files).
    Raw {
        /// The drive's calibration, composed once from the date folder.
        calib: Box<crate::kitti::Calib>,
    },
}

/// The files a conversion writes for a frame, relative to the split's output folder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    /// Camera n's image (`image_2/`, `image_3/`).
    Image(Cam),
    /// Where camera n's output pixels have source data (`--mask`).
    Mask(Cam),
    /// The LiDAR depth map of camera 2 (`depth_2/`).
    Depth,
    /// The labels (`label_2/`).
    Label,
    /// The calib (`calib/`).
    Calib,
    /// A rig output's camera of each pixel (`source_2/`).
    Source,
    /// A rig output's objects record (`objects/`).
    Objects,
    /// The distance each pixel of a rig output was stitched at (`stitch_depth_2/`).
    StitchDepth,
}

impl OutputKind {
    /// Its folder under an object split (`image_2`, `label_2`, ...).
    pub fn folder(self) -> String {
        match self {
            OutputKind::Image(c) => format!("image_{c}"),
            OutputKind::Mask(c) => format!("mask_{c}"),
            OutputKind::Depth => "depth_2".into(),
            OutputKind::Label => "label_2".into(),
            OutputKind::Calib => "calib".into(),
            OutputKind::Source => "source_2".into(),
            OutputKind::Objects => "objects".into(),
            OutputKind::StitchDepth => "stitch_depth_2".into(),
        }
    }

    /// Its files' extension.
    pub fn extension(self) -> &'static str {
        match self {
            OutputKind::Label | OutputKind::Calib => "txt",
            OutputKind::Objects => "json",
            _ => "png",
        }
    }

    /// Frame `id`'s file of this kind under an object split (`label_2/000042.txt`).
    pub fn object_path(self, id: &str) -> PathBuf {
        PathBuf::from(self.folder()).join(format!("{id}.{}", self.extension()))
    }
}

/// A KITTI dataset on disk: its root and the splits found there.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// The folder given as input.
    pub root: PathBuf,
    /// Its splits, in name order (training before testing).
    pub splits: Vec<Split>,
}

/// One frame to convert.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct FrameRef {
    /// The split's name (`training`, `testing`, or a raw drive).
    pub split: String,
    /// The frame id (the image's file stem).
    pub id: String,
}

impl std::fmt::Display for FrameRef {
    /// `split/id`, as in messages and progress reports.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.split, self.id)
    }
}

/// The object dataset's split folders.
pub const SPLITS: [&str; 2] = ["training", "testing"];

/// The frame ids (stems of `*.png`) of an image folder, sorted, and the file names that look
/// like frames but cannot be used (see [`Split::unusable`]). Hidden files are ignored.
pub(crate) fn list_frames(
    entries: std::fs::ReadDir,
    dir: &Path,
) -> Result<(Vec<String>, Vec<String>)> {
    let (mut frames, mut unusable) = (Vec::new(), Vec::new());
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        let os_name = entry.file_name();
        let lossy = os_name.to_string_lossy();
        if lossy.starts_with('.') {
            continue;
        }
        let Some((stem, ext)) = lossy.rsplit_once('.') else {
            continue;
        };
        if !ext.eq_ignore_ascii_case("png") {
            continue;
        }
        match os_name.to_str() {
            Some(_) if ext == "png" => frames.push(stem.to_owned()),
            _ => unusable.push(lossy.into_owned()),
        }
    }
    frames.sort();
    unusable.sort();
    Ok((frames, unusable))
}

/// What a folder that is not a KITTI object root looks like instead, and what to do about it.
fn layout_hint(root: &Path) -> String {
    let is_raw_date = root.join("calib_cam_to_cam.txt").is_file()
        || std::fs::read_dir(root).is_ok_and(|entries| {
            entries
                .flatten()
                .any(|e| e.file_name().to_string_lossy().contains("_drive_"))
        });
    if is_raw_date {
        return ": it looks like a KITTI raw date folder (calib_cam_to_cam.txt, *_drive_*_sync/): \
                convert it with `panoconv kitti-raw`"
            .into();
    }
    let tree = "INPUT/training/{image_2/000000.png, label_2/000000.txt, calib/000000.txt}, \
                and INPUT/testing/ likewise without label_2/";
    if root.join("image_2").is_dir() {
        return format!(
            ": image_2/ is at its top; a KITTI object root keeps it in training/ (or testing/): \
             move image_2/, label_2/, calib/ (and velodyne/) into {} (expected {tree})",
            root.join("training").display()
        );
    }
    format!(" (expected a KITTI object root: {tree})")
}

/// Why an image folder gave no frame: what it holds instead.
pub fn no_frames_reason(image_dir: &Path) -> String {
    let pattern = image_dir.join("*.png");
    let mut by_ext: std::collections::BTreeMap<String, usize> = Default::default();
    let mut total = 0;
    if let Ok(entries) = std::fs::read_dir(image_dir) {
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') {
                continue;
            }
            total += 1;
            if let Some((_, ext)) = name.rsplit_once('.') {
                *by_ext.entry(ext.to_ascii_lowercase()).or_default() += 1;
            }
        }
    }
    let what = match by_ext.iter().max_by_key(|(_, n)| **n) {
        None if total == 0 => "the folder is empty".to_owned(),
        None => format!("{total} files there, none of them .png"),
        Some((ext, n)) if matches!(ext.as_str(), "jpg" | "jpeg") => {
            format!("{n} .{ext} files there: KITTI images are PNG")
        }
        Some((ext, n)) => format!("{n} .{ext} files there, none of them .png"),
    };
    format!("{}: no frames; {what}", pattern.display())
}

/// `000000..000007 (6 frames)`: the ids a split holds, for messages.
fn id_range(frames: &[String]) -> String {
    match (frames.first(), frames.last()) {
        (Some(a), Some(_)) if frames.len() == 1 => format!("{a} (1 frame)"),
        (Some(a), Some(b)) => format!("{a}..{b} ({} frames)", frames.len()),
        _ => "no frames".into(),
    }
}

impl Split {
    /// Camera `camera`'s image of frame `id`.
    pub fn image_path(&self, camera: Cam, id: &str) -> PathBuf {
        match self.layout {
            Layout::Object => self
                .dir
                .join(format!("image_{camera}"))
                .join(format!("{id}.png")),
            Layout::Raw { .. } => self.dir.join(format!("image_0{camera}/data/{id}.png")),
        }
    }

    /// The Velodyne scan of frame `id`.
    pub fn velodyne_path(&self, id: &str) -> PathBuf {
        match self.layout {
            Layout::Object => self.dir.join("velodyne").join(format!("{id}.bin")),
            Layout::Raw { .. } => self.dir.join(format!("velodyne_points/data/{id}.bin")),
        }
    }

    /// An output file of a frame, relative to the split's output folder (None: this layout
    /// has no such file per frame; raw drives write one calib, see `split_calib_output`).
    pub fn output_path(&self, kind: OutputKind, id: &str) -> Option<PathBuf> {
        if !matches!(self.layout, Layout::Raw { .. }) {
            return Some(kind.object_path(id));
        }
        Some(PathBuf::from(match kind {
            OutputKind::Image(c) => format!("image_0{c}/data/{id}.png"),
            OutputKind::Mask(c) => format!("mask_0{c}/data/{id}.png"),
            OutputKind::Depth => format!("depth_02/data/{id}.png"),
            _ => return None,
        }))
    }

    /// The calib written once for the whole split (raw drives: `calib.txt`).
    pub fn split_calib_output(&self) -> Option<PathBuf> {
        matches!(self.layout, Layout::Raw { .. }).then(|| PathBuf::from("calib.txt"))
    }
    /// The calib of frame `id` (object layout).
    pub fn calib_path(&self, id: &str) -> PathBuf {
        self.dir.join("calib").join(format!("{id}.txt"))
    }
    /// The labels of frame `id` (object layout).
    pub fn label_path(&self, id: &str) -> PathBuf {
        self.dir.join("label_2").join(format!("{id}.txt"))
    }
}

impl Dataset {
    /// Finds the splits under `root`; `only` restricts to one split by name.
    pub fn open(root: &Path, only: Option<&str>) -> Result<Dataset> {
        if !root.is_dir() {
            return Err(Error::Setup(format!(
                "input {} is not a directory",
                root.display()
            )));
        }
        if let Some(name) = only {
            if !SPLITS.contains(&name) {
                return Err(Error::Setup(format!(
                    "unknown split {name:?}: expected training or testing"
                )));
            }
        }
        let mut splits = Vec::new();
        for name in SPLITS {
            if only.is_some_and(|o| o != name) {
                continue;
            }
            let dir = root.join(name);
            if !dir.is_dir() {
                if only.is_some() {
                    return Err(Error::Setup(format!(
                        "input has no {} folder",
                        dir.display()
                    )));
                }
                continue;
            }
            let image_dir = dir.join("image_2");
            let entries = std::fs::read_dir(&image_dir).map_err(|e| {
                Error::Setup(format!(
                    "{}: {e} (a KITTI split needs image_2/)",
                    image_dir.display()
                ))
            })?;
            let (frames, unusable) = list_frames(entries, &image_dir)?;
            let has_labels = name == "training";
            if has_labels && !dir.join("label_2").is_dir() {
                return Err(Error::Setup(format!(
                    "{}: the training split has no label_2/ folder",
                    dir.display()
                )));
            }
            splits.push(Split {
                name: name.to_owned(),
                dir,
                has_labels,
                frames,
                unusable,
                layout: Layout::Object,
            });
        }
        if splits.is_empty() {
            return Err(Error::Setup(format!(
                "input {} holds neither training/ nor testing/{}",
                root.display(),
                layout_hint(root)
            )));
        }
        Ok(Dataset {
            root: root.to_path_buf(),
            splits,
        })
    }

    /// Checks a selection before anything is written: `Err` (a set-up error) when it holds no
    /// frame at all, or names frames that no split has.
    pub fn check_selection(&self, frames: &[FrameRef], missing: &[String]) -> Result<()> {
        let ranges = || {
            self.splits
                .iter()
                .map(|s| format!("{}: {}", s.name, id_range(&s.frames)))
                .collect::<Vec<_>>()
                .join("; ")
        };
        if !missing.is_empty() {
            const SHOWN: usize = 5;
            let mut named = missing[..missing.len().min(SHOWN)].join(", ");
            if missing.len() > SHOWN {
                named.push_str(&format!(" and {} more", missing.len() - SHOWN));
            }
            let noun = if missing.len() == 1 {
                "frame"
            } else {
                "frames"
            };
            return Err(Error::Setup(format!(
                "{noun} {named} not found in {} ({})",
                self.root.display(),
                ranges()
            )));
        }
        let unusable = self.splits.iter().any(|s| !s.unusable.is_empty());
        if frames.is_empty() && !unusable {
            let reasons: Vec<String> = self
                .splits
                .iter()
                .map(|s| match s.layout {
                    Layout::Object if s.frames.is_empty() => {
                        no_frames_reason(&s.dir.join("image_2"))
                    }
                    Layout::Raw { .. } if s.frames.is_empty() => {
                        no_frames_reason(&s.dir.join("image_02/data"))
                    }
                    _ => format!("{}: {}", s.name, id_range(&s.frames)),
                })
                .collect();
            return Err(Error::Setup(format!(
                "nothing to convert: {}",
                reasons.join("; ")
            )));
        }
        Ok(())
    }

    /// Checks, before anything is written, that every split with frames has the folders the
    /// run reads: `calib/` (object layout), `image_3/` for the right camera, `velodyne/` for
    /// depth. A missing folder is one set-up error, not a failure of every frame.
    pub fn check_folders(&self, cameras: &[Cam], depth: bool) -> Result<()> {
        for split in self.splits.iter().filter(|s| !s.frames.is_empty()) {
            let first = &split.frames[0];
            let mut needed = Vec::new();
            if matches!(split.layout, Layout::Object) {
                needed.push((split.calib_path(first), "the conversion"));
            }
            if cameras.contains(&Cam::C3) {
                needed.push((split.image_path(Cam::C3, first), "--cameras 2,3"));
            }
            if depth {
                needed.push((split.velodyne_path(first), "--depth"));
            }
            for (file, option) in needed {
                let dir = file.parent().unwrap_or(&split.dir);
                if !dir.is_dir() {
                    return Err(Error::Setup(format!(
                        "{option} reads {}, which does not exist in split {}",
                        dir.display(),
                        split.name
                    )));
                }
            }
        }
        Ok(())
    }

    /// The split named `name`.
    pub fn split(&self, name: &str) -> Option<&Split> {
        self.splits.iter().find(|s| s.name == name)
    }

    /// Every frame, or those whose id is in `ids`. Listed ids found in no split come back in
    /// the second vector, so that they are reported rather than silently skipped.
    pub fn select(&self, ids: Option<&[String]>) -> (Vec<FrameRef>, Vec<String>) {
        let mut frames = Vec::new();
        let mut missing = Vec::new();
        match ids {
            None => {
                for s in &self.splits {
                    frames.extend(s.frames.iter().map(|id| FrameRef {
                        split: s.name.clone(),
                        id: id.clone(),
                    }));
                }
            }
            Some(ids) => {
                let mut ids: Vec<&String> = ids.iter().collect();
                ids.sort();
                ids.dedup();
                for id in ids {
                    let mut found = false;
                    for s in &self.splits {
                        if s.frames.binary_search(id).is_ok() {
                            found = true;
                            frames.push(FrameRef {
                                split: s.name.clone(),
                                id: id.clone(),
                            });
                        }
                    }
                    if !found {
                        missing.push(id.clone());
                    }
                }
                frames.sort();
            }
        }
        (frames, missing)
    }
}

/// Frame ids from a list file (one per line, `#` comments and blank lines ignored).
pub fn read_id_list(path: &Path) -> Result<Vec<String>> {
    let lines = crate::fs::read_lines(path)?;
    let mut ids = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let t = line.split('#').next().unwrap_or("").trim();
        if t.is_empty() {
            continue;
        }
        if t.contains(|c: char| c.is_whitespace() || c == '/' || c == '\\') {
            return Err(Error::parse(
                path,
                i + 1,
                "frame id",
                format!("{t:?} is not a frame id"),
            ));
        }
        ids.push(t.to_owned());
    }
    Ok(ids)
}
