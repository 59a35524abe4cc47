//! nuScenes' format (and the datasets written in it): the tables of a version
//! (`DATAROOT/VERSION/*.json`), streamed and indexed for a selection of scenes and cameras
//! (`dataset.rs`), and a reader that yields each sample as a neutral [`crate::source::Frame`]
//! in its level frame, every sensor placed by its own reading's ego pose (`frame.rs`); the
//! class table to KITTI's types (`classes.rs`). See docs/nuscenes.md.

pub mod classes;
mod dataset;
mod frame;
mod json;
pub mod lidar;
mod listed;
mod records;
mod source;
mod tables;
mod token;
mod velocity;

pub use dataset::{
    table_path, versions, NuScenes, SceneEntry, Selection, NUSCENES_CAMERAS, REFERENCE_CAMERA,
    REFERENCE_LIDAR,
};
pub use frame::{Item, NuScenesFrame, ObjectInfo, Options};
pub use source::{NuScenesClasses, NuScenesSelection, NuScenesSource};
pub use token::Token;
