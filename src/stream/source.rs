//! [`WorldRigSource`]: a [`RigSource`] over any [`WorldSource`], a rig whose frames come in
//! their dataset's world frame (a peer process serving a Python adapter, or a Rust one).

use super::world::WorldFrame;
use crate::error::{Error, Result};
use crate::source::{
    record_value, RigItem, RigItems, RigSource, SourceBox, SourceCamera, SourceFrame,
};
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// What a world-frame rig says of itself when opened.
#[derive(Debug, Clone)]
pub struct WorldRig {
    /// The command the manifest records (the adapter's name).
    pub name: String,
    /// The input folder: the manifest's input; inputs are recorded relative to it.
    pub root: PathBuf,
    /// The frame ids, each once (the output files are named by them).
    pub frames: Vec<String>,
    /// Frames the dataset lists whose files are not there (named, not converted).
    pub not_frames: Vec<String>,
    /// The camera set: every frame gives these cameras, in this order.
    pub cameras: Vec<SourceCamera>,
    /// The azimuth step of the rig's LiDAR, degrees, where the adapter states it.
    pub lidar_azimuth_step_deg: Option<f64>,
}

/// A rig that serves frames in its world frame. Reads come one at a time (`&mut self`):
/// [`WorldRigSource`] holds it behind a lock.
pub trait WorldSource: Send {
    /// Reads frame `id` (one of [`WorldRig::frames`]).
    fn read(&mut self, id: &str) -> Result<WorldFrame>;
}

/// A world-frame rig as a [`RigSource`]: one part, its camera set, its frames sorted by id.
pub struct WorldRigSource<S> {
    rig: WorldRig,
    command: &'static str,
    peer: Mutex<S>,
    keep_unseen: bool,
    options: Option<String>,
}

impl<S: WorldSource> WorldRigSource<S> {
    /// The source of `rig`, reading through `peer`. Frame ids must be unique, non-empty file
    /// names; the camera set non-empty, its names unique.
    pub fn new(rig: WorldRig, peer: S) -> Result<Self> {
        check_rig(&rig)?;
        // the manifest's command is a &'static str: one adapter name per process
        let command: &'static str = Box::leak(rig.name.clone().into_boxed_str());
        Ok(Self {
            rig,
            command,
            peer: Mutex::new(peer),
            keep_unseen: false,
            options: None,
        })
    }

    /// The same source keeping the boxes whose sensor-point count is 0 (left out by default,
    /// as nuScenes' evaluation does).
    pub fn keeping_unseen(mut self, keep: bool) -> Self {
        self.keep_unseen = keep;
        self
    }

    /// The same source with the adapter's own options (how it reads its dataset), recorded in
    /// the manifest so that a resume with other options is refused.
    pub fn with_options(mut self, options: Option<String>) -> Self {
        self.options = options;
        self
    }

    /// What the source said of itself.
    pub fn rig(&self) -> &WorldRig {
        &self.rig
    }
}

fn check_rig(rig: &WorldRig) -> Result<()> {
    let setup = |m: String| Err(Error::Setup(format!("source {}: {m}", rig.name)));
    let bad_name = |s: &str| {
        s.is_empty()
            || s.starts_with('.')
            || s.contains(['/', '\\', '\0', ':'])
            || s.chars().any(char::is_control)
    };
    if rig.name.is_empty() || rig.name.contains(char::is_whitespace) {
        return setup(format!("name {:?}: one word expected", rig.name));
    }
    if let Some(f) = rig.frames.iter().find(|f| bad_name(f)) {
        return setup(format!("frames: {f:?} is not a file name"));
    }
    let mut sorted = rig.frames.clone();
    sorted.sort();
    if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
        return setup(format!("frames: {:?} is listed twice", w[0]));
    }
    if rig.frames.is_empty() {
        return setup("frames: the source lists no frame".into());
    }
    if rig.cameras.is_empty() {
        return setup("cameras: the rig has no camera".into());
    }
    for (k, c) in rig.cameras.iter().enumerate() {
        if rig.cameras[..k].iter().any(|o| o.name == c.name) {
            return setup(format!("cameras[{k}].name: {:?} is named twice", c.name));
        }
    }
    Ok(())
}

impl<S: WorldSource> RigSource for WorldRigSource<S> {
    fn command(&self) -> &'static str {
        self.command
    }

    fn root(&self) -> &Path {
        &self.rig.root
    }

    fn parts(&self) -> usize {
        1
    }

    fn cameras(&self, _part: usize) -> &[SourceCamera] {
        &self.rig.cameras
    }

    fn items(&self, _cameras: &[usize]) -> Result<RigItems> {
        let mut ids = self.rig.frames.clone();
        ids.sort();
        let items = ids
            .into_iter()
            .enumerate()
            .map(|(i, id)| RigItem {
                id,
                part: 0,
                index: i as u64,
            })
            .collect();
        let mut not_frames = self.rig.not_frames.clone();
        not_frames.sort();
        Ok(RigItems { items, not_frames })
    }

    fn read(&self, item: &RigItem) -> Result<SourceFrame> {
        let world = self
            .peer
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .read(&item.id)?;
        let names: Vec<&str> = world.cameras.iter().map(|c| c.name.as_str()).collect();
        let set: Vec<&str> = self.rig.cameras.iter().map(|c| c.name.as_str()).collect();
        if names != set {
            return Err(super::world::frame_error(
                &self.rig.root,
                &item.id,
                "cameras",
                format!("{names:?}: the rig's cameras are {set:?}, in that order"),
            ));
        }
        let record = world.record.clone();
        let frame = world.into_frame(&item.id, &self.rig.root)?;
        Ok(SourceFrame { frame, record })
    }

    fn keeps(&self, _object: &SourceBox) -> bool {
        // the adapter chose each box's class
        true
    }

    fn drops_unseen(&self, object: &SourceBox) -> bool {
        !self.keep_unseen && object.sensor_points == Some(0)
    }

    fn parameters(&self) -> Map<String, Value> {
        let mut m = Map::new();
        m.insert("input".into(), record_value(&self.rig.root));
        m.insert("source".into(), record_value(&self.rig.name));
        m.insert("keep_unseen".into(), record_value(self.keep_unseen));
        // absent when not given: earlier manifests of other adapters stay valid for --resume
        if let Some(options) = &self.options {
            m.insert("source_options".into(), record_value(options));
        }
        m
    }

    fn frame_folder(&self, _item: &RigItem) -> PathBuf {
        self.rig.root.clone()
    }
}
