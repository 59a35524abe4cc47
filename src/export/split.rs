//! Which export split (`train`, `val`, `test`) each frame of a dataset belongs to.

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

/// The export split of the labelled frames not in `val`.
pub const TRAIN: &str = "train";
/// The export split held out for validation.
pub const VAL: &str = "val";
/// The export split of unlabelled frames (`testing/`).
pub const TEST: &str = "test";

/// The export split of each labelled frame id; ids absent from the result are left out.
pub fn assign(ids: &[String], rule: &SplitRule) -> Result<BTreeMap<String, &'static str>> {
    let mut out = BTreeMap::new();
    match rule {
        SplitRule::AllTrain => {
            out.extend(ids.iter().map(|id| (id.clone(), TRAIN)));
        }
        SplitRule::ImageSets(dir) => {
            let mut listed: BTreeMap<String, &'static str> = BTreeMap::new();
            for (name, split) in [("train.txt", TRAIN), ("val.txt", VAL)] {
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
            for id in ids {
                if let Some(&split) = listed.get(id) {
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
            // frames, in any listing order.
            let mut keyed: Vec<([u8; 32], &String)> = ids
                .iter()
                .map(|id| {
                    let mut h = blake3::Hasher::new();
                    h.update(&seed.to_le_bytes());
                    h.update(id.as_bytes());
                    (*h.finalize().as_bytes(), id)
                })
                .collect();
            keyed.sort();
            let n_val = (fraction * ids.len() as f64).round() as usize;
            for (i, (_, id)) in keyed.into_iter().enumerate() {
                out.insert(id.clone(), if i < n_val { VAL } else { TRAIN });
            }
        }
    }
    Ok(out)
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
        let a = assign(&all, &rule).unwrap();
        assert_eq!(a.values().filter(|s| **s == VAL).count(), 10);
        let mut reversed = all.clone();
        reversed.reverse();
        assert_eq!(assign(&reversed, &rule).unwrap(), a);
        let other_seed = assign(
            &all,
            &SplitRule::ValFraction {
                fraction: 0.25,
                seed: 8,
            },
        )
        .unwrap();
        assert_ne!(other_seed, a);
    }
}
