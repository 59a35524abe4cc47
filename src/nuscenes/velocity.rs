//! A box's velocity as nuScenes' devkit gives it (`NuScenes.box_velocity`): the difference of
//! the object's centres in its previous and next annotations (or this one where it has no
//! previous or next) over their samples' time, unknown when it has neither or the two lie more
//! than [`MAX_TIME_DIFF`] apart (twice that for a centred difference).

use super::json::Fields;
use super::records::stream;
use super::tables::{key, raw, Annotation};
use super::token::Token;
use crate::error::{Error, Result};
use nalgebra::Vector3;
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// The devkit's `max_time_diff`, seconds.
pub const MAX_TIME_DIFF: f64 = 1.5;

/// Where a neighbouring annotation puts its object, and when.
#[derive(Debug, Clone)]
pub(super) struct Neighbour {
    translation: Vector3<f64>,
    sample: Token,
}

/// The annotations next to the selected ones, and every sample's time: what velocities need.
#[derive(Debug, Default)]
pub(super) struct Tracks {
    /// Microseconds, every sample of the version.
    pub(super) sample_times: HashMap<Token, u64>,
    neighbours: HashMap<Token, Neighbour>,
}

impl Tracks {
    /// Reads from `path` (`sample_annotation.json`) the previous and next annotations of
    /// `annotations`.
    pub(super) fn read<'a>(
        path: &Path,
        annotations: impl Iterator<Item = &'a Annotation>,
        sample_times: HashMap<Token, u64>,
    ) -> Result<Self> {
        let wanted: HashSet<Token> = annotations
            .flat_map(|a| a.prev.iter().chain(&a.next).cloned())
            .collect();
        let mut neighbours = HashMap::new();
        if !wanted.is_empty() {
            stream(
                path,
                |r| {
                    let listed = r.parse::<key::Listed>().ok().and_then(|k| k.token?.token());
                    if listed.is_some_and(|t| !wanted.contains(&t)) {
                        return Ok(None);
                    }
                    read_neighbour(path, r.index, &r.parse::<raw::Annotation>()?).map(Some)
                },
                |_, (token, n)| {
                    neighbours.insert(token, n);
                    Ok(())
                },
            )?;
        }
        Ok(Tracks {
            sample_times,
            neighbours,
        })
    }

    /// The global-frame velocity (m/s) of annotation `a` of sample `sample`, None where the
    /// devkit gives NaN. `path` names the annotation table in errors.
    pub(super) fn velocity(
        &self,
        path: &Path,
        a: &Annotation,
        sample: &Token,
    ) -> Result<Option<Vector3<f64>>> {
        if a.prev.is_none() && a.next.is_none() {
            return Ok(None);
        }
        let here = (
            a.global_from_box.translation,
            self.time(path, sample, &a.token)?,
        );
        let end = |link: &Option<Token>, field: &str| -> Result<(Vector3<f64>, f64)> {
            let Some(t) = link else { return Ok(here) };
            let n = self.neighbours.get(t).ok_or_else(|| {
                Error::file(
                    path,
                    format!("record {}: {field}: no sample_annotation {t}", a.token),
                )
            })?;
            Ok((n.translation, self.time(path, &n.sample, t)?))
        };
        let (first, last) = (end(&a.prev, "prev")?, end(&a.next, "next")?);
        let dt = last.1 - first.1;
        let centred = a.prev.is_some() && a.next.is_some();
        let max = if centred {
            MAX_TIME_DIFF * 2.0
        } else {
            MAX_TIME_DIFF
        };
        let v = (last.0 - first.0) / dt;
        Ok((dt <= max && v.iter().all(|x| x.is_finite())).then_some(v))
    }

    /// Seconds of sample `sample` as the devkit computes them (1e-6 · microseconds), for
    /// annotation `record`.
    fn time(&self, path: &Path, sample: &Token, record: &Token) -> Result<f64> {
        match self.sample_times.get(sample) {
            Some(t) => Ok(1e-6 * *t as f64),
            None => Err(Error::file(
                path,
                format!("record {record}: sample_token: no sample {sample}"),
            )),
        }
    }
}

/// A raw annotation's token, centre and sample.
fn read_neighbour(path: &Path, index: usize, r: &raw::Annotation) -> Result<(Token, Neighbour)> {
    let (f, token) = Fields::new(path, index, &r.token)?;
    let translation = Vector3::from(f.numbers::<3>("translation", &r.translation)?);
    let sample = f.token("sample_token", &r.sample_token)?;
    Ok((
        token,
        Neighbour {
            translation,
            sample,
        },
    ))
}
