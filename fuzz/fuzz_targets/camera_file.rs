//! Camera files (a camera description, or a native KITTI-360 YAML, WoodScape or OpenCV
//! calibration through the YAML subset): any text gives a camera or an error naming the file,
//! never a panic; an accepted camera projects its own principal ray to a finite pixel or
//! refuses it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use panoconv::camera::description::CameraDescription;
use panoconv::camera::CameraModel;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("calibration/image_02.yaml");
    match CameraDescription::parse_any(text, path) {
        Ok(description) => {
            let camera = &description.camera;
            if let Ok(p) = camera.project(&nalgebra::Vector3::z()) {
                assert!(p.x.is_finite() && p.y.is_finite(), "{p}");
            }
        }
        Err(e) => assert!(e.to_string().contains("image_02.yaml"), "{e}"),
    }
});
