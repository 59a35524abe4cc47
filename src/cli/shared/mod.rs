//! The floor under the commands: what every command file shares, so that a command imports
//! this module (and a rig command `cli/rig.rs`) and never its parent or a sibling command.
//!
//! - `run.rs`: the run options (`RunArgs`), the progress bar (`Bar`), the worker pool
//!   (`with_pool`), the stop on SIGINT/SIGTERM (`STOP`);
//! - `outcome.rs`: the exit codes, a run's summary lines and `count`;
//! - `parse.rs`: the value parsers (`parse_size`, `parse_crop`, `parse_shard`, `parse_range`);
//! - `target.rs`: `--to` and the output scale;
//! - `augment.rs`: `--augment` and `--min-visible`;
//! - `style.rs`: `--style` and its model options;
//! - `export_after.rs`: the export files and their report (`export`, `--export`);
//! - `derived.rs`: files a tool writes inside a converted dataset, recorded in its manifest.

pub(crate) mod augment;
pub(crate) mod derived;
pub(crate) mod export_after;
pub(crate) mod outcome;
pub(crate) mod parse;
pub(crate) mod run;
pub(crate) mod style;
pub(crate) mod target;
