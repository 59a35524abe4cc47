//! The residual scan points of a frame's scene as spherical depth buffers: the nearest splat
//! per cell around a viewpoint (see the parent module).

use super::super::ground::turn;
use super::{CELLS_PER_DEG, EDGE_DEG, GAP_AGREE, GAP_DEG, SPLAT_DEG};
use nalgebra::Vector3;
use std::f64::consts::{PI, TAU};

mod strips;

/// The longitude (about the reference frame's y axis, from +z, in (−π, π]) and latitude of
/// `d` (0 and 0 for a zero `d`): `atan2` and `asin` to a tenth of a nanoradian, without libm
/// (the splats are looked up at every ray a depth-guided stitch casts).
pub(super) fn angles(d: &Vector3<f64>) -> (f64, f64) {
    let lon = turn(d.x, d.z);
    let lat = turn(d.y, (d.x * d.x + d.z * d.z).sqrt());
    let signed = |a: f64| if a > PI { a - TAU } else { a };
    (signed(lon), signed(lat))
}

/// A spherical depth buffer around a viewpoint: per cell of longitude × latitude (about the
/// reference frame's y axis), the range of the nearest splat.
#[derive(Debug, Clone)]
pub(super) struct Splats {
    width: usize,
    height: usize,
    range: Vec<f32>,
    /// Per row, the least range of each run of [`BLOCK`] cells (the last run shorter):
    /// [`Splats::nearest_within`] takes a whole run's least at once.
    blocks: Vec<f32>,
    /// Drawn on demand ([`Splats::lazy`]; `range` and `blocks` are then empty).
    strips: Option<strips::Strips>,
}

/// Cells per run whose least range is kept ([`Splats::nearest_within`]).
const BLOCK: usize = 16;

impl Splats {
    fn cell_of(&self, d: &Vector3<f64>) -> (f64, f64) {
        let (lon, lat) = angles(d);
        self.cell_at(lon, lat)
    }

    /// The cell position of the bearing at longitude `lon`, latitude `lat` ([`angles`]).
    fn cell_at(&self, lon: f64, lat: f64) -> (f64, f64) {
        (
            (lon + PI) / TAU * self.width as f64,
            (lat + PI / 2.0) / PI * self.height as f64,
        )
    }

    pub(super) fn new(origin: Vector3<f64>, points: &[Vector3<f64>]) -> Self {
        let (width, height) = buffer_size();
        let mut splats = Splats {
            width,
            height,
            range: vec![f32::INFINITY; width * height],
            blocks: Vec::new(),
            strips: None,
        };
        for p in points {
            if let Some(disc) = Disc::of(&origin, p) {
                disc.draw(&mut splats.range, (0, width));
            }
        }
        splats.fill_gaps();
        splats.index_blocks();
        splats
    }

    /// The buffer of [`Splats::new`], each strip of its columns drawn and filled on its first
    /// lookup ([`strips`]): a camera's lookups cover only the longitudes it sees.
    pub(super) fn lazy(origin: Vector3<f64>, points: &[Vector3<f64>]) -> Self {
        let (width, height) = buffer_size();
        Splats {
            width,
            height,
            range: Vec::new(),
            blocks: Vec::new(),
            strips: Some(strips::Strips::new(&origin, points)),
        }
    }

    /// Sets [`Splats::blocks`] from the ranges.
    fn index_blocks(&mut self) {
        let runs = self.width.div_ceil(BLOCK);
        self.blocks.clear();
        self.blocks.reserve(runs * self.height);
        for row in self.range.chunks(self.width) {
            (self.blocks).extend(row.chunks(BLOCK).map(|run| least(f32::INFINITY, run)));
        }
    }

    /// The least range of row `y`'s cells `a..b` (within the row), by whole runs where it can.
    fn least_in_row(&self, y: usize, a: usize, b: usize) -> f32 {
        if let Some(strips) = &self.strips {
            return (a..b).fold(f32::INFINITY, |t, x| t.min(strips.cell(x, y)));
        }
        let row = &self.range[y * self.width..(y + 1) * self.width];
        let runs = &self.blocks[y * self.width.div_ceil(BLOCK)..];
        let (first, last) = (a.div_ceil(BLOCK), b / BLOCK);
        if first >= last {
            return least(f32::INFINITY, &row[a..b]);
        }
        let t = least(f32::INFINITY, &row[a..first * BLOCK]);
        let t = least(t, &runs[first..last]);
        least(t, &row[last * BLOCK..b])
    }

    /// Closes the gaps between a scan's rings and azimuth steps that the splats leave: a run
    /// of empty cells of at most [`GAP_DEG`] between two splats, along a column then along a
    /// row, takes the range interpolated between them where they agree (within
    /// [`GAP_AGREE`] of the farther), else the farther one's: a gap across a depth
    /// discontinuity is the background's, so a fill never makes an occluder.
    fn fill_gaps(&mut self) {
        fill_window(&mut self.range, self.width);
    }

    /// Carries each surface's edge against the sky (no return) out by the parallax of a camera
    /// `baseline` metres from the viewpoint, asin(baseline / range) (at most [`EDGE_DEG`]),
    /// along columns then rows. Where the scan has no return beside a surface (the sky, or
    /// above the scan's top ring) a camera beside the viewpoint sees that surface's edge moved
    /// by its parallax; the sky next to it placed at the surface's distance is sampled through
    /// the edge as the viewpoint sees it, not taken as hidden by it.
    pub(super) fn extend_edges(&mut self, baseline: f64) {
        // (a lazy buffer, an eye's, is not extended)
        if !(baseline > 0.0) || self.strips.is_some() {
            return;
        }
        let (w, h) = (self.width, self.height);
        let cells = |range: f32, stretch: f64| {
            let angle = (baseline / range as f64)
                .min(1.0)
                .asin()
                .min(EDGE_DEG.to_radians());
            (angle.to_degrees() * CELLS_PER_DEG * stretch).ceil() as usize
        };
        for x in 0..w {
            extend_line(&mut self.range, (x, w), h, |r| cells(r, 1.0));
        }
        for y in 0..h {
            let lat = ((y as f64 + 0.5) / h as f64) * PI - PI / 2.0;
            let stretch = 1.0 / lat.cos().max(0.05);
            extend_line(&mut self.range[y * w..(y + 1) * w], (0, 1), w, |r| {
                cells(r, stretch).min(w / 2)
            });
        }
        self.index_blocks();
    }

    /// The nearest splat's range over the cells of the unit bearings within `radius` of unit
    /// `d`, one cell wider on every side (a lower bound of [`Splats::range`] there). Such a
    /// bearing's latitude is within `radius` of d's, and its longitude within
    /// 2·asin(sin(radius/2) / cos φ) (haversines; φ the largest |latitude| in reach).
    pub(super) fn nearest_within(&self, d: &Vector3<f64>, radius: f64) -> f64 {
        let (x, y) = self.cell_of(d);
        let lat = (d.y / d.norm()).clamp(-1.0, 1.0).asin();
        let rows = radius / PI * self.height as f64;
        let y0 = ((y - rows).floor() - 1.0).max(0.0) as usize;
        let y1 = ((y + rows).floor() + 1.0).min(self.height as f64 - 1.0) as usize;
        let widest = (lat.abs() + radius).min(PI / 2.0).cos();
        let s = (radius / 2.0).sin() / widest;
        let columns = if s < 1.0 {
            2.0 * s.asin() / TAU * self.width as f64
        } else {
            f64::INFINITY
        };
        let (x0, x1) = ((x - columns).floor() - 1.0, (x + columns).floor() + 1.0);
        let mut t = f32::INFINITY;
        let w = self.width;
        // the columns as at most two runs within a row (the span wraps around)
        let spans = if !(x1 - x0 + 1.0 < w as f64) {
            [(0, w), (0, 0)]
        } else {
            let start = (x0 as i64).rem_euclid(w as i64) as usize;
            let end = start + (x1 - x0) as usize + 1;
            [(start, end.min(w)), (0, end.saturating_sub(w))]
        };
        for cy in y0..=y1 {
            for (a, b) in spans {
                t = t.min(self.least_in_row(cy, a, b));
            }
        }
        t as f64
    }

    /// The nearest splat's range along the bearing at longitude `lon`, latitude `lat`
    /// ([`angles`]) from the origin (infinite: none).
    pub(super) fn range(&self, lon: f64, lat: f64) -> f64 {
        let (x, y) = self.cell_at(lon, lat);
        let (cx, w) = (crate::warp::floor(x) as i64, self.width as i64);
        // x lies in [0, w] for a longitude in [−π, π]: a compare, not a division, but for
        // the one past the end
        let cx = match cx {
            c if (0..w).contains(&c) => c,
            c => c.rem_euclid(w),
        } as usize;
        let cy = (crate::warp::floor(y).max(0.0) as usize).min(self.height - 1);
        if let Some(strips) = &self.strips {
            return strips.cell(cx, cy) as f64;
        }
        self.range[cy * self.width + cx] as f64
    }
}

/// The width and height of a buffer, cells.
fn buffer_size() -> (usize, usize) {
    (
        (360.0 * CELLS_PER_DEG) as usize,
        (180.0 * CELLS_PER_DEG) as usize,
    )
}

/// The longest run of empty cells that [`Splats::fill_gaps`] closes.
fn longest_gap() -> usize {
    (GAP_DEG * CELLS_PER_DEG).round() as usize
}

/// A residual point's disc in a buffer: its cell position, its half-width in cells of
/// longitude and its range.
#[derive(Debug, Clone, Copy)]
struct Disc {
    x: f64,
    y: f64,
    rx: f64,
    range: f32,
}

impl Disc {
    /// Point `p`'s disc seen from `origin` (None for a point at the origin).
    fn of(origin: &Vector3<f64>, p: &Vector3<f64>) -> Option<Disc> {
        let (width, height) = buffer_size();
        let v = p - origin;
        let range = v.norm();
        if !(range > 0.0) {
            return None;
        }
        let (lon, lat) = angles(&v);
        let (x, y) = (
            (lon + PI) / TAU * width as f64,
            (lat + PI / 2.0) / PI * height as f64,
        );
        let lat = (y / height as f64) * PI - PI / 2.0;
        // a disc on the sphere: wider in cells of longitude away from the equator
        let stretch = 1.0 / lat.cos().max(0.05);
        let rx = (SPLAT_DEG * CELLS_PER_DEG * stretch).min(width as f64 / 2.0);
        let range = range as f32;
        Some(Disc { x, y, rx, range })
    }

    /// The disc's columns in every row it covers as at most two runs within [0, width) (the
    /// second from the row's start where it wraps): `reach` its half-width, the runs' union
    /// holding every row's cells for `reach` = `rx`.
    fn runs(&self, reach: f64) -> [(usize, usize); 2] {
        let width = buffer_size().0;
        let (x0, x1) = (floor(self.x - reach), ceil(self.x + reach));
        let start = x0.rem_euclid(width as i64) as usize;
        let n = (x1 - x0).max(0) as usize;
        let first = n.min(width - start);
        [(start, start + first), (0, (n - first).min(width))]
    }

    /// Lowers the cells of `range` that the disc covers to its range: `range` the columns
    /// `window` (a..b) of every row of the buffer, row after row (a run over a cell twice
    /// lowers it once).
    fn draw(&self, range: &mut [f32], (a, b): (usize, usize)) {
        let height = buffer_size().1;
        let ry = SPLAT_DEG * CELLS_PER_DEG;
        let (y, rx) = (self.y, self.rx);
        let (y0, y1) = (floor(y - ry).max(0) as usize, ceil(y + ry).max(0) as usize);
        for cy in y0..y1.min(height) {
            let dy = (cy as f64 + 0.5 - y) / ry;
            let reach = rx * (1.0 - dy * dy).max(0.0).sqrt();
            let row = &mut range[cy * (b - a)..(cy + 1) * (b - a)];
            for (start, end) in self.runs(reach) {
                let (start, end) = (start.max(a), end.min(b));
                if start < end {
                    for cell in &mut row[start - a..end - a] {
                        *cell = cell.min(self.range);
                    }
                }
            }
        }
    }
}

/// ⌊x⌋ as an integer (0 for NaN), without a call for `f64::floor`.
fn floor(x: f64) -> i64 {
    let t = x as i64;
    t - i64::from((t as f64) > x)
}

/// ⌈x⌉ as an integer (0 for NaN), without a call for `f64::ceil`.
fn ceil(x: f64) -> i64 {
    let t = x as i64;
    t + i64::from((t as f64) < x)
}

/// The least of `t` and `cells` (as the folds of `f32::min` give it).
fn least(t: f32, cells: &[f32]) -> f32 {
    cells.iter().fold(t, |a, b| a.min(*b))
}

/// Carries the finite cells of one line of `range` (`n` cells from `start`, `step` apart) into
/// the empty cells beside them, `reach(range)` cells at most: an empty cell takes the nearer
/// (in cells) of the finite cells around it that reach it, the farther range on a tie.
fn extend_line(
    range: &mut [f32],
    (start, step): (usize, usize),
    n: usize,
    reach: impl Fn(f32) -> usize,
) {
    let at = |k: usize| start + k * step;
    let mut k = 0;
    while k < n {
        if range[at(k)].is_finite() {
            k += 1;
            continue;
        }
        let end = (k..n).find(|&m| range[at(m)].is_finite()).unwrap_or(n);
        let before = k.checked_sub(1).map(|j| (j, range[at(j)]));
        let after = (end < n).then(|| (end, range[at(end)]));
        let (rb, ra) = (before.map(|b| reach(b.1)), after.map(|a| reach(a.1)));
        for m in k..end {
            let from_before = before.zip(rb).filter(|((j, _), r)| m - j <= *r);
            let from_after = after.zip(ra).filter(|((j, _), r)| j - m <= *r);
            range[at(m)] = match (from_before, from_after) {
                (Some(((j, b), _)), Some(((l, a), _))) => match (m - j).cmp(&(l - m)) {
                    std::cmp::Ordering::Less => b,
                    std::cmp::Ordering::Greater => a,
                    std::cmp::Ordering::Equal => a.max(b),
                },
                (Some(((_, b), _)), None) => b,
                (None, Some(((_, a), _))) => a,
                (None, None) => f32::INFINITY,
            };
        }
        k = end;
    }
}

/// [`Splats::fill_gaps`] of a buffer's columns `w` wide (every row).
fn fill_window(range: &mut [f32], w: usize) {
    let longest = longest_gap();
    fill_columns(range, w, longest);
    for row in range.chunks_mut(w.max(1)) {
        fill_line(row, (0, 1), w, longest);
    }
}

/// [`fill_line`] of every column of `range` (rows of `w` cells), the rows read in order
/// rather than each column down the buffer: per column, the row of its last filled cell so
/// far. A gap's fill writes only cells above the row being read, so each column's fills are
/// those of its own line.
fn fill_columns(range: &mut [f32], w: usize, longest: usize) {
    let mut last = vec![usize::MAX; w];
    let h = range.len() / w.max(1);
    for k in 0..h {
        for x in 0..w {
            let r = range[k * w + x];
            if !r.is_finite() {
                continue;
            }
            let j = last[x];
            if j != usize::MAX && k - j > 1 && k - j - 1 <= longest {
                let a = range[j * w + x];
                let far = a.max(r);
                let agree = (a - r).abs() <= GAP_AGREE as f32 * far;
                for m in j + 1..k {
                    let t = (m - j) as f32 / (k - j) as f32;
                    range[m * w + x] = if agree { a + (r - a) * t } else { far };
                }
            }
            last[x] = k;
        }
    }
}

/// Fills the gaps of one line of `range` (`n` cells from `start`, `step` apart) of at most
/// `longest` cells between two filled cells (see [`Splats::fill_gaps`]).
fn fill_line(range: &mut [f32], (start, step): (usize, usize), n: usize, longest: usize) {
    let at = |k: usize| start + k * step;
    let mut last: Option<usize> = None;
    for k in 0..n {
        let r = range[at(k)];
        if !r.is_finite() {
            continue;
        }
        if let Some(j) = last.filter(|&j| k - j > 1 && k - j - 1 <= longest) {
            let (a, b) = (range[at(j)], r);
            let far = a.max(b);
            let agree = (a - b).abs() <= GAP_AGREE as f32 * far;
            for m in j + 1..k {
                let t = (m - j) as f32 / (k - j) as f32;
                range[at(m)] = if agree { a + (b - a) * t } else { far };
            }
        }
        last = Some(k);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_angles_are_libms_atan2_and_asin_to_a_tenth_of_a_nanoradian() {
        let mut state = 0x0bad_5eed_1234_5679_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut worst = 0.0f64;
        for k in 0..100_000 {
            let d = match k % 40 {
                // the axes and a pole, exactly
                0 => Vector3::new(0.0, 0.0, -1.0),
                1 => Vector3::new(-1.0, 0.0, 0.0),
                2 => Vector3::new(0.0, -2.0, 0.0),
                _ => Vector3::new(next(), next(), next()) * [1e-3, 1.0, 50.0][k % 3],
            };
            let (lon, lat) = angles(&d);
            let want = (d.x.atan2(d.z), (d.y / d.norm()).clamp(-1.0, 1.0).asin());
            assert!(lon > -PI && lon <= PI, "{d}: {lon}");
            // (−π and π are one longitude)
            let dlon = (lon - want.0).abs();
            worst = worst.max(dlon.min(TAU - dlon)).max((lat - want.1).abs());
        }
        assert!(worst < 1e-10, "{worst}");
    }
}
