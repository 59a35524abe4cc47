//! A rig served in its world frame (`stream::WorldSource`): a toy format read by a Rust adapter
//! in-process, the same files served to `panoconv rig-stream` over its pipes by a peer written
//! here, and by the Python adapter tests/toy_world_rig.py through `panoconv.convert_rig`, all
//! give the same bytes; bad answers fail their frame (exit 1) naming the frame and the field,
//! a bad rig fails the set-up (exit 2) with nothing written.

use crate::common::{self, tree_bytes, BIN};
use nalgebra::{Matrix4, Vector3};
use panoconv::camera::{ImageSize, Intrinsics, Perspective, Projection};
use panoconv::codec::png::PngCompression;
use panoconv::convert::rig::{run_rig, ObjectRule, RigJob, RigSpec, StitchMode};
use panoconv::convert::run_options::{DepthJob, RunOptions};
use panoconv::error::Result;
use panoconv::geometry::{Canvas, OutputSpec, Scale, Target};
use panoconv::reproject::depth::OcclusionFilter;
use panoconv::reproject::visibility::Visibility;
use panoconv::run::{OutputMode, Silent};
use panoconv::source::{CameraInfo, LidarPoint, Pose, SourceCamera};
use panoconv::stream::{
    box_from_yaw, WorldBox, WorldCamera, WorldFrame, WorldRig, WorldRigSource, WorldSource,
};
use panoconv::warp::StitchOptions;
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

const NAMES: [&str; 2] = ["front", "back"];
const SIZE: (u32, u32) = (200, 150);
const FRAMES: [&str; 2] = ["000000", "000001"];
/// The options of both routes: the in-process job below is what the command makes of them.
const ARGS: [&str; 6] = [
    "--to",
    "equirect",
    "--pano-width",
    "512",
    "--depth",
    "--quiet",
];

/// world_from_camera rows: front 0.2 m ahead of the origin looking +x, back 0.2 m behind
/// looking −x, both 1.6 m above the ground (camera x right, y down, z forward).
fn pose_rows(k: usize, frame: usize) -> [f64; 16] {
    let x = 3.0 * frame as f64;
    if k == 0 {
        [
            0.,
            0.,
            1.,
            x + 0.2,
            -1.,
            0.,
            0.,
            0.,
            0.,
            -1.,
            0.,
            1.6,
            0.,
            0.,
            0.,
            1.,
        ]
    } else {
        [
            0.,
            0.,
            -1.,
            x - 0.2,
            1.,
            0.,
            0.,
            0.,
            0.,
            -1.,
            0.,
            1.6,
            0.,
            0.,
            0.,
            1.,
        ]
    }
}

/// `TYPE LABEL cx cy cz length width height yaw points`, world frame.
const BOXES: &str = "Car car 9.0 -0.5 0.75 4.2 1.8 1.5 0.3 40\n\
                     Pedestrian adult -7.0 1.0 0.9 0.8 0.6 1.8 1.2 12\n\
                     Car parked 20.0 6.0 0.75 4.0 1.7 1.5 -0.4 0\n";

fn write_toy(root: &Path) {
    let (w, h) = SIZE;
    let rig = json!({"cameras": NAMES.iter().map(|n| json!({
        "name": n, "fx": 100.0, "fy": 100.0, "cx": 99.5, "cy": 74.5, "width": w, "height": h,
    })).collect::<Vec<_>>()});
    std::fs::create_dir_all(root).unwrap();
    common::write_text(&root.join("rig.json"), &rig.to_string());
    common::write_text(&root.join("frames.txt"), &FRAMES.join("\n"));
    for (f, id) in FRAMES.iter().enumerate() {
        let dir = root.join(id);
        std::fs::create_dir_all(&dir).unwrap();
        let poses: Vec<String> = (0..2)
            .map(|k| pose_rows(k, f).map(|v| v.to_string()).join(" "))
            .collect();
        common::write_text(&dir.join("poses.txt"), &(poses.join("\n") + "\n"));
        let shifted: String = BOXES
            .lines()
            .map(|l| {
                let mut t: Vec<String> = l.split_whitespace().map(str::to_owned).collect();
                t[2] = (t[2].parse::<f64>().unwrap() + 3.0 * f as f64).to_string();
                t.join(" ") + "\n"
            })
            .collect();
        common::write_text(&dir.join("boxes.txt"), &shifted);
        let mut scan = Vec::new();
        for i in -60..=60 {
            for j in -60..=60 {
                let (x, y) = (i as f64 * 0.5, j as f64 * 0.5);
                if x.hypot(y) > 2.0 {
                    for v in [x + 3.0 * f as f64, y, 0.0, 0.25] {
                        scan.extend_from_slice(&f64::to_le_bytes(v));
                    }
                }
            }
        }
        std::fs::write(dir.join("lidar.bin"), scan).unwrap();
        for (k, name) in NAMES.iter().enumerate() {
            // a gradient per camera, so that the stitch's blend and gains have work to do
            let data = (0..w * h)
                .flat_map(|p| {
                    let (u, v) = ((p % w) as u8, (p / w) as u8);
                    [u, v, if k == 0 { 200 } else { 40 }]
                })
                .collect();
            let png = common::Png {
                width: w,
                height: h,
                color: png::ColorType::Rgb,
                depth: png::BitDepth::Eight,
                data,
            };
            common::write_png(&dir.join(format!("{name}.png")), &png);
        }
    }
}

fn numbers(text: &str) -> Vec<f64> {
    text.split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect()
}

/// The toy format read in Rust.
struct ToyWorld {
    root: PathBuf,
}

impl ToyWorld {
    fn rig(&self) -> WorldRig {
        let pinhole = Perspective::new(Intrinsics::new(100.0, 100.0, 99.5, 74.5), size());
        WorldRig {
            name: "toyworld".into(),
            root: self.root.clone(),
            frames: FRAMES.map(str::to_owned).to_vec(),
            not_frames: Vec::new(),
            cameras: NAMES
                .iter()
                .map(|n| SourceCamera {
                    name: n.to_string(),
                    info: CameraInfo {
                        focal: pinhole.k,
                        max_theta: None,
                    },
                    size: size(),
                })
                .collect(),
            lidar_azimuth_step_deg: None,
        }
    }

    fn inputs(&self, id: &str) -> Vec<PathBuf> {
        ["boxes.txt", "poses.txt", "lidar.bin"]
            .map(|f| self.root.join(id).join(f))
            .to_vec()
    }
}

fn size() -> ImageSize {
    ImageSize::new(SIZE.0, SIZE.1)
}

impl WorldSource for ToyWorld {
    fn read(&mut self, id: &str) -> Result<WorldFrame> {
        let dir = self.root.join(id);
        let poses = numbers(&common::read_text(&dir.join("poses.txt")));
        let cameras = (0..2)
            .map(|k| WorldCamera {
                name: NAMES[k].into(),
                model: Arc::new(Perspective::new(
                    Intrinsics::new(100.0, 100.0, 99.5, 74.5),
                    size(),
                )),
                world_from_camera: Pose::from_matrix4(&Matrix4::from_row_slice(
                    &poses[16 * k..16 * k + 16],
                )),
                image: dir.join(format!("{}.png", NAMES[k])),
                time: None,
            })
            .collect();
        let boxes = common::read_text(&dir.join("boxes.txt"))
            .lines()
            .map(|l| {
                let t: Vec<&str> = l.split_whitespace().collect();
                let v = numbers(&t[2..9].join(" "));
                WorldBox {
                    class: t[0].into(),
                    label: t[1].into(),
                    centre: Vector3::new(v[0], v[1], v[2]),
                    size: Vector3::new(v[3], v[4], v[5]),
                    world_from_box: box_from_yaw(v[6]),
                    points: Some(t[9].parse().unwrap()),
                    instance: None,
                    velocity: None,
                    time: None,
                }
            })
            .collect();
        let bytes = std::fs::read(dir.join("lidar.bin")).unwrap();
        let lidar = bytes
            .chunks_exact(32)
            .map(|p| {
                let v: Vec<f64> = p
                    .chunks_exact(8)
                    .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
                    .collect();
                LidarPoint {
                    position: Vector3::new(v[0], v[1], v[2]),
                    intensity: v[3] as f32,
                }
            })
            .collect();
        let mut record = serde_json::Map::new();
        record.insert("toy_frame".into(), json!(id));
        Ok(WorldFrame {
            cameras,
            boxes,
            lidar,
            world_from_lidar: None,
            record,
            inputs: self.inputs(id),
        })
    }
}

/// What `rig-stream` makes of [`ARGS`].
fn job(output: &Path) -> RigJob {
    RigJob::new(RigSpec {
        run: RunOptions {
            output: output.to_owned(),
            mode: OutputMode::New,
            shard: None,
            png_compression: PngCompression::Default,
            style: None,
            augment: None,
            depth: Some(DepthJob {
                occlusion_filter: Some(OcclusionFilter {
                    azimuth_spacing: 0.2f64.to_radians(),
                    ..OcclusionFilter::default()
                }),
            }),
            export: false,
        },
        target: Target::Linear(OutputSpec {
            projection: Projection::Equirect,
            scale: Scale::PanoWidth(512),
            canvas: Canvas::Full360,
            crop: None,
            resize: None,
        }),
        cameras: vec![0, 1],
        stitch: StitchOptions {
            distance: 10.0,
            blend_width: 5f64.to_radians(),
            even_exposure: true,
        },
        stitch_mode: StitchMode::Depth,
        stitch_depth: false,
        mask: false,
        centre: None,
        objects: ObjectRule {
            max_distance: 80.0,
            min_points: 0,
            visibility: Visibility::OFF,
        },
        ego_masks: Vec::new(),
    })
    .unwrap()
}

fn rust_route(root: &Path, out: &Path) {
    let world = ToyWorld {
        root: root.to_owned(),
    };
    let source = WorldRigSource::new(world.rig(), world).unwrap();
    let summary = run_rig(&job(out), &source, &Silent, &AtomicBool::new(false)).unwrap();
    assert_eq!((summary.run.converted, summary.run.failed), (2, 0));
}

/// The wire answer of a toy frame, as a peer in any language would send it.
fn wire_frame(root: &Path, id: &str) -> (Value, Vec<u8>) {
    let dir = root.join(id);
    let poses = numbers(&common::read_text(&dir.join("poses.txt")));
    let cameras: Vec<Value> = (0..2)
        .map(|k| {
            let rows: Vec<&[f64]> = poses[16 * k..16 * k + 16].chunks(4).collect();
            json!({
                "name": NAMES[k],
                "image": dir.join(format!("{}.png", NAMES[k])),
                "camera": pinhole_wire(),
                "world_from_camera": rows,
            })
        })
        .collect();
    let boxes: Vec<Value> = common::read_text(&dir.join("boxes.txt"))
        .lines()
        .map(|l| {
            let t: Vec<&str> = l.split_whitespace().collect();
            let v = numbers(&t[2..9].join(" "));
            json!({"type": t[0], "label": t[1], "centre": &v[0..3], "size": &v[3..6],
                   "yaw": v[6], "points": t[9].parse::<u64>().unwrap()})
        })
        .collect();
    let payload = std::fs::read(dir.join("lidar.bin")).unwrap();
    let inputs = ["boxes.txt", "poses.txt", "lidar.bin"].map(|f| dir.join(f));
    let header = json!({
        "cameras": cameras,
        "boxes": boxes,
        "lidar": {"shape": [payload.len() / 32, 4]},
        "record": {"toy_frame": id},
        "inputs": inputs,
    });
    (header, payload)
}

fn pinhole_wire() -> Value {
    json!({"model": "pinhole", "width": SIZE.0, "height": SIZE.1,
           "fx": 100.0, "fy": 100.0, "cx": 99.5, "cy": 74.5})
}

fn wire_open(root: &Path) -> Value {
    json!({
        "name": "toyworld",
        "root": root,
        "frames": FRAMES,
        "cameras": NAMES.map(|n| json!({"name": n, "camera": pinhole_wire()})),
    })
}

/// Runs `panoconv rig-stream --output OUT ARGS` served by `answer` (a request → its header and
/// payload; a null header: the peer vanishes, closing its streams, instead of answering);
/// returns the exit code and stderr.
fn serve(out: &Path, args: &[&str], answer: impl Fn(&Value) -> (Value, Vec<u8>)) -> (i32, String) {
    let mut child = Command::new(BIN)
        .arg("rig-stream")
        .arg("--output")
        .arg(out)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut to_child = child.stdin.take().unwrap();
    let from_child = BufReader::new(child.stdout.take().unwrap());
    for line in from_child.lines() {
        let request: Value = serde_json::from_str(&line.unwrap()).unwrap();
        assert_eq!(request["protocol"], 1);
        let (mut header, payload) = answer(&request);
        if header.is_null() {
            break;
        }
        header["bytes"] = json!(payload.len());
        let mut message = header.to_string().into_bytes();
        message.push(b'\n');
        message.extend_from_slice(&payload);
        if to_child.write_all(&message).is_err() {
            break;
        }
    }
    drop(to_child);
    let output = child.wait_with_output().unwrap();
    (
        output.status.code().unwrap(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

/// The answers of the toy rig, `edit` changing frame 000001's.
fn toy_answer<'a>(
    root: &'a Path,
    edit: impl Fn(&mut Value, &mut Vec<u8>) + 'a,
) -> impl Fn(&Value) -> (Value, Vec<u8>) + 'a {
    move |request| match request["op"].as_str() {
        Some("open") => (wire_open(root), Vec::new()),
        _ => {
            let id = request["frame"].as_str().unwrap();
            let (mut header, mut payload) = wire_frame(root, id);
            if id == "000001" {
                edit(&mut header, &mut payload);
            }
            (header, payload)
        }
    }
}

/// The Python with the built package: $PANOCONV_PYTHON, else the repository's .venv-python.
fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("PANOCONV_PYTHON") {
        return PathBuf::from(p);
    }
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv-python/bin/python");
    assert!(
        venv.is_file(),
        "no Python with the panoconv package: set PANOCONV_PYTHON or run scripts/install_python_package.sh"
    );
    venv
}

#[test]
fn a_world_rig_in_rust_through_the_pipe_and_from_python_gives_the_same_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("toy");
    write_toy(&root);
    let rust = tmp.path().join("rust");
    rust_route(&root, &rust);
    let piped = tmp.path().join("piped");
    let (code, stderr) = serve(&piped, &ARGS, toy_answer(&root, |_, _| {}));
    assert_eq!(code, 0, "{stderr}");
    let want = tree_bytes(&rust);
    assert!(
        want.keys().any(|f| f.ends_with("depth_2/000001.png")),
        "{want:?}"
    );
    assert!(
        want == tree_bytes(&piped),
        "the piped rig differs from the Rust one"
    );
    // one frame's labels: the three boxes, the unseen one (0 points) left out
    let labels = common::read_text(&rust.join("training/label_2/000000.txt"));
    let kinds: Vec<&str> = labels
        .lines()
        .map(|l| l.split(' ').next().unwrap())
        .collect();
    assert_eq!(kinds, ["Car", "Pedestrian"], "{labels}");

    let python_out = tmp.path().join("python");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/toy_world_rig.py");
    let run = Command::new(python())
        .arg(script)
        .arg(&root)
        .arg(&python_out)
        .args(ARGS)
        .env("PANOCONV_COMMAND", BIN)
        .output()
        .unwrap();
    assert_eq!(
        run.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        want == tree_bytes(&python_out),
        "the Python adapter's rig differs from the Rust one"
    );
    // the same bytes with 1 worker as with the default pool
    let one = tmp.path().join("one");
    let mut args = ARGS.to_vec();
    args.extend(["--jobs", "1"]);
    let (code, stderr) = serve(&one, &args, toy_answer(&root, |_, _| {}));
    assert_eq!(code, 0, "{stderr}");
    assert!(want == tree_bytes(&one), "--jobs 1 differs");
}

#[test]
fn a_bad_answer_fails_its_frame_naming_the_frame_and_the_field() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("toy");
    write_toy(&root);
    type Edit = Box<dyn Fn(&mut Value, &mut Vec<u8>)>;
    let cases: Vec<(&str, Edit)> = vec![
        (
            "boxes[0].centre[1]",
            Box::new(|h, _| h["boxes"][0]["centre"][1] = json!("nan")),
        ),
        (
            "boxes[1].rotation: not a rotation",
            Box::new(|h, _| {
                h["boxes"][1].as_object_mut().unwrap().remove("yaw");
                h["boxes"][1]["rotation"] =
                    json!([[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
            }),
        ),
        (
            "cameras[1].world_from_camera: an array of shape (3, 4)",
            Box::new(|h, _| {
                h["cameras"][1]["world_from_camera"]
                    .as_array_mut()
                    .unwrap()
                    .pop();
            }),
        ),
        (
            "lidar: an array of shape [",
            Box::new(|h, _| h["lidar"]["shape"] = json!([10, 5])),
        ),
        (
            "cameras[0].image: ",
            Box::new(|h, _| h["cameras"][0]["image"] = json!("/nonexistent/front.png")),
        ),
        (
            "read: read raised KeyError",
            Box::new(|h, p| {
                *h = json!({"error": "read raised KeyError: 'x' (at toy.py:3: raise KeyError)", "field": "read"});
                p.clear();
            }),
        ),
    ];
    for (k, (want, edit)) in cases.into_iter().enumerate() {
        let out = tmp.path().join(format!("out{k}"));
        let (code, stderr) = serve(&out, &ARGS, toy_answer(&root, edit));
        assert_eq!(code, 1, "{want}: {stderr}");
        assert!(
            stderr.contains(&format!("frame 000001: {want}")),
            "{want}: {stderr}"
        );
        // the good frame is written, the bad one not at all
        let files = common::tree_files(&out);
        assert!(files.contains("training/image_2/000000.png"), "{files:?}");
        assert!(
            !files.iter().any(|f| f.contains("000001.")),
            "{want}: {files:?}"
        );
    }
}

/// A peer that vanishes mid-run (its process killed) stops the run: the frame it did not
/// answer is not recorded as failed (nor is any later one), the exit is 1 with one message
/// saying how far the run got, and `--resume` with the peer back converts the rest, byte for
/// byte as one whole run.
#[test]
fn a_vanished_source_stops_the_run_and_a_resume_finishes_it() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("toy");
    write_toy(&root);
    let whole = tmp.path().join("whole");
    let (code, stderr) = serve(&whole, &ARGS, toy_answer(&root, |_, _| {}));
    assert_eq!(code, 0, "{stderr}");
    let out = tmp.path().join("out");
    let (code, stderr) = serve(&out, &ARGS, toy_answer(&root, |h, _| *h = Value::Null));
    assert_eq!(code, 1, "{stderr}");
    assert!(
        stderr.contains("frame 000001: the source process closed the stream")
            && stderr.contains("stopped answering after 1 of 2 frames")
            && stderr.contains("--resume"),
        "{stderr}"
    );
    assert_eq!(
        stderr.matches("closed the stream").count(),
        1,
        "reported once: {stderr}"
    );
    let manifest: Value =
        serde_json::from_str(&common::read_text(&out.join("panoconv.json"))).unwrap();
    let frames = manifest["frames"].as_array().unwrap();
    assert_eq!(
        frames.len(),
        1,
        "only the answered frame is recorded: {frames:?}"
    );
    assert_eq!(frames[0]["status"], "ok");
    let resume: Vec<&str> = ARGS.iter().copied().chain(["--resume"]).collect();
    let (code, stderr) = serve(&out, &resume, toy_answer(&root, |_, _| {}));
    assert_eq!(code, 0, "{stderr}");
    assert!(
        tree_bytes(&whole) == tree_bytes(&out),
        "resumed run differs from the whole run"
    );
}

#[test]
fn a_bad_rig_is_a_set_up_error_with_nothing_written() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("toy");
    write_toy(&root);
    type Edit = Box<dyn Fn(&mut Value)>;
    let cases: Vec<(&str, Edit)> = vec![
        (
            "rig source: Toy has no read() method",
            Box::new(|o| *o = json!({"error": "Toy has no read() method"})),
        ),
        (
            "frames: \"000000\" is listed twice",
            Box::new(|o| o["frames"] = json!(["000000", "000000"])),
        ),
        (
            "frames: \"a/b\" is not a file name",
            Box::new(|o| o["frames"] = json!(["a/b"])),
        ),
        (
            "cameras[1].camera.fx",
            Box::new(|o| o["cameras"][1]["camera"]["fx"] = json!("NaN")),
        ),
        (
            "name",
            Box::new(|o| o.as_object_mut().unwrap().remove("name").map(drop).unwrap()),
        ),
    ];
    for (k, (want, edit)) in cases.into_iter().enumerate() {
        let out = tmp.path().join(format!("out{k}"));
        let (code, stderr) = serve(&out, &ARGS, |request| {
            assert_eq!(request["op"], "open", "nothing is read after a bad open");
            let mut open = wire_open(&root);
            edit(&mut open);
            (open, Vec::new())
        });
        assert_eq!(code, 2, "{want}: {stderr}");
        assert!(stderr.contains(want), "{want}: {stderr}");
        assert!(!out.exists(), "{want}: {} was written", out.display());
    }
    // --cameras names one of the source's
    let out = tmp.path().join("cams");
    let mut args = ARGS.to_vec();
    args.extend(["--cameras", "front,side"]);
    let (code, stderr) = serve(&out, &args, toy_answer(&root, |_, _| {}));
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains(
            "--cameras \"side\": not a camera of the source (expected one of front, back)"
        ),
        "{stderr}"
    );
}
