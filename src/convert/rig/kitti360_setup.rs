//! What `panoconv kitti360` opens and checks before anything is written: the sequences and
//! their cameras, the selection of frames with their ids, the ego masks, the output camera (on
//! the first frame) and the style model. Every problem here is a set-up error.

use super::kitti360::{drive_number, frame_id, EgoMaskRecord, Kitti360Job};
use super::pass::CameraInfo;
use crate::error::{Error, Result};
use crate::fs;
use crate::kitti360::{Options, Sequence};
use crate::style::{Device, StyleModel, StyleOptions};
use crate::warp::EgoMask;
use std::sync::Arc;

/// One frame to convert.
pub(super) struct Item {
    pub(super) sequence: usize,
    pub(super) frame: u32,
    pub(super) id: String,
}

/// Ego masks by rig index (None: the camera has none).
type Masks = Vec<Option<Arc<EgoMask>>>;

/// The sequences, each with what the rig pass needs of its cameras.
pub(super) fn open_sequences(job: &Kitti360Job) -> Result<Vec<(Sequence, Vec<CameraInfo>)>> {
    if job.sequences.is_empty() {
        return Err(Error::Setup("no sequence given".into()));
    }
    if job.cameras.is_empty() || job.cameras.iter().any(|&k| k > 3) {
        return Err(Error::Setup(
            "cameras are 00, 01, 02 and 03 (image_00 to image_03)".into(),
        ));
    }
    if !job.input.is_dir() {
        return Err(Error::Setup(format!(
            "input {} is not a directory",
            job.input.display()
        )));
    }
    let options = Options {
        fisheye_fov_deg: job.fisheye_fov_deg,
        lidar: job.needs_lidar(),
        // every class's box is scenery for the depth-guided stitch
        all_classes: job.classes != super::Kitti360Classes::Kitti || job.depth_guided(),
        // the reader's default (motion-compensated sweeps) until the command has an option
        ..Options::default()
    };
    let mut out = Vec::new();
    for name in &job.sequences {
        let seq = Sequence::open(&job.input, name, options)?;
        let c = &seq.calibration;
        let info = vec![
            CameraInfo {
                focal: c.perspective[0].model.k,
                max_theta: None,
            },
            CameraInfo {
                focal: c.perspective[1].model.k,
                max_theta: None,
            },
            CameraInfo {
                focal: c.fisheye[0].centre_intrinsics(),
                max_theta: Some(c.fisheye[0].max_theta()),
            },
            CameraInfo {
                focal: c.fisheye[1].centre_intrinsics(),
                max_theta: Some(c.fisheye[1].max_theta()),
            },
        ];
        out.push((seq, info));
    }
    Ok(out)
}

/// The frames to convert, with their ids; several sequences need distinct drive numbers.
pub(super) fn select(
    job: &Kitti360Job,
    sequences: &[(Sequence, Vec<CameraInfo>)],
) -> Result<Vec<Item>> {
    let several = sequences.len() > 1;
    let mut drives = Vec::new();
    let mut items = Vec::new();
    for (i, (seq, _)) in sequences.iter().enumerate() {
        let drive = if several {
            let d = drive_number(&seq.name).ok_or_else(|| {
                Error::Setup(format!(
                    "sequence {:?} has no drive number (_drive_NNNN_): several sequences are \
                     told apart by it in the frame ids",
                    seq.name
                ))
            })?;
            if drives.contains(&d) {
                return Err(Error::Setup(format!(
                    "two sequences have drive number {d}: their frame ids would collide"
                )));
            }
            drives.push(d);
            Some(d)
        } else {
            None
        };
        let frames = match &job.frames {
            Some(list) => list.clone(),
            None => seq.frames(),
        };
        for frame in frames {
            if several && frame >= 1_000_000 {
                return Err(Error::Setup(format!(
                    "frame {frame} of {} has more than six digits: it has no id when several \
                     sequences share an output",
                    seq.name
                )));
            }
            items.push(Item {
                sequence: i,
                frame,
                id: frame_id(drive, frame),
            });
        }
    }
    if items.is_empty() {
        return Err(Error::Setup("the selection holds no frame".into()));
    }
    items.sort_by(|a, b| a.id.cmp(&b.id));
    if let Some(w) = items.windows(2).find(|w| w[0].id == w[1].id) {
        return Err(Error::Setup(format!(
            "frame {} is asked for twice",
            w[0].id
        )));
    }
    Ok(items)
}

/// The ego masks of `job` by rig index, and their manifest records: each mask must belong to a
/// chosen camera, once, and have its image size in every sequence (an error names the file).
pub(super) fn read_ego_masks(
    job: &Kitti360Job,
    sequences: &[(Sequence, Vec<CameraInfo>)],
) -> Result<(Masks, Vec<EgoMaskRecord>)> {
    let mut masks: Masks = vec![None; 4];
    let mut records = Vec::new();
    for (k, path) in &job.ego_masks {
        let name = crate::kitti360::CAMERAS.get(*k).ok_or_else(|| {
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
        let mut mask = None;
        for (seq, _) in sequences {
            let c = &seq.calibration;
            let size = match k {
                0 | 1 => crate::camera::CameraModel::size(&c.perspective[*k].model),
                _ => crate::camera::CameraModel::size(&c.fisheye[*k - 2]),
            };
            let m = EgoMask::read(path, size)?;
            if mask.as_ref().is_some_and(|old| *old != m) {
                return Err(Error::file(
                    path,
                    "the sequences' images differ in size".to_owned(),
                ));
            }
            mask = Some(m);
        }
        let bytes = fs::read_file(path)?;
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
/// error, not one error per frame: checked on the first frame that reads.
pub(super) fn check_output_camera(
    job: &Kitti360Job,
    sequences: &[(Sequence, Vec<CameraInfo>)],
    items: &[Item],
) -> Result<()> {
    let Some(item) = items.first() else {
        return Ok(());
    };
    let (sequence, info) = &sequences[item.sequence];
    // (a frame that does not read fails on its own, counted)
    let Ok(frame) = sequence.frame(item.frame) else {
        return Ok(());
    };
    super::pass::output_camera(&frame, info, &job.target, job.cameras[0])
        .map(|_| ())
        .map_err(|e| Error::Setup(format!("the output camera of frame {}: {e}", item.id)))
}

/// The style model's sessions, loaded before anything is written (a missing model or ONNX
/// Runtime library is a set-up error): on the CPU one session per worker with one thread each,
/// so --jobs alone sets the core count; on a GPU two (one runs while the other's input is
/// prepared), as `kitti` loads them.
pub(super) fn load_style(job: &Kitti360Job) -> Result<Option<StyleModel>> {
    let Some(s) = &job.style else {
        return Ok(None);
    };
    // The model is the user's own file: name it missing before asking for the runtime.
    if !s.model.is_file() {
        return Err(Error::Setup(format!(
            "--style {}: no such model file",
            s.model.display()
        )));
    }
    let options = StyleOptions {
        intra_threads: 1,
        ..s.clone()
    };
    let workers = rayon::current_num_threads();
    let sessions = match options.device {
        Device::Cpu => workers,
        Device::Cuda => workers.min(2),
    };
    Ok(Some(StyleModel::load_pool(&options, sessions)?))
}
