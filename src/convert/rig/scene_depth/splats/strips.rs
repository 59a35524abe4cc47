//! A spherical depth buffer drawn on demand, strip by strip of its columns: a camera's
//! occlusion tests look its buffer up only in the longitudes it sees from its eye, so most of
//! an eye's buffer is never read.
//!
//! A strip's cells are those of the whole buffer ([`Splats::new`](super::Splats::new)): a gap is closed from the
//! two filled cells around it, at most [`longest_gap`] + 1 cells from any of its cells along a
//! column or a row, so the strip is drawn and filled over its columns widened by that many on
//! each side (clipped to the buffer: a row's fill does not wrap), from the discs that reach
//! those columns, and its cells are then those of the whole buffer.

use super::{buffer_size, fill_window, longest_gap, Disc};
use nalgebra::Vector3;
use std::sync::OnceLock;

/// Columns per strip.
const STRIP: usize = 96;

/// A buffer's strips: per strip, the discs that reach its window and, once looked up, its
/// window's filled cells.
#[derive(Debug, Clone)]
pub(super) struct Strips {
    discs: Vec<Vec<Disc>>,
    built: Vec<OnceLock<Vec<f32>>>,
}

/// Strip `s`'s window: its columns widened by the gap's reach on each side, within the buffer.
fn window(s: usize) -> (usize, usize) {
    let (width, margin) = (buffer_size().0, longest_gap() + 1);
    (
        (s * STRIP).saturating_sub(margin),
        ((s + 1) * STRIP + margin).min(width),
    )
}

impl Strips {
    /// The strips of the buffer of `points` seen from `origin`, none drawn yet.
    pub(super) fn new(origin: &Vector3<f64>, points: &[Vector3<f64>]) -> Self {
        let (width, margin) = (buffer_size().0, longest_gap() + 1);
        let count = width.div_ceil(STRIP);
        let mut discs = vec![Vec::new(); count];
        for p in points {
            let Some(disc) = Disc::of(origin, p) else {
                continue;
            };
            // the strips whose windows the disc's widest runs meet (a strip met by both runs
            // takes the disc twice: drawn twice, it lowers its cells once)
            for (start, end) in disc.runs(disc.rx) {
                if start >= end {
                    continue;
                }
                let first = start.saturating_sub(margin) / STRIP;
                let last = ((end - 1 + margin) / STRIP).min(count - 1);
                for strip in &mut discs[first..=last] {
                    strip.push(disc);
                }
            }
        }
        Strips {
            built: (0..count).map(|_| OnceLock::new()).collect(),
            discs,
        }
    }

    /// The range of cell (x, y), its strip drawn on first use.
    pub(super) fn cell(&self, x: usize, y: usize) -> f32 {
        let s = x / STRIP;
        let (a, b) = window(s);
        let cells = self.built[s].get_or_init(|| self.draw(s));
        cells[y * (b - a) + x - a]
    }

    /// Strip `s`'s window drawn and filled.
    fn draw(&self, s: usize) -> Vec<f32> {
        let (a, b) = window(s);
        let height = buffer_size().1;
        let mut cells = vec![f32::INFINITY; (b - a) * height];
        for disc in &self.discs[s] {
            disc.draw(&mut cells, (a, b));
        }
        fill_window(&mut cells, b - a);
        cells
    }
}

#[cfg(test)]
mod tests {
    use super::super::Splats;
    use super::*;

    #[test]
    fn every_cell_of_a_lazy_buffer_is_the_whole_buffers() {
        // surfaces near and far, across the wrap of longitude, near a pole and with gaps of
        // every width between rings (filled and not)
        let mut state = 0x853c_49e6_748f_ea9b_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut points = Vec::new();
        for ring in 0..40 {
            let lat = -0.5 + ring as f64 * (0.01 + 0.002 * (ring % 7) as f64);
            for k in 0..3000 {
                let lon = k as f64 / 3000.0 * std::f64::consts::TAU + 0.3 * next();
                let r = if k % 500 < 200 {
                    5.0 + next()
                } else {
                    30.0 + 20.0 * next()
                };
                points.push(
                    Vector3::new(lon.sin() * lat.cos(), lat.sin(), lon.cos() * lat.cos()) * r,
                );
            }
        }
        for _ in 0..2000 {
            let d = Vector3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            points.push(d * (2.0 + 40.0 * next()));
        }
        let origin = Vector3::new(0.3, -0.1, 0.2);
        let whole = Splats::new(origin, &points);
        let lazy = Splats::lazy(origin, &points);
        let (w, h) = buffer_size();
        let (mut finite, mut differ) = (0, 0);
        for y in 0..h {
            for x in 0..w {
                let (a, b) = (
                    whole.range[y * w + x],
                    lazy.strips.as_ref().unwrap().cell(x, y),
                );
                finite += usize::from(a.is_finite());
                differ += usize::from(a.to_bits() != b.to_bits());
            }
        }
        assert_eq!(differ, 0);
        assert!(finite > w * h / 10, "{finite}");
    }
}
