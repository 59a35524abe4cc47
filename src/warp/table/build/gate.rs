//! The pixel centres of an output that holds their bearings already (a stitch's output gated
//! by its reach bound, [`CameraModel::stored_centres`]): a row is read from the stored
//! bearings, the positions the bound refuses skipped, instead of one `unproject` per centre
//! (most of which the bound refuses).

use crate::camera::CameraModel;
use crate::warp::footprint::Footprint;
use nalgebra::Vector3;

/// Appends to `out` the bearings of the centres of row `v` (columns -1..=width) as `dst`
/// stores them, None where `seen` says the source is not seen; false, `out` unchanged, where
/// `dst` stores none.
pub(super) fn stored_centres(
    dst: &dyn CameraModel,
    v: isize,
    seen: Option<&Footprint>,
    out: &mut Vec<Option<Vector3<f64>>>,
) -> bool {
    let start = out.len();
    if !dst.stored_centres(v, out) {
        return false;
    }
    if let Some(seen) = seen {
        for (u, d) in (-1..).zip(&mut out[start..]) {
            if !seen.may_see(u, v) {
                *d = None;
            }
        }
    }
    true
}
