//! `panoconv inspect`: what a KITTI-layout dataset holds (frames, classes, image sizes,
//! calibrations, small objects) and what is wrong with it (missing files, malformed lines),
//! using the same parsers as the conversion.

use crate::codec::png;
use crate::error::{Error, Result};
use crate::fs::read_lines;
use crate::kitti::{Calib, Cam, Dataset, Label, SourceCamera, Split};
use crate::tools::inspect_files::{companion_problems, image_problem};
use crate::tools::inspect_p2::{p2_notes, Camera2};
use crate::tools::inspect_rig::{inspect_rig, RigReport};
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// Objects whose 2D box is less tall than this are ignored in training (Payen de La Garanderie
/// et al.).
pub const SMALL_OBJECT_PX: f64 = 25.0;

/// The report. Field order is the JSON key order; maps are sorted by key.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// The dataset root, as given.
    pub dataset: String,
    /// Frames (images in `image_2`) over every split inspected.
    pub frames: usize,
    /// One entry per split, in the dataset's order.
    pub splits: Vec<SplitReport>,
    /// Label lines per class (every split with labels).
    pub classes: BTreeMap<String, usize>,
    /// Sizes of the whole `image_2` images (a truncated one is a problem), most common first.
    pub image_sizes: Vec<SizeCount>,
    /// Distinct calibrations of camera 2 (P2, with the written camera if any), most common first.
    pub calibrations: Vec<CalibCount>,
    /// Frames per `projection:` line ("kitti" when the calib has none).
    pub projections: BTreeMap<String, usize>,
    /// Objects too small to train on.
    pub small_objects: SmallObjects,
    /// Everything wrong in the dataset, sorted by file, then line.
    pub problems: Vec<Problem>,
}

/// One split of the dataset.
#[derive(Debug, Clone, Serialize)]
pub struct SplitReport {
    /// The split's folder name (`training`, `testing`).
    pub name: String,
    /// Frames in the split (images in `image_2`).
    pub frames: usize,
    /// Whether the split has labels (`label_2`): the `training` split.
    pub labelled: bool,
    /// Which of the folders a frame may have exist (image_2 and calib always do).
    pub folders: Vec<String>,
}

/// The folders of a split besides image_2 and calib, in the order they are listed.
const OPTIONAL_FOLDERS: [&str; 4] = ["label_2", "image_3", "velodyne", "depth_2"];

/// The folders only panoconv writes (a rig output's source map, objects records and stitch
/// depth; the masks of `--mask`), listed after calib when present (their absence is normal).
const PANOCONV_FOLDERS: [&str; 5] = ["source_2", "mask_2", "mask_3", "stitch_depth_2", "objects"];

/// An image size and how many frames have it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct SizeCount {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Frames whose `image_2` image has this size.
    pub count: usize,
}

/// A distinct calibration of camera 2 and how many frames use it.
#[derive(Debug, Clone, Serialize)]
pub struct CalibCount {
    /// Row-major 3x4.
    pub p2: [f64; 12],
    /// Focal length along u from P2, pixels.
    pub fu: f64,
    /// Focal length along v from P2, pixels.
    pub fv: f64,
    /// Principal point column from P2, pixels.
    pub cu: f64,
    /// Principal point row from P2, pixels.
    pub cv: f64,
    /// Camera 2's optical centre in rect, metres: `−K⁻¹·P2[:, 3]`.
    pub c2: [f64; 3],
    /// Frames with this calibration.
    pub count: usize,
    /// The first frame (split/id) with this P2.
    pub first_frame: String,
    /// The camera a converted image was written with (`projection:`, `K2:`, `C2:`), when the
    /// calib has those lines: then the image is not P2's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub written: Option<WrittenCamera>,
}

/// Camera 2 as panoconv wrote it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WrittenCamera {
    /// The `projection:` line (`perspective`, `equirect`, `cylindrical`, `fisheye`).
    pub projection: String,
    /// `K2:` fu, pixels per unit of the projection's horizontal coordinate (docs/geometry.md).
    pub fu: f64,
    /// `K2:` fv, pixels per unit of the projection's vertical coordinate.
    pub fv: f64,
    /// `K2:` principal point column, pixels.
    pub cu: f64,
    /// `K2:` principal point row, pixels.
    pub cv: f64,
    /// `C2:` camera 2's optical centre in rect, metres.
    pub c2: [f64; 3],
}

/// Objects whose 2D box is less tall than [`SMALL_OBJECT_PX`].
#[derive(Debug, Clone, Serialize)]
pub struct SmallObjects {
    /// The height threshold, pixels.
    pub threshold_px: f64,
    /// Objects (DontCare excluded) whose 2D box height (bottom − top) is under the threshold.
    pub count: usize,
    /// The small objects per class.
    pub classes: BTreeMap<String, usize>,
}

/// A missing or malformed file; `line` and `field` when the problem is inside a text file.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Problem {
    /// Relative to the dataset root.
    pub file: String,
    /// Line number (from 1), when the problem is on a line of a text file.
    pub line: Option<usize>,
    /// The field of that line (e.g. `type`, `P2`), when the parser names one.
    pub field: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some(l) = self.line {
            write!(f, ":{l}")?;
        }
        if let Some(field) = &self.field {
            write!(f, ": {field}")?;
        }
        write!(f, ": {}", self.message)
    }
}

impl Problem {
    pub(crate) fn file(file: &str, message: impl Into<String>) -> Self {
        Problem {
            file: file.to_owned(),
            line: None,
            field: None,
            message: message.into(),
        }
    }

    fn from_error(file: &str, e: Error) -> Self {
        match e {
            Error::Parse {
                line,
                field,
                message,
                ..
            } => Problem {
                file: file.to_owned(),
                line: Some(line),
                field: Some(field),
                message,
            },
            Error::File { message, .. } => Problem::file(file, message),
            Error::Io { cause, .. } => Problem::file(file, cause.to_string()),
            other => Problem::file(file, other.to_string()),
        }
    }
}

fn ids_in(dir: &Path, ext: &str) -> Vec<String> {
    // a missing folder is one of the facts inspect reports, not an error here
    crate::fs::file_stems(dir, ext).unwrap_or_default()
}

/// Inspects the dataset at `root` (one split with `only`). Set-up problems (no dataset there)
/// are errors; everything wrong inside the dataset is in [`Report::problems`].
pub fn inspect(root: &Path, only: Option<&str>) -> Result<Report> {
    let dataset = Dataset::open(root, only)?;
    let mut tally = Tally::default();
    for split in &dataset.splits {
        tally.split(split);
    }
    Ok(tally.into_report(root))
}

/// What [`inspect`] has counted so far.
#[derive(Default)]
struct Tally {
    frames: usize,
    splits: Vec<SplitReport>,
    classes: BTreeMap<String, usize>,
    sizes: BTreeMap<(u32, u32), usize>,
    calibs: Vec<CalibCount>,
    projections: BTreeMap<String, usize>,
    small: BTreeMap<String, usize>,
    small_count: usize,
    problems: Vec<Problem>,
}

/// `split/sub/idext`, a file's path relative to the dataset root.
fn rel(split: &Split, sub: &str, id: &str, ext: &str) -> String {
    format!("{}/{sub}/{id}{ext}", split.name)
}

impl Tally {
    fn split(&mut self, split: &Split) {
        self.frames += split.frames.len();
        self.splits.push(SplitReport {
            name: split.name.clone(),
            frames: split.frames.len(),
            labelled: split.has_labels,
            folders: std::iter::once("image_2")
                .chain(OPTIONAL_FOLDERS)
                .chain(std::iter::once("calib"))
                .chain(PANOCONV_FOLDERS)
                .filter(|f| split.dir.join(f).is_dir())
                .map(str::to_owned)
                .collect(),
        });
        for id in &split.frames {
            self.image(split, id);
            self.calib(split, id);
            if split.has_labels {
                self.labels(split, id);
            }
        }
        let companions = companion_problems(split).into_iter();
        (self.problems).extend(companions.map(|(file, m)| Problem::file(&file, m)));
        self.orphans(split);
    }

    /// The frame's image size, when the image is whole (its chunks through IEND).
    fn image(&mut self, split: &Split, id: &str) {
        let image_rel = rel(split, "image_2", id, ".png");
        let image_path = split.image_path(Cam::C2, id);
        match png::read_file_size(&image_path) {
            Ok(s) => match image_problem(split, id) {
                Some((file, m)) => self.problems.push(Problem::file(&file, m)),
                None => *self.sizes.entry(s).or_default() += 1,
            },
            // What the conversion says of it, rather than the png crate's signature error.
            Err(_) if is_jpeg(&image_path) => self.problems.push(Problem::file(
                &image_rel,
                "cannot decode PNG: the file is a JPEG (it starts with JPEG's FF D8 FF), not a PNG: KITTI images are PNG, convert it".to_owned(),
            )),
            Err(e) => self.problems.push(Problem::from_error(&image_rel, e)),
        }
    }

    /// The frame's calibration: its projection and camera 2.
    fn calib(&mut self, split: &Split, id: &str) {
        let calib_rel = rel(split, "calib", id, ".txt");
        let calib_path = split.calib_path(id);
        if !calib_path.is_file() {
            let image_rel = rel(split, "image_2", id, ".png");
            self.problems.push(Problem::file(
                &calib_rel,
                format!("missing (the frame has {image_rel})"),
            ));
            return;
        }
        let calib = read_lines(&calib_path)
            .and_then(|lines| Calib::parse(Path::new(&calib_rel), lines))
            .and_then(|c| c.camera(Cam::C2).map(|cam| (c, cam)));
        match calib {
            Ok((calib, cam)) => {
                let name = calib.projection.map_or("kitti", |p| p.name());
                *self.projections.entry(name.to_owned()).or_default() += 1;
                self.count_calib(&calib, &cam, format!("{}/{id}", split.name));
            }
            Err(e) => self.problems.push(Problem::from_error(&calib_rel, e)),
        }
    }

    /// Counts camera 2's calibration (P2 and the written camera) among the distinct ones.
    fn count_calib(&mut self, calib: &Calib, cam: &SourceCamera, frame: String) {
        let p2: [f64; 12] = calib.p[2]
            .expect("camera(2) succeeded")
            .transpose()
            .as_slice()
            .try_into()
            .expect("3x4");
        let written = match (calib.projection, calib.k_out[2], calib.c_out[2]) {
            (Some(p), Some(k), Some(c)) => Some(WrittenCamera {
                projection: p.name().to_owned(),
                fu: k.fu,
                fv: k.fv,
                cu: k.cu,
                cv: k.cv,
                c2: [c.x, c.y, c.z],
            }),
            _ => None,
        };
        match self
            .calibs
            .iter_mut()
            .find(|c| c.p2 == p2 && c.written == written)
        {
            Some(c) => c.count += 1,
            None => self.calibs.push(CalibCount {
                p2,
                fu: cam.k.fu,
                fv: cam.k.fv,
                cu: cam.k.cu,
                cv: cam.k.cv,
                c2: [cam.centre.x, cam.centre.y, cam.centre.z],
                count: 1,
                first_frame: frame,
                written,
            }),
        }
    }

    /// The frame's label lines: classes and small objects.
    fn labels(&mut self, split: &Split, id: &str) {
        let label_rel = rel(split, "label_2", id, ".txt");
        let label_path = split.label_path(id);
        if !label_path.is_file() {
            let image_rel = rel(split, "image_2", id, ".png");
            self.problems.push(Problem::file(
                &label_rel,
                format!("missing (the frame has {image_rel})"),
            ));
            return;
        }
        let lines = match read_lines(&label_path) {
            Ok(l) => l,
            Err(e) => return self.problems.push(Problem::from_error(&label_rel, e)),
        };
        for (i, line) in lines.iter().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            match Label::parse(Path::new(&label_rel), i + 1, line) {
                Ok(label) => {
                    *self.classes.entry(label.kind.clone()).or_default() += 1;
                    let h = label.bbox[3] - label.bbox[1];
                    if !label.is_dont_care() && h < SMALL_OBJECT_PX {
                        self.small_count += 1;
                        *self.small.entry(label.kind.clone()).or_default() += 1;
                    }
                }
                Err(e) => self.problems.push(Problem::from_error(&label_rel, e)),
            }
        }
    }

    /// Files without an image.
    fn orphans(&mut self, split: &Split) {
        let mut orphans = vec![("calib", ".txt")];
        if split.has_labels {
            orphans.push(("label_2", ".txt"));
        }
        for (sub, ext) in orphans {
            for id in ids_in(&split.dir.join(sub), ext) {
                if split.frames.binary_search(&id).is_err() {
                    self.problems.push(Problem::file(
                        &rel(split, sub, &id, ext),
                        format!("no image {} for it", rel(split, "image_2", &id, ".png")),
                    ));
                }
            }
        }
    }

    fn into_report(mut self, root: &Path) -> Report {
        let mut image_sizes: Vec<SizeCount> = self
            .sizes
            .into_iter()
            .map(|((width, height), count)| SizeCount {
                width,
                height,
                count,
            })
            .collect();
        image_sizes.sort_by(|a, b| {
            b.count
                .cmp(&a.count)
                .then((b.width, b.height).cmp(&(a.width, a.height)))
        });
        // most common first; ties in order of first appearance (frames are sorted)
        self.calibs.sort_by_key(|c| std::cmp::Reverse(c.count));
        self.problems
            .sort_by(|a, b| (&a.file, a.line).cmp(&(&b.file, b.line)));
        Report {
            dataset: root.display().to_string(),
            frames: self.frames,
            splits: self.splits,
            classes: self.classes,
            image_sizes,
            calibrations: self.calibs,
            projections: self.projections,
            small_objects: SmallObjects {
                threshold_px: SMALL_OBJECT_PX,
                count: self.small_count,
                classes: self.small,
            },
            problems: self.problems,
        }
    }
}

impl Report {
    /// Whether no problem was found.
    pub fn is_clean(&self) -> bool {
        self.problems.is_empty()
    }

    /// Pretty JSON with a final newline.
    pub fn to_json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).expect("report serialises");
        s.push('\n');
        s
    }

    /// The human-readable report.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        self.text_splits(&mut s);
        self.text_counts(&mut s);
        self.text_cameras(&mut s);
        self.text_problems(&mut s);
        s
    }

    /// The dataset, its frames and each split's folders.
    fn text_splits(&self, s: &mut String) {
        let _ = writeln!(s, "dataset: {}", self.dataset);
        let per_split: Vec<String> = self
            .splits
            .iter()
            .map(|sp| format!("{} {}", sp.name, sp.frames))
            .collect();
        let _ = writeln!(s, "frames: {} ({})", self.frames, per_split.join(", "));
        for sp in &self.splits {
            let absent: Vec<&str> = OPTIONAL_FOLDERS
                .iter()
                .copied()
                .filter(|f| !sp.folders.iter().any(|g| g == f))
                .collect();
            let _ = write!(s, "  {}: {}", sp.name, sp.folders.join(" "));
            if absent.is_empty() {
                s.push('\n');
            } else {
                let _ = writeln!(s, " (no {})", absent.join(", no "));
            }
        }
    }

    /// Label lines per class and the image sizes.
    fn text_counts(&self, s: &mut String) {
        let objects: usize = self.classes.values().sum();
        let _ = writeln!(s, "classes: {objects} label lines");
        let mut classes: Vec<_> = self.classes.iter().collect();
        classes.sort_by(|a, b| b.1.cmp(a.1).then(a.0.cmp(b.0)));
        for (name, n) in classes {
            let _ = writeln!(s, "  {name:<16} {n:>7}");
        }
        let _ = writeln!(s, "image sizes: {} distinct", self.image_sizes.len());
        for z in &self.image_sizes {
            let _ = writeln!(
                s,
                "  {:<16} {:>7}",
                format!("{}x{}", z.width, z.height),
                z.count
            );
        }
    }

    /// The distinct calibrations and the projections, with the note on P2.
    fn text_cameras(&self, s: &mut String) {
        let _ = writeln!(s, "calibrations: {} distinct", self.calibrations.len());
        for c in &self.calibrations {
            // A converted image is described by the camera it was written with; P2 stays the
            // source camera's.
            let (what, fu, fv, cu, cv, c2) = match &c.written {
                Some(w) => (format!("{} K2", w.projection), w.fu, w.fv, w.cu, w.cv, w.c2),
                None => ("P2".to_owned(), c.fu, c.fv, c.cu, c.cv, c.c2),
            };
            let _ = writeln!(
                s,
                "  {:>7} frames  {what} fu {fu:.4} fv {fv:.4} cu {cu:.4} cv {cv:.4}  C2 ({:.4}, {:.4}, {:.4}) m  first {}",
                c.count, c2[0], c2[1], c2[2], c.first_frame
            );
        }
        let projections: Vec<String> = self
            .projections
            .iter()
            .map(|(p, n)| format!("{p} {n}"))
            .collect();
        let _ = writeln!(s, "projections: {}", projections.join(", "));
        // A loader that projects with P2 lands far from the written boxes (about 100 px on
        // the real frames in equirect): say so where a user looks first.
        let written: Vec<Camera2> = (self.calibrations.iter())
            .filter_map(|c| {
                c.written.as_ref().map(|w| Camera2 {
                    projection: &w.projection,
                    p2: ([c.fu, c.fv, c.cu, c.cv], c.c2),
                    written: ([w.fu, w.fv, w.cu, w.cv], w.c2),
                    frames: c.count,
                })
            })
            .collect();
        for note in p2_notes(&written) {
            let _ = writeln!(s, "{note}");
        }
    }

    /// Small objects and the problems found.
    fn text_problems(&self, s: &mut String) {
        let by_class: Vec<String> = self
            .small_objects
            .classes
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect();
        let _ = write!(
            s,
            "objects under {} px tall: {}",
            self.small_objects.threshold_px, self.small_objects.count
        );
        if by_class.is_empty() {
            s.push('\n');
        } else {
            let _ = writeln!(s, " ({})", by_class.join(", "));
        }
        if self.problems.is_empty() {
            let _ = writeln!(s, "problems: none");
        } else {
            let _ = writeln!(s, "problems: {}", self.problems.len());
            for p in &self.problems {
                let _ = writeln!(s, "  {p}");
            }
        }
    }
}

/// Whether the file starts as a JPEG does (FF D8 FF).
fn is_jpeg(path: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 3];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok()
        && head == [0xFF, 0xD8, 0xFF]
}

/// What `panoconv inspect` reports: a KITTI layout's report, or a rig dataset's description.
#[derive(Debug, Clone)]
pub enum Inspection {
    /// A KITTI object root (original or converted).
    Kitti(Report),
    /// A nuScenes or KITTI-360 root.
    Rig(RigReport),
}

/// Inspects `root`: a KITTI layout (one split with `only`), else a nuScenes or KITTI-360 root
/// (described; `only` names a KITTI split, so it is refused there); a PandaSet sequence is
/// refused with what reads it.
pub fn inspect_root(root: &Path, only: Option<&str>) -> Result<Inspection> {
    if !root.join("training").is_dir() && !root.join("testing").is_dir() {
        if let Some(rig) = inspect_rig(root)? {
            if only.is_some() {
                return Err(Error::Setup(format!(
                    "--split: {} is a {} root, not a KITTI layout with splits",
                    root.display(),
                    rig.format
                )));
            }
            return Ok(Inspection::Rig(rig));
        }
        if let Some(refusal) = super::inspect_pandaset::pandaset_refusal(root) {
            return Err(refusal);
        }
    }
    inspect(root, only).map(Inspection::Kitti)
}

impl Inspection {
    /// Whether no problem was found (a rig root's description has none to report).
    pub fn is_clean(&self) -> bool {
        match self {
            Inspection::Kitti(r) => r.is_clean(),
            Inspection::Rig(_) => true,
        }
    }

    /// Pretty JSON with a final newline.
    pub fn to_json(&self) -> String {
        match self {
            Inspection::Kitti(r) => r.to_json(),
            Inspection::Rig(r) => r.to_json(),
        }
    }

    /// The human-readable report.
    pub fn to_text(&self) -> String {
        match self {
            Inspection::Kitti(r) => r.to_text(),
            Inspection::Rig(r) => r.to_text(),
        }
    }
}
