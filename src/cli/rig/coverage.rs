//! What the summary says of the part of a rig output no camera covers (`source_2` = 255): a
//! whole sphere's rows above and below the cameras are what was asked for (`--full-360`, or a
//! scale alone, which keeps the whole sphere), said in a note with the crop that keeps the
//! band; pixels without a camera among the rows the cameras see are gaps, a warning.

use panoconv::convert::rig::{coverage, CanvasFlags, Coverage, RigJob};
use panoconv::geometry::{Canvas, Target};

/// The summary's line on the first written frame's coverage, if it has one to say: when most
/// of the frame has no camera.
pub(super) fn report_coverage(job: &RigJob, flags: &CanvasFlags) {
    if let Some(line) = coverage(&job.run.output).and_then(|c| coverage_line(job, flags, &c)) {
        eprintln!("panoconv: {line}");
    }
}

fn coverage_line(job: &RigJob, flags: &CanvasFlags, c: &Coverage) -> Option<String> {
    let fisheye = matches!(job.target, Target::Fisheye { .. });
    let file = c.file.display();
    let pct = |share: f64| format!("{:.0} %", share * 100.0);
    if !fisheye && c.uncovered_within > 0.5 {
        return Some(format!(
            "warning: {} of the rows of {file} that the cameras see has no camera (source_2 = \
             255): the chosen cameras leave gaps between them",
            pct(c.uncovered_within)
        ));
    }
    if c.uncovered <= 0.5 {
        return None;
    }
    let Some((first, last)) = c.rows else {
        return Some(format!(
            "warning: no camera covers any pixel of {file} (source_2 = 255)"
        ));
    };
    // the window of the rows the cameras see, when the written image is the whole canvas
    let band = (flags.crop.is_none() && flags.resize.is_none() && job.run.augment.is_none())
        .then(|| format!("--crop 0,{first},{},{}", c.size.0, last - first + 1));
    let beyond = format!(
        "{} of the {} rows of {file}, above and below the elevations the cameras cover, are \
         beyond every camera (source_2 = 255)",
        c.size.1 - (last - first + 1),
        c.size.1
    );
    let keeps = |what: &str| {
        band.as_ref()
            .map_or(String::new(), |b| format!("; {b} {what}"))
    };
    let scale_flag = match (flags.pano_width, flags.px_per_deg) {
        (Some(_), _) => "--pano-width",
        _ => "--px-per-deg",
    };
    let canvas = match &job.target {
        Target::Linear(spec) => Some(spec.canvas),
        Target::Fisheye { .. } => None,
    };
    Some(match canvas {
        None => format!(
            "note: {beyond}: the fisheye's field reaches past the rig's cameras{}",
            keeps("keeps the rows they cover")
        ),
        Some(Canvas::Full360) if flags.full_360 => {
            format!(
                "note: {beyond}, as --full-360 asks{}",
                keeps("keeps the band")
            )
        }
        Some(Canvas::Full360) => format!(
            "note: {scale_flag} without --full-360 or --size writes the whole sphere: {beyond}; \
             for the band the cameras cover, {}leave out {scale_flag} (2048 px for 360°)",
            band.as_ref()
                .map_or(String::new(), |b| format!("pass {b} (this scale) or "))
        ),
        Some(_) => format!(
            "warning: {} of {file} has no camera (source_2 = 255){}",
            pct(c.uncovered),
            keeps("keeps the rows the cameras cover")
        ),
    })
}
