//! The velodyne parser (the conversion does not read scans yet): its exact messages and counts
//! on malformed scans.

use std::path::Path;

#[test]
fn velodyne_wrong_size_is_refused_with_the_exact_message() {
    use panoconv::kitti::velodyne;
    let path = Path::new("training/velodyne/000001.bin");
    for len in [1usize, 15, 17, 33, 16 * 1000 + 4] {
        let err = velodyne::parse(&vec![0u8; len], path)
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            format!(
                "training/velodyne/000001.bin: {len} bytes is not a whole number of 16-byte points (x, y, z, reflectance as float32): truncated or not a velodyne scan"
            )
        );
    }
    let scan = velodyne::parse(&[], path).unwrap();
    assert!(scan.points.is_empty() && scan.dropped_non_finite == 0);
}

#[test]
fn velodyne_non_finite_points_are_dropped_and_counted() {
    use panoconv::kitti::velodyne;
    let mut bytes = Vec::new();
    for p in [
        [1.0f32, 2.0, 3.0, 0.5],
        [f32::NAN, 0.0, 0.0, 0.1],
        [0.0, f32::INFINITY, 0.0, 0.1],
        [4.0, 5.0, 6.0, f32::NAN],
    ] {
        for v in p {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    let scan = velodyne::parse(&bytes, Path::new("v.bin")).unwrap();
    assert_eq!(scan.dropped_non_finite, 2);
    assert_eq!(scan.points.len(), 2);
    assert_eq!(scan.points[1].z, 6.0);
    // a NaN reflectance is kept as it is (only coordinates are checked)
    assert!(scan.reflectance[1].is_nan());
}
