//! The sample dataset the repository ships (fixtures/synthetic_kitti) is exactly what the
//! project's own generator makes: `panoconv synth` regenerates it byte for byte.

use crate::common;
use std::path::Path;

#[test]
fn shipped_sample_is_regenerated_byte_for_byte() {
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synthetic_kitti");
    // the dataset `panoconv synth --output DIR` writes, as the other tests share it (made once
    // per binary build; tests/cli/conversion.rs checks that a second run writes the same bytes)
    let fresh = common::synth_source();
    let (a, b) = (common::tree_files(&shipped), common::tree_files(fresh));
    assert_eq!(a, b, "file lists differ");
    assert_eq!(
        a.len(),
        19,
        "4 frames: image_2, image_3, velodyne, calib; 3 labels"
    );
    for f in &a {
        assert!(
            std::fs::read(shipped.join(f)).unwrap() == std::fs::read(fresh.join(f)).unwrap(),
            "{f} differs from the generator's output"
        );
    }
}
