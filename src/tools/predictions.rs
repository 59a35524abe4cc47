//! Folder commands around the pixel-object format (see [`crate::tools::unproject`]):
//! `labels-to-pixels` (training targets from a converted dataset) and `unproject` (detector
//! outputs back to KITTI 3D results). Each frame needs the calib panoconv wrote and the image
//! beside it (for its size).

use crate::camera::{ImageSize, OutputCamera};
use crate::codec::png;
use crate::error::{Error, Result};
use crate::fs::write_atomic;
use crate::fs::{read_file, read_lines};
use crate::kitti::Cam;
use crate::kitti::{Calib, LabelFile};
use crate::tools::unproject::{
    format_pixel_line, label_to_pixel, parse_pixel_line, result_line, trained_focal_scale, BoxImage,
};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

/// Per-frame outcome of a folder command.
#[derive(Debug, Default)]
pub struct FolderSummary {
    /// Frames written.
    pub done: usize,
    /// Frames that failed: the frame id and why.
    pub failed: Vec<(String, Error)>,
    /// The files written.
    pub written: Vec<PathBuf>,
}

impl FolderSummary {
    /// Counts one frame's outcome: the file it wrote, or why it failed.
    fn record(&mut self, id: String, outcome: Result<PathBuf>) {
        match outcome {
            Ok(path) => {
                self.done += 1;
                self.written.push(path);
            }
            Err(e) => self.failed.push((id, e)),
        }
    }
}

fn txt_ids(dir: &Path) -> Result<Vec<String>> {
    crate::fs::file_stems(dir, ".txt").map_err(|e| Error::Setup(format!("{}: {e}", dir.display())))
}

/// The output camera of a converted frame (its written calib and its image's size), and the
/// calib.
fn frame_camera(
    calib_dir: &Path,
    images_dir: &Path,
    id: &str,
) -> Result<(Box<dyn OutputCamera>, Vector3<f64>, Calib)> {
    let calib = Calib::read(&calib_dir.join(format!("{id}.txt")))?;
    let image = images_dir.join(format!("{id}.png"));
    let (w, h) = png::read_size(&read_file(&image)?, &image)?;
    let (camera, centre) = calib.output_camera(Cam::C2, ImageSize::new(w, h))?;
    Ok((camera, centre, calib))
}

/// Which image the 2D boxes of `unproject`'s result lines belong to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoxChoice {
    /// The source image, as KITTI's benchmark expects: through the written calib's P2, clipped
    /// to the source image, whose size is `size` or else read from the source dataset the
    /// converted dataset's manifest names.
    Source {
        /// The source images' size (`--source-size`), when given.
        size: Option<ImageSize>,
    },
    /// The converted image the detector ran on (`--box converted`).
    Converted,
}

/// Whether `calib`'s `P2` is the nominal pinhole `K2·[I | −C2]` of its written camera, as a rig
/// output (`nuscenes`, `kitti360`, the Python sources) writes it: no camera of the rig, so no
/// source image its boxes could belong to (see `inspect_p2.rs`).
fn p2_is_nominal(calib: &Calib) -> bool {
    let (Ok(p2), Some(k2), Some(c2)) = (calib.camera(Cam::C2), calib.k_out[2], calib.c_out[2])
    else {
        return false;
    };
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * a.abs().max(b.abs()).max(1.0);
    let k = |k: &crate::camera::Intrinsics| [k.fu, k.fv, k.cu, k.cv];
    (k(&p2.k).iter().zip(&k(&k2)))
        .chain(p2.centre.iter().zip(c2.iter()))
        .all(|(&a, &b)| close(a, b))
}

/// The size of the source image of frame `id`, whose written calib is in `calib_dir`: from
/// the source dataset that the manifest of the converted dataset holding `calib_dir` names
/// (`parameters.input`, the same split, `image_2/ID.png`).
fn source_size(calib_dir: &Path, id: &str, calib: &Calib) -> Result<ImageSize> {
    let unknown = |why: String| {
        Error::file(
            &calib.path,
            format!(
                "the source image's size is unknown ({why}): give --source-size WxH, or --box converted"
            ),
        )
    };
    let root = crate::run::derived::dataset_of(calib_dir)
        .ok_or_else(|| unknown("no panoconv.json above the calib folder".into()))?;
    let manifest = root.join(crate::run::manifest::MANIFEST);
    #[derive(serde::Deserialize)]
    struct Doc {
        parameters: Params,
    }
    #[derive(serde::Deserialize)]
    struct Params {
        input: PathBuf,
    }
    let doc: Doc = std::fs::File::open(&manifest)
        .ok()
        .and_then(|f| serde_json::from_reader(std::io::BufReader::new(f)).ok())
        .ok_or_else(|| unknown(format!("{} names no input", manifest.display())))?;
    let abs_calib = std::path::absolute(calib_dir).unwrap_or_else(|_| calib_dir.to_path_buf());
    let split = abs_calib
        .parent()
        .and_then(Path::file_name)
        .ok_or_else(|| unknown("the calib folder is in no split".into()))?;
    let image = doc
        .parameters
        .input
        .join(split)
        .join("image_2")
        .join(format!("{id}.png"));
    let (w, h) = png::read_file_size(&image)
        .map_err(|_| unknown(format!("cannot read the source image {}", image.display())))?;
    Ok(ImageSize::new(w, h))
}

fn prepare_output(output: &Path) -> Result<()> {
    std::fs::create_dir_all(output).map_err(|e| Error::Setup(format!("{}: {e}", output.display())))
}

/// `SPLIT/label_2/*.txt` of a converted dataset split → `output/*.txt` in the pixel format.
pub fn labels_to_pixels(split_dir: &Path, output: &Path) -> Result<FolderSummary> {
    let label_dir = split_dir.join("label_2");
    let ids = txt_ids(&label_dir)?;
    prepare_output(output)?;
    let mut summary = FolderSummary::default();
    for id in ids {
        let run = || -> Result<PathBuf> {
            let (camera, centre, _) =
                frame_camera(&split_dir.join("calib"), &split_dir.join("image_2"), &id)?;
            let labels = LabelFile::read(&label_dir.join(format!("{id}.txt")))?;
            let mut text = String::from("# type u v distance height width length alpha score\n");
            for l in &labels.labels {
                if let Some(o) = label_to_pixel(l, camera.as_ref(), &centre) {
                    text.push_str(&format_pixel_line(&o));
                    text.push('\n');
                }
            }
            let path = output.join(format!("{id}.txt"));
            write_atomic(&path, text.as_bytes())?;
            Ok(path)
        };
        let outcome = run();
        summary.record(id, outcome);
    }
    Ok(summary)
}

/// Pixel-format predictions `input/*.txt` → KITTI result lines `output/*.txt`, using the calib
/// (and image size) of each frame. `trained_fv`: rescale distances from a detector trained on
/// perspective images of that vertical focal length. `boxes`: which image the 2D boxes belong
/// to (a calib without `projection:`, a perspective one whose P2 is the output camera, or a rig
/// output's, whose P2 is no source camera, has one image only).
pub fn unproject(
    calib_dir: &Path,
    images_dir: &Path,
    input: &Path,
    output: &Path,
    trained_fv: Option<f64>,
    boxes: BoxChoice,
) -> Result<FolderSummary> {
    let ids = txt_ids(input)?;
    prepare_output(output)?;
    let mut summary = FolderSummary::default();
    for id in ids {
        let run = || -> Result<PathBuf> {
            let (camera, centre, calib) = frame_camera(calib_dir, images_dir, &id)?;
            let converted_only = matches!(
                calib.projection,
                None | Some(crate::camera::OutputProjection::Linear(
                    crate::camera::Projection::Perspective
                ))
            ) || p2_is_nominal(&calib);
            let source = match boxes {
                BoxChoice::Source { size } if !converted_only => {
                    let size = match size {
                        Some(s) => s,
                        None => source_size(calib_dir, &id, &calib)?,
                    };
                    let p2 = calib.camera(Cam::C2)?;
                    Some((p2.camera(size), p2.centre))
                }
                _ => None,
            };
            let image = match &source {
                Some((camera, centre)) => BoxImage::Source {
                    camera,
                    centre: *centre,
                },
                None => BoxImage::Converted,
            };
            let scale = trained_fv.map_or(1.0, |f| trained_focal_scale(camera.as_ref(), f));
            let path = input.join(format!("{id}.txt"));
            let mut text = String::new();
            for (i, line) in read_lines(&path)?.iter().enumerate() {
                let t = line.trim();
                if t.is_empty() || t.starts_with('#') {
                    continue;
                }
                let obj = parse_pixel_line(&path, i + 1, t)?;
                let line = result_line(&obj, camera.as_ref(), &centre, scale, &image).ok_or_else(
                    || Error::parse(&path, i + 1, "u", "the pixel has no ray in this camera"),
                )?;
                text.push_str(&line);
                text.push('\n');
            }
            let path = output.join(format!("{id}.txt"));
            write_atomic(&path, text.as_bytes())?;
            Ok(path)
        };
        let outcome = run();
        summary.record(id, outcome);
    }
    Ok(summary)
}

/// The default image folder of a calib folder: `calib/../image_2`.
pub fn default_images_dir(calib_dir: &Path) -> PathBuf {
    calib_dir.parent().unwrap_or(Path::new(".")).join("image_2")
}
