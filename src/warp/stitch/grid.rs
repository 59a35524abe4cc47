//! The grid-guided stitch: the depth-guided stitch of pinhole rigs, its scene a grid in the
//! output's own pixels, built once a frame.
//!
//! 1. The scene's distance at every output pixel centre (`distance.rs`): the scan's returns in
//!    their nearest pixels, the gaps between rings closed along columns where both sides lie on
//!    one surface, the boxes ray-cast exactly, a wall above the top ring carried up, the ground
//!    where the ray meets it, else [`FAR_DISTANCE`](distance::FAR_DISTANCE).
//! 2. Camera i samples that point X = C + d·b where its image holds it (`camera.rs`): one
//!    trilinear sample of its image's pyramid at the level of the pixel's footprint there
//!    (log2 of the source pixels an output pixel spans, f/cos²θ pixels a radian), through a
//!    [`SampledRows`] table. Points of a box are sampled where the box was when the camera
//!    fired.
//! 3. Its weight is the stitch's margin weight (step 3 of the stitch's model, the margin the
//!    border distance over the pinhole's scale f/cos²θ), 0 where its ego mask lies within
//!    1 + max(1, s) pixels of the sample (s source pixels an output pixel).
//! 4. Camera i is occluded at the pixel when its occlusion buffer (the scan but its ground
//!    returns, and the boxes, seen from its eye, nearest depth per 8×8 source pixels) holds a
//!    surface nearer than X's depth by more than 0.3 m plus a tenth of that depth plus the
//!    scan's ring spacing (radians) times it. Occluded cameras give the pixel nothing
//!    where another camera sees it, else they blend (the fallback rule, [`FALLBACK_SOURCE`]).
//! 5. A pixel no camera's image holds at its distance (nor, on a moving box, where C2 sees it)
//!    is stitched at the proxy distance (the far fill, [`FAR_SOURCE`]). Its colour is not the
//!    surface at its distance, whose depth a depth map may hold: so no farther try (the sky's
//!    rays are at 10 km already).
//!
//! Cameras are culled per tile of [`TILE`]×[`TILE`] output pixels by their border planes,
//! widened by the tile's angular radius and the parallax of the camera's offset at the tile's
//! nearest distance: the same bytes as testing every camera at every pixel.
//!
//! [`FALLBACK_SOURCE`]: super::FALLBACK_SOURCE
//! [`FAR_SOURCE`]: super::FAR_SOURCE

mod camera;
mod distance;

use super::weights::TablesAndWeights;
use super::{fallback, Stitch, StitchCamera, StitchOptions};
use crate::camera::CameraModel;
use crate::error::Result;
use crate::warp::mask::EgoMask;
use crate::warp::reach::OutputGrid;
use crate::warp::table::sampled::{RowBlocks, Sample, SampledRows};
use camera::{GridCamera, View};
use distance::{DistanceGrid, Origin, NO_BOX};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

/// Output tile side of the cameras' cull, pixels.
const TILE: usize = 16;

/// The distance from the output centre along a unit bearing to the ground, where the ray
/// meets it.
pub type GroundHit = Box<dyn Fn(&Vector3<f64>) -> Option<f64> + Sync + Send>;

/// A frame's scene as the grid-guided stitch reads it, in the reference frame.
pub struct GridScene {
    /// The scan's returns (the vehicle's own removed).
    pub points: Vec<Vector3<f64>>,
    /// The scan's ring spacing, measured from it (the median elevation gap between
    /// neighbouring rings), radians: how far a return's surface reaches across the rings,
    /// and how uncertain its bearing is.
    pub ring_spacing: f64,
    /// Per return, whether it lies on the ground (within a band of the local ground): the
    /// ground hides nothing a camera sees beyond it, and a column gap between two of its
    /// returns takes the ground's distance.
    pub on_ground: Vec<bool>,
    /// The ground's plane normal, where it has one: a return of the ground moves to its
    /// pixel's centre along the plane (the centre's distance differs by up to half a pixel's
    /// grade, metres on a road seen at a grazing angle).
    pub ground_normal: Option<Vector3<f64>>,
    /// The boxes.
    pub boxes: Vec<GridBox>,
    /// The distance from the output centre along a unit bearing to the ground, where it meets
    /// it.
    pub ground: Option<GroundHit>,
}

impl std::fmt::Debug for GridScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GridScene")
            .field("points", &self.points.len())
            .field("boxes", &self.boxes.len())
            .field("ground", &self.ground.is_some())
            .finish()
    }
}

/// An object's box.
#[derive(Debug, Clone)]
pub struct GridBox {
    /// Its centre.
    pub centre: Vector3<f64>,
    /// Half its size along its own axes.
    pub half: Vector3<f64>,
    /// reference_from_box.
    pub rotation: Matrix3<f64>,
    /// Per camera, its move from the scene's time to the camera's (empty: still).
    pub moved: Vec<Vector3<f64>>,
}

impl GridBox {
    /// Its eight corners.
    pub(super) fn corners(&self) -> [Vector3<f64>; 8] {
        std::array::from_fn(|k| {
            let s = |bit: usize| if k & bit != 0 { 1.0 } else { -1.0 };
            self.centre + self.rotation * Vector3::new(s(1), s(2), s(4)).component_mul(&self.half)
        })
    }
}

/// Whether the grid-guided stitch builds a depth-guided stitch of `cameras`: pinholes, none
/// with a field-of-view bound.
pub fn grid_applies(cameras: &[StitchCamera]) -> bool {
    cameras
        .iter()
        .all(|c| c.model.pinhole().is_some() && c.max_theta.is_none())
}

/// Output rows a unit of the build's parallel work: a band's samples are placed first, then
/// its blocks and weights sized and made, a few allocations a band ([`SampledRows::band`];
/// every thread allocates from one heap, `run::alloc`).
const BAND: usize = 8;

/// A band of rows' share of the build: per camera its blocks and, per row from its first
/// sampled column, its weights (resolved: [`fallback::resolve`]); the pixels the fallback
/// filled and the far fill's.
struct Band {
    blocks: Vec<RowBlocks>,
    weights: Vec<BandWeights>,
    fallback: Vec<bool>,
    far: Vec<bool>,
}

/// A camera's weights in a band: per row its first sampled column and its columns' count,
/// the rows' weights one after the other.
struct BandWeights {
    spans: Vec<(usize, usize)>,
    values: Vec<f32>,
}

/// A thread's buffers for its bands: per camera a band of samples and weights (row-major,
/// negative: a fallback weight), all None and 0 between bands (a band clears only the columns
/// it set), and per camera and band row the columns it samples; the fallback's room.
struct Scratch {
    samples: Vec<Vec<Option<Sample>>>,
    weights: Vec<Vec<f32>>,
    spans: Vec<[(usize, usize); BAND]>,
    found: Vec<(usize, View)>,
    seen: Vec<bool>,
}

impl Scratch {
    fn new(cameras: usize, width: usize) -> Self {
        Self {
            samples: vec![vec![None; BAND * width]; cameras],
            weights: vec![vec![0.0; BAND * width]; cameras],
            spans: vec![[(0, 0); BAND]; cameras],
            found: Vec::with_capacity(cameras),
            seen: vec![false; BAND * width],
        }
    }
}

impl Stitch {
    /// The grid-guided stitch of `cameras` (pinholes: [`grid_applies`]) into `output` from
    /// `centre` through `scene`, with ego masks as [`Stitch::build_masked`] (see the module's
    /// notes).
    pub fn build_grid(
        output: &dyn CameraModel,
        centre: &Vector3<f64>,
        cameras: &[StitchCamera],
        masks: &[Option<&EgoMask>],
        options: StitchOptions,
        scene: &GridScene,
    ) -> Result<Stitch> {
        Self::check_masks(cameras, masks)?;
        let built = tables_and_weights(output, centre, cameras, masks, options, scene);
        Ok(Stitch::from_parts(output.size(), built, options))
    }
}

fn tables_and_weights(
    output: &dyn CameraModel,
    centre: &Vector3<f64>,
    cameras: &[StitchCamera],
    masks: &[Option<&EgoMask>],
    options: StitchOptions,
    scene: &GridScene,
) -> TablesAndWeights {
    let size = output.size();
    let (w, h) = (size.width as usize, size.height as usize);
    let out_grid = OutputGrid::of(output);
    let bearing = Bearings { grid: &out_grid };
    let grid = DistanceGrid::build(output, bearing, centre, scene, out_grid.step);
    let views: Vec<GridCamera> = cameras
        .par_iter()
        .enumerate()
        .map(|(i, c)| {
            let k = c.model.pinhole().expect("grid_applies: pinholes");
            let mask = masks.get(i).copied().flatten();
            GridCamera::new((i, c, k), centre, scene, mask)
        })
        .collect();
    let tiles = cull(&views, &grid, bearing, options.distance);
    let sampled: Vec<SampledRows> = cameras
        .iter()
        .map(|c| SampledRows::new(size, c.model.size()))
        .collect();
    let bands: Vec<Band> = (0..h.div_ceil(BAND))
        .into_par_iter()
        .map_init(
            || Scratch::new(cameras.len(), w),
            |scratch, b| {
                let rows = b * BAND..((b + 1) * BAND).min(h);
                band(
                    rows,
                    scratch,
                    (&views, &sampled),
                    (&grid, bearing, &tiles),
                    options,
                )
            },
        )
        .collect();
    let mut sampled = sampled;
    for (k, table) in sampled.iter_mut().enumerate() {
        table.reserve(bands.iter().map(|b| b.blocks[k].rounds()).sum());
    }
    // (each written once, row by row: zeros around a row's span)
    let mut weights: Vec<Vec<f32>> = (0..cameras.len())
        .map(|_| Vec::with_capacity(w * h))
        .collect();
    let (mut fallback, mut far) = (Vec::with_capacity(w * h), Vec::with_capacity(w * h));
    for band in bands {
        for ((table, blocks), (all, band_weights)) in sampled
            .iter_mut()
            .zip(&band.blocks)
            .zip(weights.iter_mut().zip(&band.weights))
        {
            table.push(blocks);
            let mut values = &band_weights.values[..];
            for &(first, len) in &band_weights.spans {
                let row;
                (row, values) = values.split_at(len);
                let start = all.len();
                all.resize(start + first, 0.0);
                all.extend_from_slice(row);
                all.resize(start + w, 0.0);
            }
        }
        fallback.extend_from_slice(&band.fallback);
        far.extend_from_slice(&band.far);
    }
    let distances = (0..w * h)
        .map(|i| match grid.origin[i] {
            Origin::Empty => 0.0,
            _ => grid.d[i] as f64,
        })
        .collect();
    TablesAndWeights {
        tables: sampled.into_iter().map(SampledRows::finish).collect(),
        weights,
        distances: Some(distances),
        fallback: Some(fallback),
        far: Some(far),
        centre: Vec::new(),
    }
}

/// Per output tile, the cameras that may hold one of its points (a bit each): at its nearest
/// distance or the far fill's (the proxy, and the sky beyond it).
fn cull(views: &[GridCamera], grid: &DistanceGrid, bearing: Bearings, proxy: f64) -> Vec<u64> {
    let (w, h) = (grid.width, grid.height);
    let (tw, th) = (w.div_ceil(TILE), h.div_ceil(TILE));
    (0..tw * th)
        .into_par_iter()
        .map(|t| {
            let (u0, v0) = ((t % tw) * TILE, (t / tw) * TILE);
            let (u1, v1) = ((u0 + TILE).min(w), (v0 + TILE).min(h));
            let mid = bearing.at(((u0 + u1) / 2) as isize, ((v0 + v1) / 2) as isize);
            let mut nearest = proxy;
            let mut radius: f64 = 0.0;
            for v in v0..v1 {
                for u in u0..u1 {
                    let i = v * w + u;
                    if grid.origin[i] != Origin::Empty {
                        nearest = nearest.min(grid.d[i] as f64);
                    }
                }
            }
            // the angle from the middle to the tile's farthest corner, one pixel out
            for (u, v) in [(u0, v0), (u1, v0), (u0, v1), (u1, v1)] {
                let b = bearing.at(u as isize, v as isize);
                radius = radius.max(b.angle(&mid));
            }
            if !mid.x.is_finite() || !radius.is_finite() {
                return u64::MAX;
            }
            views
                .iter()
                .enumerate()
                .filter(|(_, c)| c.may_see(&mid, radius, nearest))
                .fold(0u64, |m, (k, _)| m | 1 << k)
        })
        .collect()
}

/// Output rows `rows`' blocks and weights of every camera.
fn band(
    rows: std::ops::Range<usize>,
    scratch: &mut Scratch,
    (views, sampled): (&[GridCamera], &[SampledRows]),
    (grid, bearing, tiles): (&DistanceGrid, Bearings, &[u64]),
    options: StitchOptions,
) -> Band {
    let w = grid.width;
    let mut far = vec![false; rows.len() * w];
    for (r, v) in rows.clone().enumerate() {
        let far = &mut far[r * w..][..w];
        row((v, r), scratch, far, views, (grid, bearing, tiles), options);
    }
    // the fallback resolved while the band's weights are in the cache
    let n = rows.len() * w;
    let mut fallback = vec![false; n];
    let mut parts: Vec<&mut [f32]> = scratch.weights.iter_mut().map(|x| &mut x[..n]).collect();
    let seen = &mut scratch.seen[..n];
    seen.fill(false);
    fallback::resolve_pixels(&mut parts, &mut fallback, seen);
    let mut blocks = Vec::with_capacity(views.len());
    let mut weights = Vec::with_capacity(views.len());
    for (k, table) in sampled.iter().enumerate() {
        let spans = &scratch.spans[k][..rows.len()];
        let (samples, values) = (&mut scratch.samples[k], &mut scratch.weights[k]);
        let span = |r: usize| {
            let (first, end) = spans[r];
            first.min(end)..end
        };
        blocks.push(table.band((0..rows.len()).map(|r| (&samples[r * w..][..w], span(r)))));
        let mut band_weights = BandWeights {
            spans: Vec::with_capacity(rows.len()),
            values: Vec::with_capacity((0..rows.len()).map(|r| span(r).len()).sum()),
        };
        for r in 0..rows.len() {
            let span = span(r);
            let at = r * w + span.start..r * w + span.end;
            band_weights.spans.push((span.start, span.len()));
            band_weights.values.extend_from_slice(&values[at.clone()]);
            samples[at.clone()].fill(None);
            values[at].fill(0.0);
        }
        weights.push(band_weights);
    }
    Band {
        blocks,
        weights,
        fallback,
        far,
    }
}

/// Output row `v`'s samples and weights of every camera, into row `r` of the thread's band
/// buffers; its far fill's pixels.
fn row(
    (v, r): (usize, usize),
    scratch: &mut Scratch,
    far: &mut [bool],
    views: &[GridCamera],
    (grid, bearing, tiles): (&DistanceGrid, Bearings, &[u64]),
    options: StitchOptions,
) {
    let w = grid.width;
    let tw = w.div_ceil(TILE);
    let Scratch {
        samples,
        weights,
        spans,
        found,
        ..
    } = scratch;
    // per camera the columns it samples
    spans.iter_mut().for_each(|s| s[r] = (w, 0));
    for u in 0..w {
        let i = v * w + u;
        let mask = tiles[(v / TILE) * tw + u / TILE];
        // (no camera may hold the tile's points: most of a whole sphere's rows)
        if mask == 0 || grid.origin[i] == Origin::Empty {
            continue;
        }
        let b = bearing.at(u as isize, v as isize);
        let pixel = bearing.pixel_angle(u as isize, v as isize);
        let moved = (grid.box_id[i] != NO_BOX).then_some(grid.box_id[i] as usize);
        let at = |d: f64, moved: Option<usize>, found: &mut Vec<(usize, View)>| {
            found.clear();
            for (k, c) in views.iter().enumerate() {
                if mask & (1 << k) != 0 {
                    if let Some(view) = c.view(&b, d, moved, (pixel, options.blend_width)) {
                        found.push((k, view));
                    }
                }
            }
        };
        at(grid.d[i] as f64, moved, found);
        if found.is_empty() && moved.is_some() {
            // a moving box's point where no camera saw it then: the point as C2 sees it
            at(grid.d[i] as f64, None, found);
        }
        if found.is_empty() {
            at(options.distance, None, found);
            far[u] = !found.is_empty();
            found.iter_mut().for_each(|(_, view)| view.occluded = false);
        }
        for (k, view) in found.iter() {
            samples[*k][r * w + u] = Some(Sample {
                x: view.x,
                y: view.y,
                lod: view.lod,
            });
            weights[*k][r * w + u] = if view.occluded {
                -view.weight
            } else {
                view.weight
            };
            let span = &mut spans[*k][r];
            *span = (span.0.min(u), u + 1);
        }
    }
}

/// The output's pixel centre bearings (NaN where it has none) at positions -1..=width ×
/// -1..=height, computed once per output camera ([`OutputGrid`]).
#[derive(Clone, Copy)]
pub(super) struct Bearings<'a> {
    grid: &'a OutputGrid,
}

impl Bearings<'_> {
    /// The bearing of position (u, v), each within -1..=size.
    #[inline]
    pub(super) fn at(&self, u: isize, v: isize) -> Vector3<f64> {
        self.grid.bearings[(v + 1) as usize * self.grid.gw + (u + 1) as usize]
    }

    /// The angular size of output pixel (u, v): the larger turn to its neighbours' bearings
    /// (half the central difference; one-sided at an edge without a bearing), radians.
    fn pixel_angle(&self, u: isize, v: isize) -> f64 {
        let across = (self.at(u + 1, v) - self.at(u - 1, v)).norm() / 2.0;
        let down = (self.at(u, v + 1) - self.at(u, v - 1)).norm() / 2.0;
        let a = across.max(down);
        if a.is_finite() {
            return a;
        }
        let b = self.at(u, v);
        [(1, 0), (-1, 0), (0, 1), (0, -1)]
            .iter()
            .map(|&(du, dv)| (self.at(u + du, v + dv) - b).norm())
            .filter(|x| x.is_finite())
            .fold(0.0, f64::max)
    }
}
