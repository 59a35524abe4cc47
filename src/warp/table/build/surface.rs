//! The pyramid through a depth-guided stitch's scene. A table built through the scene maps each
//! output pixel's centre to the point at its own distance, so a pixel whose neighbours lie on
//! another surface (a near box before a far wall) measures a footprint spanning both: the
//! pyramid's level for it would blur the two surfaces together, where its taps, each cast
//! through the scene, sample each surface where it lies. Such a pixel keeps its taps; a pixel
//! whose neighbourhood lies on one surface measures that surface's footprint and samples the
//! pyramid by its rule (`level.rs`).
//!
//! An edge pixel's taps are at most [`EDGE_TAPS`] a side: each a bilinear tap of the source at
//! its own distance, so each surface is sampled where it lies, at a quarter of the 8×8 taps a
//! pixel 8 source pixels wide would take.

use super::{count, tap_offset, Builder, Parts};
use crate::camera::Separable;
use nalgebra::{Point2, Vector3};
use std::ops::Range;

/// The taps a side of a pixel by a depth edge. Against the exact render of the KITTI-360
/// offset rig at 360×180 (`tests/kitti360_stitch/depth_guided.rs`; its pixels span up to 10
/// source pixels) a side's taps capped at 4 read 49.12 dB, regions [41.43, 46.24, 51.04,
/// 49.20]; at 3, 48.65 dB (image_01's region 0.8 dB lower: its 10-pixel footprints alias); at
/// 5, 49.00; the scale's count (up to 8), 49.04. A pyramid level per 2×2 or 4×4 sub-pixel (a
/// quarter or a sixteenth of the footprint) blurs the surfaces' silhouettes: 47.76 and 49.06
/// dB, image_02's region 1.3 and 0.2 dB lower; 2×2 or 3×3 taps at level 0 alias: 48.70 and
/// 48.43 dB.
pub(super) const EDGE_TAPS: u32 = 4;

/// [`Surfaces::asked_alone`]'s count.
const ASKED_ALONE: usize = 16;

/// The scene of a depth-guided source at the output's pixels.
pub(crate) trait Surfaces: Sync {
    /// Whether output pixel (u, v) and its eight neighbours (those within the output) lie on
    /// one surface of the scene: the footprint measured from their mapped centres is that
    /// surface's.
    fn one_surface(&self, u: usize, v: usize) -> bool;

    /// [`Surfaces::one_surface`] of the pixels `columns` of output row `v`, into `out` (its
    /// old contents dropped).
    fn one_surface_row(&self, v: usize, columns: Range<usize>, out: &mut Vec<bool>) {
        out.clear();
        out.extend(columns.map(|u| self.one_surface(u, v)));
    }

    /// How many pixels of a row a table's build asks [`Surfaces::one_surface`] alone before
    /// it asks [`Surfaces::one_surface_row`] for the rest of the row, from the next pixel
    /// that asks: a window alone reads its 25 distances, a row 10 a pixel, so the few depth
    /// edges of a long row of pixels that need no answer (a lens's magnified pixels) cost less
    /// alone.
    fn asked_alone(&self) -> usize {
        ASKED_ALONE
    }

    /// Appends the source positions of a table's taps at output positions `at` (the table's
    /// output pixels, whose centres `one_surface` reads) along bearings `ds` (in the source's
    /// frame), as [`crate::camera::CameraModel::project_all`] gives them: the positions spare
    /// the bearings' projection back into the output.
    fn project_taps(
        &self,
        at: &[Point2<f64>],
        ds: &[Option<Vector3<f64>>],
        out: &mut Vec<Option<Point2<f64>>>,
    );

    /// The table's output camera's unprojection by columns and rows, where that camera gives
    /// each tap of a pixel with a mapped centre a separable camera's bearing (a stitch's
    /// output gated by a camera's reach: a tap is nearer its own pixel's centre than any
    /// other's, and the gate keeps that pixel): a supersampled pixel's taps then take their
    /// columns' and rows' shares, not each its own trigonometry. None (this default): each
    /// tap unprojected alone.
    fn tap_output(&self) -> Option<&dyn Separable> {
        None
    }
}

impl Builder<'_> {
    /// The footprint of an output pixel whose squared scales along u and v are `(su, sv)`:
    /// its taps along each axis and the pyramid level they sample (its rule, `level.rs`), at
    /// most [`EDGE_TAPS`] a side at level 0 where the source's scene puts a depth edge by it
    /// (`by_edge`, asked only where the pixel would sample the pyramid of a scene's source).
    #[inline]
    pub(super) fn footprint(
        &self,
        by_edge: impl FnOnce() -> bool,
        (su, sv): (f64, f64),
    ) -> (u32, u32, u32) {
        let mut level = self.level_of(su.min(sv));
        let mut most = self.cap;
        if level > 0 && self.surfaces.is_some() && by_edge() {
            (level, most) = (0, most.min(EDGE_TAPS));
        }
        // at a pyramid level the scales are 4^level times smaller
        let down = (1u32 << (2 * level)) as f64;
        (
            count(su / down).min(most),
            count(sv / down).min(most),
            level,
        )
    }

    /// The source positions of the `nu`×`nv` taps of pixel (u, v) at bearings
    /// `parts.bearings` (rotated in place) into `parts.taps`, through the scene `s`, which is
    /// given the taps' output positions: their distances need no projection into the output.
    pub(super) fn taps_through(
        &self,
        s: &dyn Surfaces,
        (u, v): (usize, usize),
        (nu, nv): (u32, u32),
        parts: &mut Parts,
    ) {
        parts.at.clear();
        for j in 0..nv {
            let y = v as f64 + tap_offset(j, nv);
            (parts.at).extend((0..nu).map(|i| Point2::new(u as f64 + tap_offset(i, nu), y)));
        }
        for d in parts.bearings.iter_mut().flatten() {
            *d = self.src_from_dst * *d;
        }
        s.project_taps(&parts.at, &parts.bearings, &mut parts.taps);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{CameraModel, ImageSize, Intrinsics, Perspective};
    use crate::warp::table::{pyramid, Wrap, MAX_SUPERSAMPLE};
    use nalgebra::Matrix3;

    /// A scene whose surfaces meet by every pixel but those of column 0; its taps are the
    /// source camera's own.
    struct EdgesBut0<'a>(&'a Perspective);

    impl Surfaces for EdgesBut0<'_> {
        fn one_surface(&self, u: usize, _: usize) -> bool {
            u == 0
        }

        fn project_taps(
            &self,
            _: &[Point2<f64>],
            ds: &[Option<Vector3<f64>>],
            out: &mut Vec<Option<Point2<f64>>>,
        ) {
            self.0.project_all(ds, out);
        }
    }

    #[test]
    fn a_pixel_by_a_depth_edge_takes_at_most_edge_taps_a_side_at_level_0() {
        // output pixels 8 source pixels wide: the rule's level 3, one tap, on one surface
        let output = Perspective::new(
            Intrinsics::new(50.0, 50.0, 31.5, 23.5),
            ImageSize::new(64, 48),
        );
        let source = Perspective::new(
            Intrinsics::new(400.0, 400.0, 319.5, 239.5),
            ImageSize::new(640, 480),
        );
        let identity = Matrix3::identity();
        let scene = EdgesBut0(&source);
        let mut b = Builder::new(
            &output,
            &source,
            &identity,
            Wrap::None,
            MAX_SUPERSAMPLE,
            None,
        );
        b.shapes = pyramid::level_shapes(b.source_size, 5);
        b.taps_below2 = 4.0;
        b.surfaces = Some(&scene);
        assert_eq!(
            b.footprint(|| !scene.one_surface(0, 5), (64.0, 64.0)),
            (1, 1, 3)
        );
        // by an edge: level 0, 4×4 taps where the scale's count is 8 (and at most 8 without
        // the scene); the count where it is smaller; each axis alone
        assert_eq!(
            b.footprint(|| !scene.one_surface(1, 5), (64.0, 64.0)),
            (EDGE_TAPS, EDGE_TAPS, 0)
        );
        assert_eq!(EDGE_TAPS, 4);
        assert_eq!(
            b.footprint(|| !scene.one_surface(1, 5), (9.0, 9.0)),
            (3, 3, 0)
        );
        assert_eq!(
            b.footprint(|| !scene.one_surface(1, 5), (64.0, 6.25)),
            (4, 3, 0)
        );
        // below the pyramid's threshold the scene is not asked: the taps' count alone
        assert_eq!(
            b.footprint(|| !scene.one_surface(1, 5), (2.0, 2.0)),
            (1, 1, 0)
        );
    }
}
