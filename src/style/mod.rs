//! CycleGAN style transfer through ONNX Runtime (issue 3; owned by the style work).

/// Placeholder until the style module lands.
#[derive(Debug, thiserror::Error)]
#[error("style transfer is not available")]
pub struct StyleError;
