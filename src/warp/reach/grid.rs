//! The output camera's part of the reach bound: the bearings of its positions, the largest
//! turn between adjacent ones, and per tile whether every position has a bearing. They depend
//! on the output camera alone, so a run that stitches frame after frame into the same output
//! computes them once: the latest grid is kept by the output's exact key
//! ([`CameraModel::exact_key`], every field's bits; never a printed or rounded form), and an
//! output that cannot say its key computes its grid afresh each time.

use super::TILE;
use crate::camera::{CameraModel, ExactKey};
use nalgebra::{Point2, Vector3};
use rayon::prelude::*;
use std::sync::{Arc, Mutex};

/// The latest output's grid by its exact key (one output at 2048×1024 holds 50 MB).
static LATEST: Mutex<Option<(ExactKey, Arc<OutputGrid>)>> = Mutex::new(None);

/// An output's positions -1..=width × -1..=height as the bound reads them.
#[derive(Debug)]
pub(in crate::warp) struct OutputGrid {
    /// Bearings, row-major (NaN: none).
    pub(in crate::warp) bearings: Vec<Vector3<f64>>,
    pub(in crate::warp) gw: usize,
    pub(super) gh: usize,
    /// A: the largest turn between adjacent positions, radians.
    pub(in crate::warp) step: f64,
    /// Per tile of [`TILE`]×[`TILE`] positions (row-major): whether each has a bearing.
    pub(super) complete: Vec<bool>,
}

impl OutputGrid {
    /// The grid of `output`: the kept one where its exact key is the kept grid's, else
    /// computed (and kept, replacing the other, where it has a key).
    pub(in crate::warp) fn of(output: &dyn CameraModel) -> Arc<OutputGrid> {
        let mut key = ExactKey::new();
        if !output.exact_key(&mut key) {
            return Arc::new(OutputGrid::compute(output));
        }
        let size = output.size();
        key.count(size.width as usize);
        key.count(size.height as usize);
        let latest = |found: &mut Option<(ExactKey, Arc<OutputGrid>)>| {
            found
                .as_ref()
                .filter(|(k, _)| *k == key)
                .map(|(_, g)| g.clone())
        };
        // (a poisoned lock only means another thread panicked; the kept grid is whole)
        if let Some(grid) = latest(&mut LATEST.lock().unwrap_or_else(|e| e.into_inner())) {
            return grid;
        }
        let grid = Arc::new(OutputGrid::compute(output));
        *LATEST.lock().unwrap_or_else(|e| e.into_inner()) = Some((key, grid.clone()));
        grid
    }

    /// The grid of `output`, computed.
    pub(super) fn compute(output: &dyn CameraModel) -> OutputGrid {
        let size = output.size();
        let (gw, gh) = (size.width as usize + 2, size.height as usize + 2);
        let bearings = grid_bearings(output, gw, gh);
        let step = largest_turn(&bearings, gw, gh);
        let complete = complete_tiles(&bearings, gw, gh);
        OutputGrid {
            bearings,
            gw,
            gh,
            step,
            complete,
        }
    }

    /// The tiles across the grid.
    pub(super) fn tiles_across(&self) -> usize {
        self.gw.div_ceil(TILE)
    }
}

/// The bearings of `output`'s positions -1..=width × -1..=height (`gw` × `gh`), row-major,
/// NaN where it has none: by column and row shares where the output separates (the same
/// values as its `unproject`, bit for bit, without the trigonometry of every position).
pub(super) fn grid_bearings(output: &dyn CameraModel, gw: usize, gh: usize) -> Vec<Vector3<f64>> {
    let mut bearings = vec![Vector3::repeat(f64::NAN); gw * gh];
    let sep = output.separable();
    let columns: Vec<_> = sep.map_or(Vec::new(), |sep| {
        (0..gw).map(|i| sep.column(i as f64 - 1.0)).collect()
    });
    bearings
        .par_chunks_mut(gw)
        .enumerate()
        .for_each_init(Vec::new, |row_bearings, (j, row)| {
            let v = j as f64 - 1.0;
            if let Some(sep) = sep {
                row_bearings.clear();
                sep.bearings(&columns, sep.row(v), row_bearings);
                for (out, d) in row.iter_mut().zip(row_bearings.iter()) {
                    if let Some(d) = d {
                        *out = *d;
                    }
                }
                return;
            }
            for (i, out) in row.iter_mut().enumerate() {
                if let Ok(d) = output.unproject(&Point2::new(i as f64 - 1.0, v)) {
                    *out = d;
                }
            }
        });
    bearings
}

/// Rows of the grid a task of [`largest_turn`] takes: each of its rows is normalised once, and
/// the row below its last once more.
const TURN_ROWS: usize = 32;

/// A: the largest turn between adjacent centres of the grid (across, down and both
/// diagonals), radians.
pub(super) fn largest_turn(bearings: &[Vector3<f64>], gw: usize, gh: usize) -> f64 {
    // the turn 2·asin(chord/2) of the longest chord (asin grows with its argument); each
    // bearing normalised once per band of rows it is read in, the chords compared squared
    // (the square root is monotonic: the same largest chord)
    let unit = |j: usize, out: &mut Vec<Vector3<f64>>| {
        out.clear();
        out.extend(bearings[j * gw..(j + 1) * gw].iter().map(|d| d.normalize()));
    };
    let chord2 = |a: &Vector3<f64>, b: &Vector3<f64>| {
        let c = (a - b).norm_squared();
        if c.is_finite() {
            c
        } else {
            0.0
        }
    };
    let step2 = (0..gh.div_ceil(TURN_ROWS))
        .into_par_iter()
        .map(|band| {
            let (mut here, mut below) = (Vec::new(), Vec::new());
            let rows = band * TURN_ROWS..((band + 1) * TURN_ROWS).min(gh);
            unit(rows.start, &mut here);
            let mut a: f64 = 0.0;
            for j in rows {
                for i in 0..gw - 1 {
                    a = a.max(chord2(&here[i], &here[i + 1]));
                }
                if j + 1 < gh {
                    unit(j + 1, &mut below);
                    for i in 0..gw {
                        a = a.max(chord2(&here[i], &below[i]));
                        if i + 1 < gw {
                            a = a.max(chord2(&here[i], &below[i + 1]));
                        }
                        if i > 0 {
                            a = a.max(chord2(&here[i], &below[i - 1]));
                        }
                    }
                    std::mem::swap(&mut here, &mut below);
                }
            }
            a
        })
        .reduce(|| 0.0, f64::max);
    2.0 * (step2.sqrt() / 2.0).min(1.0).asin()
}

/// Per tile of [`TILE`]×[`TILE`] positions (row-major), whether every position has a bearing.
fn complete_tiles(bearings: &[Vector3<f64>], gw: usize, gh: usize) -> Vec<bool> {
    let (across, down) = (gw.div_ceil(TILE), gh.div_ceil(TILE));
    (0..across * down)
        .into_par_iter()
        .map(|tile| {
            let (i0, j0) = (tile % across * TILE, tile / across * TILE);
            let (i1, j1) = ((i0 + TILE).min(gw), (j0 + TILE).min(gh));
            (j0..j1).all(|j| {
                bearings[j * gw + i0..j * gw + i1]
                    .iter()
                    .all(|d| d.x.is_finite())
            })
        })
        .collect()
}
