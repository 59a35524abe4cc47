//! Calibration files: `Calib::parse` and the camera extraction must return Ok or a tagged error
//! for any text, never panic; an accepted camera has positive finite focal lengths, and the
//! calib written for it parses back.
#![no_main]

use libfuzzer_sys::fuzz_target;
use panoconv::camera::{ImageSize, OutputCamera, Projection};
use panoconv::kitti::{Calib, Cam};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let lines: Vec<String> = text
        .split('\n')
        .map(|l| l.strip_suffix('\r').unwrap_or(l).to_owned())
        .collect();
    let Ok(calib) = Calib::parse(Path::new("calib/000000.txt"), lines) else {
        return;
    };
    for n in [Cam::C0, Cam::C1, Cam::C2, Cam::C3] {
        if let Ok(cam) = calib.camera(n) {
            assert!(cam.k.fu > 0.0 && cam.k.fv > 0.0, "{cam:?}");
            assert!(cam.k.fu.is_finite() && cam.k.fv.is_finite(), "{cam:?}");
        }
    }
    if let Ok(cam) = calib.camera(Cam::C2) {
        let size = ImageSize::new(1242, 375);
        for projection in [Projection::Equirect, Projection::Perspective] {
            let out = projection.camera(cam.k, size);
            let out: &dyn OutputCamera = out.as_ref();
            let _ = calib.render_output(&[(Cam::C2, out, cam.centre)]);
        }
    }
});
