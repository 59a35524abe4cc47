//! Running `panoconv kitti360`: the sequences opened and the selection checked before anything
//! is written, the output claimed, then each frame read, converted through the rig pass and
//! written (atomically, hashed for the manifest) in parallel on the rayon pool; a failed frame
//! leaves no file, is reported and recorded; then the manifest.

use super::gray::encode_gray8;
use super::kitti360::{
    drive_number, frame_id, Kitti360Job, Kitti360Summary, ObjectCounts, Parameters, SPLIT,
};
use super::pass::{convert_frame, CameraInfo};
use crate::codec::png;
use crate::error::{Error, Result};
use crate::fs;
use crate::kitti360::{Options, Sequence};
use crate::run::journal::{self, Journal, Previous};
use crate::run::manifest::{FrameRecord, FrameStatus, LidarRecord};
use crate::run::{OnceMap, Progress, Summary};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock};

/// The per-frame output folders under `OUT/training/`.
const FOLDERS: [&str; 6] = [
    "image_2", "calib", "label_2", "source_2", "objects", "depth_2",
];

/// One frame to convert.
struct Item {
    sequence: usize,
    frame: u32,
    id: String,
}

struct Ctx<'a> {
    job: &'a Kitti360Job,
    sequences: Vec<(Sequence, Vec<CameraInfo>)>,
    /// blake3 of the input files shared by frames (calibration, poses, boxes), by path.
    hashes: OnceMap<PathBuf, std::result::Result<String, String>>,
    objects: Mutex<ObjectCounts>,
}

fn relative(root: &Path, path: &Path) -> String {
    path.strip_prefix(root)
        .unwrap_or(path)
        .to_string_lossy()
        .replace('\\', "/")
}

impl Ctx<'_> {
    fn output_path(&self, folder: &str, id: &str, ext: &str) -> PathBuf {
        self.job
            .output
            .join(SPLIT)
            .join(folder)
            .join(format!("{id}.{ext}"))
    }

    /// Every file a frame may write.
    fn output_paths(&self, id: &str) -> Vec<PathBuf> {
        FOLDERS
            .iter()
            .map(|f| {
                let ext = if matches!(*f, "calib" | "label_2") {
                    "txt"
                } else if *f == "objects" {
                    "json"
                } else {
                    "png"
                };
                self.output_path(f, id, ext)
            })
            .collect()
    }

    fn input_hash(&self, path: &Path, per_frame: bool) -> Result<String> {
        if per_frame {
            return Ok(fs::hash_hex(&fs::read_file(path)?));
        }
        self.hashes
            .get_or_build(&path.to_path_buf(), || {
                fs::read_file(path)
                    .map(|b| fs::hash_hex(&b))
                    .map_err(|e| e.to_string())
            })
            .map_err(|m| Error::file(path, m))
    }

    fn convert(&self, item: &Item) -> Result<FrameRecord> {
        let (sequence, info) = &self.sequences[item.sequence];
        let job = self.job;
        let frame = sequence.frame(item.frame)?;
        let keep = |b: &crate::source::SourceBox| job.classes.keeps(&b.class, &b.dataset_class);
        let options = super::pass::RigOptions {
            cameras: job.cameras.clone(),
            stitch: job.stitch,
            centre: job.centre,
            objects: job.objects,
            depth: job.depth,
        };
        let out = convert_frame(&frame, info, &job.target, &options, &keep)?;
        let world_from_level = sequence.world_from_level(item.frame)?;
        let level_from_world = world_from_level.inverse().ok_or_else(|| {
            Error::file(
                &frame.provenance[0],
                format!("frame {}: singular pose", item.frame),
            )
        })?;
        let level_from_velo = level_from_world.compose(&sequence.world_from_velo(item.frame)?);
        let velo_from_imu = sequence.calibration.pose_from_velo().inverse();
        let calib = crate::kitti::rig_output::rig_calib_text(
            out.camera.as_ref(),
            &out.centre,
            &level_from_velo,
            velo_from_imu.as_ref(),
            frame.world_from_reference.as_ref(),
        );
        let mut labels = out.labels.join("\n");
        if !labels.is_empty() {
            labels.push('\n');
        }
        #[derive(serde::Serialize)]
        struct ObjectsFile<'a> {
            sequence: &'a str,
            frame: u32,
            gains: &'a [f64],
            counts: ObjectCounts,
            objects: &'a [super::objects::ObjectOutcome],
        }
        let counts = ObjectCounts::of(&out.objects);
        let objects = serde_json::to_vec_pretty(&ObjectsFile {
            sequence: &sequence.name,
            frame: item.frame,
            gains: &out.gains,
            counts,
            objects: &out.objects,
        })
        .expect("the objects record serialises");
        let size = out.camera.size();
        let compression = job.png_compression;
        let id = &item.id;
        let mut files: Vec<(PathBuf, Vec<u8>)> = vec![
            (
                self.output_path("image_2", id, "png"),
                png::encode_rgb8(&out.image, compression),
            ),
            (self.output_path("calib", id, "txt"), calib.into_bytes()),
            (self.output_path("label_2", id, "txt"), labels.into_bytes()),
            (
                self.output_path("source_2", id, "png"),
                encode_gray8(size.width, size.height, &out.source),
            ),
            (self.output_path("objects", id, "json"), objects),
        ];
        let mut lidar = None;
        if let Some((map, occluded)) = &out.depth {
            files.push((
                self.output_path("depth_2", id, "png"),
                png::encode_gray16(map.width, map.height, &map.to_u16(), compression),
            ));
            lidar = Some(LidarRecord {
                points: frame.lidar.len(),
                dropped_non_finite: 0,
                dropped_occluded: *occluded,
                depth_pixels: map.valid(),
            });
        }
        // the images of the cameras used, and every other input the frame read
        let unused: Vec<&PathBuf> = frame
            .rig
            .iter()
            .enumerate()
            .filter(|(k, _)| !job.cameras.contains(k))
            .map(|(_, c)| &c.image)
            .collect();
        let per_frame: Vec<&PathBuf> = frame.rig.iter().map(|c| &c.image).collect();
        let mut inputs = Vec::new();
        for path in frame.provenance.iter().filter(|p| !unused.contains(p)) {
            let own = per_frame.contains(&path) || path.extension().is_some_and(|e| e == "bin");
            inputs.push((relative(&job.input, path), self.input_hash(path, own)?));
        }
        let mut outputs = Vec::new();
        for (path, bytes) in &files {
            fs::write_atomic(path, bytes)?;
            outputs.push((relative(&job.output, path), fs::hash_hex(bytes)));
        }
        self.objects
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .add(&counts);
        Ok(FrameRecord {
            split: SPLIT.to_owned(),
            id: id.clone(),
            status: FrameStatus::Ok,
            error: None,
            inputs,
            outputs,
            views: Vec::new(),
            lidar,
        })
    }
}

/// The sequences, each with what the rig pass needs of its cameras.
fn open_sequences(job: &Kitti360Job) -> Result<Vec<(Sequence, Vec<CameraInfo>)>> {
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
        all_classes: job.classes != super::Kitti360Classes::Kitti,
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
fn select(job: &Kitti360Job, sequences: &[(Sequence, Vec<CameraInfo>)]) -> Result<Vec<Item>> {
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

/// An output camera that cannot be made (a scale too large, a crop of no pixel) is a set-up
/// error, not one error per frame: checked on the first frame that reads.
fn check_output_camera(
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

/// Runs a conversion. Set-up problems return `Err` before anything is written; a broken frame
/// is reported through `progress`, recorded in the manifest and counted in the summary.
/// `stop` (SIGINT, SIGTERM) ends the taking of frames. Must run inside the caller's rayon pool.
pub fn run_kitti360(
    job: &Kitti360Job,
    progress: &dyn Progress,
    stop: &AtomicBool,
) -> Result<Kitti360Summary> {
    let started = std::time::Instant::now();
    let sequences = open_sequences(job)?;
    let mut items = select(job, &sequences)?;
    check_output_camera(job, &sequences, &items)?;
    let _lock = journal::claim_output(
        &job.input,
        &job.output,
        job.shard,
        job.overwrite || job.resume || job.shard.is_some(),
    )?;
    if let Some(shard) = job.shard {
        items.retain(|i| shard.owns(SPLIT, &i.id));
    }
    let parameters = serde_json::to_value(Parameters::new(job)).expect("parameters serialise");
    let previous = if job.resume {
        journal::load_previous(&job.output, job.shard, &parameters)?
    } else {
        Previous::default()
    };
    if job.overwrite && !job.resume && job.shard.is_none() {
        crate::run::clear::clear_previous_run(&job.output)?;
    }
    for folder in FOLDERS {
        if folder == "depth_2" && job.depth.is_none() {
            continue;
        }
        let dir = job.output.join(SPLIT).join(folder);
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    }
    if job.resume {
        journal::remove_stale_temporaries(&job.output);
    }
    let ctx = Ctx {
        job,
        sequences,
        hashes: OnceMap::default(),
        objects: Mutex::new(ObjectCounts::default()),
    };
    let mut journal = Journal::new(
        &job.output,
        job.shard,
        "kitti360",
        parameters,
        job.resume,
        items.len(),
    )?;
    if job.resume && job.shard.is_none() {
        journal.keep_derived(journal::previous_derived(&job.output));
    }
    progress.start(items.len());
    let device_full: OnceLock<Error> = OnceLock::new();
    let (taken, resumed) = (AtomicUsize::new(0), AtomicUsize::new(0));
    items.par_iter().for_each(|item| {
        if stop.load(Ordering::Relaxed) || device_full.get().is_some() {
            return;
        }
        taken.fetch_add(1, Ordering::Relaxed);
        if let Some(r) = previous.get(SPLIT, &item.id) {
            if journal::still_valid(&r, &job.input, &job.output) {
                journal.record(r);
                resumed.fetch_add(1, Ordering::Relaxed);
                progress.frame_done();
                return;
            }
        }
        let record = match ctx.convert(item) {
            Ok(record) => {
                progress.frame_done();
                record
            }
            Err(e) => {
                // a failed frame leaves no output, not even one of an earlier run
                for p in ctx.output_paths(&item.id) {
                    let _ = std::fs::remove_file(p);
                }
                if e.is_device_full() {
                    let _ = device_full.set(e);
                    taken.fetch_sub(1, Ordering::Relaxed);
                    return;
                }
                let name = format!("{}/{}", SPLIT, item.id);
                progress.frame_failed(&name, &e);
                FrameRecord::failed(SPLIT, &item.id, &e)
            }
        };
        journal.record(record);
    });
    progress.finish();
    let taken = taken.into_inner();
    let interrupted = taken < items.len();
    let device_full = device_full.into_inner().map(|e| {
        format!(
            "output device full after {taken} of {} frames ({e}): free space and run again with --resume",
            items.len()
        )
    });
    let finished = journal
        .finish(!interrupted)
        .map_err(|e| match &device_full {
            Some(full) => Error::DeviceFull(format!(
                "{full}; the manifest could not be written either ({e})"
            )),
            None => e,
        })?;
    let objects = *ctx.objects.lock().unwrap_or_else(|e| e.into_inner());
    Ok(Kitti360Summary {
        run: Summary {
            frames: finished.frames,
            converted: finished.frames - finished.failed,
            failed: finished.failed,
            resumed: resumed.into_inner(),
            interrupted: interrupted && device_full.is_none(),
            device_full,
            seconds: started.elapsed().as_secs_f64(),
            tables_built: 0,
        },
        objects,
    })
}
