//! `panoconv rig-stream`: a rig whose frames another process serves over stdin and stdout
//! (`panoconv.convert_rig` in Python, docs/python.md), converted with every option of a rig
//! command.

use super::rig::{ego_masks, run_rig_command, setup, RigArgs, RigChoice};
use anyhow::{bail, Result};
use clap::Args;
use panoconv::source::RigSource;
use panoconv::stream::{StreamPeer, WorldRigSource};
use std::io::BufReader;
use std::process::ExitCode;

pub(super) const RIG_STREAM_EXAMPLES: &str = "Examples:
  panoconv rig-stream --to equirect --pano-width 2048 --depth --output /tmp/rig_equi
  python acme.py /data/acme /tmp/acme_equi --to equirect  # docs/python.md: convert_rig(AcmeRig(..))
  python -m panoconv pandaset --input /data/pandaset/002 --to equirect --output /tmp/pandaset_equi

The peer (panoconv.convert_rig serving a Python RigSource; docs/python.md) answers `open` (name,
root, frames, cameras) and `read` (a frame in its world frame: cameras with world_from_camera,
boxes, LiDAR) on stdin, one JSON line each and then its raw LiDAR bytes. Output: as nuscenes:
OUT/training/{image_2,label_2,calib,source_2,objects}/ID.* and OUT/panoconv.json; the rect is the
level frame of the rig's first camera; calib has Tr_rect_to_world: (to the source's world).";

/// The azimuth step of a 10 Hz spinning LiDAR (Pandar64, HDL-64E at 0.17-0.2), degrees: the
/// default when the source does not state its own.
const DEFAULT_AZIMUTH_STEP_DEG: f64 = 0.2;

/// `panoconv rig-stream`.
#[derive(Args)]
pub(super) struct RigStreamArgs {
    /// Cameras to use, by the source's names, in this order [default: every camera of the
    /// source, in its order].
    #[arg(long, value_delimiter = ',', value_name = "NAME,...")]
    cameras: Option<Vec<String>>,
    /// Ego masks, one per camera (PNG, the camera's image size; non-zero = the vehicle's
    /// body): the camera gives no output pixel whose sample would touch its mask.
    #[arg(long, value_delimiter = ',', value_name = "NAME=PATH,...")]
    ego_mask: Vec<String>,
    /// Keep objects whose sensor-point count is 0 (left out by default, as the nuScenes
    /// detection evaluation does).
    #[arg(long)]
    keep_unseen: bool,
    /// The serving adapter's own options (how it reads its dataset, e.g. PandaSet's `--lidar`),
    /// as one text: recorded in the manifest's parameters, so `--resume` with other options is
    /// refused like any other changed parameter.
    #[arg(long, value_name = "TEXT")]
    source_options: Option<String>,
    #[command(flatten)]
    rig: RigArgs,
}

pub(super) fn rig_stream(args: RigStreamArgs) -> Result<ExitCode> {
    run_rig_command(&args.rig, || {
        let mut peer = StreamPeer::new(BufReader::new(std::io::stdin()), std::io::stdout());
        let rig = peer.open()?;
        let step = rig
            .lidar_azimuth_step_deg
            .unwrap_or(DEFAULT_AZIMUTH_STEP_DEG);
        let source = WorldRigSource::new(rig, peer)?
            .keeping_unseen(args.keep_unseen)
            .with_options(args.source_options.clone());
        let names: Vec<String> = source.cameras(0).iter().map(|c| c.name.clone()).collect();
        let cameras = chosen(&names, args.cameras.as_deref())?;
        let camera = |name: &str| {
            let k = names.iter().position(|c| c == name)?;
            cameras.contains(&k).then_some(k)
        };
        let expected: Vec<&str> = cameras.iter().map(|&k| names[k].as_str()).collect();
        let job = args.rig.job(RigChoice {
            command: "rig-stream",
            cameras: cameras.clone(),
            ego_masks: ego_masks(&args.ego_mask, camera, &expected.join(", "))?,
            lidar_azimuth_step_deg: step,
            min_points: 0,
        })?;
        Ok((job, source))
    })
}

/// The rig indices of `--cameras` (every camera when not given), each named camera one of
/// the source's.
fn chosen(names: &[String], given: Option<&[String]>) -> Result<Vec<usize>> {
    let Some(given) = given else {
        return Ok((0..names.len()).collect());
    };
    let mut out = Vec::new();
    for g in given.iter().map(|g| g.trim()) {
        match names.iter().position(|n| n == g) {
            Some(k) => out.push(k),
            None => bail!(setup(format!(
                "--cameras {g:?}: not a camera of the source (expected one of {})",
                names.join(", ")
            ))),
        }
    }
    Ok(out)
}
