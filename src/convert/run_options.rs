//! The options every dataset conversion shares (`kitti`, `kitti-raw`, `kitti360` and any rig
//! dataset): the output folder and its mode, the shard, the PNG effort, the style pass, the
//! augmented views, the depth maps and the export asked for after the run. One value
//! ([`RunOptions`]) with its rules ([`RunOptions::validate`], checked before the output folder
//! is locked or a model loaded), and the one loader of the style model's sessions.

use crate::codec::png::PngCompression;
use crate::error::{Error, Result};
use crate::geometry::augment::Augment;
use crate::reproject::depth::OcclusionFilter;
use crate::run::{OutputMode, Shard};
use crate::style::{Device, StyleModel, StyleOptions};
use serde::Serialize;
use std::path::PathBuf;

/// The options of a run, whatever the dataset.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// The output folder.
    pub output: PathBuf,
    /// New, `--overwrite` or `--resume`.
    pub mode: OutputMode,
    /// `--shard K/N`: this process converts one shard of the frames.
    pub shard: Option<Shard>,
    /// PNG encoder effort.
    pub png_compression: PngCompression,
    /// `--style` and its options.
    pub style: Option<StyleJob>,
    /// `--augment` and its draw: random scale-and-crop views of each frame's output.
    pub augment: Option<Augment>,
    /// `--depth` and its occlusion filter.
    pub depth: Option<DepthJob>,
    /// Whether `--export` asks for an export after the conversion.
    pub export: bool,
}

impl RunOptions {
    /// The rules between these options that hold for every dataset: `--export` needs the
    /// whole output (not one shard of it).
    pub fn validate(&self) -> Result<()> {
        if self.shard.is_some() && self.export {
            return Err(Error::Setup(
                "--export needs the whole output: not with --shard (run panoconv export after \
                 merge)"
                    .into(),
            ));
        }
        Ok(())
    }
}

/// The depth output of a conversion.
#[derive(Debug, Clone, Serialize)]
pub struct DepthJob {
    /// None turns the occlusion correction off.
    pub occlusion_filter: Option<OcclusionFilter>,
}

/// The style pass of a conversion.
#[derive(Debug, Clone)]
pub struct StyleJob {
    /// The model, the ONNX Runtime library and the device.
    pub options: StyleOptions,
    /// Before or after the warp.
    pub order: StyleOrder,
    /// Equal-size images of up to this many consecutive frames go through the model in one
    /// run (1: frame by frame). Outputs do not depend on it (`convert::style_pass`).
    pub batch: usize,
}

/// Whether the style pass takes the source images or the warped ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StyleOrder {
    /// Style the source image, then warp it (as the paper does).
    BeforeWarp,
    /// Warp, then style the output image.
    AfterWarp,
}

/// The style model's sessions, loaded before anything is written: a missing model file or
/// ONNX Runtime library, or a bad model, is a set-up error. On the CPU, one session per worker
/// with one thread each, so --jobs alone sets the core count. On a GPU each session holds its
/// own weights and activation arena in device memory, and one device runs one model at a time
/// anyway: two sessions (one computing while the other's inputs are prepared) serve any number
/// of workers. Must run inside the run's rayon pool.
pub(crate) fn load_style(style: Option<&StyleJob>) -> Result<Option<StyleModel>> {
    let Some(s) = style else {
        return Ok(None);
    };
    // The model is the user's own file: name it missing before asking for the runtime.
    if !s.options.model.is_file() {
        return Err(Error::Setup(format!(
            "--style {}: no such model file",
            s.options.model.display()
        )));
    }
    let options = StyleOptions {
        intra_threads: 1,
        ..s.options.clone()
    };
    let workers = rayon::current_num_threads();
    let sessions = match options.device {
        Device::Cpu => workers,
        Device::Cuda => workers.min(2),
    };
    Ok(Some(StyleModel::load_pool(&options, sessions)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_export_needs_the_whole_output() {
        let mut options = RunOptions {
            output: PathBuf::from("out"),
            mode: OutputMode::New,
            shard: None,
            png_compression: PngCompression::Default,
            style: None,
            augment: None,
            depth: None,
            export: true,
        };
        assert!(options.validate().is_ok());
        options.shard = Some(Shard { index: 0, count: 2 });
        let e = options.validate().unwrap_err().to_string();
        assert!(e.contains("--export needs the whole output"), "{e}");
    }
}
