//! The PNG codec floor of a conversion: for each frame, read and decode its input PNG
//! and encode its already-warped output image, in parallel over frames like `panoconv kitti`,
//! with no warp, no labels and no writes. `panoconv kitti` cannot be faster than this.
//!
//!     codec_floor --pairs FILE [--compression fast|default|best] [--jobs N] [--io DIR]
//!                 (--io DIR: also the I/O every converted frame must do, which the floor
//!                 alone leaves out: the BLAKE3 hashes the manifest records of the input and
//!                 the output PNG, and the output's atomic write under DIR)
//!     codec_floor --sweep FILE...   (single thread: decode and encoder settings per image)
//!     codec_floor --remap IMAGE CALIB   (the equirect table of CALIB's P2: build, serial and
//!                                        parallel, and apply on one thread, minimum of N runs)
//!     codec_floor --fisheye-table CAMERA IMAGE CALIB   (the `kitti --to fisheye` table of
//!                 CALIB's P2: mapping every pixel and only the footprint, serial and parallel)
//!
//! FILE lists one frame a line: `INPUT.png WARPED.png` (the warped images are decoded once,
//! before the clock starts).

use panoconv::codec::png::{decode_rgb8, encode_rgb8, PngCompression};
use panoconv::image::RgbImage;
use panoconv::kitti::Cam;
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn die(msg: &str) -> ! {
    eprintln!("codec_floor: {msg}");
    std::process::exit(2)
}

fn load(path: &Path) -> RgbImage {
    let bytes = std::fs::read(path).unwrap_or_else(|e| die(&format!("{}: {e}", path.display())));
    decode_rgb8(&bytes, path).unwrap_or_else(|e| die(&e.to_string()))
}

fn floor(pairs_file: &Path, compression: PngCompression, jobs: usize, io: Option<&Path>) {
    let text = std::fs::read_to_string(pairs_file).unwrap_or_else(|e| die(&e.to_string()));
    let pairs: Vec<(PathBuf, PathBuf)> = text
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let mut it = l.split_whitespace();
            match (it.next(), it.next()) {
                (Some(a), Some(b)) => (PathBuf::from(a), PathBuf::from(b)),
                _ => die(&format!("bad line {l:?}")),
            }
        })
        .collect();
    let mut warped: HashMap<PathBuf, RgbImage> = HashMap::new();
    for (_, w) in &pairs {
        if !warped.contains_key(w) {
            warped.insert(w.clone(), load(w));
        }
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .expect("thread pool");
    let started = Instant::now();
    let bytes: usize = pool.install(|| {
        pairs
            .par_iter()
            .enumerate()
            .map(|(n, (input, w))| {
                let data = std::fs::read(input)
                    .unwrap_or_else(|e| die(&format!("{}: {e}", input.display())));
                let img = decode_rgb8(&data, input).unwrap_or_else(|e| die(&e.to_string()));
                std::hint::black_box(&img);
                let png = encode_rgb8(&warped[w], compression);
                if let Some(dir) = io {
                    frame_io(input, &data, &png, dir, n);
                }
                png.len()
            })
            .sum()
    });
    let s = started.elapsed().as_secs_f64();
    println!(
        "{{\"frames\": {}, \"seconds\": {s:.4}, \"fps\": {:.2}, \"bytes\": {bytes}, \"jobs\": {jobs}}}",
        pairs.len(),
        pairs.len() as f64 / s
    );
}

/// The I/O of a converted frame beyond its codec work: the manifest's hashes of the input and
/// output PNG, and of the calib and label (KITTI layout beside `image_2/`) read, hashed and
/// written back as they are; every output written atomically under `dir`.
fn frame_io(input: &Path, data: &[u8], png: &[u8], dir: &Path, n: usize) {
    let write = |name: String, bytes: &[u8]| {
        std::hint::black_box(panoconv::fs::hash_hex(bytes));
        panoconv::fs::write_atomic(&dir.join(name), bytes).unwrap_or_else(|e| die(&e.to_string()));
    };
    std::hint::black_box(panoconv::fs::hash_hex(data));
    write(format!("{n}.png"), png);
    let (Some(split), Some(id)) = (input.parent().and_then(Path::parent), input.file_stem()) else {
        return;
    };
    for folder in ["calib", "label_2"] {
        let text = split.join(folder).join(id).with_extension("txt");
        if let Ok(bytes) = std::fs::read(&text) {
            std::hint::black_box(panoconv::fs::hash_hex(&bytes));
            write(format!("{n}.{folder}.txt"), &bytes);
        }
    }
}

/// Median milliseconds of `f` over `n` runs.
fn time_ms<T>(n: usize, mut f: impl FnMut() -> T) -> f64 {
    let mut t: Vec<f64> = (0..n)
        .map(|_| {
            let s = Instant::now();
            std::hint::black_box(f());
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[n / 2]
}

fn sweep(files: &[PathBuf]) {
    let imgs: Vec<(Vec<u8>, RgbImage)> = files
        .iter()
        .map(|p| {
            let b = std::fs::read(p).unwrap_or_else(|e| die(&e.to_string()));
            let i = decode_rgb8(&b, p).unwrap_or_else(|e| die(&e.to_string()));
            (b, i)
        })
        .collect();
    let n = 7;
    let decode: f64 = imgs
        .iter()
        .map(|(b, _)| time_ms(n, || decode_rgb8(b, Path::new("x")).unwrap()))
        .sum();
    println!(
        "decode_rgb8            {:7.2} ms/img",
        decode / imgs.len() as f64
    );
    for c in [
        PngCompression::Fast,
        PngCompression::Default,
        PngCompression::Best,
    ] {
        report(&format!("preset {c:?}"), &imgs, |i| encode_rgb8(i, c));
    }
    use png::{AdaptiveFilterType as A, Compression as C, FilterType as F};
    #[allow(clippy::type_complexity)]
    let settings: [(&str, C, F, A); 10] = [
        ("fdeflate none", C::Fast, F::NoFilter, A::NonAdaptive),
        ("fdeflate sub", C::Fast, F::Sub, A::NonAdaptive),
        ("fdeflate up", C::Fast, F::Up, A::NonAdaptive),
        ("fdeflate avg", C::Fast, F::Avg, A::NonAdaptive),
        ("fdeflate paeth", C::Fast, F::Paeth, A::NonAdaptive),
        ("fdeflate adaptive", C::Fast, F::Paeth, A::Adaptive),
        ("zlib6 sub", C::Default, F::Sub, A::NonAdaptive),
        ("zlib6 paeth", C::Default, F::Paeth, A::NonAdaptive),
        ("zlib6 adaptive", C::Default, F::Paeth, A::Adaptive),
        ("zlib9 adaptive", C::Best, F::Paeth, A::Adaptive),
    ];
    for (name, c, f, a) in settings {
        report(name, &imgs, |i| {
            let mut out = Vec::new();
            let mut enc = png::Encoder::new(&mut out, i.width(), i.height());
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            enc.set_compression(c);
            enc.set_filter(f);
            enc.set_adaptive_filter(a);
            let mut w = enc.write_header().expect("header");
            w.write_image_data(i.as_raw()).expect("data");
            drop(w);
            out
        });
    }
}

/// Prints the median encode time and the mean size of `encode` over `imgs`.
fn report(name: &str, imgs: &[(Vec<u8>, RgbImage)], encode: impl Fn(&RgbImage) -> Vec<u8>) {
    let bytes: usize = imgs.iter().map(|(_, i)| encode(i).len()).sum();
    let single = time_ms(1, || encode(&imgs[0].1));
    let n = if single > 30.0 { 1 } else { 7 };
    let ms: f64 = imgs.iter().map(|(_, i)| time_ms(n, || encode(i))).sum();
    println!(
        "encode {name:<18} {:7.2} ms/img {:>9} bytes/img",
        ms / imgs.len() as f64,
        bytes / imgs.len()
    );
}

/// Minimum milliseconds of `f` over `n` runs (the figure least disturbed by other load).
fn min_ms<T>(n: usize, mut f: impl FnMut() -> T) -> f64 {
    (0..n)
        .map(|_| {
            let s = Instant::now();
            std::hint::black_box(f());
            s.elapsed().as_secs_f64() * 1e3
        })
        .fold(f64::INFINITY, f64::min)
}

/// The table of a fisheye target (`kitti --to fisheye --camera CAMERA`) from the source camera
/// of CALIB and IMAGE's size: the full mapping (every pixel's lens inversion) against the
/// mapping within the source's footprint, serial and on the pool; the tables are checked equal.
fn fisheye_table(camera: &Path, image: &Path, calib: &Path) {
    use nalgebra::{Matrix3, Vector3};
    use panoconv::camera::description::CameraDescription;
    use panoconv::camera::{CameraModel, FisheyeCamera, ImageSize, Perspective};
    use panoconv::warp::{Footprint, RemapTable, Wrap, MAX_SUPERSAMPLE};
    let desc = CameraDescription::read(camera).unwrap_or_else(|e| die(&e.to_string()));
    let out = FisheyeCamera {
        lens: desc.camera,
        rect_from_camera: desc.output_from_camera,
    };
    let img = load(image);
    let calib = panoconv::kitti::calib::Calib::read(calib).unwrap_or_else(|e| die(&e.to_string()));
    let k = calib
        .camera(Cam::C2)
        .unwrap_or_else(|e| die(&e.to_string()))
        .k;
    let src = Perspective::new(k, ImageSize::new(img.width(), img.height()));
    let id = Matrix3::identity();
    let blind = out.rect_from_camera * -Vector3::z();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("thread pool");
    let build = |seen: Option<&Footprint>, parallel| {
        RemapTable::build_within(&out, &src, &id, Wrap::None, MAX_SUPERSAMPLE, seen, parallel)
    };
    let footprint_ms = min_ms(5, || Footprint::new(&out, &src, &id, &blind));
    let seen = Footprint::new(&out, &src, &id, &blind);
    // (wall ms, CPU ms of the process) of the fastest of `n` runs: on a shared machine the CPU
    // time is the steadier figure, the wall time of the parallel build the one a user waits
    let timed = |n: usize, parallel: bool, within: bool| {
        (0..n)
            .map(|_| {
                let (wall, cpu) = (Instant::now(), cpu_ms());
                // the footprint's own cost counted in, as a run pays it
                let seen = within
                    .then(|| Footprint::new(&out, &src, &id, &blind))
                    .flatten();
                std::hint::black_box(build(seen.as_ref(), parallel));
                (wall.elapsed().as_secs_f64() * 1e3, cpu_ms() - cpu)
            })
            .fold((f64::INFINITY, f64::INFINITY), |a, b| {
                (a.0.min(b.0), a.1.min(b.1))
            })
    };
    let full_serial = one.install(|| timed(1, false, false));
    let full_parallel = timed(1, true, false);
    let within_serial = one.install(|| timed(5, false, true));
    let within_parallel = timed(5, true, true);
    assert!(
        build(seen.as_ref(), true) == build(None, false),
        "the tables differ"
    );
    let s = out.size();
    println!(
        "{}x{} {} table, every pixel: serial {:.1} ms CPU, parallel {:.1} ms wall / {:.1} ms CPU",
        s.width,
        s.height,
        out.lens.name(),
        full_serial.1,
        full_parallel.0,
        full_parallel.1
    );
    println!(
        "within the footprint ({:.1} % of the pixels, found in {footprint_ms:.2} ms): serial \
         {:.1} ms CPU, parallel {:.1} ms wall / {:.1} ms CPU ({} threads); same table",
        100.0 * seen.as_ref().map_or(1.0, |f| f.share(s.width)),
        within_serial.1,
        within_parallel.0,
        within_parallel.1,
        rayon::current_num_threads()
    );
}

/// CPU time of the whole process so far (every thread), in ms.
fn cpu_ms() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid timespec for the call to fill.
    unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut t) };
    t.tv_sec as f64 * 1e3 + t.tv_nsec as f64 * 1e-6
}

/// The remap stages of one frame as `panoconv kitti --to equirect` runs them.
fn remap(image: &Path, calib: &Path) {
    use nalgebra::Matrix3;
    use panoconv::camera::{ImageSize, Perspective, Projection};
    use panoconv::geometry::{output_camera, OutputSpec};
    use panoconv::warp::{RemapTable, Wrap};
    let img = load(image);
    let calib = panoconv::kitti::calib::Calib::read(calib).unwrap_or_else(|e| die(&e.to_string()));
    let k = calib
        .camera(Cam::C2)
        .unwrap_or_else(|e| die(&e.to_string()))
        .k;
    let src = Perspective::new(k, ImageSize::new(img.width(), img.height()));
    let out = output_camera(&OutputSpec::new(Projection::Equirect), k, &src)
        .unwrap_or_else(|e| die(&e.to_string()));
    let id = Matrix3::identity();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("thread pool");
    let serial =
        one.install(|| min_ms(5, || RemapTable::build(out.as_ref(), &src, &id, Wrap::None)));
    let parallel = min_ms(5, || {
        RemapTable::build_parallel(out.as_ref(), &src, &id, Wrap::None, 8)
    });
    println!(
        "table build      {serial:7.2} ms serial, {parallel:7.2} ms parallel ({} threads)",
        rayon::current_num_threads()
    );
    for (name, max_supersample) in [("antialiased", 8), ("bilinear", 1)] {
        let table = RemapTable::build_with(out.as_ref(), &src, &id, Wrap::None, max_supersample);
        let s = table.size();
        let fresh = one.install(|| min_ms(40, || table.apply(&img)));
        let mut buf = table.apply(&img);
        let reused = one.install(|| min_ms(40, || table.apply_into(&img, &mut buf)));
        println!(
            "apply {name:<11} {fresh:7.3} ms, apply_into {reused:7.3} ms ({}x{}, 1 thread)",
            s.width, s.height
        );
    }
    let bytes = std::fs::read(image).unwrap_or_else(|e| die(&e.to_string()));
    let decode = min_ms(40, || decode_rgb8(&bytes, image).unwrap());
    let crate_decode = min_ms(40, || {
        panoconv::codec::png::decode_rgb8_with_png_crate(&bytes, image).unwrap()
    });
    println!("decode_rgb8      {decode:7.3} ms (the png crate's decoder: {crate_decode:.3} ms)");
    // A frame's image as `panoconv kitti` makes it: decoded whole then warped into the
    // encoder, or decoded row by row as the warp reads the rows (`PngSource`).
    let table = RemapTable::build(out.as_ref(), &src, &id, Wrap::None);
    let c = PngCompression::Default;
    let whole = || {
        let img = decode_rgb8(&bytes, image).unwrap();
        panoconv::warp::warp_encode(&table, &img, c)
    };
    let streamed = || {
        let mut source = panoconv::warp::PngSource::new(bytes.clone(), image).unwrap();
        source.warp_encode(&table, c).unwrap()
    };
    assert!(
        whole() == streamed(),
        "the streamed warp must give the same bytes"
    );
    let copy = min_ms(40, || bytes.clone());
    let (mut w, mut st) = (f64::MAX, f64::MAX);
    for _ in 0..8 {
        w = w.min(min_ms(5, whole));
        st = st.min(min_ms(5, streamed) - copy);
    }
    println!("decode+warp+encode {w:7.3} ms whole, {st:7.3} ms row by row (1 thread)");
}

fn main() {
    // The same allocator settings as `panoconv` (src/main.rs), so the floor is not slowed by
    // page faults that the conversion avoids.
    panoconv::run::alloc::keep_freed_memory();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut pairs = None;
    let mut compression = PngCompression::Default;
    let mut jobs = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut io = None;
    let mut i = 0;
    while i < args.len() {
        let val = || {
            args.get(i + 1)
                .cloned()
                .unwrap_or_else(|| die("missing value"))
        };
        match args[i].as_str() {
            "--sweep" => {
                let files: Vec<PathBuf> = args[i + 1..].iter().map(PathBuf::from).collect();
                return sweep(&files);
            }
            "--fisheye-table" => match (args.get(i + 1), args.get(i + 2), args.get(i + 3)) {
                (Some(camera), Some(image), Some(calib)) => {
                    return fisheye_table(Path::new(camera), Path::new(image), Path::new(calib))
                }
                _ => die("--fisheye-table CAMERA IMAGE CALIB"),
            },
            "--remap" => match (args.get(i + 1), args.get(i + 2)) {
                (Some(image), Some(calib)) => return remap(Path::new(image), Path::new(calib)),
                _ => die("--remap IMAGE CALIB"),
            },
            "--pairs" => pairs = Some(PathBuf::from(val())),
            "--io" => io = Some(PathBuf::from(val())),
            "--jobs" => jobs = val().parse().unwrap_or_else(|_| die("bad --jobs")),
            "--compression" => {
                compression = match val().as_str() {
                    "fast" => PngCompression::Fast,
                    "default" => PngCompression::Default,
                    "best" => PngCompression::Best,
                    v => die(&format!("bad --compression {v}")),
                }
            }
            a => die(&format!("unknown argument {a}")),
        }
        i += 2;
    }
    floor(
        &pairs.unwrap_or_else(|| die("--pairs FILE is required")),
        compression,
        jobs,
        io.as_deref(),
    );
}
