//! Style pass at KITTI size (1242x375) vs a bare ort session run on the same preprocessed
//! tensor: the overhead of panoconv's conversion, padding, cropping and session handling.
//!
//! Needs the ONNX Runtime library (ORT_DYLIB_PATH or `.ort/`, see `scripts/install_ort.sh`).
//! `cargo bench --bench style`
//!
//! With the real generator `.style/vintagify.onnx` (`scripts/make_vintagify_onnx.sh`) and the
//! real frames (`$PANOCONV_KITTI`, default `../shared/kitti`), it first prints the peak RSS of
//! `panoconv kitti --style vintagify.onnx --jobs 2` on the six training frames.

use std::fs::File;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use ort::session::builder::GraphOptimizationLevel;
use ort::session::Session;
use ort::value::TensorRef;
use panoconv::image::RgbImage;
use panoconv::style::{convert, runtime, Device, StyleModel, StyleOptions};

#[path = "../tests/common/paths.rs"]
#[allow(dead_code)]
mod paths;
use paths::ort_lib;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/style")
}

fn read_png(path: &Path) -> RgbImage {
    let mut reader = png::Decoder::new(File::open(path).unwrap())
        .read_info()
        .unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    RgbImage::from_raw(info.width, info.height, buf).unwrap()
}

struct Setup {
    opts: StyleOptions,
    model: StyleModel,
    bare: Session,
    img: RgbImage,
    tensor: Vec<f32>,
    shape: [i64; 4],
}

fn setup() -> Setup {
    let lib = ort_lib();
    let opts = StyleOptions {
        model: fixtures().join("generator.onnx"),
        ort_lib: Some(lib.clone()),
        device: Device::Cpu,
        intra_threads: 0,
    };
    let model = StyleModel::load(&opts).expect("load style model");
    // Same environment, same options as StyleModel uses.
    let (env, _) = runtime::environment(Some(&lib))
        .map_err(|e| format!("{e:?}"))
        .unwrap();
    let bare = Session::builder(&env)
        .unwrap()
        .with_optimization_level(GraphOptimizationLevel::All)
        .unwrap()
        .commit_from_file(&opts.model)
        .unwrap();
    let img = read_png(&fixtures().join("input_1242x375.png"));
    let (pw, ph) = (
        convert::padded_extent(img.width()),
        convert::padded_extent(img.height()),
    );
    let tensor = convert::image_to_chw(&img, pw, ph);
    Setup {
        opts,
        model,
        bare,
        img,
        tensor,
        shape: [1, 3, ph as i64, pw as i64],
    }
}

fn bare_run(s: &mut Session, tensor: &[f32], shape: [i64; 4]) -> f32 {
    let input = TensorRef::from_array_view((shape, tensor)).unwrap();
    let out = s.run(ort::inputs![input]).unwrap();
    let (_, data) = out[0].try_extract_tensor::<f32>().unwrap();
    data[0]
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

/// Peak RSS of the conversion of the real training frames with the real generator, through the
/// binary (the process's own arena, sessions and threads, as a user runs it).
fn style_run_peak_rss() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let model = root.join(".style/vintagify.onnx");
    let kitti = std::env::var_os("PANOCONV_KITTI")
        .map_or_else(|| root.join("../shared/kitti"), PathBuf::from);
    if !model.is_file() || !kitti.join("training/image_2").is_dir() {
        println!(
            "style run peak RSS: skipped (needs {} and {})",
            model.display(),
            kitti.display()
        );
        return;
    }
    let out = tempfile::tempdir().unwrap();
    let input = out.path().join("in");
    std::fs::create_dir(&input).unwrap();
    // training only (the testing frame has no labels): linked, not copied
    std::os::unix::fs::symlink(kitti.join("training"), input.join("training")).unwrap();
    let t = Instant::now();
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_panoconv"))
        .args([
            "kitti", "--to", "equirect", "--jobs", "2", "--quiet", "--style",
        ])
        .arg(&model)
        .arg("--ort-lib")
        .arg(ort_lib())
        .arg("--input")
        .arg(&input)
        .arg("--output")
        .arg(out.path().join("out"))
        .status()
        .unwrap();
    assert!(status.success(), "panoconv failed: {status}");
    // SAFETY: getrusage fills the struct; RUSAGE_CHILDREN: the largest waited-for child.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut usage) };
    println!(
        "style run (vintagify, 6 real frames 1242x375, --jobs 2, CPU): peak RSS {:.0} MB, {:.1} s (target under 1500 MB)",
        usage.ru_maxrss as f64 / 1024.0,
        t.elapsed().as_secs_f64()
    );
}

fn bench(c: &mut Criterion) {
    style_run_peak_rss();
    let mut s = setup();
    // Warm up both (first runs allocate the arenas).
    for _ in 0..2 {
        black_box(s.model.stylize(&s.img).unwrap());
        black_box(bare_run(&mut s.bare, &s.tensor, s.shape));
    }

    // Interleaved medians for the printed overhead ratio (less sensitive to drift than two
    // separate criterion groups).
    let (mut full, mut bare) = (Vec::new(), Vec::new());
    for _ in 0..15 {
        let t = Instant::now();
        black_box(s.model.stylize(&s.img).unwrap());
        full.push(t.elapsed());
        let t = Instant::now();
        black_box(bare_run(&mut s.bare, &s.tensor, s.shape));
        bare.push(t.elapsed());
    }
    let (f, b) = (median(full), median(bare));
    println!(
        "style 1242x375: stylize {:.2} ms, bare ort run {:.2} ms (median of 15) -> overhead ratio {:.3} ({:+.2} ms)",
        f.as_secs_f64() * 1e3,
        b.as_secs_f64() * 1e3,
        f.as_secs_f64() / b.as_secs_f64(),
        (f.as_secs_f64() - b.as_secs_f64()) * 1e3
    );

    // The pipeline's configuration: one-thread sessions. Four equal-size frames one by one
    // against one batch of four (what `--style-batch 4` does).
    let one = StyleModel::load(&StyleOptions {
        intra_threads: 1,
        ..s.opts.clone()
    })
    .expect("load style model");
    let four = [&s.img, &s.img, &s.img, &s.img];
    black_box(one.stylize_batch(&four).unwrap());
    let (mut singles, mut batched) = (Vec::new(), Vec::new());
    for _ in 0..5 {
        let t = Instant::now();
        for img in four {
            black_box(one.stylize(img).unwrap());
        }
        singles.push(t.elapsed());
        let t = Instant::now();
        black_box(one.stylize_batch(&four).unwrap());
        batched.push(t.elapsed());
    }
    let (a, b) = (median(singles), median(batched));
    println!(
        "style 1242x375, 1 thread: 4 single runs {:.1} ms, one batch of 4 {:.1} ms (median of 5) -> batch speed-up {:.2}",
        a.as_secs_f64() * 1e3,
        b.as_secs_f64() * 1e3,
        a.as_secs_f64() / b.as_secs_f64()
    );

    let mut g = c.benchmark_group("style_1242x375");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    g.bench_function("stylize", |bch| {
        bch.iter(|| s.model.stylize(black_box(&s.img)).unwrap())
    });
    g.bench_function("bare_session_run", |bch| {
        bch.iter(|| bare_run(&mut s.bare, black_box(&s.tensor), s.shape))
    });
    g.bench_function("preprocess_only", |bch| {
        bch.iter(|| convert::image_to_chw(black_box(&s.img), 1244, 376))
    });
    g.bench_function("postprocess_only", |bch| {
        bch.iter(|| convert::chw_to_image(black_box(&s.tensor), 1244, 376, 1242, 375))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
