//! What `--to`, `--pano-width` and `--px-per-deg` name: the output projection and its scale.
//! The `--to` values are read from the library's one list of projections
//! (`camera::PROJECTIONS`, by their names), so that a new projection is a `--to` value of every
//! command without an edit here.

use anyhow::Result;
use clap::builder::PossibleValue;
use clap::ValueEnum;
use panoconv::camera::{OutputProjection, Projection, PROJECTIONS};
use panoconv::geometry::Scale;

/// A dataset command's `--to`: a linear projection, or a real fisheye camera.
#[derive(Clone, Copy)]
pub(crate) struct To(pub(crate) OutputProjection);

/// A folder conversion's `--to`: a linear projection.
#[derive(Clone, Copy)]
pub(crate) struct FolderTo(pub(crate) Projection);

/// `--to`'s values: the projections, then the fisheye.
const TO_VALUES: [To; PROJECTIONS.len() + 1] = {
    let mut values = [To(OutputProjection::Fisheye); PROJECTIONS.len() + 1];
    let mut i = 0;
    while i < PROJECTIONS.len() {
        values[i] = To(OutputProjection::Linear(PROJECTIONS[i]));
        i += 1;
    }
    values
};

const FOLDER_TO_VALUES: [FolderTo; PROJECTIONS.len()] = {
    let mut values = [FolderTo(PROJECTIONS[0]); PROJECTIONS.len()];
    let mut i = 0;
    while i < PROJECTIONS.len() {
        values[i] = FolderTo(PROJECTIONS[i]);
        i += 1;
    }
    values
};

impl ValueEnum for To {
    fn value_variants<'a>() -> &'a [Self] {
        &TO_VALUES
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        Some(match self.0 {
            OutputProjection::Linear(p) => PossibleValue::new(p.name()),
            OutputProjection::Fisheye => PossibleValue::new("fisheye")
                .help("A real fisheye camera, described by --camera FILE"),
        })
    }
}

impl ValueEnum for FolderTo {
    fn value_variants<'a>() -> &'a [Self] {
        &FOLDER_TO_VALUES
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        Some(PossibleValue::new(self.0.name()))
    }
}

/// What `--to` names: a linear projection or a fisheye camera.
pub(crate) fn projection_of(to: To) -> OutputProjection {
    to.0
}

/// The output scale `--pano-width` or `--px-per-deg` asks for (default: the source's own).
pub(crate) fn scale_of(pano_width: Option<u32>, px_per_deg: Option<f64>) -> Result<Scale> {
    Ok(Scale::from_flags(pano_width, px_per_deg)?)
}
