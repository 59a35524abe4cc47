//! The stitch on a real scan: the four REAL frames of ../shared/pandaset/002 (PandaSet, Hesai
//! and Scale AI, CC BY 4.0; six 1920x1080 cameras around the car, a 360° Pandar64), rebuilt as
//! a nuScenes data root by tests/pandaset_nuscenes.py and converted as `panoconv nuscenes`
//! converts it. Each frame's figures in both stitch modes ([`StitchFigures`]): the
//! depth-guided stitch (the default) leaves at most 0.5 % of what the cameras cover black, at
//! most 0.1 % as isolated holes, and its cameras agree at least as well in their overlaps as
//! the fixed stitch's at 10 m.

use crate::common::{self, real_pandaset};
use crate::opencv_ref::test_python;
use panoconv::camera::Projection;
use panoconv::convert::rig::{
    output_camera, read_images, rig_stitch, ObjectRule, RigOptions, StitchMode,
};
use panoconv::geometry::{Canvas, OutputSpec, Scale, Target};
use panoconv::image::RgbImage;
use panoconv::nuscenes::{NuScenesSelection, NuScenesSource};
use panoconv::source::{RigSource, VehicleBox};
use panoconv::warp::{StitchFigures, StitchOptions, FALLBACK_SOURCE, NO_SOURCE};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The bars of the "done when", per frame with default options.
const MAX_BLACK_PERCENT: f64 = 0.5;
const MAX_ISOLATED_PERCENT: f64 = 0.1;

/// The car's own returns in PandaSet's LiDAR frame (x right, y forward, z up, its origin at the
/// road under the sensor; `--vehicle-box`): the roof and the sensor's mount, 0.4-1.7 m up
/// within a metre and a half of the origin. nuScenes' default box sits below a sensor 1.84 m
/// up, so it does not fit this frame.
const PANDASET_VEHICLE_BOX: &str = "-1.2,-1.6,0.2,1.2,1.2,2.2";

/// The PandaSet frames as a nuScenes data root (version v1.0-mini), made once.
fn root() -> &'static Path {
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

/// Each frame's figures with `mode` at the 2048 px panorama's scale.
fn figures(mode: StitchMode) -> Vec<StitchFigures> {
    let mut selection = NuScenesSelection::new(root().into(), "v1.0-mini".into());
    selection.vehicle_box = VehicleBox::parse(PANDASET_VEHICLE_BOX).unwrap();
    let source = NuScenesSource::open(selection).unwrap();
    let cameras: Vec<usize> = (0..source.cameras(0).len()).collect();
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
    assert_eq!(items.len(), 4);
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

#[test]
fn the_default_stitch_of_real_frames_is_never_black_where_a_camera_sees_and_agrees_at_its_seams() {
    let (depth, fixed) = (figures(StitchMode::Depth), figures(StitchMode::Fixed));
    for (k, (d, f)) in depth.iter().zip(&fixed).enumerate() {
        eprintln!(
            "frame {k}: depth-guided black {:.3} %, isolated {:.3} %, fallback {:.2} %, seam {:.2} levels over {} px; fixed black {:.3} %, isolated {:.3} %, seam {:.2} levels over {} px",
            d.black_percent(),
            d.isolated_percent(),
            d.fallback_percent(),
            d.seam_levels,
            d.overlap,
            f.black_percent(),
            f.isolated_percent(),
            f.seam_levels,
            f.overlap
        );
        assert!(d.covered > 500_000, "frame {k}: {d:?}");
        assert!(d.black_percent() <= MAX_BLACK_PERCENT, "frame {k}: {d:?}");
        assert!(
            d.isolated_percent() <= MAX_ISOLATED_PERCENT,
            "frame {k}: {d:?}"
        );
        assert!(
            d.overlap > 10_000 && d.seam_levels <= f.seam_levels,
            "frame {k}: depth-guided {d:?} against fixed {f:?}"
        );
    }
}

#[test]
fn real_frames_convert_without_the_vehicles_returns_in_depth_and_with_fallbacks_marked() {
    let out = tempfile::tempdir().unwrap();
    let run = common::panoconv([
        "nuscenes",
        "--to",
        "equirect",
        "--input",
        root().to_str().unwrap(),
        "--version",
        "v1.0-mini",
        "--pano-width",
        "1024",
        "--depth",
        "--vehicle-box",
        PANDASET_VEHICLE_BOX,
        "-q",
        "--output",
        out.path().to_str().unwrap(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let training = out.path().join("training");
    let mut ids: Vec<_> = std::fs::read_dir(training.join("depth_2"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    ids.sort();
    assert_eq!(ids.len(), 4);
    for depth_path in &ids {
        let name = depth_path.file_name().unwrap();
        let png = common::read_png(depth_path);
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
        let source = common::read_png(&training.join("source_2").join(name)).data;
        let marked = source
            .iter()
            .filter(|&&s| s != NO_SOURCE && s & FALLBACK_SOURCE != 0)
            .count();
        assert!(
            source
                .iter()
                .all(|&s| s == NO_SOURCE || (s & !FALLBACK_SOURCE) < 6),
            "{name:?}: a source value outside 0-5, 128-133 and 255"
        );
        eprintln!("{name:?}: {marked} fallback pixels");
    }
}
