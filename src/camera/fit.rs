//! Converting a lens to another model: the target's parameters are fitted to the source by
//! Levenberg-Marquardt on the reprojection error of a dense grid of the source's pixels (every
//! grid pixel with a ray inside the source's field of view), and the fit is then measured on a
//! second grid offset by half a step, so the reported errors are not those the fit minimised.
//!
//! The fitted lens keeps the source's image size and field of view (or the narrower one asked
//! for); where the target model cannot reach that far, the widest field angle sampled.

use super::double_sphere::DoubleSphere;
use super::eucm::Eucm;
use super::fisheye::{Fisheye, RadialModel};
use super::lens::Lens;
use super::lens_domain::FisheyeError;
use super::unified::{MeiDistortion, Unified};
use super::{CameraModel, Intrinsics};
use nalgebra::{DMatrix, DVector, Point2, Vector3};

/// The models a lens can be converted to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TargetModel {
    /// Kannala-Brandt / OpenCV fisheye ([`RadialModel::KannalaBrandt`]).
    KannalaBrandt,
    /// The unified model with Mei's distortion ([`Unified`]).
    Mei,
    /// The extended unified camera model ([`Eucm`]).
    Eucm,
    /// The double sphere model ([`DoubleSphere`]).
    DoubleSphere,
}

impl TargetModel {
    /// The model's name as in a camera description's `"model"` key.
    pub fn name(self) -> &'static str {
        match self {
            TargetModel::KannalaBrandt => "kannala_brandt",
            TargetModel::Mei => "mei",
            TargetModel::Eucm => "eucm",
            TargetModel::DoubleSphere => "double_sphere",
        }
    }
}

/// A fitted lens and its reprojection errors (pixels) over the evaluation grid.
#[derive(Debug, Clone)]
pub struct FitReport {
    /// The fitted lens in the target model.
    pub lens: Lens,
    /// Root mean square reprojection error over the evaluation grid, in pixels.
    pub rms_px: f64,
    /// Largest reprojection error over the evaluation grid, in pixels (infinite when some
    /// evaluation ray has no image in the fitted lens).
    pub max_px: f64,
    /// Rays the fit minimised the error over.
    pub fit_rays: usize,
    /// Rays of the evaluation grid (offset by half a step from the fit's).
    pub eval_rays: usize,
    /// Levenberg-Marquardt iterations of the best start.
    pub iterations: usize,
}

/// Grid points per image side (the larger one) of the fit.
const GRID: usize = 160;
const MAX_ITERATIONS: usize = 300;

/// (bearing, source pixel) on a grid of the source image, offset by `shift` steps, for rays up
/// to `max_theta` from the axis.
fn samples(source: &Lens, shift: f64, max_theta: f64) -> Vec<(Vector3<f64>, Point2<f64>)> {
    let s = source.size();
    let step = s.width.max(s.height) as f64 / GRID as f64;
    let mut out = Vec::new();
    let mut v = -0.5 + shift * step;
    while v <= s.height as f64 - 0.5 {
        let mut u = -0.5 + shift * step;
        while u <= s.width as f64 - 0.5 {
            let p = Point2::new(u, v);
            match source.unproject(&p) {
                Ok(d) if d.x.hypot(d.y).atan2(d.z) <= max_theta => out.push((d, p)),
                _ => {}
            }
            u += step;
        }
        v += step;
    }
    out
}

fn build(
    target: TargetModel,
    p: &[f64],
    like: &Lens,
    max_theta: f64,
) -> Result<Lens, FisheyeError> {
    let k = Intrinsics::new(p[0], p[1], p[2], p[3]);
    let size = like.size();
    Ok(match target {
        TargetModel::KannalaBrandt => Fisheye::new(
            RadialModel::KannalaBrandt([p[4], p[5], p[6], p[7]]),
            k,
            size,
            2.0 * max_theta,
        )?
        .erased(),
        TargetModel::Mei => Unified::new(
            p[4],
            MeiDistortion {
                k1: p[5],
                k2: p[6],
                p1: p[7],
                p2: p[8],
            },
            k,
            0.0,
            size,
            max_theta,
        )?
        .erased(),
        TargetModel::Eucm => Eucm::new(p[4], p[5], k, size, max_theta)?.erased(),
        TargetModel::DoubleSphere => DoubleSphere::new(p[4], p[5], k, size, max_theta)?.erased(),
    })
}

/// Starting parameters: the source's scale at the centre with the target family's simplest
/// members (several for MEI, whose ξ and k1 trade off and leave local minima), and the source's
/// own parameters when it already belongs to the target family.
fn initial(target: TargetModel, source: &Lens) -> Vec<Vec<f64>> {
    let c = source.centre_intrinsics();
    let mut starts = match target {
        // r ≈ θ
        TargetModel::KannalaBrandt => vec![vec![c.fu, c.fv, c.cu, c.cv, 0.0, 0.0, 0.0, 0.0]],
        // r ≈ θ/(1 + ξ) near the axis
        TargetModel::Mei => [0.5, 1.0, 2.0, 3.0]
            .iter()
            .map(|xi| {
                let f = 1.0 + xi;
                vec![f * c.fu, f * c.fv, c.cu, c.cv, *xi, 0.0, 0.0, 0.0, 0.0]
            })
            .collect(),
        // α = 0.5, β = 1 (ξ = 0): r = 2 tan(θ/2)
        TargetModel::Eucm => vec![vec![c.fu, c.fv, c.cu, c.cv, 0.5, 1.0]],
        TargetModel::DoubleSphere => vec![vec![c.fu, c.fv, c.cu, c.cv, 0.0, 0.5]],
    };
    let k = source.intrinsics();
    // The source's own parameters when it is of the target's model (MEI's skew is not
    // fitted: only a source without one).
    let own = (source.name() == target.name())
        .then(|| source.parameters())
        .and_then(|p| match p.split_last() {
            Some((("skew", skew), rest)) => (*skew == 0.0).then(|| rest.to_vec()),
            _ => Some(p),
        })
        .map(|p| p.into_iter().map(|(_, v)| v).collect::<Vec<f64>>());
    if let Some(rest) = own {
        starts.push([vec![k.fu, k.fv, k.cu, k.cv], rest].concat());
    }
    starts
}

/// Residuals (target pixel − source pixel, x then y), or None when the candidate cannot be
/// built or rejects a ray.
fn residuals(lens: &Lens, rays: &[(Vector3<f64>, Point2<f64>)]) -> Option<Vec<f64>> {
    let mut r = Vec::with_capacity(2 * rays.len());
    for (d, p) in rays {
        let q = lens.project(d).ok()?;
        r.push(q.x - p.x);
        r.push(q.y - p.y);
    }
    r.iter().all(|v| v.is_finite()).then_some(r)
}

/// Fits `target` to `source` (see the module doc) over the source's pixels whose rays lie
/// within `max_theta` of the axis (None: the source's whole field of view).
pub fn fit(
    source: &Lens,
    target: TargetModel,
    max_theta: Option<f64>,
) -> Result<FitReport, FisheyeError> {
    let max_theta = max_theta.unwrap_or(f64::INFINITY).min(source.max_theta());
    let rays = samples(source, 0.0, max_theta);
    if rays.len() < 16 {
        return Err(FisheyeError::FieldOfView(
            "the source camera has too few pixels with a ray to fit another model".into(),
        ));
    }
    let check = samples(source, 0.5, max_theta);
    // The fitted lens must see every ray of both grids.
    let widest = rays
        .iter()
        .chain(&check)
        .map(|(d, _)| d.x.hypot(d.y).atan2(d.z))
        .fold(0.0f64, f64::max);
    let cost_of = |p: &[f64]| -> Option<(f64, Vec<f64>)> {
        let lens = build(target, p, source, widest).ok()?;
        let r = residuals(&lens, &rays)?;
        Some((r.iter().map(|v| v * v).sum(), r))
    };
    let mut best: Option<(Vec<f64>, f64, usize)> = None;
    for start in initial(target, source) {
        let Some(found) = levenberg_marquardt(start, &cost_of) else {
            continue;
        };
        if best.as_ref().is_none_or(|b| found.1 < b.1) {
            best = Some(found);
        }
    }
    let (params, _, iterations) = best.ok_or_else(|| {
        FisheyeError::FieldOfView(format!(
            "the {} model cannot start from the source's field of view ({:.1}°)",
            target.name(),
            2.0 * widest.to_degrees()
        ))
    })?;
    // The fitted lens sees the source's whole field of view when it can, else what was sampled.
    let lens = build(target, &params, source, max_theta)
        .or_else(|_| build(target, &params, source, widest))?;
    let errors: Vec<f64> = check
        .iter()
        .map(|(d, p)| lens.project(d).map_or(f64::INFINITY, |q| (q - p).norm()))
        .collect();
    let rms_px = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    let max_px = errors.iter().copied().fold(0.0, f64::max);
    Ok(FitReport {
        lens,
        rms_px,
        max_px,
        fit_rays: rays.len(),
        eval_rays: check.len(),
        iterations,
    })
}

/// Sum of squares and residuals of a parameter vector; None where it is infeasible.
type CostFn<'a> = dyn Fn(&[f64]) -> Option<(f64, Vec<f64>)> + 'a;

/// Levenberg-Marquardt from `params` on a sum of squares `cost_of` (None: infeasible):
/// (parameters, cost, iterations), or None when the start itself is infeasible.
///
/// Hand-written rather than the `levenberg-marquardt` crate (MINPACK's): a lens model's
/// parameters have a feasible range (a field of view the model must reach, a positive
/// focal length), and here an infeasible trial step is only a rejected step (damping up) and
/// the Jacobian takes a backward difference at the range's edge, where that crate's problem
/// must give residuals for every point it tries and stops at the first it cannot; the loop is
/// 70 lines over nalgebra, which the crate depends on anyway.
fn levenberg_marquardt(mut params: Vec<f64>, cost_of: &CostFn) -> Option<(Vec<f64>, f64, usize)> {
    let (mut cost, mut r) = cost_of(&params)?;
    let n = params.len();
    let mut lambda: f64 = 1e-3;
    let mut iterations = 0;
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        let mut converged = false;
        // Forward-difference Jacobian, accumulated straight into JᵀJ and Jᵀr.
        let mut columns = Vec::with_capacity(n);
        for j in 0..n {
            let h = 1e-7 * (1.0 + params[j].abs());
            // Forward difference, backward at the edge of the parameter range.
            let column = [h, -h].iter().find_map(|&dh| {
                let mut q = params.clone();
                q[j] += dh;
                let (_, rq) = cost_of(&q)?;
                Some(
                    rq.iter()
                        .zip(&r)
                        .map(|(a, b)| (a - b) / dh)
                        .collect::<Vec<f64>>(),
                )
            });
            // Boxed in on both sides by the parameter range: stop here.
            let Some(column) = column else {
                return Some((params, cost, iterations));
            };
            columns.push(column);
        }
        let jtj = DMatrix::from_fn(n, n, |a, b| {
            columns[a]
                .iter()
                .zip(&columns[b])
                .map(|(x, y)| x * y)
                .sum::<f64>()
        });
        let jtr = DVector::from_fn(n, |a, _| {
            columns[a].iter().zip(&r).map(|(x, y)| x * y).sum()
        });
        let mut accepted = false;
        for _ in 0..20 {
            let mut damped = jtj.clone();
            for d in 0..n {
                damped[(d, d)] += lambda * jtj[(d, d)].max(1e-12);
            }
            let Some(step) = damped.lu().solve(&(-&jtr)) else {
                lambda *= 10.0;
                continue;
            };
            let candidate: Vec<f64> = params.iter().zip(step.iter()).map(|(p, s)| p + s).collect();
            match cost_of(&candidate) {
                Some((c, rc)) if c < cost => {
                    let gain = (cost - c) / cost.max(1e-300);
                    params = candidate;
                    cost = c;
                    r = rc;
                    lambda = (lambda / 3.0).max(1e-12);
                    accepted = true;
                    converged = gain < 1e-12;
                    break;
                }
                _ => lambda *= 10.0,
            }
        }
        if !accepted || converged {
            break;
        }
    }
    Some((params, cost, iterations))
}
