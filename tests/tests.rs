//! The integration tests, one crate: every file of tests/ is a module here, so the suite links
//! once instead of once per file. Run one file's tests with `cargo test --test tests FILE::`
//! (for example `cargo test --test tests corpus::`).
//!
//! Proptest keeps its regression files next to the file that holds the test
//! (`tests/FILE.proptest-regressions`), whatever the crate root.

mod common;
mod opencv_ref;

mod architecture;
mod camera;
mod camera_files;
mod camera_lens;
mod camera_models;
mod camera_models_random;
mod choices;
mod cli;
mod completions;
mod corpus;
mod crop;
mod dataset_truth;
mod depth;
mod eval_depth;
mod export;
mod export_classes;
mod failed_run_output;
mod first_contact;
mod first_run;
mod fisheye;
mod fisheye_pyramid;
mod fisheye_target;
mod footprint;
mod fuzz_parsers;
mod help_examples;
mod inspect;
mod inspect_pandaset;
mod inspect_rig_output;
mod kitti360;
mod kitti360_command;
mod kitti360_options;
mod kitti360_scripts;
mod kitti360_stitch;
mod kitti_benchmark;
mod labels;
mod labels_meant;
mod missing_scan;
mod nuscenes;
mod nuscenes_command;
mod nuscenes_depth_stitch;
mod nuscenes_devkit;
mod nuscenes_stitch;
mod pandaset;
mod pano;
mod pano_pyramid;
mod png;
mod png_rows;
mod preview;
mod preview_text;
mod raw;
mod resume;
mod rig_canvas;
mod rig_coverage;
mod rig_mask;
mod rig_plugin;
mod rig_stream;
mod rig_uncovered;
mod sample;
mod scale;
mod setup_text;
mod stitch_cache;
mod style;
mod style_batch;
mod style_cli;
mod table_parts;
mod tidy;
mod truncated_images;
mod trust;
mod unproject;
mod unproject_rig;
mod vehicle_box;
mod verify;
mod warp;
