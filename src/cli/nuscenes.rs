//! `panoconv nuscenes`: the camera rigs of a nuScenes-format dataset into panoramas (or one
//! camera converted), with their 3D boxes, LiDAR depth and the source map, as a KITTI dataset.

use super::rig::{ego_masks, run_rig_command, RigArgs, RigChoice};
use anyhow::Result;
use clap::Args;
use panoconv::nuscenes::{NuScenesClasses, NuScenesSelection, NuScenesSource};
use panoconv::source::{RigSource, VehicleBox};
use std::path::PathBuf;
use std::process::ExitCode;

pub(super) const NUSCENES_EXAMPLES: &str = "Examples:
  panoconv nuscenes --to equirect --input fixtures/nuscenes --version v1.0-mini --output /tmp/nus_equi --pano-width 1024
  panoconv nuscenes --to equirect --depth --input /data/nuscenes --version v1.0-trainval --scenes scene-0061,scene-0103 --output O
  panoconv nuscenes --to cylindrical --cameras CAM_FRONT_LEFT,CAM_FRONT,CAM_FRONT_RIGHT --input R --version v1.0-mini --output O_front
  panoconv nuscenes --to equirect --classes movable_object.barrier --export coco,yolo --input R --version v1.0-mini --output O
  panoconv nuscenes --to equirect --augment 4 --seed 7 --crop-size 1024x512 --min-objects 2 --input R --version v1.0-mini --output O_aug

Output: OUT/training/{image_2,label_2,calib,source_2,objects}/ID.* (depth_2 with --depth) and
OUT/panoconv.json. ID is the scene's place in scene.json times 1000 plus the sample's place in
its scene (002004: the third scene's fifth sample). The rect of every file is the sample's level
frame (y down along gravity, z CAM_FRONT's heading, origin at CAM_FRONT's centre at the LiDAR
keyframe's pose); every camera and the LiDAR are placed by their own reading's ego pose. calib
has Tr_rect_to_world: (to nuScenes' global frame); source_2 names the camera of each pixel by
its place in --cameras (255 none). docs/nuscenes.md has the frames, the time model and the class
table.";

/// `panoconv nuscenes`.
#[derive(Args)]
pub(super) struct NuScenesArgs {
    /// Data root (holding samples/ and the version folder of *.json tables).
    #[arg(long, short = 'i')]
    input: PathBuf,
    /// The version folder of the tables (v1.0-mini, v1.0-trainval, ...).
    #[arg(long, value_name = "NAME")]
    version: String,
    /// Convert only these scenes (by name, comma-separated, e.g. scene-0061).
    #[arg(long, value_delimiter = ',', value_name = "NAME,...")]
    scenes: Option<Vec<String>>,
    /// Camera channels to use, in this order [default: every camera of the dataset: nuScenes'
    /// six clockwise from CAM_FRONT, then any others by name].
    #[arg(long, value_delimiter = ',', value_name = "CHANNEL,...")]
    cameras: Option<Vec<String>>,
    /// Ego masks, one per camera (PNG, the camera's image size; non-zero = the vehicle's
    /// body): the camera gives no output pixel whose sample would touch its mask.
    #[arg(long, value_delimiter = ',', value_name = "CHANNEL=PATH,...")]
    ego_mask: Vec<String>,
    /// Also write these categories (e.g. movable_object.barrier), named by their category, or
    /// `all`.
    #[arg(long, value_delimiter = ',', value_name = "CATEGORY,...")]
    classes: Option<Vec<String>>,
    /// Keep objects with no LiDAR and no radar point (left out by default, as the nuScenes
    /// detection evaluation does).
    #[arg(long)]
    keep_unseen: bool,
    /// The LiDAR returns dropped as the vehicle's own, in LIDAR_TOP's frame (x right, y
    /// forward, z up): a box X0,Y0,Z0,X1,Y1,Z1, a range R, or none (metres) [default: the
    /// devkit's 1 m square lengthened to the car's bonnet and boot: -1,-2,-1.5,1,2.7,0.3].
    #[arg(long, value_name = "BOX", allow_hyphen_values = true, value_parser = VehicleBox::parse)]
    vehicle_box: Option<VehicleBox>,
    #[command(flatten)]
    rig: RigArgs,
}

/// The azimuth step of nuScenes' HDL-32E at 20 Hz, degrees.
const HDL32_AZIMUTH_STEP_DEG: f64 = 0.33;

pub(super) fn nuscenes(args: NuScenesArgs) -> Result<ExitCode> {
    let classes = classes(&args)?;
    let mut selection = NuScenesSelection::new(args.input.clone(), args.version.trim().into());
    selection.scenes = args
        .scenes
        .as_ref()
        .map(|s| s.iter().map(|n| n.trim().to_owned()).collect());
    selection.cameras = args
        .cameras
        .as_ref()
        .map(|s| s.iter().map(|n| n.trim().to_owned()).collect());
    selection.classes = classes;
    selection.keep_unseen = args.keep_unseen;
    if let Some(b) = args.vehicle_box {
        selection.vehicle_box = b;
    }
    run_rig_command(&args.rig, || {
        // the tables name the cameras (and so the job's) when --cameras does not
        let source = NuScenesSource::open(selection)?;
        let channels: Vec<String> = source.cameras(0).iter().map(|c| c.name.clone()).collect();
        let camera = |name: &str| channels.iter().position(|c| c == name);
        let job = args.rig.job(RigChoice {
            command: "nuscenes",
            cameras: (0..channels.len()).collect(),
            ego_masks: ego_masks(&args.ego_mask, camera, &channels.join(", "))?,
            lidar_azimuth_step_deg: HDL32_AZIMUTH_STEP_DEG,
            min_points: 0,
        })?;
        let source = source.with_lidar(job.needs_lidar());
        check_classes(&source, &args)?;
        Ok((job, source))
    })
}

/// `--classes`: the KITTI types only, every category, or the KITTI types and the named ones.
fn classes(args: &NuScenesArgs) -> Result<NuScenesClasses> {
    Ok(match &args.classes {
        None => NuScenesClasses::Kitti,
        Some(list) if list.iter().any(|c| c.trim() == "all") => NuScenesClasses::All,
        Some(list) => NuScenesClasses::Also(list.iter().map(|c| c.trim().to_owned()).collect()),
    })
}

/// Every category `--classes` names is one of the dataset's (category.json).
fn check_classes(source: &NuScenesSource, args: &NuScenesArgs) -> Result<()> {
    let Some(list) = &args.classes else {
        return Ok(());
    };
    let dataset = source.dataset();
    panoconv::nuscenes::classes::check_named(
        list,
        &dataset.category_names(),
        &dataset.table("category"),
    )?;
    Ok(())
}
