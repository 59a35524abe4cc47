//! The per-frame stitch of `panoconv kitti360`: build (tables and weights) and apply for a
//! 2048x1024 equirect panorama of the four cameras of the synthetic sequence
//! (fixtures/kitti360), the work the command repeats for every frame.

use criterion::{criterion_group, criterion_main, Criterion};
use panoconv::camera::{Equirect, ImageSize, Intrinsics};
use panoconv::image::RgbImage;
use panoconv::kitti360::{Options, Sequence};
use panoconv::warp::{Stitch, StitchCamera, StitchOptions};
use std::f64::consts::PI;
use std::hint::black_box;
use std::path::Path;

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/kitti360");
    let seq = Sequence::open(&root, "2013_05_28_drive_0000_sync", Options::default())
        .expect("fixtures/kitti360");
    let frame = seq.frame(250).expect("frame 250");
    let (w, h) = (2048u32, 1024u32);
    let f = w as f64 / (2.0 * PI);
    let output = Equirect::new(
        Intrinsics::new(f, f, w as f64 / 2.0, h as f64 / 2.0),
        ImageSize::new(w, h),
    );
    let centre = frame
        .rig
        .iter()
        .map(|c| c.centre())
        .sum::<nalgebra::Vector3<f64>>()
        / 4.0;
    let inverses: Vec<_> = frame
        .rig
        .iter()
        .map(|c| c.reference_from_camera.inverse().expect("a pose"))
        .collect();
    let fisheye = &seq.calibration.fisheye;
    let max_theta = [
        None,
        None,
        Some(fisheye[0].max_theta()),
        Some(fisheye[1].max_theta()),
    ];
    let cameras: Vec<StitchCamera> = frame
        .rig
        .iter()
        .zip(&inverses)
        .zip(max_theta)
        .map(|((c, inv), max_theta)| StitchCamera {
            model: c.model.as_ref(),
            rotation: inv.rotation,
            translation: inv.translation,
            max_theta,
        })
        .collect();
    let images: Vec<RgbImage> = frame
        .rig
        .iter()
        .map(|c| {
            let bytes = std::fs::read(&c.image).expect("a fixture image");
            panoconv::codec::decode_rgb8(&bytes, &c.image).expect("a PNG")
        })
        .collect();
    let refs: Vec<&RgbImage> = images.iter().collect();
    let mut group = c.benchmark_group("kitti360_stitch");
    group.sample_size(10);
    group.bench_function("build_2048x1024_x4", |b| {
        b.iter(|| {
            black_box(Stitch::build(
                &output,
                &centre,
                &cameras,
                StitchOptions::default(),
            ))
        })
    });
    let stitch = Stitch::build(&output, &centre, &cameras, StitchOptions::default());
    group.bench_function("apply_2048x1024_x4", |b| {
        b.iter(|| black_box(stitch.apply(&refs)))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
