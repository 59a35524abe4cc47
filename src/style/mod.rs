//! CycleGAN style transfer through ONNX Runtime (issue 3; owned by the style work).
