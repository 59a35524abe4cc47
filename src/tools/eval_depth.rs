//! Depth-estimation metrics, as used by Payen de La Garanderie et al. and Kumar et al. (after
//! Eigen et al.): abs rel, sq rel, RMSE, RMSE log and the δ < 1.25ᵏ accuracies.
//!
//! Ground-truth pixels count when min < gt < max; predictions are clamped to [min, max]. The
//! metrics are computed per image and then averaged over images (the monodepth convention).
//! Ground-truth depth maps are KITTI 16-bit PNGs, value = round(d·256), 0 = no depth; a
//! prediction is such a PNG, or float metres in a `.npy` or `.npz` of the same stem
//! ([`crate::tools::depth_array`]).

use crate::codec::png::decode_gray16;
use crate::error::{Error, Result};
use crate::fs::read_file;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Depth-estimation metrics of one image, or their mean over images (see [`mean`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct DepthMetrics {
    /// Mean of |pred − gt| / gt.
    pub abs_rel: f64,
    /// Mean of (pred − gt)² / gt, metres.
    pub sq_rel: f64,
    /// Root of the mean of (pred − gt)², metres.
    pub rmse: f64,
    /// Root of the mean of (ln pred − ln gt)².
    pub rmse_log: f64,
    /// Share of pixels with max(pred/gt, gt/pred) < 1.25, from 0 to 1.
    pub delta_1: f64,
    /// Share of pixels with max(pred/gt, gt/pred) < 1.25², from 0 to 1.
    pub delta_2: f64,
    /// Share of pixels with max(pred/gt, gt/pred) < 1.25³, from 0 to 1.
    pub delta_3: f64,
    /// Valid ground-truth pixels used.
    pub pixels: usize,
}

/// Metrics of one image; None when no ground-truth pixel is valid.
pub fn image_metrics(pred: &[f64], gt: &[f64], min: f64, max: f64) -> Option<DepthMetrics> {
    let mut m = DepthMetrics::default();
    let (mut se, mut sle) = (0.0, 0.0);
    for (&p, &g) in pred.iter().zip(gt) {
        if !(g > min && g < max) {
            continue;
        }
        let p = p.clamp(min, max);
        m.pixels += 1;
        m.abs_rel += (p - g).abs() / g;
        m.sq_rel += (p - g).powi(2) / g;
        se += (p - g).powi(2);
        sle += (p.ln() - g.ln()).powi(2);
        let ratio = (p / g).max(g / p);
        m.delta_1 += f64::from(u8::from(ratio < 1.25));
        m.delta_2 += f64::from(u8::from(ratio < 1.25f64.powi(2)));
        m.delta_3 += f64::from(u8::from(ratio < 1.25f64.powi(3)));
    }
    if m.pixels == 0 {
        return None;
    }
    let n = m.pixels as f64;
    Some(DepthMetrics {
        abs_rel: m.abs_rel / n,
        sq_rel: m.sq_rel / n,
        rmse: (se / n).sqrt(),
        rmse_log: (sle / n).sqrt(),
        delta_1: m.delta_1 / n,
        delta_2: m.delta_2 / n,
        delta_3: m.delta_3 / n,
        pixels: m.pixels,
    })
}

/// The mean of per-image metrics (pixels: their sum).
pub fn mean(images: &[DepthMetrics]) -> DepthMetrics {
    let n = images.len().max(1) as f64;
    let avg = |f: fn(&DepthMetrics) -> f64| images.iter().map(f).sum::<f64>() / n;
    DepthMetrics {
        abs_rel: avg(|m| m.abs_rel),
        sq_rel: avg(|m| m.sq_rel),
        rmse: avg(|m| m.rmse),
        rmse_log: avg(|m| m.rmse_log),
        delta_1: avg(|m| m.delta_1),
        delta_2: avg(|m| m.delta_2),
        delta_3: avg(|m| m.delta_3),
        pixels: images.iter().map(|m| m.pixels).sum(),
    }
}

fn read_depth(path: &Path) -> Result<(u32, u32, Vec<f64>)> {
    let (w, h, v) = decode_gray16(&read_file(path)?, path)?;
    Ok((w, h, v.into_iter().map(|x| x as f64 / 256.0).collect()))
}

/// The prediction for ground truth `name`: `pred/name` (a 16-bit PNG), else the `.npy` or
/// `.npz` of the same stem (float metres); with none of them, the PNG's read error.
/// A depth map: width, height, metres row by row.
type DepthValues = (u32, u32, Vec<f64>);

fn read_prediction(pred: &Path, name: &str) -> Result<(PathBuf, DepthValues)> {
    let png = pred.join(name);
    if !png.exists() {
        for ext in ["npy", "npz"] {
            let array = png.with_extension(ext);
            if array.is_file() {
                let depth = crate::tools::depth_array::read_depth_array(&array)?;
                return Ok((array, depth));
            }
        }
    }
    let depth = read_depth(&png)?;
    Ok((png, depth))
}

/// The outcome of [`evaluate`] (the JSON of `eval-depth --json`, `failed` aside).
#[derive(Debug, Serialize)]
pub struct Evaluation {
    /// Ground truth counts above this depth, metres (`--min-depth`).
    pub min_depth: f64,
    /// Ground truth counts below this depth, metres (`--max-depth`).
    pub max_depth: f64,
    /// Images evaluated (those in `mean`).
    pub images: usize,
    /// The metrics averaged over the evaluated images.
    pub mean: DepthMetrics,
    /// Frames that could not be evaluated (missing or mismatched prediction, no valid pixel).
    #[serde(skip)]
    pub failed: Vec<(String, Error)>,
}

/// Evaluates every `gt/*.png` against `pred/` (same file names).
pub fn evaluate(pred: &Path, gt: &Path, min: f64, max: f64) -> Result<Evaluation> {
    if !(min >= 0.0 && max > min) {
        return Err(Error::Setup(format!("bad depth range {min}..{max}")));
    }
    let mut names: Vec<String> = crate::fs::file_stems(gt, ".png")
        .map_err(|e| Error::Setup(format!("{}: {e}", gt.display())))?
        .into_iter()
        .map(|stem| stem + ".png")
        .collect();
    names.sort(); // by file name, as reported
    if names.is_empty() {
        return Err(Error::Setup(format!(
            "{}: no ground-truth PNG",
            gt.display()
        )));
    }
    let mut per_image = Vec::new();
    let mut failed = Vec::new();
    for name in names {
        let run = || -> Result<DepthMetrics> {
            let (gw, gh, g) = read_depth(&gt.join(&name))?;
            let (pred_path, (pw, ph, p)) = read_prediction(pred, &name)?;
            if (pw, ph) != (gw, gh) {
                return Err(Error::file(
                    &pred_path,
                    format!("{pw}x{ph} prediction for a {gw}x{gh} ground truth"),
                ));
            }
            image_metrics(&p, &g, min, max).ok_or_else(|| {
                Error::file(
                    &gt.join(&name),
                    format!("no ground-truth pixel within {min}..{max} m"),
                )
            })
        };
        match run() {
            Ok(m) => per_image.push(m),
            Err(e) => failed.push((name, e)),
        }
    }
    Ok(Evaluation {
        min_depth: min,
        max_depth: max,
        images: per_image.len(),
        mean: mean(&per_image),
        failed,
    })
}
