//! How a command runs: the options every converting command shares ([`RunArgs`]), the
//! progress bar, the one worker pool, and the stop on SIGINT/SIGTERM.

use super::outcome::EXIT_INTERRUPTED;
use anyhow::{bail, Context as _, Result};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use panoconv::codec::png::PngCompression;
use panoconv::error::Error;
use panoconv::run::Progress;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};

/// How a run is carried out, shared by every converting subcommand.
#[derive(Args)]
pub(crate) struct RunArgs {
    /// Worker threads (default: all cores).
    #[arg(long, short = 'j', value_name = "N")]
    pub(crate) jobs: Option<usize>,
    /// Replace a previous run's output: the files its manifest or journal lists are removed
    /// first (the result is what a run into an empty folder leaves); any other file there is
    /// named and refused.
    #[arg(long)]
    pub(crate) overwrite: bool,
    /// PNG compression effort.
    #[arg(long, value_enum, default_value_t = CompressionArg::Default)]
    png_compression: CompressionArg,
    /// No progress bar and no summary line.
    #[arg(long, short = 'q')]
    pub(crate) quiet: bool,
}

impl RunArgs {
    /// The encoder setting `--png-compression` names.
    pub(crate) fn png_compression(&self) -> PngCompression {
        match self.png_compression {
            CompressionArg::Fast => PngCompression::Fast,
            CompressionArg::Default => PngCompression::Default,
            CompressionArg::Best => PngCompression::Best,
        }
    }
}

/// `--png-compression`'s values (the library's `PngCompression` knows nothing of clap).
#[derive(Clone, Copy, ValueEnum)]
enum CompressionArg {
    Fast,
    Default,
    Best,
}

/// An indicatif bar on a terminal; nothing at all otherwise (logs stay clean), unless
/// `PANOCONV_PROGRESS=lines` asks for the notes of long steps as lines (for logs and tests).
pub(crate) struct Bar {
    bar: ProgressBar,
    /// What an item is called in messages: `frame`, or `image` for folder conversions.
    noun: &'static str,
    lines: bool,
}

impl Bar {
    pub(crate) fn new(quiet: bool) -> Self {
        Self::counting(quiet, "frame")
    }

    /// A bar whose items are called `noun` (`image`: a folder conversion's).
    pub(crate) fn counting(quiet: bool, noun: &'static str) -> Self {
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
        let terminal = std::io::stderr().is_terminal();
        if quiet || !terminal {
            bar.set_draw_target(ProgressDrawTarget::hidden());
        }
        let lines = !quiet
            && !terminal
            && std::env::var_os("PANOCONV_PROGRESS").is_some_and(|v| v == "lines");
        bar.set_style(
            ProgressStyle::with_template(
                &format!("{{spinner}} [{{elapsed_precise}}] {{bar:40}} {{pos}}/{{len}} {noun}s ({{rate}}, eta {{eta}}) {{msg}}"),
            )
            .expect("valid template")
            .with_key(
                "rate",
                |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = write!(w, "{:.1}/s", state.per_sec());
                },
            ),
        );
        Self { bar, noun, lines }
    }
}

impl Progress for Bar {
    fn start(&self, total: usize) {
        self.bar.set_length(total as u64);
    }
    fn frame_done(&self) {
        self.bar.inc(1);
    }
    fn note(&self, message: &str) {
        // a spinner that moves while the step runs, so the bar does not sit still at 0/N
        if message.is_empty() {
            self.bar.disable_steady_tick();
        } else if !self.bar.is_hidden() {
            self.bar
                .enable_steady_tick(std::time::Duration::from_millis(120));
        }
        self.bar.set_message(message.to_owned());
        if self.lines && !message.is_empty() {
            eprintln!("panoconv: {message}");
        }
    }
    fn frame_failed(&self, item: &str, error: &Error) {
        self.bar
            .suspend(|| eprintln!("panoconv: {} {item} failed: {error}", self.noun));
        self.bar.inc(1);
    }
    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// Runs `body` on a pool of `jobs` threads: the one place threads are made.
pub(crate) fn with_pool<T: Send>(
    jobs: Option<usize>,
    body: impl FnOnce() -> T + Send,
) -> Result<T> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = jobs {
        if n == 0 {
            bail!(Error::Setup("--jobs must be at least 1".into()));
        }
        builder = builder.num_threads(n);
    }
    let pool = builder.build().context("cannot start worker threads")?;
    Ok(pool.install(body))
}

/// Set by SIGINT/SIGTERM: the conversion takes no new frame, finishes those in flight and
/// writes its manifest.
pub(crate) static STOP: AtomicBool = AtomicBool::new(false);

pub(crate) fn install_stop_handler() {
    // ctrlc replaces the default handlers, so a second signal while stopping exits at once.
    let _ = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) {
            std::process::exit(EXIT_INTERRUPTED as i32);
        }
    });
}
