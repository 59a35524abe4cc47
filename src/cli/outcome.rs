//! How a conversion's run ends on the command line, for every converting command: the summary
//! line and the one mapping from a run's summary to its exit code.

use super::{count, EXIT_FRAMES_FAILED, EXIT_INTERRUPTED};
use panoconv::run::Summary;
use std::path::Path;
use std::process::ExitCode;

/// The summary line: items converted (kept from a previous run), failed, time, rate, output.
pub(super) fn report(run: &Summary, noun: &str, output: &Path) {
    let resumed = if run.resumed > 0 {
        format!(" ({} kept from the previous run)", run.resumed)
    } else {
        String::new()
    };
    eprintln!(
        "panoconv: {} converted{resumed}, {} failed in {:.2} s ({:.1} {noun}s/s) -> {}",
        count(run.converted, noun),
        run.failed,
        run.seconds,
        (run.converted - run.resumed) as f64 / run.seconds.max(1e-9),
        output.display()
    );
}

/// The exit code of a run that stopped short or failed items (1: a full device or failed
/// items, 130: interrupted), saying why; None when every item was converted (the caller may
/// go on, e.g. to `--export`, and then exits 0).
pub(super) fn exit_code(run: &Summary) -> Option<ExitCode> {
    if let Some(full) = &run.device_full {
        eprintln!("panoconv: {full}");
        return Some(ExitCode::from(EXIT_FRAMES_FAILED));
    }
    if run.interrupted {
        eprintln!(
            "panoconv: interrupted; the manifest lists the finished frames: run again with \
             --resume"
        );
        return Some(ExitCode::from(EXIT_INTERRUPTED));
    }
    (run.failed > 0).then(|| ExitCode::from(EXIT_FRAMES_FAILED))
}
