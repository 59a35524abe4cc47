//! The new models as sources of `panoconv fisheye`'s warp, against the exact render.

use super::*;
use crate::common::psnr;
use panoconv::camera::description::CameraDescription;
use panoconv::camera::CameraModel;

#[test]
fn fisheye_to_cylindrical_matches_the_exact_render_for_the_new_models() {
    use panoconv::camera::{rotation_ypr, Cylindrical, Projection, Rotated};
    use panoconv::convert::pano::FisheyeView;
    use panoconv::geometry::Scale;
    let scene = &panoconv::tools::synth::frames()[0].scene;
    let centre = Vector3::new(0.0, panoconv::tools::synth::GROUND_Y - 1.2, 0.0);
    for (name, cam) in cameras() {
        // A 480-pixel-wide version of each camera (the affine part scaled by the half-pixel
        // rule), so that the renders stay quick.
        let s = cam.size();
        let scale = 480.0 / s.width as f64;
        let k = cam.intrinsics();
        let size = ImageSize::new(480, (s.height as f64 * scale).round() as u32);
        let k = Intrinsics::new(
            k.fu * scale,
            k.fv * scale,
            (k.cu + 0.5) * scale - 0.5,
            (k.cv + 0.5) * scale - 0.5,
        );
        let desc = CameraDescription {
            camera: cam.with_intrinsics(k, size).unwrap(),
            output_from_camera: rotation_ypr(0.0, -8f64.to_radians(), 2f64.to_radians()),
        };
        let source = Rotated::new(desc.camera.clone(), desc.output_from_camera);
        let fisheye_image = scene.render(&source, &centre);
        let spec = FisheyeView {
            projection: Projection::Cylindrical,
            hfov: Some(160f64.to_radians()),
            vfov: Some(80f64.to_radians()),
            scale: Scale::PixelsPerDegree(desc.camera.centre_intrinsics().fu.to_radians() / 1.5),
        };
        let view = spec.plan(&desc).unwrap();
        let warped = view.table.apply(&fisheye_image);
        let out_cam = Rotated::new(
            Cylindrical::new(view.camera.intrinsics(), view.camera.size()),
            desc.output_from_camera * view.source_from_output,
        );
        let inside = |u, v| view.table.is_inside(u, v);
        // `Scene::render` where the table covers
        let exact = crate::common::render_where(scene, &out_cam, &centre, 0.55, 6, inside);
        let (db, n) = psnr(&warped, &exact, inside);
        let total = (view.camera.size().width * view.camera.size().height) as usize;
        eprintln!("{name}: PSNR {db:.2} dB over {n} of {total} px");
        assert!(n > total / 2, "{name}: coverage {n}/{total}");
        assert!(db >= 45.0, "{name}: {db:.2} dB");
    }
}
