//! CycleGAN style transfer through ONNX Runtime (the `ort` crate, `load-dynamic`).
//!
//! * Convention: RGB8 -> float32 NCHW `x / 127.5 - 1`; output `(y + 1) * 127.5`, clipped to
//!   `0..=255`, rounded half away from zero. Each image is reflect-padded at the bottom/right to a
//!   multiple of 4 (the generator downsamples twice), run, and cropped back.
//! * Models with a fixed spatial input size run in overlapping tiles blended with linear ramps
//!   (see [`convert::AxisTiles`]).
//! * The ONNX Runtime library is found at run time: explicit path (`--ort-lib`), then
//!   `ORT_DYLIB_PATH`, then `libonnxruntime.so*` beside the executable (see [`runtime`]).
//! * Concurrency: `ort::Session::run` takes `&mut self` in 2.0.0-rc.15, so a [`StyleModel`] owns a
//!   small pool of sessions, each behind a `Mutex`. [`StyleModel::load`] makes one session that
//!   uses `intra_threads` threads inside each operator (the efficient choice for a big conv net:
//!   parallel callers queue on it); [`StyleModel::load_pool`] makes several for callers that want
//!   frame-level parallelism (each session holds its own copy of the weights and activations).
//!
//! See `docs/style.md`.

pub mod convert;
mod error;
pub mod runtime;

pub use error::StyleError;
#[cfg(not(feature = "ort"))]
mod without_runtime;
#[cfg(not(feature = "ort"))]
pub use without_runtime::StyleModel;

#[cfg(feature = "ort")]
use std::path::Path;
use std::path::PathBuf;
#[cfg(feature = "ort")]
use std::sync::atomic::{AtomicUsize, Ordering};
#[cfg(feature = "ort")]
use std::sync::{Mutex, MutexGuard};

#[cfg(feature = "ort")]
use ort::session::builder::GraphOptimizationLevel;
#[cfg(feature = "ort")]
use ort::session::Session;
#[cfg(feature = "ort")]
use ort::value::{TensorElementType, TensorRef, ValueType};

#[cfg(feature = "ort")]
use crate::image::RgbImage;
#[cfg(feature = "ort")]
use convert::{AxisTiles, Blender};

/// Where inference runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Device {
    /// ONNX Runtime's CPU execution provider.
    #[default]
    Cpu,
    /// The CUDA execution provider (device 0). An error, not a CPU fallback, when unavailable.
    Cuda,
}

/// How to load a style model.
#[derive(Clone, Debug)]
pub struct StyleOptions {
    /// The `.onnx` generator.
    pub model: PathBuf,
    /// Explicit ONNX Runtime library (`--ort-lib`); else `ORT_DYLIB_PATH`, else beside the exe.
    pub ort_lib: Option<PathBuf>,
    /// Where inference runs (`--device`).
    pub device: Device,
    /// Threads inside each operator; 0 lets ONNX Runtime choose (one per physical core).
    pub intra_threads: usize,
}

/// What was loaded, for run manifests.
#[derive(serde::Serialize, Clone, Debug)]
pub struct StyleInfo {
    /// File name of the model.
    pub name: String,
    /// BLAKE3 of the model file, hex.
    pub blake3: String,
    /// The pre- and post-processing applied around the model: [`CONVENTION`].
    pub convention: String,
    /// The model's declared input shape, `-1` for a dynamic axis.
    pub input_shape: Vec<i64>,
    /// `Some((tile_w, tile_h))` when the model has a fixed spatial size and runs tiled; a
    /// dynamic axis of a half-fixed model is reported as 0 (it is not split).
    pub tiled: Option<(u32, u32)>,
}

/// The convention string recorded in [`StyleInfo::convention`].
pub const CONVENTION: &str =
    "cyclegan: x/127.5-1 in, (y+1)*127.5 out (clipped to 0..255, rounded half away from zero), \
     reflect pad bottom/right to multiple of 4, crop back";

/// Fraction of a fixed tile that neighbouring tiles overlap by (at least): `tile / 4`.
pub const TILE_OVERLAP_DIVISOR: u32 = 4;

/// Tile starts are multiples of this (the generator's total downsampling factor), so tiles and
/// whole-image runs share the same stride-2 sampling grid.
pub const TILE_ALIGN: u32 = 4;

/// Largest number of frames (or tiles) sent to the model in one run.
pub const MAX_BATCH: usize = 8;

/// One spatial axis of the model input.
#[cfg(feature = "ort")]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Axis {
    Dynamic,
    Fixed(u32),
}

#[cfg(feature = "ort")]
impl Axis {
    fn of(d: i64) -> Axis {
        if d > 0 {
            Axis::Fixed(d as u32)
        } else {
            Axis::Dynamic
        }
    }

    /// Tiles covering an image extent `n` along this axis.
    fn tiles(self, n: u32) -> AxisTiles {
        match self {
            Axis::Dynamic => AxisTiles::whole(convert::padded_extent(n)),
            Axis::Fixed(t) => AxisTiles::plan(
                convert::padded_extent(n),
                t,
                t / TILE_OVERLAP_DIVISOR,
                TILE_ALIGN,
            ),
        }
    }
}

/// A loaded generator. `Send + Sync`; build it once per run and share it.
#[cfg(feature = "ort")]
pub struct StyleModel {
    path: PathBuf,
    info: StyleInfo,
    sessions: Vec<Mutex<Session>>,
    next: AtomicUsize,
    /// Model runs so far, and the images (batch items or tiles) they took.
    runs: AtomicUsize,
    items: AtomicUsize,
    dynamic_batch: bool,
    height: Axis,
    width: Axis,
    library: PathBuf,
}

#[cfg(feature = "ort")]
impl std::fmt::Debug for StyleModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StyleModel")
            .field("path", &self.path)
            .field("info", &self.info)
            .field("sessions", &self.sessions.len())
            .field("library", &self.library)
            .finish()
    }
}

#[cfg(feature = "ort")]
impl StyleModel {
    /// Loads the model with one session (see the module docs for the concurrency choice).
    pub fn load(opts: &StyleOptions) -> Result<StyleModel, StyleError> {
        Self::load_pool(opts, 1)
    }

    /// Loads the model with `sessions` (at least 1) independent sessions, so that up to that
    /// many calls run concurrently.
    pub fn load_pool(opts: &StyleOptions, sessions: usize) -> Result<StyleModel, StyleError> {
        let model = opts.model.clone();
        // Library first: without it nothing else can be checked, and its message matters most.
        let (env, library) =
            runtime::environment(opts.ort_lib.as_deref()).map_err(|e| match e {
                runtime::LibError::Missing(detail) => StyleError::OrtLibraryMissing {
                    model: model.clone(),
                    detail,
                },
                runtime::LibError::Load { lib, detail } => StyleError::OrtLibraryLoad {
                    model: model.clone(),
                    lib,
                    detail,
                },
            })?;
        let bytes = std::fs::read(&model).map_err(|source| StyleError::ModelUnreadable {
            model: model.clone(),
            source,
        })?;
        let blake3 = blake3::hash(&bytes).to_hex().to_string();
        drop(bytes);

        // One container: the sessions of the pool share the weights ONNX Runtime re-lays out
        // for its kernels instead of holding a copy each.
        let prepacked = ort::session::builder::PrepackedWeights::new();
        let mut pool = Vec::with_capacity(sessions.max(1));
        for _ in 0..sessions.max(1) {
            pool.push(Mutex::new(new_session(&env, opts, &prepacked, &library)?));
        }
        let first = pool[0].get_mut().unwrap_or_else(|p| p.into_inner());
        let (input_shape, dynamic_batch, height, width) = validate(&model, first)?;

        let tiled = match (height, width) {
            (Axis::Dynamic, Axis::Dynamic) => None,
            (h, w) => {
                let f = |a: Axis| match a {
                    Axis::Fixed(t) => t,
                    Axis::Dynamic => 0,
                };
                Some((f(w), f(h)))
            }
        };
        let info = StyleInfo {
            name: model.file_name().map_or_else(
                || model.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            ),
            blake3,
            convention: CONVENTION.to_string(),
            input_shape,
            tiled,
        };
        Ok(StyleModel {
            path: model,
            info,
            sessions: pool,
            next: AtomicUsize::new(0),
            runs: AtomicUsize::new(0),
            items: AtomicUsize::new(0),
            dynamic_batch,
            height,
            width,
            library,
        })
    }

    /// What was loaded: name, hash, convention, input shape and tiling.
    pub fn info(&self) -> &StyleInfo {
        &self.info
    }

    /// The canonical path of the ONNX Runtime library in use.
    pub fn library(&self) -> &Path {
        &self.library
    }

    /// Styles one image; the result has the input's size.
    pub fn stylize(&self, img: &RgbImage) -> Result<RgbImage, StyleError> {
        self.check_size(img)?;
        if self.info.tiled.is_some() {
            return self.stylize_tiled(img);
        }
        let (w, h) = (img.width(), img.height());
        let (pw, ph) = (convert::padded_extent(w), convert::padded_extent(h));
        let data = convert::image_to_chw(img, pw, ph);
        self.run(&data, [1, 3, ph as i64, pw as i64], |out| {
            convert::chw_to_image(out, pw, ph, w, h)
        })
    }

    /// Styles several images. Equal-size frames go through the model together (up to
    /// [`MAX_BATCH`] per run) when its batch axis is dynamic and it is not tiled; otherwise one
    /// by one. The results are identical to [`StyleModel::stylize`] on each image.
    pub fn stylize_batch(&self, imgs: &[&RgbImage]) -> Result<Vec<RgbImage>, StyleError> {
        self.stylize_batch_by(imgs, |_, _| MAX_BATCH)
    }

    /// As [`StyleModel::stylize_batch`], with at most `run_len(width, height)` images of that
    /// size per run (asked only for sizes that several images share; clamped to 1..=MAX_BATCH).
    pub fn stylize_batch_by(
        &self,
        imgs: &[&RgbImage],
        run_len: impl Fn(u32, u32) -> usize,
    ) -> Result<Vec<RgbImage>, StyleError> {
        if !self.batches() {
            return imgs.iter().map(|i| self.stylize(i)).collect();
        }
        let mut out: Vec<Option<RgbImage>> = vec![None; imgs.len()];
        // Groups of equal size, in order of first appearance.
        let mut groups: Vec<((u32, u32), Vec<usize>)> = Vec::new();
        for (i, img) in imgs.iter().enumerate() {
            self.check_size(img)?;
            let key = (img.width(), img.height());
            match groups.iter_mut().find(|(k, _)| *k == key) {
                Some((_, v)) => v.push(i),
                None => groups.push((key, vec![i])),
            }
        }
        for ((w, h), idx) in groups {
            let (pw, ph) = (convert::padded_extent(w), convert::padded_extent(h));
            let per = 3 * pw as usize * ph as usize;
            let len = if idx.len() > 1 { run_len(w, h) } else { 1 };
            for chunk in idx.chunks(len.clamp(1, MAX_BATCH)) {
                let mut data = vec![0f32; per * chunk.len()];
                for (slot, &i) in data.chunks_mut(per).zip(chunk) {
                    convert::window_to_chw(imgs[i], 0, 0, pw, ph, slot);
                }
                let shape = [chunk.len() as i64, 3, ph as i64, pw as i64];
                let res = self.run(&data, shape, |o| {
                    o.chunks(per)
                        .map(|s| convert::chw_to_image(s, pw, ph, w, h))
                        .collect::<Vec<_>>()
                })?;
                for (&i, r) in chunk.iter().zip(res) {
                    out[i] = Some(r);
                }
            }
        }
        Ok(out
            .into_iter()
            .map(|o| o.expect("every index grouped"))
            .collect())
    }

    /// (model runs, images or tiles they took) since the model was loaded.
    pub fn runs(&self) -> (usize, usize) {
        (
            self.runs.load(Ordering::Relaxed),
            self.items.load(Ordering::Relaxed),
        )
    }

    /// Whether [`StyleModel::stylize_batch`] puts several images in one run (a dynamic batch
    /// axis and whole-image inference).
    pub fn batches(&self) -> bool {
        self.dynamic_batch && self.info.tiled.is_none()
    }

    /// Whether a batch of `n` images of this size gives exactly the bytes of single runs: a
    /// runtime may pick other kernels (other rounding) for other batch sizes. Checked on a fixed
    /// pattern, so the answer depends on the model, the runtime and the size only.
    pub fn batch_matches_single(
        &self,
        width: u32,
        height: u32,
        n: usize,
    ) -> Result<bool, StyleError> {
        let pattern = probe_pattern(width, height);
        let single = self.stylize(&pattern)?;
        let batch = self.stylize_batch(&vec![&pattern; n.max(1)])?;
        Ok(batch.iter().all(|b| b.as_raw() == single.as_raw()))
    }

    fn check_size(&self, img: &RgbImage) -> Result<(), StyleError> {
        if img.width() == 0 || img.height() == 0 {
            return Err(StyleError::EmptyImage {
                model: self.path.clone(),
                width: img.width(),
                height: img.height(),
            });
        }
        Ok(())
    }

    fn stylize_tiled(&self, img: &RgbImage) -> Result<RgbImage, StyleError> {
        let (w, h) = (img.width(), img.height());
        let xs = self.width.tiles(w);
        let ys = self.height.tiles(h);
        let (tw, th) = (xs.tile, ys.tile);
        let wx: Vec<Vec<f32>> = (0..xs.starts.len()).map(|k| xs.weights(k)).collect();
        let wy: Vec<Vec<f32>> = (0..ys.starts.len()).map(|k| ys.weights(k)).collect();
        let tiles: Vec<(usize, usize)> = (0..ys.starts.len())
            .flat_map(|j| (0..xs.starts.len()).map(move |i| (i, j)))
            .collect();
        let per = 3 * tw as usize * th as usize;
        let group = if self.dynamic_batch { MAX_BATCH } else { 1 };
        let mut blend = Blender::new(w, h);
        for chunk in tiles.chunks(group) {
            let mut data = vec![0f32; per * chunk.len()];
            for (slot, &(i, j)) in data.chunks_mut(per).zip(chunk) {
                convert::window_to_chw(img, xs.starts[i] as i64, ys.starts[j] as i64, tw, th, slot);
            }
            let shape = [chunk.len() as i64, 3, th as i64, tw as i64];
            self.run(&data, shape, |o| {
                for (s, &(i, j)) in o.chunks(per).zip(chunk) {
                    blend.add(s, (xs.starts[i], ys.starts[j]), &wx[i], &wy[j]);
                }
            })?;
        }
        Ok(blend.finish())
    }

    /// Runs one `[n, 3, h, w]` tensor and hands the same-shaped output to `f` while the session
    /// is held (no copy of the output).
    fn run<R>(
        &self,
        data: &[f32],
        shape: [i64; 4],
        f: impl FnOnce(&[f32]) -> R,
    ) -> Result<R, StyleError> {
        let run_err = |e: ort::Error| StyleError::Run {
            model: self.path.clone(),
            detail: e.to_string(),
        };
        let input = TensorRef::from_array_view((shape, data)).map_err(run_err)?;
        let mut session = self.acquire();
        let outputs = session.run(ort::inputs![input]).map_err(run_err)?;
        self.runs.fetch_add(1, Ordering::Relaxed);
        self.items.fetch_add(shape[0] as usize, Ordering::Relaxed);
        let (oshape, out) = outputs[0].try_extract_tensor::<f32>().map_err(run_err)?;
        if **oshape != shape[..] {
            return Err(StyleError::BadOutput {
                model: self.path.clone(),
                expected: shape.to_vec(),
                got: oshape.to_vec(),
            });
        }
        Ok(f(out))
    }

    /// A free session if there is one, else waits on one (round robin).
    fn acquire(&self) -> MutexGuard<'_, Session> {
        let n = self.sessions.len();
        let start = self.next.fetch_add(1, Ordering::Relaxed) % n;
        for k in 0..n {
            if let Ok(g) = self.sessions[(start + k) % n].try_lock() {
                return g;
            }
        }
        self.sessions[start]
            .lock()
            .unwrap_or_else(|p| p.into_inner())
    }
}

/// A fixed image with edges, gradients and noise, for [`StyleModel::batch_matches_single`].
#[cfg(feature = "ort")]
fn probe_pattern(width: u32, height: u32) -> RgbImage {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut data = Vec::with_capacity(width as usize * height as usize * 3);
    for y in 0..height {
        for x in 0..width {
            // xorshift64: deterministic noise on every platform
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let noise = (state >> 58) as u32;
            let square = if (x / 16 + y / 16) % 2 == 0 { 60 } else { 0 };
            data.push(((x * 255 / width.max(1)) / 2 + square + noise) as u8);
            data.push(((y * 255 / height.max(1)) / 2 + square + noise) as u8);
            data.push((128 + noise * 2) as u8);
        }
    }
    RgbImage::from_raw(width, height, data).expect("width * height * 3 bytes")
}

/// One session. On the CPU without ONNX Runtime's arena and memory pattern: the arena grows
/// in powers of two and keeps its peak, and a pattern is a second block planned for each input
/// shape, so a session of a real generator held about 1.4 GB for a 1242x375 frame where its
/// tensors need a third of that; plain allocations are freed as each operator's inputs die.
/// Where a tensor lives changes no value computed.
#[cfg(feature = "ort")]
fn new_session(
    env: &ort::environment::Environment,
    opts: &StyleOptions,
    prepacked: &ort::session::builder::PrepackedWeights,
    library: &Path,
) -> Result<Session, StyleError> {
    let model = &opts.model;
    let serr = |detail: String| StyleError::Session {
        model: model.clone(),
        detail,
    };
    let mut b = Session::builder(env)
        .map_err(|e| serr(e.to_string()))?
        .with_optimization_level(GraphOptimizationLevel::All)
        .map_err(|e| serr(e.to_string()))?
        .with_prepacked_weights(prepacked)
        .map_err(|e| serr(e.to_string()))?;
    if opts.device == Device::Cpu {
        b = b
            .with_memory_pattern(false)
            .map_err(|e| serr(e.to_string()))?
            .with_execution_providers([ort::ep::CPU::default().with_arena_allocator(false).build()])
            .map_err(|e| serr(e.to_string()))?;
    }
    if opts.intra_threads > 0 {
        b = b
            .with_intra_threads(opts.intra_threads)
            .map_err(|e| serr(e.to_string()))?;
    }
    if opts.device == Device::Cuda {
        runtime::append_cuda(&mut b, library).map_err(|detail| StyleError::Cuda {
            model: model.clone(),
            detail,
        })?;
    }
    b.commit_from_file(model).map_err(|e| {
        use ort::ErrorCode as C;
        match e.code() {
            C::InvalidProtobuf | C::InvalidGraph | C::NoModel => StyleError::NotOnnx {
                model: model.clone(),
                detail: e.to_string(),
            },
            C::NoSuchFile => StyleError::ModelUnreadable {
                model: model.clone(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, e.to_string()),
            },
            _ => serr(e.to_string()),
        }
    })
}

/// Checks the model is an image-to-image generator; returns the input shape, whether the batch
/// axis is dynamic, and the H and W axes.
#[cfg(feature = "ort")]
fn validate(model: &Path, s: &Session) -> Result<(Vec<i64>, bool, Axis, Axis), StyleError> {
    if s.inputs().len() != 1 || s.outputs().is_empty() {
        return Err(StyleError::Arity {
            model: model.to_path_buf(),
            inputs: s.inputs().len(),
            outputs: s.outputs().len(),
        });
    }
    let check = |which: &'static str, o: &ort::value::Outlet| -> Result<Vec<i64>, StyleError> {
        let name = o.name().to_string();
        let (ty, shape) = match o.dtype() {
            ValueType::Tensor { ty, shape, .. } => (*ty, shape.to_vec()),
            other => {
                return Err(StyleError::ElementType {
                    model: model.to_path_buf(),
                    which,
                    name,
                    found: format!("{other:?}"),
                })
            }
        };
        if shape.len() != 4 {
            return Err(StyleError::Rank {
                model: model.to_path_buf(),
                which,
                name,
                rank: shape.len(),
                shape,
            });
        }
        if shape[1] != 3 {
            return Err(StyleError::Channels {
                model: model.to_path_buf(),
                which,
                name,
                channels: shape[1],
                shape,
            });
        }
        if ty != TensorElementType::Float32 {
            return Err(StyleError::ElementType {
                model: model.to_path_buf(),
                which,
                name,
                found: format!("a {ty:?} tensor"),
            });
        }
        Ok(shape)
    };
    let ishape = check("input", &s.inputs()[0])?;
    let oshape = check("output", &s.outputs()[0])?;
    if ishape
        .iter()
        .zip(&oshape)
        .any(|(&i, &o)| i > 0 && o > 0 && i != o)
    {
        return Err(StyleError::ShapeMismatch {
            model: model.to_path_buf(),
            input: ishape,
            output: oshape,
        });
    }
    let dynamic_batch = match ishape[0] {
        d if d <= 0 => true,
        1 => false,
        b => {
            return Err(StyleError::Batch {
                model: model.to_path_buf(),
                batch: b,
            })
        }
    };
    Ok((
        ishape.clone(),
        dynamic_batch,
        Axis::of(ishape[2]),
        Axis::of(ishape[3]),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_is_send_sync() {
        fn ok<T: Send + Sync>() {}
        ok::<StyleModel>();
        ok::<StyleError>();
    }
}
