//! How a conversion's run ends on the command line, for every converting command: the summary
//! line and the one mapping from a run's summary to its exit code.

use panoconv::run::Summary;
use std::path::Path;
use std::process::ExitCode;

/// Exit codes: some items failed (or the device filled), a set-up error, interrupted.
pub(crate) const EXIT_FRAMES_FAILED: u8 = 1;
pub(crate) const EXIT_SETUP: u8 = 2;
pub(crate) const EXIT_INTERRUPTED: u8 = 130;

/// `1 frame`, `2 frames`.
pub(crate) fn count(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// The summary line: items converted (kept from a previous run), failed, time, rate, output.
pub(crate) fn report(run: &Summary, noun: &str, output: &Path) {
    let resumed = if run.resumed > 0 {
        format!(" ({} kept from the previous run)", run.resumed)
    } else {
        String::new()
    };
    if run.converted == 0 && run.failed > 0 {
        // no rate of nothing; and the folder holds no dataset, only the failures' record
        eprintln!(
            "panoconv: 0 {noun}s converted, {} failed in {:.2} s: nothing written to {} but \
             its manifest, which records the failures",
            run.failed,
            run.seconds,
            output.display(),
        );
        return;
    }
    eprintln!(
        "panoconv: {} converted{resumed}, {} failed in {:.2} s ({}) -> {}",
        count(run.converted, noun),
        run.failed,
        run.seconds,
        rate(run.converted - run.resumed, run.seconds, noun),
        output.display()
    );
}

/// The style pass's line: images styled in how many model runs, if styled.
pub(crate) fn report_style(style_runs: Option<(usize, usize)>) {
    if let Some((runs, images)) = style_runs {
        eprintln!(
            "panoconv: style pass: {} in {}",
            count(images, "image"),
            count(runs, "model run")
        );
    }
}

/// The speed of a run: `12.3 frames/s`, or `4.2 s/frame` when under one item a second (where
/// a rate would round to `0.0`).
fn rate(items: usize, seconds: f64, noun: &str) -> String {
    let per_second = items as f64 / seconds.max(1e-9);
    if items == 0 || per_second >= 1.0 {
        format!("{per_second:.1} {noun}s/s")
    } else {
        format!("{:.1} s/{noun}", seconds / items as f64)
    }
}

/// The exit code of a run that stopped short or failed items (1: a full device, a lost source
/// or failed items, 130: interrupted), saying why; None when every item was converted (the caller may
/// go on, e.g. to `--export`, and then exits 0).
pub(crate) fn exit_code(run: &Summary) -> Option<ExitCode> {
    if let Some(stopped) = run.device_full.as_ref().or(run.source_lost.as_ref()) {
        eprintln!("panoconv: {stopped}");
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

#[cfg(test)]
mod tests {
    use super::rate;

    #[test]
    fn a_slow_run_reports_seconds_per_frame_not_a_zero_rate() {
        assert_eq!(rate(6, 0.5, "frame"), "12.0 frames/s");
        assert_eq!(rate(1, 1.0, "frame"), "1.0 frames/s");
        assert_eq!(rate(2, 50.0, "frame"), "25.0 s/frame");
        assert_eq!(rate(3, 1000.0, "image"), "333.3 s/image");
        assert_eq!(rate(0, 3.0, "frame"), "0.0 frames/s");
    }
}
