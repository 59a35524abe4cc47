//! KITTI files of an output camera made from a rig (`panoconv kitti360`): the label line of a
//! neutral [`SourceBox`] and the calib of a frame whose rect is the dataset's reference frame.
//!
//! The rect of such an output is the frame's reference frame (KITTI-360's level frame), so
//! `R0_rect` is the identity, `Tr_velo_to_cam` maps the Velodyne straight into it, and the
//! `projection:`/`K2:`/`C2:` lines (and a fisheye's lens lines) are the ones `Calib` writes for
//! every converted dataset. `Tr_rect_to_world:` places the frame in the dataset's world.

use super::calib::{format_sci, Calib};
use super::Cam;
use crate::camera::OutputCamera;
use crate::source::{Pose, SourceBox};
use nalgebra::Vector3;
use std::f64::consts::PI;
use std::path::Path;

/// An angle wrapped to (−π, π].
fn wrap(a: f64) -> f64 {
    let w = (a + PI).rem_euclid(2.0 * PI) - PI;
    if w <= -PI {
        w + 2.0 * PI
    } else {
        w
    }
}

/// KITTI's `location` of a box: its geometric centre moved down (reference +y) by half its
/// height. For an upright box it is the centre of its bottom face; a tilted box keeps its true
/// centre in the upright box KITTI's columns describe.
pub fn kitti_location(b: &SourceBox) -> Vector3<f64> {
    b.centre + Vector3::new(0.0, b.height() / 2.0, 0.0)
}

/// The 15 columns of a KITTI label line for `b`: type, truncation (`%.2f`), occlusion, alpha
/// (`rotation_y − atan2(x, z)` of the location, as KITTI: relative to the reference frame's
/// origin), the 2D box `bbox`, height width length, location and rotation_y
/// ([`SourceBox::yaw`], its heading for a tilted box), all with two decimals.
pub fn label_line(b: &SourceBox, bbox: [f64; 4], truncation: f64, occlusion: u8) -> String {
    let location = kitti_location(b);
    let ry = wrap(b.yaw());
    let alpha = wrap(ry - location.x.atan2(location.z));
    format!(
        "{} {:.2} {} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2}",
        b.class,
        truncation,
        occlusion,
        alpha,
        bbox[0],
        bbox[1],
        bbox[2],
        bbox[3],
        b.height(),
        b.width(),
        b.length(),
        location.x,
        location.y,
        location.z,
        ry
    )
}

fn row_major(p: &Pose) -> String {
    p.to_row_major_3x4()
        .iter()
        .map(|&v| format_sci(v))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The calib of an output camera whose rect is the reference frame: `P0:`..`P3:` the pinhole
/// K2·[I | −C2] of the output intrinsics (exact for a perspective output; for the others a
/// nominal matrix, the projection lines describe the image), `R0_rect:` identity,
/// `Tr_velo_to_cam:` (reference_from_velo) and `Tr_imu_to_velo:` when known, then `Calib`'s
/// `projection:`, `K2:`, `C2:` (and lens) lines, and `Tr_rect_to_world:` (3x4, row-major)
/// when the dataset has a world frame.
pub fn rig_calib_text(
    camera: &dyn OutputCamera,
    centre: &Vector3<f64>,
    reference_from_velo: Option<&Pose>,
    velo_from_imu: Option<&Pose>,
    world_from_reference: Option<&Pose>,
) -> String {
    let k = camera.intrinsics();
    let t = -Vector3::new(
        k.fu * centre.x + k.cu * centre.z,
        k.fv * centre.y + k.cv * centre.z,
        centre.z,
    );
    let p = [
        k.fu, 0.0, k.cu, t.x, 0.0, k.fv, k.cv, t.y, 0.0, 0.0, 1.0, t.z,
    ]
    .map(format_sci)
    .join(" ");
    let mut lines: Vec<String> = (0..4).map(|n| format!("P{n}: {p}")).collect();
    let identity = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0].map(format_sci);
    lines.push(format!("R0_rect: {}", identity.join(" ")));
    if let Some(velo) = reference_from_velo {
        lines.push(format!("Tr_velo_to_cam: {}", row_major(velo)));
    }
    if let Some(imu) = velo_from_imu {
        lines.push(format!("Tr_imu_to_velo: {}", row_major(imu)));
    }
    // Lines of this writer's own making: they always parse.
    let calib = Calib::parse(Path::new("calib"), lines).expect("the rig calib's own lines parse");
    let mut text = calib.render_output(&[(Cam::C2, camera, *centre)]);
    if let Some(world) = world_from_reference {
        text.push_str(&format!("Tr_rect_to_world: {}\n", row_major(world)));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{ImageSize, Intrinsics, Projection};
    use crate::kitti::Label;

    #[test]
    fn a_label_line_parses_back_to_the_box() {
        let b = SourceBox::from_kitti("Car", [1.52, 1.65, 3.9], Vector3::new(-3.0, 1.7, 12.0), 2.9);
        let line = label_line(&b, [1.0, 2.0, 30.0, 40.0], 0.0, 0);
        let l = Label::parse(Path::new("l"), 1, &line).unwrap();
        assert_eq!(l.kind, "Car");
        assert_eq!(l.dimensions, [1.52, 1.65, 3.9]);
        assert!((l.location - Vector3::new(-3.0, 1.7, 12.0)).norm() < 1e-9);
        assert_eq!(l.rotation_y, 2.9);
        let want_alpha = wrap(2.9 - (-3.0f64).atan2(12.0));
        assert!(
            (l.alpha - want_alpha).abs() <= 0.005,
            "{} {want_alpha}",
            l.alpha
        );
        assert_eq!(l.bbox, [1.0, 2.0, 30.0, 40.0]);
        assert!((wrap(3.5) - (3.5 - 2.0 * PI)).abs() < 1e-12 && wrap(PI) == PI);
    }

    #[test]
    fn the_calib_reads_back_as_the_output_camera() {
        let k = Intrinsics::new(100.0, 100.0, 319.5, 159.5);
        let camera = Projection::Equirect.camera(k, ImageSize::new(640, 320));
        let centre = Vector3::new(0.1, -0.2, 0.3);
        let velo = Pose::new(nalgebra::Matrix3::identity(), Vector3::new(0.0, -1.0, 0.5));
        let world = Pose::new(nalgebra::Matrix3::identity(), Vector3::new(10.0, 20.0, 3.0));
        let text = rig_calib_text(camera.as_ref(), &centre, Some(&velo), None, Some(&world));
        let lines: Vec<String> = text.lines().map(str::to_owned).collect();
        let calib = Calib::parse(Path::new("c"), lines).unwrap();
        let (read, c) = calib
            .output_camera(Cam::C2, ImageSize::new(640, 320))
            .unwrap();
        assert_eq!(read.intrinsics(), k);
        assert_eq!(c, centre);
        assert_eq!(calib.r0_rect, Some(nalgebra::Matrix3::identity()));
        assert_eq!(calib.tr_velo_to_cam.unwrap()[(1, 3)], -1.0);
        assert!(text.ends_with(&format!("Tr_rect_to_world: {}\n", row_major(&world))));
        // every P line is the pinhole K2·[I | −C2], whose centre is C2
        let p2 = calib.camera(Cam::C2).unwrap();
        assert!((p2.centre - centre).norm() < 1e-9);
    }
}
