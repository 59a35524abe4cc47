//! Which export split (`train`, `val`, `test`) each frame of a dataset belongs to.
//!
//! The unit of a split is the *source* frame: the `--augment` views of one KITTI frame are
//! crops of the same image and objects, so they all go to the same side, or val would hold
//! what train has seen. The views' source frames come from the dataset's manifest.

use crate::error::{Error, Result};
use crate::kitti::dataset::read_id_list;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// How the labelled frames (`training/`) are divided between `train` and `val`; frames of
/// `testing/` are always `test`.
#[derive(Debug, Clone, PartialEq)]
pub enum SplitRule {
    /// `DIR/train.txt` and `DIR/val.txt` (KITTI's ImageSets); frames in neither are left out.
    ImageSets(PathBuf),
    /// A seeded, reproducible draw of round(fraction · n) frames for `val`.
    ValFraction {
        /// Share of the labelled frames put in `val`, from 0 to 1 (`--val-fraction`).
        fraction: f64,
        /// Seed of the draw (`--seed`): the same seed and frames give the same split.
        seed: u64,
    },
    /// Every labelled frame is `train`.
    AllTrain,
}

impl SplitRule {
    /// `DATASET/ImageSets` when it holds train.txt and val.txt, else every frame in `train`.
    pub fn default_for(dataset: &Path) -> Self {
        let dir = dataset.join("ImageSets");
        if dir.join("train.txt").is_file() && dir.join("val.txt").is_file() {
            SplitRule::ImageSets(dir)
        } else {
            SplitRule::AllTrain
        }
    }
}

/// An export split; the order of the variants is the order of the files and the report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ExportSplit {
    /// The labelled frames not in `val`.
    Train,
    /// Held out for validation.
    Val,
    /// The unlabelled frames (`testing/`).
    Test,
}

impl ExportSplit {
    /// Every split, in order.
    pub const ALL: [ExportSplit; 3] = [ExportSplit::Train, ExportSplit::Val, ExportSplit::Test];

    /// The split's name in file and folder names (`train`, `val`, `test`).
    pub fn name(self) -> &'static str {
        match self {
            ExportSplit::Train => "train",
            ExportSplit::Val => "val",
            ExportSplit::Test => "test",
        }
    }
}

impl std::fmt::Display for ExportSplit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The source frame of each `--augment` view of `split`, from the manifest at `root`
/// (empty for a dataset that is not augmented, or has no manifest).
pub fn view_sources(root: &Path, split: &str) -> BTreeMap<String, String> {
    #[derive(serde::Deserialize)]
    struct Doc {
        #[serde(default)]
        frames: Vec<Record>,
    }
    #[derive(serde::Deserialize)]
    struct Record {
        #[serde(default)]
        split: String,
        #[serde(default)]
        id: String,
        #[serde(default)]
        views: Vec<View>,
    }
    #[derive(serde::Deserialize)]
    struct View {
        id: String,
    }
    let Ok(file) = std::fs::File::open(root.join(crate::run::manifest::MANIFEST)) else {
        return BTreeMap::new();
    };
    let Ok(doc) = serde_json::from_reader::<_, Doc>(std::io::BufReader::new(file)) else {
        return BTreeMap::new();
    };
    doc.frames
        .into_iter()
        .filter(|r| r.split == split)
        .flat_map(|r| {
            let source = r.id;
            r.views.into_iter().map(move |v| (v.id, source.clone()))
        })
        .collect()
}

/// The export split of each labelled frame id; ids absent from the result are left out.
/// `sources` maps a view to its source frame ([`view_sources`]): a frame's views share its
/// split, drawn (or looked up in the image sets) by the source frame's id.
pub fn assign(
    ids: &[String],
    rule: &SplitRule,
    sources: &BTreeMap<String, String>,
) -> Result<BTreeMap<String, ExportSplit>> {
    let source = |id: &String| sources.get(id).unwrap_or(id).clone();
    let mut out = BTreeMap::new();
    match rule {
        SplitRule::AllTrain => {
            out.extend(ids.iter().map(|id| (id.clone(), ExportSplit::Train)));
        }
        SplitRule::ImageSets(dir) => {
            let listed = image_sets(dir)?;
            for id in ids {
                // A view is listed by its own id, or else by its source frame's.
                if let Some(&split) = listed.get(id).or_else(|| listed.get(&source(id))) {
                    out.insert(id.clone(), split);
                }
            }
        }
        SplitRule::ValFraction { fraction, seed } => {
            if !(0.0..=1.0).contains(fraction) {
                return Err(Error::Setup(format!(
                    "--val-fraction {fraction}: expected a number from 0 to 1"
                )));
            }
            // Ordering by a keyed hash of the id gives the same draw for the same seed and
            // frames, in any listing order. The draw is over source frames.
            let units: std::collections::BTreeSet<String> = ids.iter().map(source).collect();
            let mut keyed: Vec<([u8; 32], &String)> = units
                .iter()
                .map(|id| {
                    let mut h = blake3::Hasher::new();
                    h.update(&seed.to_le_bytes());
                    h.update(id.as_bytes());
                    (*h.finalize().as_bytes(), id)
                })
                .collect();
            keyed.sort();
            let n_val = (fraction * units.len() as f64).round() as usize;
            let side: BTreeMap<&String, ExportSplit> = keyed
                .into_iter()
                .enumerate()
                .map(|(i, (_, unit))| {
                    let split = if i < n_val {
                        ExportSplit::Val
                    } else {
                        ExportSplit::Train
                    };
                    (unit, split)
                })
                .collect();
            for id in ids {
                out.insert(id.clone(), side[&source(id)]);
            }
        }
    }
    Ok(out)
}

/// The split of each id an image sets folder lists (`train.txt`, `val.txt`, both needed; an
/// id in both is refused).
fn image_sets(dir: &Path) -> Result<BTreeMap<String, ExportSplit>> {
    let mut listed: BTreeMap<String, ExportSplit> = BTreeMap::new();
    for (name, split) in [
        ("train.txt", ExportSplit::Train),
        ("val.txt", ExportSplit::Val),
    ] {
        let file = dir.join(name);
        if !file.is_file() {
            return Err(Error::Setup(format!(
                "{}: missing (image sets need train.txt and val.txt)",
                file.display()
            )));
        }
        for id in read_id_list(&file)? {
            if let Some(other) = listed.insert(id.clone(), split) {
                if other != split {
                    return Err(Error::Setup(format!(
                        "{}: frame {id} is in both train.txt and val.txt",
                        dir.display()
                    )));
                }
            }
        }
    }
    Ok(listed)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ids(n: usize) -> Vec<String> {
        (0..n).map(|i| format!("{i:06}")).collect()
    }

    #[test]
    fn val_fraction_is_exact_and_reproducible() {
        let all = ids(40);
        let rule = SplitRule::ValFraction {
            fraction: 0.25,
            seed: 7,
        };
        let none = BTreeMap::new();
        let a = assign(&all, &rule, &none).unwrap();
        assert_eq!(a.values().filter(|s| **s == ExportSplit::Val).count(), 10);
        let mut reversed = all.clone();
        reversed.reverse();
        assert_eq!(assign(&reversed, &rule, &none).unwrap(), a);
        let other_seed = assign(
            &all,
            &SplitRule::ValFraction {
                fraction: 0.25,
                seed: 8,
            },
            &none,
        )
        .unwrap();
        assert_ne!(other_seed, a);
    }
}
