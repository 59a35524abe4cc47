//! `panoconv inspect`'s note on `P2` when it is not the camera of the images (equirect,
//! cylindrical and fisheye outputs): what it is there, which differs by command. `kitti` keeps
//! the source camera's `P2`, the view the image shows; the rig commands (`nuscenes`,
//! `kitti360`) write `P0`..`P3` as the nominal pinhole `K2·[I | −C2]` of the written camera,
//! no camera of the rig, whose view (a LiDAR field-of-view filter's) is a forward wedge of a
//! panorama. Told apart by the calib itself: a nominal `P2` has `K2`'s intrinsics and `C2`.

use std::collections::BTreeMap;

/// One distinct calibration with a written camera, as the note sees it.
pub(crate) struct Camera2<'a> {
    /// The `projection:` line.
    pub projection: &'a str,
    /// P2's fu, fv, cu, cv and its centre.
    pub p2: ([f64; 4], [f64; 3]),
    /// `K2:`'s fu, fv, cu, cv and `C2:`.
    pub written: ([f64; 4], [f64; 3]),
    /// Frames with this calibration.
    pub frames: usize,
}

/// Whether `c`'s `P2` is the nominal pinhole of its written camera (a rig output's).
fn is_nominal(c: &Camera2) -> bool {
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * a.abs().max(b.abs()).max(1.0);
    let (k, centre) = c.p2;
    let (k2, c2) = c.written;
    (k.iter().zip(&k2))
        .chain(centre.iter().zip(&c2))
        .all(|(&a, &b)| close(a, b))
}

/// `equirect 3, fisheye 1`: frames per projection.
fn counts(calibs: &[&Camera2]) -> String {
    let mut by: BTreeMap<&str, usize> = BTreeMap::new();
    for c in calibs {
        *by.entry(c.projection).or_default() += c.frames;
    }
    let parts: Vec<String> = by.iter().map(|(p, n)| format!("{p} {n}")).collect();
    parts.join(", ")
}

/// The note's lines (none when every image is P2's, or has no written camera).
pub(crate) fn p2_notes(calibrations: &[Camera2]) -> Vec<String> {
    let how = "project with the projection:, K2: and C2: lines (docs/formats.md), or take u, \
               v, distance from `panoconv labels-to-pixels`";
    let not_p2 = calibrations
        .iter()
        .filter(|c| c.projection != "perspective");
    let (nominal, source): (Vec<&Camera2>, Vec<&Camera2>) = not_p2.partition(|c| is_nominal(c));
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
        let [fu, _, cu, _] = first.written.0;
        let half_deg = (cu / fu).atan().to_degrees();
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
