//! The style options every converting command shares: `--style`, `--ort-lib`, `--device`,
//! `--style-batch`.

use clap::{Args, ValueEnum};
use panoconv::convert::run_options::{StyleJob, StyleOrder};
use panoconv::style::{Device, StyleOptions};
use std::path::PathBuf;

/// `--style` and the options of its model runs.
#[derive(Args)]
pub(crate) struct StyleArgs {
    /// CycleGAN generator (ONNX) giving each source image the target domain's look, before the
    /// warp (a rig's cameras: before the stitch).
    #[arg(long, value_name = "MODEL.onnx")]
    style: Option<PathBuf>,
    /// ONNX Runtime library (libonnxruntime.so); else $ORT_DYLIB_PATH, else beside the binary.
    #[arg(long, value_name = "PATH", requires = "style")]
    ort_lib: Option<PathBuf>,
    /// Where the style model runs.
    #[arg(long, value_enum, default_value_t = DeviceArg::Cpu, requires = "style")]
    device: DeviceArg,
    /// Equal-size images of up to N consecutive frames go through the model in one run, when
    /// its batch axis is dynamic [default: 4 with --device cuda, 1 on the CPU, where a batch
    /// is no faster]. Outputs are the same for every N.
    #[arg(long, value_name = "N", requires = "style",
          value_parser = clap::value_parser!(u16).range(1..=panoconv::style::MAX_BATCH as i64))]
    style_batch: Option<u16>,
}

#[derive(Clone, Copy, ValueEnum)]
enum DeviceArg {
    Cpu,
    Cuda,
}

impl StyleArgs {
    /// The style pass asked for (before the warp; `kitti` sets `--style-after-warp`'s order
    /// itself).
    pub(crate) fn job(&self) -> Option<StyleJob> {
        let model = self.style.clone()?;
        let device = match self.device {
            DeviceArg::Cpu => Device::Cpu,
            DeviceArg::Cuda => Device::Cuda,
        };
        Some(StyleJob {
            options: StyleOptions {
                model,
                ort_lib: self.ort_lib.clone(),
                device,
                intra_threads: 1,
            },
            order: StyleOrder::BeforeWarp,
            // a batch is no faster on the CPU
            batch: self.style_batch.map_or(
                match device {
                    Device::Cpu => 1,
                    Device::Cuda => 4,
                },
                usize::from,
            ),
        })
    }
}
