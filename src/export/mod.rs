//! Exports of a converted (or plain KITTI) dataset to the formats trainers load as they are:
//! COCO JSON, the Ultralytics YOLO layout, and Omni3D's JSON (docs/formats.md, "Exports").
//!
//! Everything comes from the *written* files: `label_2` for the objects, `calib` for the
//! camera (`projection:`/`K2:`/`C2:`, or `P2` for plain KITTI), the image for its size. A
//! frame is read whole or reported as failed; nothing is written until every frame has been
//! read, and each file is written atomically.

mod boxes;
mod classes;
mod coco;
mod exact;
mod omni3d;
mod split;
mod yolo;

pub use classes::{ClassLookup, ClassMap};
pub use exact::ExactBox;
pub use split::{ExportSplit, SplitRule};

use crate::camera::{ImageSize, OutputCamera};
use crate::codec::png;
use crate::error::{Error, Result};
use crate::fs::read_lines;
use crate::fs::{hash_hex, write_atomic};
use crate::kitti::Cam;
use crate::kitti::{Calib, Dataset, FrameRef, Label};
use crate::reproject::visibility::Visibility;
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

/// An export format (`--format`, or `--export` of a conversion).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// COCO detection JSON, `instances_<split>.json` (`export/coco.rs`).
    Coco,
    /// The Ultralytics YOLO folder layout (`export/yolo.rs`).
    Yolo,
    /// Omni3D's JSON for Cube R-CNN, `Omni3D_<split>.json` (`export/omni3d.rs`).
    Omni3d,
}

impl Format {
    /// The format's name on the command line: `coco`, `yolo` or `omni3d`.
    pub fn name(self) -> &'static str {
        match self {
            Format::Coco => "coco",
            Format::Yolo => "yolo",
            Format::Omni3d => "omni3d",
        }
    }
}

/// How to export a dataset, whatever the format.
#[derive(Debug, Clone)]
pub struct ExportOptions {
    /// Which KITTI types become which categories (`--classes`).
    pub classes: ClassMap,
    /// How the labelled frames divide into train and val (`--image-sets`, `--val-fraction`).
    pub split_rule: SplitRule,
    /// Replace export files (or a YOLO folder) that already exist.
    pub overwrite: bool,
    /// Put before every image path in COCO's `file_name` and Omni3D's `file_path` (which are
    /// otherwise relative to the dataset root), e.g. `kitti_equi/` for Cube R-CNN's
    /// `datasets/` image root.
    pub path_prefix: String,
    /// Which labelled objects are exported as objects; the others become ignore regions
    /// (`--min-visible`; the label's truncation stands for the hidden share of its box).
    pub visibility: Visibility,
}

/// One file an export wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportedFile {
    /// Where it was written (inside the output folder given).
    pub path: PathBuf,
    /// The path relative to the dataset root, when the file is inside the dataset.
    pub in_dataset: Option<String>,
    /// blake3 of its bytes, hexadecimal.
    pub blake3: String,
}

/// What an export wrote and read, for the summary line.
#[derive(Debug, Default)]
pub struct ExportReport {
    /// Every file written (YOLO: its label files and `data.yaml`, not the image links).
    pub files: Vec<ExportedFile>,
    /// Images per export split, in the order train, val, test.
    pub images: Vec<(ExportSplit, usize)>,
    /// Objects exported (DontCare and dropped classes aside).
    pub objects: usize,
    /// DontCare regions of the exported frames (COCO writes them as `iscrowd` annotations).
    pub ignore_regions: usize,
    /// Labelled frames in no image set (with [`SplitRule::ImageSets`]).
    pub left_out: usize,
    /// Frames that could not be read; they are not in the export.
    pub failed: Vec<(FrameRef, Error)>,
}

/// A labelled object of a frame, with its category.
#[derive(Debug, Clone)]
pub struct Object {
    /// The parsed `label_2` line.
    pub label: Label,
    /// Index into the categories (id = index + 1).
    pub category: usize,
    /// The box with its full rotation, where the conversion wrote one (`objects/ID.json`).
    pub exact: Option<ExactBox>,
    /// The line of `label_2/ID.txt` it was read from, from 1.
    pub line: usize,
}

/// A region whose detections count neither way: a DontCare line, or an object the
/// visibility rule leaves out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IgnoreRegion {
    /// The line of `label_2/ID.txt` it was read from, from 1.
    pub line: usize,
    /// [left, top, right, bottom], KITTI's pixel convention.
    pub bbox: [f64; 4],
}

/// One image of the export with everything the formats need.
#[derive(Debug)]
pub struct Frame {
    /// Train, val or test.
    pub split: ExportSplit,
    /// The frame id (file stem of `image_2/ID.png`).
    pub id: String,
    /// The image's id in the export split's file: the frame number when every id of the split is
    /// one, else its position from 1.
    pub image_id: u64,
    /// The image, as found under the dataset root.
    pub image: PathBuf,
    /// The image path relative to the dataset root (`/`-separated).
    pub image_rel: String,
    /// Image size, pixels.
    pub size: ImageSize,
    /// Camera 2 as the image was written (`projection:`/`K2:`/`C2:`, or `P2`).
    pub camera: Box<dyn OutputCamera>,
    /// Camera 2's optical centre in rect, metres.
    pub centre: Vector3<f64>,
    /// Objects of a mapped class, in `label_2` order (DontCare and dropped classes aside).
    pub objects: Vec<Object>,
    /// DontCare rectangles and the objects `--min-visible` leaves out, in `label_2` order.
    pub ignore_regions: Vec<IgnoreRegion>,
}

/// A dataset read for export: frames in export order (train, val, test; ids sorted).
#[derive(Debug)]
pub struct ExportData {
    /// The dataset root the frames were read from.
    pub root: PathBuf,
    /// See [`ExportOptions::path_prefix`].
    pub path_prefix: String,
    /// Category names; the id of `categories[i]` is `i + 1`.
    pub categories: Vec<String>,
    /// Every frame read, in export order.
    pub frames: Vec<Frame>,
    /// Labelled frames in no image set (with [`SplitRule::ImageSets`]).
    pub left_out: usize,
    /// Frames that could not be read; they are not in the export.
    pub failed: Vec<(FrameRef, Error)>,
}

impl ExportData {
    /// The export splits present, in order, with their frames.
    pub fn splits(&self) -> Vec<(ExportSplit, Vec<&Frame>)> {
        ExportSplit::ALL
            .into_iter()
            .map(|s| (s, self.frames.iter().filter(|f| f.split == s).collect()))
            .filter(|(_, f): &(_, Vec<&Frame>)| !f.is_empty())
            .collect()
    }
}

/// Reads every frame of the dataset at `root` (KITTI layout) for export.
pub fn read_dataset(root: &Path, options: &ExportOptions) -> Result<ExportData> {
    let dataset = Dataset::open(root, None)?;
    let mut data = ExportData {
        root: root.to_path_buf(),
        path_prefix: options.path_prefix.clone(),
        categories: options.classes.categories().to_vec(),
        frames: Vec::new(),
        left_out: 0,
        failed: Vec::new(),
    };
    for s in &dataset.splits {
        let frame_ref = |id: &str| FrameRef {
            split: s.name.clone(),
            id: id.to_owned(),
        };
        for name in &s.unusable {
            let path = s.dir.join("image_2").join(name);
            data.failed.push((
                frame_ref(name),
                Error::file(&path, "not a usable frame name (expected NNNNNN.png)"),
            ));
        }
        let assigned = if s.has_labels {
            for id in labels_without_image(&s.dir, &s.frames)? {
                let label = s.label_path(&id);
                let image = s.image_path(Cam::C2, &id);
                data.failed.push((
                    frame_ref(&id),
                    Error::file(&label, format!("no image {}", image.display())),
                ));
            }
            let sources = split::view_sources(root, &s.name);
            let assigned = split::assign(&s.frames, &options.split_rule, &sources)?;
            data.left_out += s.frames.len() - assigned.len();
            assigned
        } else {
            s.frames
                .iter()
                .map(|id| (id.clone(), ExportSplit::Test))
                .collect()
        };
        for (id, export_split) in assigned {
            let image_rel = format!("{}/image_2/{id}.png", s.name);
            let read = read_frame(s, &id, options);
            match read {
                Ok((size, camera, centre, objects, ignore_regions)) => data.frames.push(Frame {
                    split: export_split,
                    image_id: 0,
                    image: s.image_path(Cam::C2, &id),
                    id,
                    image_rel,
                    size,
                    camera,
                    centre,
                    objects,
                    ignore_regions,
                }),
                Err(e) => data.failed.push((frame_ref(&id), e)),
            }
        }
    }
    data.frames
        .sort_by(|a, b| a.split.cmp(&b.split).then(a.id.cmp(&b.id)));
    data.failed.sort_by(|a, b| a.0.cmp(&b.0));
    // Each export split is a file of its own: ids are unique within it (KITTI's training/ and
    // testing/ both count from 000000).
    for split_frames in data.frames.chunk_by_mut(|a, b| a.split == b.split) {
        assign_image_ids(split_frames);
    }
    Ok(data)
}

/// Image ids of one export split: the frame number when every id is one (KITTI's), else the
/// position from 1.
fn assign_image_ids(frames: &mut [Frame]) {
    const MAX_EXACT: u64 = 1 << 53; // JSON readers hold numbers as doubles
    let numbers: Option<Vec<u64>> = frames
        .iter()
        .map(|f| f.id.parse::<u64>().ok().filter(|&n| n < MAX_EXACT))
        .collect();
    let mut unique = numbers.clone().unwrap_or_default();
    unique.sort_unstable();
    unique.dedup();
    match numbers {
        Some(n) if unique.len() == frames.len() => {
            for (f, n) in frames.iter_mut().zip(n) {
                f.image_id = n;
            }
        }
        _ => {
            for (i, f) in frames.iter_mut().enumerate() {
                f.image_id = i as u64 + 1;
            }
        }
    }
}

/// Ids of `label_2/*.txt` with no image among `frames` (sorted).
fn labels_without_image(split_dir: &Path, frames: &[String]) -> Result<Vec<String>> {
    let dir = split_dir.join("label_2");
    let mut ids = crate::fs::file_stems(&dir, ".txt").map_err(|e| Error::io(&dir, e))?;
    ids.retain(|id| frames.binary_search(id).is_err());
    Ok(ids)
}

type FrameParts = (
    ImageSize,
    Box<dyn OutputCamera>,
    Vector3<f64>,
    Vec<Object>,
    Vec<IgnoreRegion>,
);

fn read_frame(
    split: &crate::kitti::Split,
    id: &str,
    options: &ExportOptions,
) -> Result<FrameParts> {
    let image = split.image_path(Cam::C2, id);
    let (w, h) = png::read_file_size(&image)?;
    let size = ImageSize::new(w, h);
    let calib = Calib::read(&split.calib_path(id))?;
    let (camera, centre) = calib.image_camera(Cam::C2, size)?;
    let (objects, ignore_regions) = if split.has_labels {
        read_labels(split, id, options)?
    } else {
        (Vec::new(), Vec::new())
    };
    Ok((size, camera, centre, objects, ignore_regions))
}

/// The objects and ignore regions of frame `id`'s `label_2` file, each object with its exact
/// box where the conversion wrote `objects/ID.json`. That file lists the written objects in
/// label order and no DontCare region (a rig conversion writes an object its `--min-visible`
/// leaves out as a DontCare line, and records it as dropped), so its boxes pair with the
/// lines other than DontCare.
fn read_labels(
    split: &crate::kitti::Split,
    id: &str,
    options: &ExportOptions,
) -> Result<(Vec<Object>, Vec<IgnoreRegion>)> {
    let path = split.label_path(id);
    let exact_path = split.dir.join("objects").join(format!("{id}.json"));
    let exact = exact::read_exact_boxes(&exact_path)?;
    let mut labels = Vec::new();
    for (i, line) in read_lines(&path)?.iter().enumerate() {
        if !line.trim().is_empty() {
            labels.push((i + 1, Label::parse(&path, i + 1, line)?));
        }
    }
    let written = labels.iter().filter(|(_, l)| !l.is_dont_care()).count();
    if let Some(e) = exact.as_ref().filter(|e| e.len() != written) {
        return Err(Error::file(
            &exact_path,
            format!(
                "lists {} written objects but {} has {written} label lines other than DontCare",
                e.len(),
                path.display()
            ),
        ));
    }
    let mut exact = exact.map(Vec::into_iter);
    let (mut objects, mut ignore_regions) = (Vec::new(), Vec::new());
    for (line, label) in labels {
        let exact = match label.is_dont_care() {
            true => None,
            false => exact.as_mut().and_then(Iterator::next),
        };
        let hidden = label.truncated.clamp(0.0, 1.0);
        if label.is_dont_care() || !options.visibility.accepts(label.bbox, hidden) {
            let bbox = label.bbox;
            ignore_regions.push(IgnoreRegion { line, bbox });
            continue;
        }
        match options.classes.lookup(&label.kind) {
            ClassLookup::Category(category) => objects.push(Object {
                label,
                category,
                exact,
                line,
            }),
            ClassLookup::Dropped => {}
            ClassLookup::Unknown => {
                let hint = format!(
                    "unknown class {:?}: map it with --classes {0}=NAME (or {0}=- to drop it)",
                    label.kind
                );
                return Err(Error::parse(&path, line, "type", hint));
            }
        }
    }
    Ok((objects, ignore_regions))
}

/// Writes a format's export of the dataset at `root` into `output`.
pub fn export(
    root: &Path,
    format: Format,
    output: &Path,
    options: &ExportOptions,
) -> Result<ExportReport> {
    let data = read_dataset(root, options)?;
    let files = match format {
        Format::Coco => write_json_files(&data, output, options, coco::render)?,
        Format::Omni3d => write_json_files(&data, output, options, omni3d::render)?,
        Format::Yolo => yolo::write(&data, output, options)?,
    };
    let mut report = ExportReport {
        files,
        images: data
            .splits()
            .iter()
            .map(|(s, frames)| (*s, frames.len()))
            .collect(),
        left_out: data.left_out,
        ..Default::default()
    };
    for f in &data.frames {
        report.objects += f.objects.len();
        report.ignore_regions += f.ignore_regions.len();
    }
    report.failed = data.failed;
    Ok(report)
}

/// Renders one export split: the file's name and bytes.
type RenderSplit = fn(&ExportData, &str, &[&Frame]) -> Result<(String, Vec<u8>)>;

/// One JSON file per export split (`render` gives its name and bytes), all rendered before any
/// is written.
fn write_json_files(
    data: &ExportData,
    output: &Path,
    options: &ExportOptions,
    render: RenderSplit,
) -> Result<Vec<ExportedFile>> {
    let mut rendered = Vec::new();
    for (split, frames) in data.splits() {
        let (name, bytes) = render(data, split.name(), &frames)?;
        rendered.push((output.join(name), bytes));
    }
    if rendered.is_empty() {
        return Err(Error::Setup(format!(
            "{}: no frame to export",
            data.root.display()
        )));
    }
    if output.exists() && !output.is_dir() {
        return Err(Error::Setup(format!(
            "output {} exists and is not a directory",
            output.display()
        )));
    }
    for (path, _) in &rendered {
        if path.exists() && !options.overwrite {
            return Err(Error::Setup(format!(
                "{} exists (use --overwrite to replace it)",
                path.display()
            )));
        }
    }
    std::fs::create_dir_all(output).map_err(|e| Error::io(output, e))?;
    let mut files = Vec::new();
    for (path, bytes) in rendered {
        write_atomic(&path, &bytes)?;
        files.push(exported_file(&data.root, path, &bytes)?);
    }
    Ok(files)
}

pub(crate) fn exported_file(root: &Path, path: PathBuf, bytes: &[u8]) -> Result<ExportedFile> {
    Ok(ExportedFile {
        in_dataset: relative_inside(root, &path)?,
        blake3: hash_hex(bytes),
        path,
    })
}

/// `path` relative to `root` (`/`-separated) when it lies inside it.
fn relative_inside(root: &Path, path: &Path) -> Result<Option<String>> {
    let (root, path) = (crate::fs::resolve(root)?, crate::fs::resolve(path)?);
    Ok(path.strip_prefix(&root).ok().map(|rel| {
        rel.components()
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join("/")
    }))
}

/// `v` rounded to `decimals` places, so the JSON shows the precision the data has (a KITTI box
/// is given to 0.01 px) instead of binary noise.
pub(crate) fn round_to(v: f64, decimals: i32) -> f64 {
    let s = 10f64.powi(decimals);
    let r = (v * s).round() / s;
    if r == 0.0 {
        0.0 // no "-0.0" in the files
    } else {
        r
    }
}
