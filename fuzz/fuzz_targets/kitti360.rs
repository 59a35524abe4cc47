//! KITTI-360's readers: the 3D boxes' XML and the Velodyne scan must return Ok or an error
//! naming the file for any bytes, never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use panoconv::kitti360::parse_boxes;
use panoconv::kitti360::velodyne::parse_scan;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let scan = Path::new("velodyne_points/data/0000000000.bin");
    if let Err(e) = parse_scan(data, scan) {
        assert!(e.to_string().contains("0000000000.bin"), "{e}");
    }
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let xml = Path::new("data_3d_bboxes/train/seq.xml");
    match parse_boxes(text, xml) {
        Ok(boxes) => {
            for b in &boxes {
                assert!(b.world_vertices().iter().all(|v| v.iter().all(|c| c.is_finite())));
            }
        }
        Err(e) => assert!(e.to_string().contains("seq.xml"), "{e}"),
    }
});
