//! `panoconv nuscenes` through the real binary on synthetic scenes (`panoconv synth --nuscenes`,
//! the KITTI-360 synthesiser's analytic scene seen by nuScenes' six cameras): every object at
//! its exact location with its exact 2D box and the depth map against the scene, on the
//! zero-baseline rig and on the rig with nuScenes' real offsets and per-camera firing times;
//! the objects records, the summary's counts, thread counts, the tools and the exports on the
//! output, one camera converted alone, and bad input.

use crate::common::{self, assert_success, iou, panoconv, read_manifest, read_text};
use crate::kitti360_command::{
    check_depth_share, check_labels, exact_box, truths, written, Written, LIDAR_STEP, MIN_IOU,
};
use panoconv::tools::synth360::scene::FIRST_FRAME;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Panorama width of the tests: two pixels per degree.
const WIDTH: &str = "720";
const VERSION: &str = "v1.0-mini";

/// A synthetic scene (scale 0.25, two samples), made once per binary build.
pub(crate) fn scene(zero_baseline: bool) -> &'static Path {
    static ZERO: OnceLock<PathBuf> = OnceLock::new();
    static OFFSET: OnceLock<PathBuf> = OnceLock::new();
    let cell = if zero_baseline { &ZERO } else { &OFFSET };
    cell.get_or_init(|| {
        let mut args = vec!["--nuscenes", "--scale", "0.25", "--frames", "2"];
        if zero_baseline {
            args.push("--zero-baseline");
        }
        let name = if zero_baseline { "zero" } else { "offset" };
        common::synth_cache("panoconv-nuscenes", name, &args)
    })
}

/// `panoconv nuscenes --input ROOT --version v1.0-mini --output OUT EXTRA...`
fn nuscenes(root: &Path, output: &Path, extra: &[&str]) -> common::Run {
    let mut args = vec![
        "nuscenes",
        "--input",
        root.to_str().unwrap(),
        "--version",
        VERSION,
        "--output",
        output.to_str().unwrap(),
    ];
    args.extend(extra);
    panoconv(&args)
}

/// The depth map against the scene: ≥ 99.5 % of its pixels within 5 % of the scene's
/// distance somewhere in the pixel, ≤ 0.2 % occlusion leaks. Over the pixel's area, not only
/// through its centre: the HDL-32E's lowest-elevation ground returns just under the horizon
/// (2 px per degree) see the ground's distance change by more than 5 % within one pixel.
fn check_depth(out: &Path, id: &str, w: &Written, frame: u32, what: &str) {
    check_depth_share(out, id, w, frame, what, 0.995, true);
}

/// The panorama options of the label and depth checks.
const PANORAMA: [&str; 7] = [
    "--to",
    "equirect",
    "--pano-width",
    WIDTH,
    "--depth",
    "--lidar-azimuth-step",
    LIDAR_STEP,
];

#[test]
fn the_zero_baseline_panorama_has_exact_labels_and_depth() {
    let root = scene(true);
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    assert_success(&nuscenes(root, &out, &PANORAMA));
    for sample in 0..2u32 {
        let id = format!("{sample:06}");
        let w = written(&out, &id);
        assert!(
            w.centre.norm() < 1e-9,
            "all centres at CAM_FRONT's: C2 {}",
            w.centre
        );
        let what = format!("nuscenes zero baseline, sample {sample}");
        check_labels(&w, FIRST_FRAME + sample, &what);
        check_depth(&out, &id, &w, FIRST_FRAME + sample, &what);
    }
    // the six cameras cover every azimuth about the horizon; not the poles (255: none)
    let source = common::read_png(&out.join("training/source_2/000000.png"));
    let row = |v: u32| &source.data[(v * source.width) as usize..((v + 1) * source.width) as usize];
    assert!(row(source.height / 2).iter().all(|&s| s < 6));
    for k in 0..6u8 {
        assert!(
            row(source.height / 2).contains(&k),
            "camera {k} supplies none"
        );
    }
    assert!(row(0).iter().all(|&s| s == 255), "nothing sees the zenith");
}

#[test]
fn the_offset_rig_at_its_cameras_own_times_has_exact_labels_and_depth_with_any_jobs() {
    let root = scene(false);
    let tmp = tempfile::tempdir().unwrap();
    let (one, two) = (tmp.path().join("one"), tmp.path().join("two"));
    for (out, jobs) in [(&one, "1"), (&two, "2")] {
        let mut args = PANORAMA.to_vec();
        args.extend(["--jobs", jobs]);
        let run = nuscenes(root, out, &args);
        assert_success(&run);
        // the annotated child 95 m ahead has no LiDAR point: left out and counted
        assert!(
            run.stderr.contains(", 2 seen by no sensor,"),
            "{}",
            run.stderr
        );
    }
    let (a, b) = (common::tree_bytes(&one), common::tree_bytes(&two));
    let files: Vec<&String> = a.keys().filter(|k| *k != "panoconv.json").collect();
    assert_eq!(files.len(), 2 * 6, "{files:?}");
    for f in files {
        assert!(a[f] == b[f], "{f} differs between --jobs 1 and --jobs 2");
    }
    let m = read_manifest(&one);
    assert_eq!(m["command"], "nuscenes");
    assert_eq!(m["parameters"]["version"], VERSION);
    assert_eq!(m["parameters"]["stitch_mode"], "depth");
    for sample in 0..2u32 {
        let id = format!("{sample:06}");
        let w = written(&one, &id);
        // C2: the mean of the six centres, not CAM_FRONT's
        assert!(w.centre.norm() > 0.1, "C2 {}", w.centre);
        let what = format!("nuscenes offset rig, sample {sample}");
        let n = check_labels(&w, FIRST_FRAME + sample, &what);
        check_depth(&one, &id, &w, FIRST_FRAME + sample, &what);
        // the objects record: the scene, the sample, and per object what nuScenes says of it
        let rec: serde_json::Value =
            serde_json::from_str(&read_text(&one.join(format!("training/objects/{id}.json"))))
                .unwrap();
        assert_eq!(rec["scene"], "scene-0001");
        assert_eq!(rec["sample_token"].as_str().unwrap().len(), 32);
        assert_eq!(rec["counts"]["written"].as_u64().unwrap() as usize, n);
        let annotations = rec["annotations"].as_array().unwrap();
        let objects = rec["objects"].as_array().unwrap();
        assert_eq!(annotations.len(), objects.len());
        for (a, o) in annotations.iter().zip(objects) {
            assert_eq!(a["category"], o["dataset_class"]);
            assert_eq!(a["annotation"].as_str().unwrap().len(), 32);
            assert_eq!(a["instance"].as_str().unwrap().len(), 32);
            let points = a["lidar_points"].as_u64().unwrap() + a["radar_points"].as_u64().unwrap();
            if points == 0 {
                assert_eq!(o["dropped"], "unseen", "{a}");
            }
        }
        // the barrier has no KITTI type: dropped for its class, and listed
        assert!(objects
            .iter()
            .any(|o| o["dataset_class"] == "movable_object.barrier" && o["dropped"] == "class"));
    }

    // the tools and the exports on the output
    assert_success(&panoconv(["verify", one.to_str().unwrap()]));
    let inspect = panoconv(["inspect", one.to_str().unwrap()]);
    assert_success(&inspect);
    assert!(
        inspect.stdout.contains("problems: none"),
        "{}",
        inspect.stdout
    );
    for format in ["coco", "omni3d", "yolo"] {
        let dest = if format == "yolo" {
            tmp.path().join("yolo")
        } else {
            one.join("annotations")
        };
        assert_success(&panoconv([
            "export",
            one.to_str().unwrap(),
            "--format",
            format,
            "--output",
            dest.to_str().unwrap(),
        ]));
    }
    let coco: serde_json::Value =
        serde_json::from_str(&read_text(&one.join("annotations/instances_train.json"))).unwrap();
    assert_eq!(coco["images"].as_array().unwrap().len(), 2);
    let labelled: usize = (0..2)
        .map(|s| written(&one, &format!("{s:06}")).labels.labels.len())
        .sum();
    assert_eq!(coco["annotations"].as_array().unwrap().len(), labelled);
    let omni: serde_json::Value =
        serde_json::from_str(&read_text(&one.join("annotations/Omni3D_train.json"))).unwrap();
    assert_eq!(omni["annotations"].as_array().unwrap().len(), labelled);
    let yolo = read_text(&tmp.path().join("yolo/labels/train/000000.txt"));
    assert_eq!(
        yolo.lines().count(),
        written(&one, "000000").labels.labels.len()
    );
}

#[test]
fn one_camera_is_converted_alone_with_exact_boxes() {
    let root = scene(false);
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let run = nuscenes(
        root,
        &out,
        &[
            "--to",
            "perspective",
            "--cameras",
            "CAM_FRONT",
            "--keep-unseen",
        ],
    );
    assert_success(&run);
    let w = written(&out, "000001");
    // the camera's own size and centre: C2 is CAM_FRONT's optical centre (a perspective output
    // looks along the level frame's forward axis, which CAM_FRONT sees)
    assert_eq!(w.camera.size(), panoconv::camera::ImageSize::new(400, 225));
    let truth = truths(&w, FIRST_FRAME + 1);
    assert!(!w.labels.labels.is_empty());
    for l in &w.labels.labels {
        let t = truth
            .iter()
            .min_by(|a, b| {
                (a.location - l.location)
                    .norm()
                    .total_cmp(&(b.location - l.location).norm())
            })
            .unwrap();
        assert!((t.location - l.location).norm() < 0.01, "{}", l.location);
        let exact = exact_box(&w, &t.corners).expect("a written object is in the image");
        assert!(
            iou(l.bbox, exact) >= MIN_IOU,
            "{:?} vs exact {exact:?}",
            l.bbox
        );
    }
    let m = read_manifest(&out);
    assert_eq!(m["parameters"]["cameras"], serde_json::json!(["CAM_FRONT"]));
}

#[test]
fn bad_input_is_a_set_up_error_naming_what_is_wrong() {
    let root = scene(true);
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let cases: [(&[&str], &str); 4] = [
        (&["--to", "equirect", "--cameras", "CAM_TOP"], "CAM_TOP"),
        (
            &["--to", "equirect", "--classes", "vehicle.spaceship"],
            "vehicle.spaceship",
        ),
        (
            &["--to", "equirect", "--ego-mask", "CAM_UNDER=m.png"],
            "CAM_UNDER",
        ),
        (
            &["--to", "equirect", "--scenes", "scene-9999"],
            "scene-9999",
        ),
    ];
    for (extra, named) in cases {
        let run = nuscenes(root, &out, extra);
        assert_eq!(run.code, 2, "{extra:?}: {}", run.stderr);
        assert!(run.stderr.contains(named), "{extra:?}: {}", run.stderr);
        assert!(!out.exists(), "{extra:?} wrote {}", out.display());
    }
    let run = panoconv([
        "nuscenes",
        "--to",
        "equirect",
        "--input",
        root.to_str().unwrap(),
        "--version",
        "v1.0-trainval",
        "--output",
        out.to_str().unwrap(),
    ]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("v1.0-trainval"), "{}", run.stderr);
}

#[test]
fn classes_add_categories_without_a_kitti_type_named_by_their_category() {
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/nuscenes");
    let tmp = tempfile::tempdir().unwrap();
    let labels = |extra: &[&str]| -> String {
        let out = tmp.path().join(extra.join("_").replace(['-', '.'], ""));
        let mut args = vec![
            "--to",
            "equirect",
            "--pano-width",
            "360",
            "--stitch-mode",
            "fixed",
        ];
        args.extend(extra);
        assert_success(&nuscenes(&fixture, &out, &args));
        read_text(&out.join("training/label_2/000000.txt"))
    };
    let kitti = labels(&[]);
    let barrier = labels(&["--classes", "movable_object.barrier"]);
    assert!(!kitti.contains("movable_object.barrier"), "{kitti}");
    let added: Vec<&str> = barrier
        .lines()
        .filter(|l| l.starts_with("movable_object.barrier "))
        .collect();
    assert_eq!(added.len(), 1, "{barrier}");
    // the other objects are the same lines
    assert_eq!(barrier.lines().count(), kitti.lines().count() + 1);
    for line in kitti.lines() {
        assert!(barrier.contains(line), "{line}");
    }
}
