//! The style model of a build without ONNX Runtime (the `ort` feature off: the library as the
//! Python wheel and other embedders take it). Loading fails with [`StyleError::NotBuilt`], so
//! no `StyleModel` ever exists in such a build: it holds an empty enum, and its methods match
//! on it, which the compiler checks as unreachable.

use super::{StyleError, StyleInfo, StyleOptions};
use crate::image::RgbImage;
use std::path::Path;

/// A value that cannot exist.
#[derive(Debug)]
enum Never {}

/// A loaded generator: none can be loaded in this build.
#[derive(Debug)]
pub struct StyleModel {
    never: Never,
}

impl StyleModel {
    /// Fails: this build has no ONNX Runtime.
    pub fn load(opts: &StyleOptions) -> Result<StyleModel, StyleError> {
        Self::load_pool(opts, 1)
    }

    /// Fails: this build has no ONNX Runtime.
    pub fn load_pool(opts: &StyleOptions, _sessions: usize) -> Result<StyleModel, StyleError> {
        Err(StyleError::NotBuilt {
            model: opts.model.clone(),
        })
    }

    /// The model's description.
    pub fn info(&self) -> &StyleInfo {
        match self.never {}
    }

    /// The canonical path of the ONNX Runtime library in use.
    pub fn library(&self) -> &Path {
        match self.never {}
    }

    /// Styles one image.
    pub fn stylize(&self, _img: &RgbImage) -> Result<RgbImage, StyleError> {
        match self.never {}
    }

    /// Styles images in batches.
    pub fn stylize_batch(&self, _imgs: &[&RgbImage]) -> Result<Vec<RgbImage>, StyleError> {
        match self.never {}
    }

    /// Styles images in batches of at most `run_len(width, height)`.
    pub fn stylize_batch_by(
        &self,
        _imgs: &[&RgbImage],
        _run_len: impl Fn(u32, u32) -> usize,
    ) -> Result<Vec<RgbImage>, StyleError> {
        match self.never {}
    }

    /// Model runs so far, and the images they took.
    pub fn runs(&self) -> (usize, usize) {
        match self.never {}
    }

    /// Whether the model takes batches.
    pub fn batches(&self) -> bool {
        match self.never {}
    }

    /// Whether a batch gives the single runs' bytes.
    pub fn batch_matches_single(
        &self,
        _width: u32,
        _height: u32,
        _n: usize,
    ) -> Result<bool, StyleError> {
        match self.never {}
    }
}
