//! The table's unit tests: a table stores and writes only the groups it reaches.

use super::*;
use crate::camera::{Fisheye, Intrinsics, Perspective, RadialModel};
use nalgebra::Vector3;

#[test]
fn a_table_stores_rounds_only_for_the_groups_it_reaches_and_writes_only_them() {
    // a 190° lens from a 70° pinhole: most of the lens's image takes nothing
    let source = Perspective::new(
        Intrinsics::new(90.0, 90.0, 63.5, 40.5),
        ImageSize::new(128, 80),
    );
    let lens = Fisheye::new(
        RadialModel::Equidistant,
        Intrinsics::new(40.0, 40.0, 60.0, 45.0),
        ImageSize::new(121, 91),
        190f64.to_radians(),
    )
    .expect("lens");
    // the pixels beyond the footprint have no mapped centre
    let turn = Matrix3::identity();
    let seen = crate::warp::footprint::Footprint::new(&lens, &source, &turn, &-Vector3::z());
    assert!(seen.is_some(), "a footprint");
    let build = |parallel| {
        let (wrap, cap) = (Wrap::None, MAX_SUPERSAMPLE);
        RemapTable::build_within(&lens, &source, &turn, wrap, cap, seen.as_ref(), parallel)
    };
    let table = build(false);
    assert!(table == build(true), "serial and parallel bands");
    let (w, h) = (121usize, 91usize);
    let groups = w.div_ceil(LANES);
    // most groups have no round, and no pixel of such a group is covered
    let without = table.depth.iter().filter(|&&k| k == 0).count();
    assert!(without * 2 > groups * h, "{without} groups without a round");
    let mut src = RgbImage::new(128, 80);
    for (i, b) in src.as_raw_mut().iter_mut().enumerate() {
        *b = (i * 29 % 251) as u8;
    }
    let full = table.apply(&src);
    let mut kept = RgbImage::new(w as u32, h as u32);
    kept.as_raw_mut().fill(7);
    table.apply_stored_into(&src, &mut kept);
    let mut beyond = 0;
    for v in 0..h {
        let stored: Vec<usize> = table.stored_spans(v).flatten().collect();
        for u in 0..w {
            let (a, b) = (
                full.pixel(u as u32, v as u32),
                kept.pixel(u as u32, v as u32),
            );
            if stored.contains(&u) {
                assert_eq!(a, b, "({u}, {v})");
            } else {
                // black in the whole image, left as it was by the stored spans' writer
                assert_eq!((a, b), ([0; 3], [7; 3]), "({u}, {v})");
                assert!(table.cover[v * w + u] == Cover::None, "({u}, {v})");
                beyond += 1;
            }
        }
    }
    assert!(beyond > w * h / 3, "{beyond} pixels beyond");
}
