//! The pyramid through a depth-guided stitch's scene. A table built through the scene maps each
//! output pixel's centre to the point at its own distance, so a pixel whose neighbours lie on
//! another surface (a near box before a far wall) measures a footprint spanning both: the
//! pyramid's level for it would blur the two surfaces together, where its taps, each cast
//! through the scene, sample each surface where it lies. Such a pixel keeps its taps; a pixel
//! whose neighbourhood lies on one surface measures that surface's footprint and samples the
//! pyramid by its rule (`level.rs`).

use super::Builder;

/// The scene of a depth-guided source at the output's pixels.
pub(crate) trait Surfaces: Sync {
    /// Whether output pixel (u, v) and its eight neighbours (those within the output) lie on
    /// one surface of the scene: the footprint measured from their mapped centres is that
    /// surface's.
    fn one_surface(&self, u: usize, v: usize) -> bool;
}

impl Builder<'_> {
    /// The pyramid level of output pixel (u, v), whose smaller squared scale is `scale2`
    /// ([`Builder::level_of`]), or 0 where the source's scene puts a depth edge by it.
    #[inline]
    pub(super) fn level_at(&self, (u, v): (usize, usize), scale2: f64) -> u32 {
        let level = self.level_of(scale2);
        match self.surfaces {
            // (the scene is asked only where the pixel would sample the pyramid)
            Some(s) if level > 0 && !s.one_surface(u, v) => 0,
            _ => level,
        }
    }
}
