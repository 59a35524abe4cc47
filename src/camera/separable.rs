//! Unprojection by columns and rows, for cameras whose pixel bearings separate.
//!
//! A remap table unprojects every pixel centre of the output image, and more positions inside
//! the supersampled pixels. For the linear projections the bearing of pixel (u, v) is a cheap
//! combination of something u alone determines (equirect: the sine and cosine of the
//! longitude) and something v alone determines (the latitude's): a grid of pixels then costs
//! one share per column and one per row instead of the trigonometry of every pixel. Each
//! projection that separates says so once, in its [`crate::camera::Mapping`]
//! (`split_a`, `split_b`, `join`, of which its own `ab_to_bearing` is made, so the batch and
//! the per-pixel bearings are the same arithmetic, bit for bit).

use nalgebra::Vector3;

/// What one column (or one row) contributes to its pixels' bearings; opaque outside the
/// camera that made it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Share(pub(super) [f64; 2]);

/// A camera's unprojection split into a column share and a row share (see the module's notes).
/// [`crate::camera::CameraModel::separable`] gives it where a camera has one.
pub trait Separable: Sync {
    /// The share of the bearing that the pixel column position `u` determines.
    fn column(&self, u: f64) -> Share;
    /// The share of the bearing that the pixel row position `v` determines.
    fn row(&self, v: f64) -> Share;
    /// Appends to `out` the bearing of each column of `columns` (shares of this camera's
    /// [`Separable::column`]) on the row of `row`: exactly what
    /// [`crate::camera::CameraModel::unproject`] gives for that pixel (`None` for its errors).
    fn bearings(&self, columns: &[Share], row: Share, out: &mut Vec<Option<Vector3<f64>>>);
    /// [`Separable::bearings`] coordinate by coordinate: the bearing of `columns[i]` on the row
    /// of `row` in `x[i]`, `y[i]`, `z[i]` (each as long as `columns`), a NaN `x[i]` where
    /// `bearings` gives `None` (the others may be NaN too). For batch kernels that take
    /// coordinates in lanes.
    fn bearing_lanes(&self, columns: &[Share], row: Share, [x, y, z]: [&mut [f64]; 3]) {
        let mut one = Vec::with_capacity(columns.len());
        self.bearings(columns, row, &mut one);
        for (i, d) in one.iter().enumerate() {
            let d = d.unwrap_or(Vector3::repeat(f64::NAN));
            (x[i], y[i], z[i]) = (d.x, d.y, d.z);
        }
    }
}
