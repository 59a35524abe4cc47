//! What can go wrong with a style model: every variant names the model file, and the ONNX
//! Runtime ones say how to get the library.

use super::runtime;
use std::path::PathBuf;

/// Everything that can go wrong; every variant names the model path.
#[derive(thiserror::Error, Debug)]
pub enum StyleError {
    /// No ONNX Runtime library file: the one named by `--ort-lib` or `ORT_DYLIB_PATH` does not
    /// exist, or none was named and none lies beside the executable.
    #[error("style model {}: {detail}; {}", model.display(), runtime::HOW_TO_GET)]
    OrtLibraryMissing {
        /// The model file.
        model: PathBuf,
        /// Which path is missing, or where the library was looked for.
        detail: String,
    },
    /// The ONNX Runtime library file exists but cannot be loaded or initialised, or another
    /// library is already loaded in the process.
    #[error("style model {}: cannot use the ONNX Runtime library {}: {detail}; {}", model.display(), lib.display(), runtime::HOW_TO_GET)]
    OrtLibraryLoad {
        /// The model file.
        model: PathBuf,
        /// The library file that failed.
        lib: PathBuf,
        /// The loader's or runtime's message.
        detail: String,
    },
    /// This build of panoconv has no style pass (built without its `ort` feature).
    #[error("style model {}: this panoconv was built without the style pass (cargo feature `ort`)", model.display())]
    NotBuilt {
        /// The model file.
        model: PathBuf,
    },
    /// The model file cannot be read.
    #[error("style model {}: cannot read the file: {source}", model.display())]
    ModelUnreadable {
        /// The model file.
        model: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not an ONNX model ONNX Runtime can parse.
    #[error("style model {} is not a valid ONNX model: {detail}", model.display())]
    NotOnnx {
        /// The model file.
        model: PathBuf,
        /// ONNX Runtime's message.
        detail: String,
    },
    /// ONNX Runtime refused to build a session for the model (options, unsupported operators).
    #[error("style model {}: ONNX Runtime cannot create a session: {detail}", model.display())]
    Session {
        /// The model file.
        model: PathBuf,
        /// ONNX Runtime's message.
        detail: String,
    },
    /// `--device cuda` was asked for and the CUDA execution provider cannot be used.
    #[error("style model {}: CUDA requested (--device cuda) but unavailable: {detail}", model.display())]
    Cuda {
        /// The model file.
        model: PathBuf,
        /// Why CUDA is unavailable.
        detail: String,
    },
    /// The model does not have exactly one input and at least one output.
    #[error("style model {}: expected one image input and at least one output, found {inputs} inputs and {outputs} outputs", model.display())]
    Arity {
        /// The model file.
        model: PathBuf,
        /// The model's number of inputs.
        inputs: usize,
        /// The model's number of outputs.
        outputs: usize,
    },
    /// The input or first output is not a float32 tensor.
    #[error("style model {}: {which} `{name}` is {found}, expected a float32 tensor", model.display())]
    ElementType {
        /// The model file.
        model: PathBuf,
        /// `"input"` or `"output"`.
        which: &'static str,
        /// The tensor's name in the model.
        name: String,
        /// The type found instead.
        found: String,
    },
    /// The input or first output is not a rank-4 NCHW tensor.
    #[error("style model {}: {which} `{name}` has rank {rank} (shape {shape:?}, -1 = dynamic), expected a rank-4 NCHW image [N,3,H,W]", model.display())]
    Rank {
        /// The model file.
        model: PathBuf,
        /// `"input"` or `"output"`.
        which: &'static str,
        /// The tensor's name in the model.
        name: String,
        /// The tensor's rank.
        rank: usize,
        /// The tensor's declared shape, `-1` for a dynamic axis.
        shape: Vec<i64>,
    },
    /// The input or first output does not have 3 channels on axis 1.
    #[error("style model {}: {which} `{name}` has {channels} channels (shape {shape:?}, -1 = dynamic), expected 3 (RGB) on axis 1 of [N,3,H,W]", model.display())]
    Channels {
        /// The model file.
        model: PathBuf,
        /// `"input"` or `"output"`.
        which: &'static str,
        /// The tensor's name in the model.
        name: String,
        /// The declared size of axis 1 (`-1` when dynamic).
        channels: i64,
        /// The tensor's declared shape, `-1` for a dynamic axis.
        shape: Vec<i64>,
    },
    /// The declared output shape differs from the input's on an axis fixed in both.
    #[error("style model {}: output shape {output:?} differs from input shape {input:?} (-1 = dynamic); a style generator must return an image of its input's size", model.display())]
    ShapeMismatch {
        /// The model file.
        model: PathBuf,
        /// The input's declared shape, `-1` for a dynamic axis.
        input: Vec<i64>,
        /// The output's declared shape, `-1` for a dynamic axis.
        output: Vec<i64>,
    },
    /// The batch axis is fixed to a size other than 1.
    #[error("style model {}: fixed batch size {batch} is not supported (need 1 or a dynamic batch axis)", model.display())]
    Batch {
        /// The model file.
        model: PathBuf,
        /// The declared batch size.
        batch: i64,
    },
    /// An image with no pixels was given to stylize.
    #[error("style model {}: cannot stylize an empty {width}x{height} image", model.display())]
    EmptyImage {
        /// The model file.
        model: PathBuf,
        /// The image's width in pixels.
        width: u32,
        /// The image's height in pixels.
        height: u32,
    },
    /// ONNX Runtime failed while running the model.
    #[error("style model {}: inference failed: {detail}", model.display())]
    Run {
        /// The model file.
        model: PathBuf,
        /// ONNX Runtime's message.
        detail: String,
    },
    /// The model returned a tensor whose shape is not the input's.
    #[error("style model {}: returned shape {got:?} for input shape {expected:?}", model.display())]
    BadOutput {
        /// The model file.
        model: PathBuf,
        /// The shape of the input tensor of that run.
        expected: Vec<i64>,
        /// The shape returned.
        got: Vec<i64>,
    },
}

impl From<StyleError> for crate::error::Error {
    fn from(e: StyleError) -> Self {
        crate::error::Error::Style(Box::new(e))
    }
}
