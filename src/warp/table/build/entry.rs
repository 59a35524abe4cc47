//! The table's builders, one public entry point per footprint rule: the taps everywhere, the
//! source pyramid, the pyramid above a footprint of a few source pixels (taps below), and that
//! rule where a scene's surfaces allow it. Each sets up one [`Builder`] and builds.

use super::{pyramid, Builder, Surfaces};
use crate::camera::CameraModel;
use crate::warp::footprint::Footprint;
use crate::warp::table::{RemapTable, Wrap, MAX_SUPERSAMPLE};
use nalgebra::Matrix3;

impl RemapTable {
    /// Exactly [`RemapTable::build_with`], mapping only the output pixels within `seen` (the
    /// others take nothing from the source: see [`Footprint`]), serially or with bands of rows
    /// in parallel (see [`RemapTable::build_parallel`] for where that is allowed).
    pub fn build_within(
        dst: &dyn CameraModel,
        src: &dyn CameraModel,
        src_from_dst: &Matrix3<f64>,
        wrap: Wrap,
        max_supersample: u32,
        seen: Option<&Footprint>,
        parallel: bool,
    ) -> RemapTable {
        let b = Builder::new(dst, src, src_from_dst, wrap, max_supersample, seen);
        b.build(parallel)
    }

    /// As [`RemapTable::build_within`], where an output pixel 1.5 or more source pixels wide
    /// along both of its axes samples the source's pyramid instead (see [`pyramid`]): one
    /// bilinear tap (more along the longer axis of an anisotropic footprint) at the level
    /// where it spans 0.75 to 1.5 level pixels, about what a bilinear lookup costs to build
    /// and apply, against a tap for each source pixel under it. Pixels finer than that are
    /// exactly [`RemapTable::build_within`]'s. Apply the
    /// table to [`RemapTable::input`]'s buffer (`apply` and `apply_into` build it). A 360°
    /// source (its columns wrap) takes the taps of [`RemapTable::build_within`] here (see
    /// [`RemapTable::build_pyramid_above_wrap`] for its pyramid).
    ///
    /// [`pyramid`]: crate::warp::pyramid
    pub fn build_pyramid_within(
        dst: &dyn CameraModel,
        src: &dyn CameraModel,
        src_from_dst: &Matrix3<f64>,
        wrap: Wrap,
        max_supersample: u32,
        seen: Option<&Footprint>,
        parallel: bool,
    ) -> RemapTable {
        let mut b = Builder::new(dst, src, src_from_dst, wrap, max_supersample, seen);
        b.shapes = match b.one_block {
            true => pyramid::level_shapes(b.source_size, b.cap.ilog2() + 1),
            false => Vec::new(),
        };
        b.build(parallel)
    }

    /// As [`RemapTable::build_pyramid_within`] (no wrap, at most 8×8 taps, every output pixel
    /// mapped), where a pixel under `taps_below` source pixels along its shorter axis takes
    /// the taps of [`RemapTable::build_within`] and a coarser one the pyramid's level by its
    /// rule. A stitch's tables take the taps below 2 source pixels: there a level's blur
    /// costs more against an exact render than the few taps do.
    pub fn build_pyramid_above(
        dst: &dyn CameraModel,
        src: &dyn CameraModel,
        src_from_dst: &Matrix3<f64>,
        taps_below: f64,
        parallel: bool,
    ) -> RemapTable {
        Self::build_pyramid_guided(dst, src, src_from_dst, taps_below, None, parallel)
    }

    /// As [`RemapTable::build_pyramid_above`], where `surfaces` (a depth-guided stitch's
    /// scene at the output's pixels) says which pixels' footprints lie on one surface: only
    /// those sample the pyramid, a pixel by a depth edge keeps its taps (see `surface.rs`).
    pub(crate) fn build_pyramid_guided(
        dst: &dyn CameraModel,
        src: &dyn CameraModel,
        src_from_dst: &Matrix3<f64>,
        taps_below: f64,
        surfaces: Option<&dyn Surfaces>,
        parallel: bool,
    ) -> RemapTable {
        let rule = (taps_below, surfaces);
        Self::pyramid_above(dst, src, src_from_dst, Wrap::None, rule, None, parallel)
    }

    /// [`RemapTable::build_pyramid_above`] of a source whose columns may wrap (`wrap`): a 360°
    /// panorama's views (`panoconv pano`). Its levels wrap as its columns do, those whose
    /// widths divide the source's (all five of a 2048-wide panorama, four of a 1000-wide one,
    /// none of an odd width: the taps). A pyramid sample's coverage is its centre's.
    pub fn build_pyramid_above_wrap(
        dst: &dyn CameraModel,
        src: &dyn CameraModel,
        src_from_dst: &Matrix3<f64>,
        wrap: Wrap,
        taps_below: f64,
        parallel: bool,
    ) -> RemapTable {
        let rule = (taps_below, None);
        Self::pyramid_above(dst, src, src_from_dst, wrap, rule, None, parallel)
    }

    /// [`RemapTable::build_pyramid_above`] mapping only the output pixels within `seen` (the
    /// others take nothing from the source), as [`RemapTable::build_within`] does: a fisheye
    /// target's table (a lens sees a KITTI camera through a small part of its image).
    pub fn build_pyramid_above_within(
        dst: &dyn CameraModel,
        src: &dyn CameraModel,
        src_from_dst: &Matrix3<f64>,
        taps_below: f64,
        seen: Option<&Footprint>,
        parallel: bool,
    ) -> RemapTable {
        let rule = (taps_below, None);
        Self::pyramid_above(dst, src, src_from_dst, Wrap::None, rule, seen, parallel)
    }

    /// The pyramid above `taps_below` source pixels, where `surfaces` allows it, within `seen`.
    fn pyramid_above(
        dst: &dyn CameraModel,
        src: &dyn CameraModel,
        src_from_dst: &Matrix3<f64>,
        wrap: Wrap,
        (taps_below, surfaces): (f64, Option<&dyn Surfaces>),
        seen: Option<&Footprint>,
        parallel: bool,
    ) -> RemapTable {
        let mut b = Builder::new(dst, src, src_from_dst, wrap, MAX_SUPERSAMPLE, seen);
        b.shapes = b.level_shapes(5);
        b.taps_below2 = taps_below * taps_below;
        // (a wrapping source's taps lie inside along its columns: a pyramid sample's coverage
        // is its centre's, the taps' wherever its rows are inside, as a panorama's all are)
        b.taps_cover = wrap == Wrap::None;
        b.surfaces = surfaces;
        if b.by_parts.is_none() {
            b.tap_parts = surfaces.and_then(|s| s.tap_output());
        }
        b.build(parallel)
    }
}

impl Builder<'_> {
    /// The source pyramid's levels the table may sample, at most `levels` (level 0 first):
    /// none where a tap's block may split but across a 360° source's wrap (a one-pixel-wide
    /// source), a wrapping source's those whose widths divide its own.
    fn level_shapes(&self, levels: u32) -> Vec<(u32, u32, u32)> {
        match (self.one_block, self.wrap) {
            (true, _) => pyramid::level_shapes(self.source_size, levels),
            (false, Wrap::Horizontal) if self.source_size.width >= 2 => {
                pyramid::wrapping_level_shapes(self.source_size, levels)
            }
            (false, _) => Vec::new(),
        }
    }
}
