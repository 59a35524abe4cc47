//! A nuScenes-format data root's stitch figures, per sample, in both stitch modes at the
//! 2048 px panorama's scale (`Stitch::figures`: the share of what the cameras cover left black,
//! as isolated holes, filled by the fallback rule, and the two cameras' gain-matched difference
//! in their overlaps). For real frames that no test can ship: for example the nuScenes sample
//! of mmdetection3d's demo, rebuilt by scripts/mmdet3d_nuscenes.py.
//!
//!     cargo run --release --example stitch_figures -- DATAROOT [VERSION] [VEHICLE_BOX]

use panoconv::camera::Projection;
use panoconv::convert::rig::{
    output_camera, read_images, rig_stitch, ObjectRule, RigOptions, StitchMode,
};
use panoconv::geometry::{Canvas, OutputSpec, Scale, Target};
use panoconv::image::RgbImage;
use panoconv::nuscenes::{NuScenesSelection, NuScenesSource};
use panoconv::source::{RigSource, VehicleBox};
use panoconv::warp::{StitchFigures, StitchOptions};
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(root) = args.first() else {
        eprintln!("usage: stitch_figures DATAROOT [VERSION] [VEHICLE_BOX]");
        return ExitCode::from(2);
    };
    let version = args.get(1).map_or("v1.0-mini", String::as_str);
    let mut selection = NuScenesSelection::new(root.into(), version.into());
    if let Some(b) = args.get(2) {
        match VehicleBox::parse(b) {
            Ok(v) => selection.vehicle_box = v,
            Err(e) => {
                eprintln!("VEHICLE_BOX: {e}");
                return ExitCode::from(2);
            }
        }
    }
    match run(selection) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}

fn run(selection: NuScenesSelection) -> Result<(), Box<dyn std::error::Error>> {
    let source = NuScenesSource::open(selection)?;
    let cameras: Vec<usize> = (0..source.cameras(0).len()).collect();
    let info: Vec<_> = source.cameras(0).iter().map(|c| c.info).collect();
    let target = Target::Linear(OutputSpec {
        projection: Projection::Equirect,
        scale: Scale::PanoWidth(2048),
        canvas: Canvas::Full360,
        crop: None,
        resize: None,
    });
    for item in source.items(&cameras)?.items {
        let frame = source.read(&item)?.frame;
        let camera = output_camera(&frame, &info, &target, &cameras)?;
        for mode in [StitchMode::Depth, StitchMode::Fixed] {
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
                    visibility: Default::default(),
                },
                depth: None,
                ego_masks: Vec::new(),
                style: None,
            };
            let images = read_images(&frame, &options)?;
            let refs: Vec<&RgbImage> = images.iter().collect();
            let built = rig_stitch(&frame, &info, camera.as_ref(), &options)?;
            print(&item.id, mode, &built.stitch.figures(&refs));
        }
    }
    Ok(())
}

fn print(id: &str, mode: StitchMode, f: &StitchFigures) {
    println!(
        "{id} {mode:?}: covered {} px, black {:.3} %, isolated {:.3} %, fallback {:.2} %, far fill {:.2} %, seam {:.2} levels over {} px",
        f.covered,
        f.black_percent(),
        f.isolated_percent(),
        f.fallback_percent(),
        f.far_percent(),
        f.seam_levels,
        f.overlap
    );
}
