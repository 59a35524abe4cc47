//! The dataset seam: [`RigSource`], what a rig command needs from a dataset, whatever its files
//! look like.
//!
//! A rig dataset (KITTI-360, nuScenes) is opened once with its selection (sequences or scenes,
//! frames, the per-camera options its cameras take) and then offers: its parts (a sequence, a
//! scene), each part's camera set ([`SourceCamera`]: the name, the scale an output keeps by
//! default, the lens's field of view, the image size), the frames under the selection as
//! [`RigItem`]s with a stable output id each, and `read(item)`: one [`SourceFrame`], the
//! [`Frame`] holding everything a writer needs (the rig, the boxes, the LiDAR points, the
//! sensor transforms, the hashes of the files that the read took) with the dataset's fields of
//! its objects record, made from the same read. The run reads each frame once and hands that
//! read to every step that needs it (the output-camera check, each output view): an adapter
//! rebuilds nothing per view, and an error in a read is the frame's error. The generic rig run (`convert::rig::run_rig`)
//! does the rest (output folder, style, augment, stitch, labels, depth, manifest) for any
//! dataset; what differs between datasets stays in its adapter, next to its reader.

use super::{Frame, SourceBox};
use crate::camera::{ImageSize, Intrinsics};
use crate::error::Result;
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};

/// What a reader knows of a rig camera besides its model and pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraInfo {
    /// Pixels per radian and principal point at the image centre (the scale an output keeps
    /// by default).
    pub focal: Intrinsics,
    /// Half the field of view of a lens that has one, radians.
    pub max_theta: Option<f64>,
}

/// One camera of a part's rig, by its index in every frame's `rig` of that part.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceCamera {
    /// The dataset's name for it (`image_00`, `CAM_FRONT`): the manifest records it.
    pub name: String,
    /// Its default output scale and field of view.
    pub info: CameraInfo,
    /// Its images' size (an ego mask must have it).
    pub size: ImageSize,
}

/// One frame of the selection.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RigItem {
    /// The output id: the frame's files are named by it. Stable: the same frame has the same
    /// id whatever the shard, a resume, or the other frames selected.
    pub id: String,
    /// The part (sequence, scene) it belongs to: an index below [`RigSource::parts`].
    pub part: usize,
    /// The adapter's own index of the frame within its part (KITTI-360: the frame number;
    /// nuScenes: the sample's place in its scene).
    pub index: u64,
}

/// The frames of a selection, and what the dataset lists that is not a frame.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RigItems {
    /// The frames, each id once, sorted by id.
    pub items: Vec<RigItem>,
    /// What the dataset lists without the files of a frame (a KITTI-360 pose without an image
    /// of a chosen camera: `sequence/frame`), ascending: named in the summary, not failures.
    pub not_frames: Vec<String>,
}

/// One frame as a [`RigSource`] read it.
#[derive(Debug, Clone)]
pub struct SourceFrame {
    /// The neutral frame.
    pub frame: Frame,
    /// The first fields of each of its views' `objects/ID.json` (which frame of the dataset it
    /// is: `"sequence"` and `"frame"`, or `"scene"`, `"sample_token"` and what the dataset
    /// says of each object, in `frame.objects`' order).
    pub record: Map<String, Value>,
}

/// A rig dataset opened with its selection. `Sync`: frames are read on rayon's workers.
pub trait RigSource: Sync {
    /// The command's name, as the manifest records it (`kitti360`).
    fn command(&self) -> &'static str;

    /// The dataset root: the manifest's input; inputs are recorded relative to it.
    fn root(&self) -> &Path;

    /// How many parts (sequences, scenes) the selection holds.
    fn parts(&self) -> usize;

    /// The camera set of a part: index k is `rig[k]` of each of its frames.
    fn cameras(&self, part: usize) -> &[SourceCamera];

    /// The frames under the selection that have the images of the chosen `cameras` (indices
    /// into [`RigSource::cameras`]), each id once, sorted by id, and the listed frames that
    /// lack one. An empty or contradictory selection, or one that names a frame without its
    /// images, is a set-up error (`Error::Setup`).
    fn items(&self, cameras: &[usize]) -> Result<RigItems>;

    /// Reads one frame: its rig (image paths, not pixels: the run decodes the chosen cameras'
    /// images and hashes those bytes), its boxes in the reference frame, its LiDAR points
    /// when the source was opened to read them, its sensor transforms and the hashes of the
    /// per-frame files it read (`Frame::input_hashes`), with its objects record's fields.
    /// Called once per frame and run; any problem is the frame's error.
    fn read(&self, item: &RigItem) -> Result<SourceFrame>;

    /// Which of a frame's boxes are the dataset's objects (labelled or dropped, and listed in
    /// `objects/ID.json`) when it also reads others as scenery for a depth-guided stitch; None:
    /// every box is.
    fn listed(&self) -> Option<fn(&SourceBox) -> bool> {
        None
    }

    /// Whether a box of this class is written (the dataset's class table and the selection's
    /// classes); the others are dropped for their class.
    fn keeps(&self, object: &SourceBox) -> bool;

    /// The label types besides KITTI's that the written labels may carry (the categories the
    /// selection's classes add, named as written), in a fixed order: an export after the
    /// conversion gives each a category of its own.
    fn label_types(&self) -> Vec<String> {
        Vec::new()
    }

    /// Whether a box is left out because the dataset's own count says no sensor saw it
    /// ([`SourceBox::sensor_points`] is 0) and the selection leaves such boxes out (nuScenes'
    /// evaluation rule); counted as unseen.
    fn drops_unseen(&self, _object: &SourceBox) -> bool {
        false
    }

    /// The dataset's fields of the manifest's `parameters` (input, selection, per-camera
    /// options): the run adds its own (output, stitch, objects, depth, style, ...).
    fn parameters(&self) -> Map<String, Value>;

    /// The order of the manifest's `parameters` keys, the dataset's and the run's together;
    /// keys not named keep their place after those named. Empty: the dataset's first.
    fn parameter_order(&self) -> &'static [&'static str] {
        &[]
    }

    /// The folder named when a frame fails without a file of its own to name (a panic, a
    /// style pass over the group).
    fn frame_folder(&self, item: &RigItem) -> PathBuf;

    /// The LiDAR scan the frame of `item` reads, when the source was opened to read scans:
    /// its file and its name in a message (`sample TOKEN's LIDAR_TOP sweep`). A frame that
    /// fails on that file is told what of the run reads it and how to do without it. None:
    /// no scan is read, or the source names none.
    fn scan_file(&self, _item: &RigItem) -> Option<(PathBuf, String)> {
        None
    }
}

/// A value a manifest or an objects record holds, serialised (the selections' and records'
/// types always serialise).
pub fn record_value(v: impl serde::Serialize) -> Value {
    serde_json::to_value(v).expect("record values serialise")
}
