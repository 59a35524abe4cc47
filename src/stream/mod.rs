//! Rig frames served in their dataset's world frame, by another process or by Rust code: the
//! [`RigSource`](crate::source::RigSource) of a dataset whose reader is not in this crate.
//!
//! A [`WorldSource`] gives each frame as a [`WorldFrame`]: cameras with their poses, boxes,
//! LiDAR points in the world frame (metres, z up). [`WorldRigSource`] turns it into the
//! seam's neutral frames, in the level frame of the rig's first camera (the frame `kitti360`
//! and `nuscenes` write), so that every rule of a rig run applies unchanged. [`StreamPeer`]
//! is a `WorldSource` over a pipe: `panoconv rig-stream` serves a Python adapter through it
//! (docs/python.md), each field of each answer checked here.

mod decode;
mod peer;
mod source;
mod world;

pub use peer::{StreamPeer, PROTOCOL};
pub use source::{WorldRig, WorldRigSource, WorldSource};
pub use world::{box_from_yaw, frame_error, WorldBox, WorldCamera, WorldFrame};
