//! Criterion benchmarks of the core stages on a KITTI-sized synthetic frame.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use nalgebra::Matrix3;
use panoconv::camera::{
    CameraModel, FisheyeCamera, ImageSize, Intrinsics, Lens, Perspective, Projection,
};
use panoconv::codec::png::{decode_rgb8, encode_rgb8, PngCompression};
use panoconv::convert::kitti::transform_label;
use panoconv::geometry::{output_camera, Canvas, OutputSpec, Scale};
use panoconv::kitti::Label;
use panoconv::tools::synth::{frames, label_lines};
use panoconv::warp::{warp_encode, Kernel, PngSource, RemapTable, Wrap};
use std::hint::black_box;
use std::path::Path;

#[path = "../tests/common/paths.rs"]
#[allow(dead_code)]
mod paths;

fn setup() -> (
    Perspective,
    panoconv::image::RgbImage,
    panoconv::tools::synth::SynthFrame,
) {
    let frame = frames().into_iter().next().unwrap();
    let src = Perspective::new(frame.calib.intrinsics(), frame.calib.size);
    let image = frame.scene.render(&src, &frame.calib.centre());
    (src, image, frame)
}

fn specs() -> Vec<(&'static str, OutputSpec)> {
    vec![
        ("equirect", OutputSpec::new(Projection::Equirect)),
        ("cylindrical", OutputSpec::new(Projection::Cylindrical)),
        (
            "equirect_2048",
            OutputSpec {
                projection: Projection::Equirect,
                scale: Scale::PanoWidth(2048),
                canvas: Canvas::Tight,
                ..OutputSpec::new(Projection::Equirect)
            },
        ),
    ]
}

fn bench(c: &mut Criterion) {
    let (src, image, frame) = setup();
    let k = frame.calib.intrinsics();

    let mut g = c.benchmark_group("table_build");
    g.sample_size(10);
    for (name, spec) in specs() {
        let out = output_camera(&spec, k, &src).unwrap();
        g.bench_function(name, |b| {
            b.iter(|| RemapTable::build(out.as_ref(), &src, &Matrix3::identity(), Wrap::None))
        });
        // the same table, bands of rows on rayon's pool
        g.bench_function(format!("{name}/parallel"), |b| {
            b.iter(|| {
                RemapTable::build_parallel(out.as_ref(), &src, &Matrix3::identity(), Wrap::None, 8)
            })
        });
    }
    g.finish();

    pyramid_tables(c, &src, k, &image);

    // Elements are output pixels: "bilinear" is one tap a pixel (antialiasing off), the others
    // the tables the CLI builds (supersampled where the output is coarser than the source).
    let mut g = c.benchmark_group("remap");
    for (name, spec) in specs() {
        let out = output_camera(&spec, k, &src).unwrap();
        let s = out.size();
        g.throughput(Throughput::Elements(s.width as u64 * s.height as u64));
        for (kind, max_supersample) in [("antialiased", 8), ("bilinear", 1)] {
            let table = RemapTable::build_with(
                out.as_ref(),
                &src,
                &Matrix3::identity(),
                Wrap::None,
                max_supersample,
            );
            g.bench_function(
                BenchmarkId::new(
                    format!("{name}/{kind}"),
                    format!("{}x{}", s.width, s.height),
                ),
                |b| b.iter(|| table.apply(black_box(&image))),
            );
        }
        // into a reused buffer, as the pipeline does (no fresh 1 MB image a frame)
        let table = RemapTable::build(out.as_ref(), &src, &Matrix3::identity(), Wrap::None);
        let mut buf = table.apply(&image);
        g.bench_function(
            BenchmarkId::new(
                format!("{name}/antialiased_into"),
                format!("{}x{}", s.width, s.height),
            ),
            |b| b.iter(|| table.apply_into(black_box(&image), &mut buf)),
        );
        // each kernel on one thread (Auto is AVX-512 where the CPU has it), the same bytes
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        for kernel in [Kernel::Auto, Kernel::Avx2, Kernel::Sse2, Kernel::Scalar] {
            g.bench_function(
                BenchmarkId::new(format!("{name}/{kernel:?}"), "1 thread"),
                |b| {
                    b.iter(|| one.install(|| table.apply_with(black_box(&image), &mut buf, kernel)))
                },
            );
        }
    }
    g.finish();

    let labels: Vec<Label> = label_lines(&frame.calib, &frame.scene, None)
        .lines()
        .map(|l| Label::parse(Path::new("bench"), 1, l).unwrap())
        .collect();
    let mut g = c.benchmark_group("labels");
    for (name, spec) in specs() {
        let out = output_camera(&spec, k, &src).unwrap();
        g.throughput(Throughput::Elements(labels.len() as u64));
        g.bench_function(name, |b| {
            b.iter(|| {
                for l in &labels {
                    black_box(transform_label(
                        l,
                        &frame.calib.centre(),
                        &src,
                        out.as_ref(),
                    ));
                }
            })
        });
    }
    g.finish();

    // The 2D box of each 3D box alone (transform_label -> source_box_in_image), DontCare
    // aside: in the panorama, and in a 190° fisheye, whose faces are also searched for the rim.
    let objects: Vec<&Label> = labels
        .iter()
        .filter(|l| l.to_source_box().is_some())
        .collect();
    let equirect = output_camera(&OutputSpec::new(Projection::Equirect), k, &src).unwrap();
    let fisheye = FisheyeCamera {
        lens: Lens::from_parameters(
            "kannala_brandt",
            Intrinsics::new(330.0, 330.0, 639.5, 482.5),
            &[0.02, -0.005, 0.001, -0.0002],
            ImageSize::new(1280, 966),
            95f64.to_radians(),
        )
        .unwrap(),
        rect_from_camera: Matrix3::identity(),
    };
    let mut g = c.benchmark_group("source_box_in_image");
    g.throughput(Throughput::Elements(objects.len() as u64));
    let cameras: [(&str, &dyn CameraModel); 2] =
        [("equirect", equirect.as_ref()), ("fisheye_190", &fisheye)];
    for (name, camera) in cameras {
        g.bench_function(name, |b| {
            b.iter(|| {
                for l in &objects {
                    black_box(transform_label(l, &frame.calib.centre(), &src, camera));
                }
            })
        });
    }
    g.finish();

    let mut g = c.benchmark_group("png");
    g.sample_size(20);
    let out = output_camera(&OutputSpec::new(Projection::Equirect), k, &src).unwrap();
    let warped =
        RemapTable::build(out.as_ref(), &src, &Matrix3::identity(), Wrap::None).apply(&image);
    let pano = output_camera(
        &OutputSpec {
            projection: Projection::Equirect,
            scale: Scale::PanoWidth(2048),
            canvas: Canvas::Full360,
            ..OutputSpec::new(Projection::Equirect)
        },
        k,
        &src,
    )
    .unwrap();
    let pano_img =
        RemapTable::build(pano.as_ref(), &src, &Matrix3::identity(), Wrap::None).apply(&image);
    // A real KITTI frame when $PANOCONV_KITTI (default ../shared/kitti) is there (the synthetic
    // one is far smoother, so its codec figures are optimistic); decoded from its original file,
    // as the CLI does.
    let real = paths::real_kitti().join("training/image_2/000001.png");
    if let Ok(bytes) = std::fs::read(&real) {
        let img = decode_rgb8(&bytes, &real).unwrap();
        g.bench_function(BenchmarkId::new("decode", "real_kitti_original"), |b| {
            b.iter(|| decode_rgb8(black_box(&bytes), &real).unwrap())
        });
        for comp in [PngCompression::Fast, PngCompression::Default] {
            g.bench_function(
                BenchmarkId::new(format!("encode_{comp:?}"), "real_kitti"),
                |b| b.iter(|| encode_rgb8(black_box(&img), comp)),
            );
        }
        // The fdeflate crate's own compressor on the same Sub-filtered rows, for
        // `encode_Fast/real_kitti` (the same zlib stream, from panoconv's compressor).
        g.bench_function(BenchmarkId::new("fdeflate_crate_sub", "real_kitti"), |b| {
            b.iter(|| fdeflate_sub(black_box(&img)))
        });
        // A frame's image as `panoconv kitti --to equirect` makes it: decoded whole, then
        // warped into the encoder; or decoded row by row as the warp reads the rows.
        let calib = paths::real_kitti().join("training/calib/000001.txt");
        let real_k = panoconv::kitti::calib::Calib::read(&calib)
            .unwrap()
            .camera(panoconv::kitti::Cam::C2)
            .unwrap()
            .k;
        let size = panoconv::camera::ImageSize::new(img.width(), img.height());
        let real_src = Perspective::new(real_k, size);
        let real_out =
            output_camera(&OutputSpec::new(Projection::Equirect), real_k, &real_src).unwrap();
        let table = RemapTable::build(
            real_out.as_ref(),
            &real_src,
            &Matrix3::identity(),
            Wrap::None,
        );
        let c = PngCompression::Default;
        g.bench_function(BenchmarkId::new("decode_warp_encode", "whole"), |b| {
            b.iter(|| warp_encode(&table, &decode_rgb8(black_box(&bytes), &real).unwrap(), c))
        });
        g.bench_function(BenchmarkId::new("decode_warp_encode", "row_by_row"), |b| {
            b.iter_batched(
                || bytes.clone(),
                |bytes| {
                    PngSource::new(bytes, &real)
                        .unwrap()
                        .warp_encode(&table, c)
                        .unwrap()
                },
                criterion::BatchSize::LargeInput,
            )
        });
    }
    for (name, img) in [
        ("kitti_1242x375", &image),
        ("equirect_kitti", &warped),
        ("pano_2048x1024", &pano_img),
    ] {
        let encoded = encode_rgb8(img, PngCompression::Default);
        g.bench_function(BenchmarkId::new("decode", name), |b| {
            b.iter(|| decode_rgb8(black_box(&encoded), Path::new("bench")).unwrap())
        });
        for comp in [PngCompression::Fast, PngCompression::Default] {
            g.bench_function(BenchmarkId::new(format!("encode_{comp:?}"), name), |b| {
                b.iter(|| encode_rgb8(black_box(img), comp))
            });
        }
    }
    g.finish();
}

/// The antialiased table of a drawn view built and applied with a tap per source pixel
/// (`taps`, the command's) and through the source's pyramid (`pyramid`, the Python package's
/// default; applying builds the pyramid), against plain bilinear: KITTI's frame to the 2048
/// equirect (finer than the source but at its sides) and to a 640x480 190° fisheye turned as a
/// drawn camera is (about 5 source pixels a pixel; within the source's footprint), serially,
/// as the Python package builds.
fn pyramid_tables(
    c: &mut Criterion,
    src: &Perspective,
    k: Intrinsics,
    image: &panoconv::image::RgbImage,
) {
    let spec = OutputSpec {
        projection: Projection::Equirect,
        scale: Scale::PanoWidth(2048),
        canvas: Canvas::Tight,
        ..OutputSpec::new(Projection::Equirect)
    };
    let equirect = output_camera(&spec, k, src).unwrap();
    let lens = panoconv::camera::Fisheye::new(
        panoconv::camera::RadialModel::Equidistant,
        Intrinsics::new(150.0, 150.0, 321.3, 238.6),
        ImageSize::new(640, 480),
        190f64.to_radians(),
    )
    .unwrap();
    let turn = panoconv::camera::rotation_ypr(0.05, -0.04, 0.03);
    let id = Matrix3::identity();
    // only the part of the lens the source reaches is mapped, as the Python package does
    let blind = -nalgebra::Vector3::z();
    let seen = panoconv::warp::Footprint::new(&lens, src, &turn, &blind);
    assert!(seen.is_some(), "the lens's footprint");
    // the views benches/random_cameras.py draws per training sample: a turned equirect crop
    // (120°) and cylindrical view (105°) at 640×480, their principal points off centre
    let drawn = |projection: Projection, fov: f64| {
        let f = 640.0 / fov.to_radians();
        projection.camera(
            Intrinsics::new(f, f, 323.5, 236.0),
            ImageSize::new(640, 480),
        )
    };
    let (crop, cylinder) = (
        drawn(Projection::Equirect, 120.0),
        drawn(Projection::Cylindrical, 105.0),
    );
    let crop_seen = panoconv::warp::Footprint::new(crop.as_ref(), src, &turn, &blind);
    let cylinder_seen = panoconv::warp::Footprint::new(cylinder.as_ref(), src, &turn, &blind);
    let cases: [(&str, &dyn CameraModel, &Matrix3<f64>, _); 4] = [
        ("equirect_2048", equirect.as_ref(), &id, None),
        ("fisheye_640", &lens, &turn, seen.as_ref()),
        ("crop_640", crop.as_ref(), &turn, crop_seen.as_ref()),
        (
            "cylindrical_640",
            cylinder.as_ref(),
            &turn,
            cylinder_seen.as_ref(),
        ),
    ];
    let mut g = c.benchmark_group("pyramid_table");
    g.sample_size(10);
    for (name, dst, rot, seen) in cases {
        type Build = fn(
            &dyn CameraModel,
            &dyn CameraModel,
            &Matrix3<f64>,
            Wrap,
            u32,
            Option<&panoconv::warp::Footprint>,
            bool,
        ) -> RemapTable;
        let builds: [(&str, Build, u32); 3] = [
            ("taps", RemapTable::build_within, 8),
            ("pyramid", RemapTable::build_pyramid_within, 8),
            ("bilinear", RemapTable::build_within, 1),
        ];
        for (kind, build, ss) in builds {
            g.bench_function(format!("{name}/{kind}/build"), |b| {
                b.iter(|| build(dst, src, rot, Wrap::None, ss, seen, false))
            });
            let table = build(dst, src, rot, Wrap::None, ss, seen, false);
            let mut buf = table.apply(image);
            g.bench_function(format!("{name}/{kind}/apply"), |b| {
                b.iter(|| table.apply_into(black_box(image), &mut buf))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

/// The image's rows Sub-filtered and compressed by `fdeflate::Compressor`, one call a row as
/// panoconv's encoder makes: the zlib stream of `encode_rgb8(img, PngCompression::Fast)`.
fn fdeflate_sub(img: &panoconv::image::RgbImage) -> Vec<u8> {
    let len = img.width() as usize * 3;
    let mut z = fdeflate::Compressor::new(Vec::with_capacity(len * img.height() as usize))
        .expect("write to a Vec");
    let mut row = vec![1u8; len + 1];
    for raw in img.as_raw().chunks_exact(len) {
        row[1..4].copy_from_slice(&raw[..3]);
        for i in 3..len {
            row[1 + i] = raw[i].wrapping_sub(raw[i - 3]);
        }
        z.write_data(&row).expect("write to a Vec");
    }
    z.finish().expect("write to a Vec")
}
