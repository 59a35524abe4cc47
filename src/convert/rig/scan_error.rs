//! A frame that fails on its LiDAR scan says what of the run reads the scan and how to do
//! without it: without `--depth`, a missing scan fails the frame only because the default
//! depth-guided stitch needs it, which the reader's own error (`FILE: No such file or
//! directory`) does not tell.

use super::job::RigSpec;
use crate::error::Error;
use crate::source::{RigItem, RigSource};

impl RigSpec {
    /// What of the run reads each frame's scan, each with the option that does without it
    /// (None: leave out `--depth`), in the order a message names them.
    fn scan_uses(&self) -> Vec<(String, Option<&'static str>)> {
        let mut uses = Vec::new();
        if self.run.depth.is_some() {
            uses.push(("--depth (depth_2/)".into(), None));
        }
        if self.objects.min_points > 0 {
            uses.push((
                format!(
                    "--min-points {} (the objects' LiDAR check)",
                    self.objects.min_points
                ),
                Some("--min-points 0"),
            ));
        }
        if self.depth_guided() {
            uses.push((
                "the depth-guided stitch (--stitch-mode depth, the default)".into(),
                Some("--stitch-mode fixed (every pixel at --stitch-distance)"),
            ));
        }
        uses
    }
}

/// `e`, a failure to read the frame of `item`, told what reads the scan when it is about the
/// frame's scan file; any other error as it is.
pub(super) fn explain_scan_error(
    job: &RigSpec,
    source: &dyn RigSource,
    item: &RigItem,
    e: Error,
) -> Error {
    let (path, reason) = match &e {
        Error::Io { path, cause } => (path, cause.to_string()),
        Error::File { path, message } => (path, message.clone()),
        Error::Parse {
            path,
            line,
            field,
            message,
        } => (path, format!("line {line}: {field}: {message}")),
        _ => return e,
    };
    let Some((scan, what)) = source.scan_file(item) else {
        return e;
    };
    let uses = job.scan_uses();
    if *path != scan || uses.is_empty() {
        return e;
    }
    let (names, flags): (Vec<String>, Vec<Option<&str>>) = uses.into_iter().unzip();
    let verb = if names.len() == 1 { "needs" } else { "need" };
    let flags: Vec<&str> = flags.into_iter().flatten().collect();
    let mut ways = Vec::new();
    if job.run.depth.is_some() {
        ways.push("leave out --depth".to_owned());
    }
    if !flags.is_empty() {
        ways.push(format!("pass {}", flags.join(" and ")));
    }
    Error::file(
        &scan,
        format!(
            "{what} cannot be read: {reason}; {} {verb} it: restore the file, or {}",
            and_list(&names),
            ways.join(" and ")
        ),
    )
}

/// `a`, `a and b`, `a, b and c`.
fn and_list(items: &[String]) -> String {
    match items.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
        _ => items.join(""),
    }
}
