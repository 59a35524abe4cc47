//! Calibration files: `Calib::parse` and the camera extraction must return Ok or a tagged error
//! for any text, never panic; an accepted camera has positive finite focal lengths.
#![no_main]

use libfuzzer_sys::fuzz_target;
use panoconv::kitti::Calib;
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
    for n in 0..4 {
        if let Ok(cam) = calib.camera(n) {
            assert!(cam.k.fu > 0.0 && cam.k.fv > 0.0, "{cam:?}");
            assert!(cam.k.fu.is_finite() && cam.k.fv.is_finite(), "{cam:?}");
        }
    }
    if let Ok(cam) = calib.camera(2) {
        let _ = calib.render_output("equirect", &[(2, cam.k, cam.centre)]);
        let _ = calib.render_output("perspective", &[(2, cam.k, cam.centre)]);
    }
});
