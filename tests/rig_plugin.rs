//! A dataset added without editing the library: a rig dataset of a format panoconv does not
//! know ("toyrig": two pinhole cameras back to back, a text file of boxes and a LiDAR scan
//! per frame), read by an adapter written here, outside the crate, against the public
//! `source::RigSource` seam, and converted by the generic `convert::rig::run_rig`. The run
//! gives it what it gives KITTI-360 and nuScenes: the stitched panorama with its `source_2`
//! map, exact labels, depth maps, the manifest, the objects records and a failed frame counted
//! with its file named.

use crate::common::{self, iou, read_manifest, read_text};
use crate::kitti360_command::{exact_box, Written};
use nalgebra::{Matrix3, Vector3};
use panoconv::camera::{ImageSize, Intrinsics, Perspective, Projection};
use panoconv::codec::png::PngCompression;
use panoconv::convert::rig::{run_rig, ObjectRule, RigJob, RigSpec, StitchMode};
use panoconv::convert::run_options::{DepthJob, RunOptions};
use panoconv::error::{Error, Result};
use panoconv::geometry::{Canvas, OutputSpec, Scale, Target};
use panoconv::kitti::{Calib, Cam, LabelFile};
use panoconv::reproject::depth::OcclusionFilter;
use panoconv::reproject::visibility::Visibility;
use panoconv::run::{OutputMode, Silent};
use panoconv::source::{
    record_value, CameraInfo, Frame, LidarPoint, Pose, RigCamera, RigItem, RigItems, RigSource,
    SourceBox, SourceCamera, SourceFrame,
};
use panoconv::warp::StitchOptions;
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// Each camera: 200x150, 90° across; the two sit 0.4 m apart along the optical axis.
const SIZE: ImageSize = ImageSize {
    width: 200,
    height: 150,
};
const FOCAL: f64 = 100.0;
const NAMES: [&str; 2] = ["front", "back"];
/// front: red, back: blue (a panorama pixel names its camera by its colour too)
const COLOURS: [[u8; 3]; 2] = [[200, 40, 40], [40, 40, 200]];
/// The camera height above a flat ground (reference y is down).
const GROUND_Y: f64 = 1.6;

fn pinhole() -> Perspective {
    Perspective::new(
        Intrinsics::new(FOCAL, FOCAL, 99.5, 74.5),
        ImageSize::new(SIZE.width, SIZE.height),
    )
}

/// front at z = +0.2 looking +z; back at z = −0.2 looking −z (turned 180° about y)
fn reference_from_camera(k: usize) -> Pose {
    if k == 0 {
        Pose::new(Matrix3::identity(), Vector3::new(0.0, 0.0, 0.2))
    } else {
        let turn = Matrix3::new(-1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0);
        Pose::new(turn, Vector3::new(0.0, 0.0, -0.2))
    }
}

/// The adapter: everything the seam asks, and nothing of the library edited.
struct ToyRig {
    root: PathBuf,
    frames: Vec<String>,
    cameras: Vec<SourceCamera>,
}

impl ToyRig {
    fn open(root: &Path) -> Result<Self> {
        let list = root.join("frames.txt");
        let text = std::fs::read_to_string(&list).map_err(|e| Error::io(&list, e))?;
        let cameras = NAMES
            .iter()
            .map(|n| SourceCamera {
                name: n.to_string(),
                info: CameraInfo {
                    focal: pinhole().k,
                    max_theta: None,
                },
                size: SIZE,
            })
            .collect();
        Ok(Self {
            root: root.to_owned(),
            frames: text.split_whitespace().map(str::to_owned).collect(),
            cameras,
        })
    }

    /// `CLASS h w l x y z ry` per line: KITTI's object fields, in the rig's reference frame.
    fn boxes(&self, path: &Path) -> Result<Vec<SourceBox>> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let mut boxes = Vec::new();
        for (n, line) in text.lines().enumerate() {
            let t: Vec<&str> = line.split_whitespace().collect();
            let v: Vec<f64> = t.iter().skip(1).filter_map(|s| s.parse().ok()).collect();
            if t.len() != 8 || v.len() != 7 {
                return Err(Error::file(
                    path,
                    format!("line {}: 8 fields expected", n + 1),
                ));
            }
            let location = Vector3::new(v[3], v[4], v[5]);
            boxes.push(SourceBox::from_kitti(
                t[0],
                [v[0], v[1], v[2]],
                location,
                v[6],
            ));
        }
        Ok(boxes)
    }
}

impl RigSource for ToyRig {
    fn command(&self) -> &'static str {
        "toyrig"
    }
    fn root(&self) -> &Path {
        &self.root
    }
    fn parts(&self) -> usize {
        1
    }
    fn cameras(&self, _part: usize) -> &[SourceCamera] {
        &self.cameras
    }
    fn items(&self, _cameras: &[usize]) -> Result<RigItems> {
        let items = (self.frames.iter().enumerate())
            .map(|(i, id)| RigItem {
                id: id.clone(),
                part: 0,
                index: i as u64,
            })
            .collect();
        Ok(RigItems {
            items,
            not_frames: Vec::new(),
        })
    }
    fn read(&self, item: &RigItem) -> Result<SourceFrame> {
        let dir = self.root.join(&item.id);
        let rig = (0..2)
            .map(|k| RigCamera {
                name: NAMES[k].into(),
                model: Arc::new(pinhole()),
                reference_from_camera: reference_from_camera(k),
                image: dir.join(format!("{}.png", NAMES[k])),
                time: None,
            })
            .collect();
        let frame = Frame {
            id: item.id.clone(),
            provenance: vec![dir.join("boxes.txt")],
            rig,
            objects: self.boxes(&dir.join("boxes.txt"))?,
            regions: Vec::new(),
            lidar: ground_scan(),
            world_from_reference: None,
            reference_from_lidar: None,
            lidar_from_imu: None,
            input_hashes: Vec::new(),
        };
        let mut record = Map::new();
        record.insert("toy_frame".into(), Value::from(item.id.clone()));
        Ok(SourceFrame { frame, record })
    }
    fn keeps(&self, object: &SourceBox) -> bool {
        object.class != "Tree"
    }
    fn parameters(&self) -> Map<String, Value> {
        let mut m = Map::new();
        m.insert("input".into(), record_value(&self.root));
        m
    }
    fn frame_folder(&self, item: &RigItem) -> PathBuf {
        self.root.join(&item.id)
    }
}

/// A flat ground 1.6 m below the cameras, every 0.25 m out to 30 m (the scan a LiDAR on the
/// roof would give of an empty road).
fn ground_scan() -> Vec<LidarPoint> {
    let mut points = Vec::new();
    for i in -120..=120 {
        for j in -120..=120 {
            let (x, z) = (i as f64 * 0.25, j as f64 * 0.25);
            if x.hypot(z) > 2.0 {
                points.push(LidarPoint {
                    position: Vector3::new(x, GROUND_Y, z),
                    intensity: 0.5,
                });
            }
        }
    }
    points
}

/// Two frames and one without its back image; the boxes on the ground.
fn write_dataset(root: &Path) {
    let boxes = "Car 1.50 1.80 4.20 0.50 1.60 9.00 0.30\n\
                 Pedestrian 1.80 0.60 0.80 -1.00 1.60 -7.00 1.20\n\
                 Tree 6.00 1.00 1.00 3.00 1.60 15.00 0.00\n";
    for id in ["000000", "000001", "000002"] {
        let dir = root.join(id);
        std::fs::create_dir_all(&dir).unwrap();
        common::write_text(&dir.join("boxes.txt"), boxes);
        for (k, name) in NAMES.iter().enumerate() {
            if id == "000002" && k == 1 {
                continue;
            }
            let data = COLOURS[k].repeat((SIZE.width * SIZE.height) as usize);
            let png = common::Png {
                width: SIZE.width,
                height: SIZE.height,
                color: png::ColorType::Rgb,
                depth: png::BitDepth::Eight,
                data,
            };
            common::write_png(&dir.join(format!("{name}.png")), &png);
        }
    }
    common::write_text(&root.join("frames.txt"), "000000\n000001\n000002\n");
}

fn job(output: &Path) -> RigJob {
    RigJob::new(RigSpec {
        run: RunOptions {
            output: output.to_owned(),
            mode: OutputMode::New,
            shard: None,
            png_compression: PngCompression::Fast,
            style: None,
            augment: None,
            depth: Some(DepthJob {
                occlusion_filter: Some(OcclusionFilter::default()),
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
            even_exposure: false,
        },
        stitch_mode: StitchMode::Depth,
        stitch_depth: false,
        mask: false,
        centre: None,
        objects: ObjectRule {
            max_distance: 80.0,
            min_points: 0,
            visibility: Visibility {
                min_side_px: 0.0,
                min_share: 0.0,
            },
        },
        ego_masks: Vec::new(),
    })
    .unwrap()
}

/// A frame's output camera and labels (a dataset without a world frame writes no
/// `Tr_rect_to_world`).
fn written(out: &Path, id: &str) -> Written {
    let split = out.join("training");
    let calib = Calib::read(&split.join(format!("calib/{id}.txt"))).unwrap();
    let image = common::read_rgb8(&split.join(format!("image_2/{id}.png")));
    let size = ImageSize::new(image.width, image.height);
    let (camera, centre) = calib.output_camera(Cam::C2, size).unwrap();
    Written {
        camera,
        centre,
        world_rotation: Matrix3::identity(),
        world_translation: Vector3::zeros(),
        labels: LabelFile::read(&split.join(format!("label_2/{id}.txt"))).unwrap(),
    }
}

#[test]
fn a_dataset_adapter_outside_the_library_gets_the_whole_rig_run() {
    let tmp = tempfile::tempdir().unwrap();
    let (root, out) = (tmp.path().join("toy"), tmp.path().join("out"));
    write_dataset(&root);
    let source = ToyRig::open(&root).unwrap();
    let summary = run_rig(&job(&out), &source, &Silent, &AtomicBool::new(false)).unwrap();
    assert_eq!(
        (
            summary.run.frames,
            summary.run.converted,
            summary.run.failed
        ),
        (3, 2, 1)
    );
    // the frame without its back image is listed with the file named
    let manifest = read_manifest(&out);
    let failed = manifest.to_string();
    assert!(failed.contains("back.png"), "{failed}");
    assert_eq!(manifest["command"], "toyrig");
    assert_eq!(summary.objects.written, 4);
    assert_eq!(summary.objects.class, 2);

    // the labels: each kept box at its place (C2 is the mean of the two centres, the origin)
    // and its exact 2D box in the panorama
    let boxes = source.boxes(&root.join("000000/boxes.txt")).unwrap();
    let w = written(&out, "000001");
    assert!(read_text(&out.join("training/calib/000001.txt")).contains("P2:"));
    assert!(w.centre.norm() < 1e-9, "{}", w.centre);
    assert_eq!(w.labels.labels.len(), 2);
    for (l, b) in w.labels.labels.iter().zip(&boxes) {
        assert_eq!(l.kind, b.class);
        assert!(
            (l.location - b.bottom_centre()).norm() < 0.006,
            "{}",
            l.location
        );
        assert!((l.rotation_y - b.yaw()).abs() < 0.006);
        // corner i at ±half extents by its bits (x, y, z), the order exact_box takes
        let corners = std::array::from_fn(|i| {
            let s = |bit: usize| if i >> bit & 1 == 1 { 0.5 } else { -0.5 };
            b.centre + b.rotation * b.size.component_mul(&Vector3::new(s(0), s(1), s(2)))
        });
        let exact = exact_box(&w, &corners).expect("in the panorama");
        assert!(iou(l.bbox, exact) >= 0.99, "{:?} vs {exact:?}", l.bbox);
    }

    // the panorama: ahead from the front camera, behind from the back one, by source_2 and
    // by colour
    let split = out.join("training");
    let image = common::read_rgb8(&split.join("image_2/000001.png"));
    let source_map = common::read_png(&split.join("source_2/000001.png"));
    let at = |u: u32, v: u32| (v * image.width + u) as usize;
    let (ahead, behind) = (at(256, 100), at(0, 100));
    assert_eq!((source_map.data[ahead], source_map.data[behind]), (0, 1));
    assert_eq!(image.data[3 * ahead..3 * ahead + 3], COLOURS[0]);
    assert_eq!(image.data[3 * behind..3 * behind + 3], COLOURS[1]);

    // depth: the ground 10 m ahead, seen from C2, is where the scan put it (within 5 %)
    let depth = common::read_png(&split.join("depth_2/000001.png"));
    let v = (127.5 + (GROUND_Y / 10.0).atan() * 512.0 / (2.0 * std::f64::consts::PI)).round();
    let i = 2 * at(256, v as u32);
    let d = u16::from_be_bytes([depth.data[i], depth.data[i + 1]]) as f64 / 256.0;
    let along =
        (GROUND_Y / ((v - 127.5) * 2.0 * std::f64::consts::PI / 512.0).tan()).hypot(GROUND_Y);
    assert!((d - along).abs() < 0.05 * along, "{d} m against {along} m");

    // the objects record carries the adapter's own field and the run's verdicts
    let record: Value =
        serde_json::from_str(&read_text(&split.join("objects/000001.json"))).unwrap();
    assert_eq!(record["toy_frame"], "000001");
    assert!(record.to_string().contains("\"class\""), "{record}");

    // and `panoconv verify` judges it like any other: the failed frame fails it unless allowed
    let verify = common::panoconv(["verify", out.to_str().unwrap()]);
    let said = format!("{}{}", verify.stdout, verify.stderr);
    assert_eq!(verify.code, 1, "{said}");
    assert!(
        said.contains("1 failed frame") && said.contains("000002"),
        "{said}"
    );
    let allowed = ["verify", "--allow-failed", out.to_str().unwrap()];
    common::assert_success(&common::panoconv(allowed));
}

#[test]
fn a_library_job_gets_the_rules_and_errors_of_the_command_line() {
    // each rule, broken by a library caller, refused by RigJob::new with the message the
    // command line prints for the same value (one check, in one place)
    let tmp = tempfile::tempdir().unwrap();
    let k360 = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/kitti360");
    type Break = fn(&mut RigSpec);
    let cases: [(Break, &[&str], &str); 4] = [
        (
            |s| s.stitch.distance = 0.0,
            &["--stitch-distance", "0"],
            "--stitch-distance must be positive",
        ),
        (
            |s| s.stitch.blend_width = -1.0,
            &["--blend-width=-1"],
            "--blend-width must be positive",
        ),
        (
            |s| s.objects.max_distance = f64::INFINITY,
            &["--max-distance", "inf"],
            "--max-distance must be positive",
        ),
        (
            |s| {
                let f = OcclusionFilter {
                    azimuth_spacing: 0.0,
                    ..OcclusionFilter::default()
                };
                s.run.depth = Some(DepthJob {
                    occlusion_filter: Some(f),
                });
            },
            &["--depth", "--lidar-azimuth-step", "0"],
            "--lidar-azimuth-step must be positive",
        ),
    ];
    for (i, (broken, flags, message)) in cases.into_iter().enumerate() {
        let mut spec = job(&tmp.path().join("lib")).spec().clone();
        broken(&mut spec);
        match RigJob::new(spec) {
            Err(Error::Setup(m)) => assert_eq!(m, message),
            other => panic!("{message}: got {other:?}"),
        }
        let out = tmp.path().join(format!("cli{i}"));
        let mut args = vec!["kitti360", "--to", "equirect", "--input"];
        args.extend([
            k360.to_str().unwrap(),
            "--sequence",
            "2013_05_28_drive_0000_sync",
        ]);
        args.extend(["--output", out.to_str().unwrap()]);
        args.extend(flags);
        let run = common::panoconv(&args);
        assert_eq!(run.code, 2, "{}", run.stderr);
        assert_eq!(run.stderr.trim(), format!("panoconv: error: {message}"));
        assert!(!out.exists(), "a refused job writes nothing");
    }
}
