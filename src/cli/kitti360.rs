//! `panoconv kitti360`: a KITTI-360 sequence's rig into panoramas (or one camera converted),
//! with labels, calib, depth and the source map, as a KITTI dataset.

use super::rig::{ego_masks, run_rig_command, setup, RigArgs, RigChoice};
use anyhow::{bail, Result};
use clap::Args;
use panoconv::kitti360::{
    Kitti360Classes, Kitti360Selection, Kitti360Source, DEFAULT_FISHEYE_FOV_DEG,
};
use panoconv::source::VehicleBox;
use std::path::PathBuf;
use std::process::ExitCode;

pub(super) const KITTI360_EXAMPLES: &str = "Examples:
  panoconv kitti360 --to equirect --input fixtures/kitti360 --sequence 2013_05_28_drive_0000_sync --output /tmp/k360_equi --pano-width 1024
  panoconv kitti360 --to equirect --depth --input /data/KITTI-360 --sequence 2013_05_28_drive_0000_sync --output O --frames 250,251
  panoconv kitti360 --to cylindrical --cameras 02 --input /data/KITTI-360 --sequence 2013_05_28_drive_0000_sync --output O_left
  panoconv kitti360 --to equirect --input R --sequence 2013_05_28_drive_0000_sync,2013_05_28_drive_0003_sync --output O --export coco
  panoconv kitti360 --to equirect --style miami_BtoA.onnx --input R --sequence 2013_05_28_drive_0000_sync --output O_miami
  panoconv kitti360 --to equirect --augment 4 --seed 7 --crop-size 1024x512 --min-objects 2 --input R --sequence 2013_05_28_drive_0000_sync --output O_aug

Output: OUT/training/{image_2,label_2,calib,source_2,objects}/ID.* (depth_2 with --depth) and
OUT/panoconv.json. ID is the frame number in 6 digits (000250); with several sequences the
drive number comes first (0003000250). The rect of every file is the frame's level frame
(y down along gravity, z the heading of image_00, origin at image_00's centre): calib has
R0_rect = I, Tr_velo_to_cam into it, projection:/K2:/C2: and Tr_rect_to_world: (to the
KITTI-360 world). source_2 names the camera of each pixel (0-3, 255 none). docs/kitti360.md
has the stitch model, the class table and the rule for the objects written.";

/// `panoconv kitti360`.
#[derive(Args)]
pub(super) struct Kitti360Args {
    /// KITTI-360 root (calibration/, data_2d_raw/, data_3d_raw/, data_poses/, data_3d_bboxes/).
    #[arg(long, short = 'i')]
    input: PathBuf,
    /// Sequence folder name(s), comma-separated (e.g. 2013_05_28_drive_0000_sync).
    #[arg(long, value_delimiter = ',', required = true, value_name = "NAME,...")]
    sequence: Vec<String>,
    /// Convert only these KITTI-360 frame numbers (comma-separated, e.g. 250,251), of every
    /// sequence.
    #[arg(long, value_delimiter = ',', value_name = "N,...")]
    frames: Option<Vec<String>>,
    /// Rig cameras to use: 00 and 01 (forward pinholes), 02 (left fisheye), 03 (right).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "00,01,02,03",
        value_name = "K,..."
    )]
    cameras: Vec<String>,
    /// Ego masks, one per camera (PNG, the camera's image size; non-zero = the vehicle's
    /// body): the camera gives no output pixel whose sample would touch its mask.
    #[arg(long, value_delimiter = ',', value_name = "K=PATH,...")]
    ego_mask: Vec<String>,
    /// Also write these KITTI-360 classes (named by their KITTI-360 class), or `all`.
    #[arg(long, value_delimiter = ',', value_name = "CLASS,...")]
    classes: Option<Vec<String>>,
    /// Field of view of the fisheyes image_02 and image_03, degrees (one value, or two).
    #[arg(long, value_delimiter = ',', value_name = "DEG[,DEG]")]
    fisheye_fov: Option<Vec<f64>>,
    /// The Velodyne returns dropped as the vehicle's own, in the Velodyne's frame: a range R,
    /// a box X0,Y0,Z0,X1,Y1,Z1, or none (metres) [default: 3, the range the KITTI-360 scripts
    /// crop].
    #[arg(long, value_name = "BOX", allow_hyphen_values = true, value_parser = VehicleBox::parse)]
    vehicle_box: Option<VehicleBox>,
    #[command(flatten)]
    rig: RigArgs,
}

/// The rig index of a camera named `00` to `03` (or `0` to `3`): image_00 to image_03.
fn rig_camera(name: &str) -> Option<usize> {
    match name.trim() {
        "00" | "0" => Some(0),
        "01" | "1" => Some(1),
        "02" | "2" => Some(2),
        "03" | "3" => Some(3),
        _ => None,
    }
}

/// HDL-64E's azimuth step, degrees.
const HDL64_AZIMUTH_STEP_DEG: f64 = 0.09;

pub(super) fn kitti360(args: Kitti360Args) -> Result<ExitCode> {
    run_rig_command(&args.rig, || {
        let job = args.rig.job(choice(&args)?)?;
        let selection = selection(&args, job.needs_lidar(), job.depth_guided())?;
        Ok((job, Kitti360Source::open(selection)?))
    })
}

/// The cameras of `--cameras`, the masks of `--ego-mask`, KITTI-360's LiDAR defaults.
fn choice(args: &Kitti360Args) -> Result<RigChoice> {
    let mut cameras = Vec::new();
    for c in &args.cameras {
        let Some(k) = rig_camera(c) else {
            bail!(setup(format!(
                "--cameras {:?}: expected 00, 01, 02 or 03 (image_00 to image_03)",
                c.trim()
            )))
        };
        if cameras.contains(&k) {
            bail!(setup(format!("--cameras names {c} twice")));
        }
        cameras.push(k);
    }
    Ok(RigChoice {
        command: "kitti360",
        cameras,
        ego_masks: ego_masks(&args.ego_mask, rig_camera, "00, 01, 02 or 03")?,
        lidar_azimuth_step_deg: HDL64_AZIMUTH_STEP_DEG,
        min_points: 3,
    })
}

/// What of the KITTI-360 root is read: `--sequence`, `--frames`, `--classes`,
/// `--fisheye-fov`.
fn selection(args: &Kitti360Args, lidar: bool, scenery: bool) -> Result<Kitti360Selection> {
    let frames = match &args.frames {
        Some(list) => {
            let mut out = Vec::new();
            for t in list {
                out.push(
                    t.trim()
                        .parse::<u32>()
                        .map_err(|_| setup(format!("--frames {t:?}: not a frame number")))?,
                );
            }
            Some(out)
        }
        None => None,
    };
    let classes = match &args.classes {
        None => Kitti360Classes::Kitti,
        Some(list) if list.iter().any(|c| c == "all") => Kitti360Classes::All,
        Some(list) => {
            panoconv::kitti360::classes::check_named(list)?;
            Kitti360Classes::Also(list.clone())
        }
    };
    let fisheye_fov_deg = match args.fisheye_fov.as_deref() {
        None => [DEFAULT_FISHEYE_FOV_DEG; 2],
        Some([a]) => [*a, *a],
        Some([a, b]) => [*a, *b],
        Some(_) => bail!(setup("--fisheye-fov takes one or two angles".into())),
    };
    Ok(Kitti360Selection {
        input: args.input.clone(),
        sequences: args.sequence.iter().map(|s| s.trim().to_owned()).collect(),
        frames,
        classes,
        fisheye_fov_deg,
        lidar,
        scenery,
        vehicle_box: args.vehicle_box.unwrap_or(VehicleBox::KITTI360),
    })
}
