//! The stitch on a real scan: the four REAL frames of ../shared/pandaset/002 (PandaSet, Hesai
//! and Scale AI, CC BY 4.0; six 1920x1080 cameras around the car, a 360° Pandar64 and a
//! forward PandarGT), read by the Python adapter (`panoconv.sources.pandaset`, what
//! `python -m panoconv pandaset` converts) over the rig-stream protocol. Each frame's figures
//! in both stitch modes ([`StitchFigures`], printed with `--nocapture`): the depth-guided
//! stitch (the default) leaves at most 0.5 % of what the cameras cover black, at most 0.1 % as
//! isolated holes, and its cameras agree at least as well in their overlaps as the fixed
//! stitch's at 10 m. The same frames converted through the binary keep the car's own returns
//! out of the depth maps and mark the fallback's pixels in `source_2` and `mask_2`. Then the
//! nuScenes-format path: the frames rebuilt as nuScenes tables (tests/pandaset_nuscenes.py)
//! and read by the nuScenes reader hold the same bars.

use crate::common::{self, read_png, real_pandaset};
use crate::opencv_ref::test_python;
use panoconv::camera::Projection;
use panoconv::convert::rig::{
    output_camera, read_images, rig_stitch, ObjectRule, RigOptions, StitchMode,
};
use panoconv::geometry::{Canvas, OutputSpec, Scale, Target};
use panoconv::image::RgbImage;
use panoconv::nuscenes::{NuScenesSelection, NuScenesSource};
use panoconv::source::{RigSource, VehicleBox};
use panoconv::stream::{StreamPeer, WorldRigSource};
use panoconv::warp::{StitchFigures, StitchOptions, FALLBACK_SOURCE, FAR_SOURCE, NO_SOURCE};
use std::io::BufReader;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::sync::OnceLock;

const BIN: &str = env!("CARGO_BIN_EXE_panoconv");

/// The bars of the "done when", per frame with default options.
const MAX_BLACK_PERCENT: f64 = 0.5;
const MAX_ISOLATED_PERCENT: f64 = 0.1;

/// The Python with the panoconv package: $PANOCONV_PYTHON, else the repository's .venv-python.
fn adapter_python() -> PathBuf {
    if let Some(p) = std::env::var_os("PANOCONV_PYTHON") {
        return PathBuf::from(p);
    }
    let venv = common::repo().join(".venv-python/bin/python");
    assert!(
        venv.is_file(),
        "no Python with the panoconv package: set PANOCONV_PYTHON or run scripts/install_python_package.sh"
    );
    venv
}

/// The adapter's side of the protocol in a child process: `panoconv.convert_rig`'s own server
/// (`panoconv.rig._serve`) answering on its stdin and stdout, as it answers `rig-stream`.
const SERVE: &str = "import sys, types
from panoconv.rig import _serve
from panoconv.sources.pandaset import PandaSet
_serve(types.SimpleNamespace(stdout=sys.stdin.buffer, stdin=sys.stdout.buffer), PandaSet(sys.argv[1]))
";

type Peer = StreamPeer<BufReader<ChildStdout>, ChildStdin>;

/// The PandaSet adapter with its defaults, as a [`RigSource`] over the protocol, and its
/// process (which ends when the source, holding its stdin, is dropped).
fn adapter() -> (WorldRigSource<Peer>, Child) {
    let mut serve = Command::new(adapter_python());
    serve.args(["-c", SERVE]).arg(real_pandaset());
    served(serve)
}

/// The source that the Python process `serve` answers for on its stdin and stdout.
fn served(mut serve: Command) -> (WorldRigSource<Peer>, Child) {
    let mut child = serve
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("cannot run the adapter's Python");
    let output = BufReader::new(child.stdout.take().unwrap());
    let mut peer = StreamPeer::new(output, child.stdin.take().unwrap());
    let rig = peer.open().expect("the adapter opens the sequence");
    (WorldRigSource::new(rig, peer).unwrap(), child)
}

/// Each frame's figures of `source` with `mode`, 2048 px wide, every camera, default options.
fn figures(source: &dyn RigSource, mode: StitchMode) -> Vec<StitchFigures> {
    let cameras: Vec<usize> = (0..source.cameras(0).len()).collect();
    assert_eq!(cameras.len(), 6);
    let info: Vec<_> = source.cameras(0).iter().map(|c| c.info).collect();
    let target = Target::Linear(OutputSpec {
        projection: Projection::Equirect,
        scale: Scale::PanoWidth(2048),
        canvas: Canvas::Full360,
        crop: None,
        resize: None,
    });
    let options = RigOptions {
        cameras: cameras.clone(),
        stitch: StitchOptions::default(),
        stitch_mode: mode,
        stitch_depth: false,
        listed: None,
        centre: None,
        objects: ObjectRule {
            max_distance: 80.0,
            min_points: 0,
            visibility: panoconv::reproject::visibility::Visibility::default(),
        },
        depth: None,
        ego_masks: Vec::new(),
        style: None,
    };
    let items = source.items(&cameras).unwrap().items;
    items
        .iter()
        .map(|item| {
            let frame = source.read(item).unwrap().frame;
            let camera = output_camera(&frame, &info, &target, &cameras).unwrap();
            let images = read_images(&frame, &options).unwrap();
            let refs: Vec<&RgbImage> = images.iter().collect();
            let built = rig_stitch(&frame, &info, camera.as_ref(), &options).unwrap();
            assert_eq!(built.mode, mode);
            built.stitch.figures(&refs)
        })
        .collect()
}

/// Prints each frame's figures of both modes and checks the bars on them.
fn check_bars(route: &str, depth: &[StitchFigures], fixed: &[StitchFigures]) {
    assert_eq!(depth.len(), fixed.len());
    for (k, (d, f)) in depth.iter().zip(fixed).enumerate() {
        eprintln!(
            "{route}: frame {k}: depth-guided black {:.3} %, isolated {:.3} %, fallback {:.2} %, far fill {:.2} %, seam {:.2} levels over {} px; fixed black {:.3} %, isolated {:.3} %, seam {:.2} levels over {} px",
            d.black_percent(),
            d.isolated_percent(),
            d.fallback_percent(),
            d.far_percent(),
            d.seam_levels,
            d.overlap,
            f.black_percent(),
            f.isolated_percent(),
            f.seam_levels,
            f.overlap
        );
        assert!(d.covered > 500_000, "{route}: frame {k}: {d:?}");
        assert!(
            d.black_percent() <= MAX_BLACK_PERCENT,
            "{route}: frame {k}: {d:?}"
        );
        assert!(
            d.isolated_percent() <= MAX_ISOLATED_PERCENT,
            "{route}: frame {k}: {d:?}"
        );
        assert!(
            d.overlap > 10_000 && d.seam_levels <= f.seam_levels,
            "{route}: frame {k}: depth-guided {d:?} against fixed {f:?}"
        );
    }
}

#[test]
fn the_default_stitch_of_real_frames_is_never_black_where_a_camera_sees_and_agrees_at_its_seams() {
    let (source, mut child) = adapter();
    let depth = figures(&source, StitchMode::Depth);
    let fixed = figures(&source, StitchMode::Fixed);
    drop(source);
    assert!(
        child.wait().unwrap().success(),
        "the adapter's process failed"
    );
    check_bars("adapter", &depth, &fixed);
}

/// `python -m panoconv pandaset` of the real frames at 1024 px with `args`, into a new folder.
fn convert_adapter(args: &[&str]) -> tempfile::TempDir {
    let out = tempfile::tempdir().unwrap();
    let run = Command::new(adapter_python())
        .args(["-m", "panoconv", "pandaset", "--input"])
        .arg(real_pandaset())
        .args(["--to", "equirect", "--pano-width", "1024", "-q"])
        .args(args)
        .arg("--output")
        .arg(out.path())
        .env("PANOCONV_COMMAND", BIN)
        .output()
        .expect("cannot run the adapter's Python");
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    out
}

#[test]
fn the_depth_guided_stitch_is_not_black_where_the_fixed_stitch_has_a_sample() {
    // near the car, between two cameras, the scene's point lies in no camera's image where the
    // 10 m sphere's does: the far fill stitches those pixels at 10 m (source_2 = camera + 64)
    let (depth, fixed) = (
        convert_adapter(&[]),
        convert_adapter(&["--stitch-mode", "fixed"]),
    );
    for frame in ["00", "20", "40", "60"] {
        let name = format!("training/source_2/{frame}.png");
        let d = read_png(&depth.path().join(&name)).data;
        let f = read_png(&fixed.path().join(&name)).data;
        let given = f.iter().filter(|&&s| s != NO_SOURCE).count();
        let lost = (d.iter().zip(&f))
            .filter(|&(&d, &f)| f != NO_SOURCE && d == NO_SOURCE)
            .count();
        let far = (d.iter())
            .filter(|&&s| s != NO_SOURCE && s & FAR_SOURCE != 0)
            .count();
        let lost_percent = 100.0 * lost as f64 / given as f64;
        eprintln!("frame {frame}: {lost} of the fixed stitch's {given} pixels black ({lost_percent:.3} %), {far} far-filled");
        assert!(
            lost_percent <= MAX_BLACK_PERCENT,
            "frame {frame}: {lost} of {given}"
        );
        assert!(far > 1_000, "frame {frame}: {far} far-filled pixels");
    }
}

#[test]
fn real_frames_convert_without_the_vehicles_returns_in_depth_and_with_fallbacks_masked() {
    let out = tempfile::tempdir().unwrap();
    let run = Command::new(adapter_python())
        .args(["-m", "panoconv", "pandaset", "--input"])
        .arg(real_pandaset())
        .args([
            "--to",
            "equirect",
            "--pano-width",
            "1024",
            "--depth",
            "--mask",
        ])
        .args(["-q", "--output"])
        .arg(out.path())
        .env("PANOCONV_COMMAND", BIN)
        .output()
        .expect("cannot run the adapter's Python");
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let verify = common::panoconv(["verify", out.path().to_str().unwrap()]);
    assert_eq!(verify.code, 0, "{}", verify.stderr);
    let training = out.path().join("training");
    let mut ids: Vec<_> = std::fs::read_dir(training.join("depth_2"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    ids.sort();
    assert_eq!(ids.len(), 4);
    for depth_path in &ids {
        let name = depth_path.file_name().unwrap();
        let png = read_png(depth_path);
        let depth: Vec<u16> = png
            .data
            .chunks(2)
            .map(|b| u16::from_be_bytes([b[0], b[1]]))
            .collect();
        // the Pandar64 sits about 2 m above the road: no surface but the car's own body lies
        // within 2 m of the panorama's centre along a ray the cameras see
        let near = depth.iter().filter(|&&d| d > 0 && d < 2 * 256).count();
        let written = depth.iter().filter(|&&d| d > 0).count();
        assert!(written > 5_000, "{name:?}: {written} depth pixels");
        assert_eq!(near, 0, "{name:?}: {near} depth pixels nearer than 2 m");
        let source = read_png(&training.join("source_2").join(name)).data;
        assert!(
            source
                .iter()
                .all(|&s| s == NO_SOURCE || (s & !(FALLBACK_SOURCE | FAR_SOURCE)) < 6),
            "{name:?}: a source value outside 0-5, 64-69, 128-133 and 255"
        );
        let fallback = |s: u8| s != NO_SOURCE && s & (FALLBACK_SOURCE | FAR_SOURCE) != 0;
        let marked = source.iter().filter(|&&s| fallback(s)).count();
        assert!(marked > 100, "{name:?}: {marked} fallback pixels");
        // mask_2: white exactly where a camera passed the occlusion test (1 bit a pixel)
        let mask = read_png(&training.join("mask_2").join(name));
        assert_eq!(mask.depth, png::BitDepth::One, "{name:?}");
        let stride = (mask.width as usize).div_ceil(8);
        for (i, &s) in source.iter().enumerate() {
            let (u, v) = (i % mask.width as usize, i / mask.width as usize);
            let white = mask.data[v * stride + u / 8] >> (7 - u % 8) & 1 == 1;
            assert_eq!(white, s < FAR_SOURCE, "{name:?}: pixel {i}: source {s}");
        }
        eprintln!("{name:?}: {marked} fallback pixels, left out of mask_2");
    }
}

/// The car's own returns in PandaSet's LiDAR frame (x right, y forward, z up, its origin at the
/// road under the sensor; `--vehicle-box`): the Python reader's `VEHICLE_BOX`, the roof and
/// the sensors' mount 1.35-1.6 m up, the front-left and front-right cameras' housings 1.5-1.7 m
/// ahead included. nuScenes' default box sits below a sensor 1.84 m up, so it does not fit
/// this frame.
const PANDASET_VEHICLE_BOX: &str = "-1.0,-1.3,1.0,1.0,2.2,2.0";

/// The PandaSet frames as a nuScenes data root (version v1.0-mini), made once.
fn nuscenes_root() -> &'static Path {
    static ROOT: OnceLock<PathBuf> = OnceLock::new();
    ROOT.get_or_init(|| {
        let dir = tempfile::Builder::new()
            .prefix("pandaset_nuscenes")
            .tempdir()
            .unwrap()
            .keep();
        let script = common::repo().join("tests/pandaset_nuscenes.py");
        let run = Command::new(test_python())
            .arg(&script)
            .arg(real_pandaset())
            .arg(&dir)
            .output()
            .expect("cannot run the test python");
        assert!(
            run.status.success(),
            "pandaset_nuscenes.py failed: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        dir
    })
}

#[test]
fn the_nuscenes_format_path_of_the_real_frames_holds_the_same_bars() {
    let mut selection = NuScenesSelection::new(nuscenes_root().into(), "v1.0-mini".into());
    selection.vehicle_box = VehicleBox::parse(PANDASET_VEHICLE_BOX).unwrap();
    let source = NuScenesSource::open(selection).unwrap();
    let depth = figures(&source, StitchMode::Depth);
    let fixed = figures(&source, StitchMode::Fixed);
    assert_eq!(depth.len(), 4);
    check_bars("nuScenes tables", &depth, &fixed);
}

#[test]
fn the_nuscenes_format_path_writes_no_depth_on_the_cars_own_body() {
    // the nearest surface but the car's own (its roof, the cameras' housings 0.9-1.2 m from
    // the panorama's centre) is a parked car 2.4 m from the sensor
    let out = tempfile::tempdir().unwrap();
    let run = common::panoconv([
        "nuscenes",
        "--input",
        nuscenes_root().to_str().unwrap(),
        "--version",
        "v1.0-mini",
        &format!("--vehicle-box={PANDASET_VEHICLE_BOX}"),
        "--to",
        "equirect",
        "--pano-width",
        "1024",
        "--depth",
        "-q",
        "--output",
        out.path().to_str().unwrap(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let maps = out.path().join("training/depth_2");
    let mut names: Vec<_> = std::fs::read_dir(&maps)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    assert_eq!(names.len(), 4);
    for path in &names {
        let png = read_png(path);
        let depth: Vec<u16> = (png.data.chunks(2))
            .map(|b| u16::from_be_bytes([b[0], b[1]]))
            .collect();
        let near = depth.iter().filter(|&&d| d > 0 && d < 2 * 256).count();
        let written = depth.iter().filter(|&&d| d > 0).count();
        assert!(written > 5_000, "{path:?}: {written} depth pixels");
        assert_eq!(near, 0, "{path:?}: {near} depth pixels nearer than 2 m");
    }
}

/// How far inside an image a pixel's centre must lie to count as held: the written distance's
/// rounding (1/256 m) and the calibration's moves a centre by hundredths of a pixel.
const HELD_INSIDE_PX: f64 = 0.05;

/// Table `name` of the nuScenes root `root` (version v1.0-mini).
fn nuscenes_table(root: &Path, name: &str) -> Vec<serde_json::Value> {
    let path = root.join(format!("v1.0-mini/{name}.json"));
    serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap()
}

/// The rotation of a nuScenes quaternion [w, x, y, z] and its translation.
fn nuscenes_pose(v: &serde_json::Value) -> (nalgebra::Matrix3<f64>, nalgebra::Vector3<f64>) {
    let f = |key: &str, i: usize| v[key][i].as_f64().unwrap();
    let q = nalgebra::Quaternion::new(
        f("rotation", 0),
        f("rotation", 1),
        f("rotation", 2),
        f("rotation", 3),
    );
    let r = nalgebra::UnitQuaternion::from_quaternion(q)
        .to_rotation_matrix()
        .into_inner();
    (
        r,
        nalgebra::Vector3::new(
            f("translation", 0),
            f("translation", 1),
            f("translation", 2),
        ),
    )
}

/// A camera of a nuScenes sample: its ego pose and calibration (rotation, translation), its
/// pinhole (fu, fv, cu, cv) and its image's size.
struct NuCamera {
    ego: (nalgebra::Matrix3<f64>, nalgebra::Vector3<f64>),
    mount: (nalgebra::Matrix3<f64>, nalgebra::Vector3<f64>),
    k: [f64; 4],
    size: (f64, f64),
}

impl NuCamera {
    /// Whether world point `x` lies in the camera's image, [`HELD_INSIDE_PX`] inside.
    fn holds(&self, x: &nalgebra::Vector3<f64>) -> bool {
        let ((ego_r, ego_t), (cam_r, cam_t), k) = (&self.ego, &self.mount, &self.k);
        let q = cam_r.transpose() * (ego_r.transpose() * (x - ego_t) - cam_t);
        let (px, py) = (k[0] * q.x / q.z + k[2], k[1] * q.y / q.z + k[3]);
        let m = HELD_INSIDE_PX - 0.5;
        let (w, h) = self.size;
        q.z > 0.0 && px >= m && px <= w - 1.0 - m && py >= m && py <= h - 1.0 - m
    }
}

/// A nuScenes table by token.
type ByToken = std::collections::HashMap<String, serde_json::Value>;

/// The cameras of sample `token` (`tables`: calibrated_sensor, ego_pose, sensor by token).
fn nuscenes_cameras(
    data: &[serde_json::Value],
    tables: &[ByToken; 3],
    token: &str,
) -> Vec<NuCamera> {
    let [calibrated, poses, sensors] = tables;
    let text = |v: &serde_json::Value, key: &str| v[key].as_str().unwrap().to_string();
    (data.iter())
        .filter(|d| d["sample_token"] == token)
        .filter_map(|d| {
            let c = &calibrated[&text(d, "calibrated_sensor_token")];
            (sensors[&text(c, "sensor_token")]["modality"] == "camera").then(|| {
                let k = |r: usize, col: usize| c["camera_intrinsic"][r][col].as_f64().unwrap();
                NuCamera {
                    ego: nuscenes_pose(&poses[&text(d, "ego_pose_token")]),
                    mount: nuscenes_pose(c),
                    k: [k(0, 0), k(1, 1), k(0, 2), k(1, 2)],
                    size: (d["width"].as_f64().unwrap(), d["height"].as_f64().unwrap()),
                }
            })
        })
        .collect()
}

/// Of frame `id` of the conversion `out` (written with `--stitch-depth`), how many trusted
/// pixels (source_2 below 64) and black ones (255) one of `cameras` holds at the pixel's
/// stitched distance, and how many there are: the point at that distance (stitch_depth_2; the
/// sky's 0 as 10 km) from C2 along the pixel's equirect bearing (K2), through
/// Tr_rect_to_world into the world.
fn seen_in_frame(out: &Path, id: &str, cameras: &[NuCamera]) -> ([usize; 2], [usize; 2]) {
    let calib = std::fs::read_to_string(out.join(format!("training/calib/{id}.txt"))).unwrap();
    let field = |key: &str| -> Vec<f64> {
        let line = (calib.lines())
            .find(|l| l.starts_with(&format!("{key}:")))
            .unwrap();
        (line[key.len() + 1..].split_whitespace())
            .map(|x| x.parse().unwrap())
            .collect()
    };
    let (k2, c2, t) = (field("K2"), field("C2"), field("Tr_rect_to_world"));
    let world_from_rect =
        nalgebra::Matrix3::from_row_slice(&[t[0], t[1], t[2], t[4], t[5], t[6], t[8], t[9], t[10]]);
    let (world_at, c2) = (
        nalgebra::Vector3::new(t[3], t[7], t[11]),
        nalgebra::Vector3::new(c2[0], c2[1], c2[2]),
    );
    let source = read_png(&out.join(format!("training/source_2/{id}.png")));
    let depth = read_png(&out.join(format!("training/stitch_depth_2/{id}.png"))).data;
    let w = source.width as usize;
    let (mut seen, mut all) = ([0usize; 2], [0usize; 2]);
    for (i, &s) in source.data.iter().enumerate() {
        let class = match s {
            NO_SOURCE => 1,
            s if s < FAR_SOURCE => 0,
            _ => continue,
        };
        let (u, v) = ((i % w) as f64, (i / w) as f64);
        let (lon, lat) = ((u - k2[2]) / k2[0], (v - k2[5]) / k2[4]);
        let n = nalgebra::Vector3::new(lat.cos() * lon.sin(), lat.sin(), lat.cos() * lon.cos());
        let t = u16::from_be_bytes([depth[2 * i], depth[2 * i + 1]]) as f64 / 256.0;
        let t = if t > 0.0 { t } else { 1e4 };
        let x = world_from_rect * (c2 + n * t) + world_at;
        all[class] += 1;
        seen[class] += cameras.iter().any(|c| c.holds(&x)) as usize;
    }
    (seen, all)
}

/// Per frame of the conversion `out` of nuScenes root `root`, [`seen_in_frame`] through the
/// sample's cameras' own ego poses and calibrations (the nuScenes tables): independent of the
/// stitch's own geometry.
fn seen_pixels(root: &Path, out: &Path) -> Vec<(String, [usize; 2], [usize; 2])> {
    let by_token = |name: &str| -> ByToken {
        (nuscenes_table(root, name).into_iter())
            .map(|v| (v["token"].as_str().unwrap().to_string(), v))
            .collect()
    };
    let tables = ["calibrated_sensor", "ego_pose", "sensor"].map(by_token);
    let (samples, data) = (by_token("sample"), nuscenes_table(root, "sample_data"));
    let mut result = Vec::new();
    for (place, scene) in nuscenes_table(root, "scene").iter().enumerate() {
        let mut token = scene["first_sample_token"].as_str().unwrap().to_string();
        for k in 0.. {
            let id = format!("{:06}", place * 1000 + k);
            let cameras = nuscenes_cameras(&data, &tables, &token);
            assert_eq!(cameras.len(), 6, "sample {token}");
            let (seen, all) = seen_in_frame(out, &id, &cameras);
            result.push((id, seen, all));
            match samples[&token]["next"].as_str() {
                Some(next) if !next.is_empty() => token = next.to_string(),
                _ => break,
            }
        }
    }
    result
}

#[test]
fn the_depth_guided_stitch_of_real_frames_is_never_black_where_a_camera_sees_the_pixels_centre() {
    // a pixel no table weighs (its footprint partly beyond every image: on the far fill's rim,
    // its taps on the surface the far fill replaced) takes the camera that holds its centre
    let out = tempfile::tempdir().unwrap();
    let run = Command::new(BIN)
        .args(["nuscenes", "--input"])
        .arg(nuscenes_root())
        .args([
            "--version",
            "v1.0-mini",
            "--vehicle-box",
            PANDASET_VEHICLE_BOX,
        ])
        .args([
            "--to",
            "equirect",
            "--pano-width",
            "1024",
            "--stitch-depth",
            "--quiet",
        ])
        .arg("--output")
        .arg(out.path())
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let frames = seen_pixels(nuscenes_root(), out.path());
    assert_eq!(frames.len(), 4);
    for (id, [trusted_seen, black_seen], [trusted, black]) in frames {
        eprintln!("{id}: {black_seen} of {black} black pixels where a camera sees the centre; {trusted_seen} of {trusted} trusted ones seen");
        // the measure's geometry: every pixel a camera passed the occlusion test for is seen
        // (within 0.01 %: the written distance's rounding at an image's edge)
        assert!(
            trusted > 100_000 && trusted - trusted_seen <= trusted / 10_000,
            "{id}"
        );
        assert_eq!(
            black_seen, 0,
            "{id}: {black_seen} black pixels a camera sees"
        );
    }
}
