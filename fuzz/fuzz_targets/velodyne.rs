//! Velodyne scans: `velodyne::parse` must accept exactly the whole-point sizes, never panic,
//! and keep only finite points.
#![no_main]

use libfuzzer_sys::fuzz_target;
use panoconv::kitti::velodyne;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    match velodyne::parse(data, Path::new("velodyne/000000.bin")) {
        Ok(scan) => {
            assert!(data.len().is_multiple_of(16));
            assert_eq!(scan.points.len() + scan.dropped_non_finite, data.len() / 16);
            assert_eq!(scan.points.len(), scan.reflectance.len());
            assert!(scan.points.iter().all(|p| p.iter().all(|v| v.is_finite())));
        }
        Err(_) => assert!(!data.len().is_multiple_of(16)),
    }
});
