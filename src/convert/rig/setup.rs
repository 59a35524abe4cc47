//! What a rig run checks before anything is written, whatever the dataset: the cameras chosen
//! against the source's camera sets, the ego masks, the output camera (on the first frame the
//! run converts).
//! Every problem here is a set-up error.

use super::job::{EgoMaskRecord, RigJob};
use super::pass::output_camera;
use crate::error::{Error, Result};
use crate::fs;
use crate::source::{RigItem, RigSource, SourceFrame};
use crate::warp::EgoMask;
use std::sync::Arc;

/// Ego masks by rig index (None: the camera has none).
pub(super) type Masks = Vec<Option<Arc<EgoMask>>>;

/// Every chosen camera is in every part's camera set.
pub(super) fn check_cameras(job: &RigJob, source: &dyn RigSource) -> Result<()> {
    for part in 0..source.parts() {
        let cameras = source.cameras(part);
        if let Some(k) = job.cameras.iter().find(|&&k| k >= cameras.len()) {
            let names: Vec<&str> = cameras.iter().map(|c| c.name.as_str()).collect();
            return Err(Error::Setup(format!(
                "camera {k}: the rig's cameras are 0 to {} ({})",
                cameras.len().saturating_sub(1),
                names.join(", ")
            )));
        }
    }
    Ok(())
}

/// The ego masks of `job` by rig index, and their manifest records: each mask must belong to a
/// chosen camera, once, and have its image size in every part (an error names the file).
pub(super) fn read_ego_masks(
    job: &RigJob,
    source: &dyn RigSource,
) -> Result<(Masks, Vec<EgoMaskRecord>)> {
    let count = (0..source.parts())
        .map(|p| source.cameras(p).len())
        .max()
        .unwrap_or(0);
    let mut masks: Masks = vec![None; count];
    let mut records = Vec::new();
    for (k, path) in &job.ego_masks {
        let name = source
            .cameras(0)
            .get(*k)
            .map(|c| c.name.clone())
            .ok_or_else(|| {
                Error::file(path, format!("an ego mask for camera {k}: no such camera"))
            })?;
        if !job.cameras.contains(k) {
            return Err(Error::file(
                path,
                format!("an ego mask for {name}, which --cameras does not use"),
            ));
        }
        if masks[*k].is_some() {
            return Err(Error::file(path, format!("a second ego mask for {name}")));
        }
        // read once: the record's hash and the mask come from the same bytes
        let bytes = fs::read_file(path)?;
        let image = crate::codec::decode_rgb8(&bytes, path)?;
        let mut mask: Option<EgoMask> = None;
        for part in 0..source.parts() {
            let size = source.cameras(part)[*k].size;
            // a part of another image size fails here, naming the mask's size and the camera's
            if mask.as_ref().is_none_or(|m| m.size() != size) {
                mask = Some(EgoMask::from_image(&image, path, size)?);
            }
        }
        records.push(EgoMaskRecord {
            camera: name,
            path: path.clone(),
            hash: fs::hash_hex(&bytes),
        });
        masks[*k] = mask.map(Arc::new);
    }
    Ok((masks, records))
}

/// An output camera that cannot be made (a scale too large, a crop of no pixel) is a set-up
/// error, not one error per frame: checked on `first`, the first frame the run converts, as it
/// was read (a frame that does not read fails on its own, counted).
pub(super) fn check_output_camera(
    job: &RigJob,
    source: &dyn RigSource,
    item: &RigItem,
    first: &Result<SourceFrame>,
) -> Result<()> {
    let Ok(read) = first else {
        return Ok(());
    };
    let info: Vec<_> = source.cameras(item.part).iter().map(|c| c.info).collect();
    output_camera(&read.frame, &info, &job.target, &job.cameras)
        .map(|_| ())
        .map_err(|e| Error::Setup(format!("the output camera of frame {}: {e}", item.id)))
}
