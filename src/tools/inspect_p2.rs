//! `panoconv inspect`'s note on `P2` when it is not the camera of the images (equirect,
//! cylindrical and fisheye outputs): what it is there, which differs by command. `kitti` keeps
//! the source camera's `P2`, the view the image shows; the rig commands (`nuscenes`,
//! `kitti360`) write `P0`..`P3` as the nominal pinhole `K2·[I | −C2]` of the written camera,
//! no camera of the rig, whose view (a LiDAR field-of-view filter's) is a forward wedge of a
//! panorama. Told apart by the calib itself: a nominal `P2` has `K2`'s intrinsics and `C2`.

use super::inspect::CalibCount;
use std::collections::BTreeMap;

/// Whether `c`'s `P2` is the nominal pinhole of its written camera (a rig output's).
fn is_nominal(c: &CalibCount) -> bool {
    let Some(w) = &c.written else {
        return false;
    };
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * a.abs().max(b.abs()).max(1.0);
    [(c.fu, w.fu), (c.fv, w.fv), (c.cu, w.cu), (c.cv, w.cv)]
        .into_iter()
        .chain((0..3).map(|i| (c.c2[i], w.c2[i])))
        .all(|(a, b)| close(a, b))
}

/// `equirect 3, fisheye 1`: frames per projection.
fn counts(calibs: &[&CalibCount]) -> String {
    let mut by: BTreeMap<&str, usize> = BTreeMap::new();
    for c in calibs {
        let w = c.written.as_ref().expect("only written cameras");
        *by.entry(w.projection.as_str()).or_default() += c.count;
    }
    let parts: Vec<String> = by.iter().map(|(p, n)| format!("{p} {n}")).collect();
    parts.join(", ")
}

/// The note's lines (none when every image is P2's, or has no written camera).
pub(crate) fn p2_notes(calibrations: &[CalibCount]) -> Vec<String> {
    let how = "project with the projection:, K2: and C2: lines (docs/formats.md), or take u, \
               v, distance from `panoconv labels-to-pixels`";
    let not_p2 = calibrations.iter().filter(|c| {
        c.written
            .as_ref()
            .is_some_and(|w| w.projection != "perspective")
    });
    let (nominal, source): (Vec<&CalibCount>, Vec<&CalibCount>) =
        not_p2.partition(|c| is_nominal(c));
    let mut notes = Vec::new();
    if !source.is_empty() {
        notes.push(format!(
            "P2: not the camera of these images ({}): it is the source camera's pinhole, kept \
             for LiDAR field-of-view filters; {how}",
            counts(&source)
        ));
    }
    if let Some(first) = nominal.first() {
        // the pinhole's view of the image's left half: atan(cu / fu)
        let half_deg = (first.cu / first.fu).atan().to_degrees();
        notes.push(format!(
            "P2: not the camera of these images ({}): P0 to P3 are the nominal pinhole K2·[I | \
             −C2] of the written camera (a rig output's), no camera of the rig; a LiDAR \
             field-of-view filter with it keeps only the points ahead of C2, within about \
             ±{half_deg:.0}° of rect's z axis, not all the image shows; {how}",
            counts(&nominal)
        ));
    }
    notes
}
