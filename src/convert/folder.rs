//! Folder batch conversion (`panoconv pano`, `panoconv fisheye`): every PNG image of a folder is
//! warped into one or more views, each written as `NAME[SUFFIX].png` with its camera beside it
//! in `NAME[SUFFIX].txt` (`projection:`, `K:`, `R:`). The views (output cameras and remap
//! tables) are built once per source image size and shared by every image of that size.
//!
//! Same rules as the KITTI conversion: set-up problems fail before anything is written; a bad
//! image is reported with its path, leaves no output, and the others are converted.

use crate::camera::{ImageSize, LinearCamera};
use crate::codec::png::PngCompression;
use crate::error::{Error, Result};
use crate::fs;
use crate::fs::read_file;
use crate::kitti::calib::format_sci;
use crate::run::journal::Previous;
use crate::run::manifest::{FrameRecord, FrameStatus};
use crate::run::OnceMap;
use crate::run::{Claim, FrameWork, OutputFolder, OutputMode, Progress, Summary};
use crate::warp::{warp_encode, RemapTable};
use nalgebra::Matrix3;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// One output of each source image.
#[derive(Clone)]
pub struct FolderView {
    /// Appended to the input's file stem ("" for a single view).
    pub suffix: String,
    /// The output image's camera.
    pub camera: Arc<dyn LinearCamera>,
    /// Rotation from the output camera's axes to the source camera's: d_src = R · d_out.
    pub source_from_output: Matrix3<f64>,
    /// The remap table from the source image to this view.
    pub table: Arc<RemapTable>,
}

/// What a folder conversion makes of each image (`pano`, `fisheye`): its views, and how the
/// manifest names the command and its parameters.
pub trait FolderPlan: Sync {
    /// The subcommand, as the manifest's `command` records it.
    fn command(&self) -> &'static str;
    /// The manifest's `parameters` for a run of `job` with this plan.
    fn parameters(&self, job: &FolderJob) -> serde_json::Value;
    /// The views of a source image of `size` (an error fails that image).
    fn views(&self, size: ImageSize) -> Result<Vec<FolderView>>;
}

/// A folder conversion: where from, where to, how to write.
pub struct FolderJob {
    /// The folder of input images.
    pub input: PathBuf,
    /// The output folder.
    pub output: PathBuf,
    /// Write into a non-empty output folder.
    pub overwrite: bool,
    /// PNG encoder effort.
    pub png_compression: PngCompression,
}

/// The text written beside each output image.
pub fn camera_text(view: &FolderView) -> String {
    let join = |v: &[f64]| {
        v.iter()
            .map(|&x| format_sci(x))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let r = &view.source_from_output;
    let r_rows: Vec<f64> = (0..3)
        .flat_map(|i| (0..3).map(move |j| r[(i, j)]))
        .collect();
    format!(
        "projection: {}\nK: {}\nR: {}\n",
        view.camera.projection().name(),
        join(&view.camera.intrinsics().matrix()),
        join(&r_rows)
    )
}

/// An input image.
struct Input {
    path: PathBuf,
    name: String,
    stem: String,
}

fn list_inputs(dir: &Path) -> Result<Vec<Input>> {
    if !dir.is_dir() {
        return Err(Error::Setup(format!(
            "input {} is not a directory",
            dir.display()
        )));
    }
    let mut inputs = Vec::new();
    for e in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let e = e.map_err(|e| Error::io(dir, e))?;
        let path = e.path();
        if !path.is_file() {
            continue;
        }
        let name = e.file_name().to_string_lossy().into_owned();
        if !crate::codec::is_readable_image(&path) {
            continue;
        }
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        inputs.push(Input { path, name, stem });
    }
    inputs.sort_by(|a, b| a.name.cmp(&b.name));
    if inputs.is_empty() {
        return Err(Error::Setup(format!(
            "input {} holds no PNG, JPEG, TIFF or WebP images",
            dir.display()
        )));
    }
    Ok(inputs)
}

struct Ctx<'a> {
    job: &'a FolderJob,
    plan: &'a dyn FolderPlan,
    views: OnceMap<ImageSize, std::result::Result<Arc<Vec<FolderView>>, String>>,
}

impl Ctx<'_> {
    fn convert_image(&self, input: &Input, written: &mut Vec<PathBuf>) -> Result<FrameRecord> {
        let bytes = read_file(&input.path)?;
        let image = crate::codec::decode_rgb8(&bytes, &input.path)?;
        let size = ImageSize::new(image.width(), image.height());
        let views = self
            .views
            .get_or_build(&size, || {
                self.plan
                    .views(size)
                    .map(Arc::new)
                    .map_err(|e| e.to_string())
            })
            .map_err(|m| Error::file(&input.path, m))?;
        let mut outputs = Vec::new();
        for view in views.iter() {
            // warped row by row as the encoder takes the rows (one image per worker already),
            // from the source's pyramid built once where the table samples one
            let png = warp_encode(&view.table, &image, self.job.png_compression);
            let txt = camera_text(view);
            for (ext, data) in [("png", png), ("txt", txt.into_bytes())] {
                let name = format!("{}{}.{ext}", input.stem, view.suffix);
                let path = self.job.output.join(&name);
                written.push(path.clone());
                fs::write_atomic(&path, &data)?;
                outputs.push((name, fs::hash_hex(&data)));
            }
        }
        Ok(FrameRecord {
            split: String::new(),
            id: input.name.clone(),
            status: FrameStatus::Ok,
            error: None,
            inputs: vec![(input.name.clone(), fs::hash_hex(&bytes))],
            outputs,
            views: Vec::new(),
            lidar: None,
        })
    }
}

/// The folder's images for the run's frame loop.
impl FrameWork for Ctx<'_> {
    type Item = Input;

    fn key<'k>(&self, input: &'k Input) -> (&'k str, &'k str) {
        ("", &input.name)
    }

    fn convert(&self, group: &[&Input]) -> Vec<Result<FrameRecord>> {
        group
            .iter()
            .map(|input| {
                let mut written = Vec::new();
                self.convert_image(input, &mut written).inspect_err(|_| {
                    for p in written {
                        let _ = std::fs::remove_file(p);
                    }
                })
            })
            .collect()
    }
}

/// Converts every image of `job.input`. Set-up problems return `Err` before anything is
/// written; a bad image is reported through `progress` and counted in the summary.
/// Must run inside the caller's rayon pool.
pub fn run_folder(
    job: &FolderJob,
    plan: &dyn FolderPlan,
    progress: &dyn Progress,
) -> Result<Summary> {
    let started = std::time::Instant::now();
    let inputs = list_inputs(&job.input)?;
    // Held until the run returns: one process per output.
    let folder = OutputFolder::claim(Claim {
        input: &job.input,
        output: &job.output,
        shard: None,
        mode: OutputMode::from_flags(job.overwrite, false),
        resumable: false,
        started,
    })?;
    // Two stems with different extensions would write the same outputs.
    let mut stems: Vec<&str> = inputs.iter().map(|i| i.stem.as_str()).collect();
    stems.sort_unstable();
    if let Some(w) = stems.windows(2).find(|w| w[0] == w[1]) {
        return Err(Error::Setup(format!(
            "two input images are named {:?} (with different extensions); their outputs would collide",
            w[0]
        )));
    }
    folder.prepare()?;
    let ctx = Ctx {
        job,
        plan,
        views: OnceMap::default(),
    };
    let never = AtomicBool::new(false);
    let mut run = folder.start(
        plan.command(),
        plan.parameters(job),
        Previous::default(),
        inputs.len(),
        progress,
        &never,
    )?;
    run.run(&inputs, 1, &ctx);
    run.finish(ctx.views.len(), |_| Ok(()))
}
