//! Which KITTI types become which export categories (`--classes`), with stable ids.

use crate::error::{Error, Result};

/// KITTI's object classes, in the order of its devkit: the default categories, ids 1..=8.
pub const KITTI_CLASSES: [&str; 8] = [
    "Car",
    "Van",
    "Truck",
    "Pedestrian",
    "Person_sitting",
    "Cyclist",
    "Tram",
    "Misc",
];

/// KITTI's ignore regions: never a category, always an ignore region (COCO) or left out.
pub use crate::kitti::DONT_CARE;

/// What a label's type becomes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClassLookup {
    /// Index into [`ClassMap::categories`] (the category id is the index + 1).
    Category(usize),
    /// Mapped to nothing (`Type=-`): the object is left out.
    Dropped,
    /// Not in the map.
    Unknown,
}

/// Label type → category. Categories are numbered in the order the map names them, so the
/// ids depend on the map alone, never on the data.
#[derive(Debug, Clone, PartialEq)]
pub struct ClassMap {
    categories: Vec<String>,
    /// (type, index into categories or None for dropped)
    rules: Vec<(String, Option<usize>)>,
    /// `*=...`: what every type not named becomes.
    fallback: Option<Option<usize>>,
}

impl Default for ClassMap {
    fn default() -> Self {
        Self::kitti()
    }
}

impl ClassMap {
    /// KITTI's eight classes as themselves; any other type is unknown.
    pub fn kitti() -> Self {
        Self {
            categories: KITTI_CLASSES.iter().map(|c| c.to_string()).collect(),
            rules: KITTI_CLASSES
                .iter()
                .enumerate()
                .map(|(i, c)| (c.to_string(), Some(i)))
                .collect(),
            fallback: None,
        }
    }

    /// KITTI's eight classes, then each of `others` (the other label types a conversion
    /// writes: the categories its `--classes` named) as a category of its own, ids 9 on in
    /// the order given; a name already a KITTI class is not repeated.
    pub fn kitti_and(others: &[String]) -> Self {
        let mut map = Self::kitti();
        for name in others {
            if !map.categories.contains(name) {
                map.rules.push((name.clone(), Some(map.categories.len())));
                map.categories.push(name.clone());
            }
        }
        map
    }

    /// `FROM=TO,...`: `TO` empty or `-` drops the type, `*` as FROM stands for every type not
    /// named. Only the types named (or `*`) are known; categories are the distinct `TO` names
    /// in order of first appearance.
    pub fn parse(spec: &str) -> Result<Self> {
        let bad = |msg: String| Error::Setup(format!("--classes: {msg}"));
        let mut map = Self {
            categories: Vec::new(),
            rules: Vec::new(),
            fallback: None,
        };
        for entry in spec.split(',').map(str::trim).filter(|e| !e.is_empty()) {
            let (from, to) = entry
                .split_once('=')
                .ok_or_else(|| bad(format!("{entry:?} is not FROM=TO (e.g. Van=Car, Misc=-)")))?;
            let (from, to) = (from.trim(), to.trim());
            if from.is_empty() || from.contains(char::is_whitespace) {
                return Err(bad(format!("{entry:?}: no class name before '='")));
            }
            if from == DONT_CARE {
                return Err(bad(format!(
                    "{entry:?}: DontCare regions are always ignore regions, not a class"
                )));
            }
            if to.contains(char::is_whitespace) {
                return Err(bad(format!(
                    "{entry:?}: a category name cannot hold spaces"
                )));
            }
            let target = if to.is_empty() || to == "-" {
                None
            } else {
                Some(match map.categories.iter().position(|c| c == to) {
                    Some(i) => i,
                    None => {
                        map.categories.push(to.to_owned());
                        map.categories.len() - 1
                    }
                })
            };
            if from == "*" {
                if map.fallback.is_some() {
                    return Err(bad("'*' is given twice".into()));
                }
                map.fallback = Some(target);
            } else {
                if map.rules.iter().any(|(f, _)| f == from) {
                    return Err(bad(format!("{from:?} is mapped twice")));
                }
                map.rules.push((from.to_owned(), target));
            }
        }
        if map.categories.is_empty() {
            return Err(bad("no category left (every class is dropped)".into()));
        }
        Ok(map)
    }

    /// Category names; the id of `categories()[i]` is `i + 1`.
    pub fn categories(&self) -> &[String] {
        &self.categories
    }

    /// What a label of KITTI type `kind` becomes: a category, dropped, or unknown to the map.
    pub fn lookup(&self, kind: &str) -> ClassLookup {
        let target = self
            .rules
            .iter()
            .find(|(f, _)| f == kind)
            .map(|(_, t)| *t)
            .or(self.fallback);
        match target {
            Some(Some(i)) => ClassLookup::Category(i),
            Some(None) => ClassLookup::Dropped,
            None => ClassLookup::Unknown,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merges_drops_and_numbers_by_first_appearance() {
        let m = ClassMap::parse(
            "Van=Car, Car=Car, Pedestrian=Person, Person_sitting=Person, Misc=-, *=-",
        )
        .unwrap();
        assert_eq!(m.categories(), ["Car", "Person"]);
        assert_eq!(m.lookup("Van"), ClassLookup::Category(0));
        assert_eq!(m.lookup("Person_sitting"), ClassLookup::Category(1));
        assert_eq!(m.lookup("Misc"), ClassLookup::Dropped);
        assert_eq!(m.lookup("Tram"), ClassLookup::Dropped);
    }

    #[test]
    fn kitti_and_numbers_the_others_after_kitti() {
        let m = ClassMap::kitti_and(&["movable_object.barrier".into(), "Car".into()]);
        assert_eq!(m.categories().len(), 9);
        assert_eq!(m.lookup("movable_object.barrier"), ClassLookup::Category(8));
        assert_eq!(m.lookup("Car"), ClassLookup::Category(0));
        assert_eq!(m.lookup("building"), ClassLookup::Unknown);
    }

    #[test]
    fn unknown_types_and_bad_specs() {
        assert_eq!(ClassMap::kitti().lookup("Bus"), ClassLookup::Unknown);
        assert_eq!(ClassMap::kitti().lookup("Tram"), ClassLookup::Category(6));
        let m = ClassMap::parse("Car=Car").unwrap();
        assert_eq!(m.lookup("Van"), ClassLookup::Unknown);
        for bad in [
            "Car",
            "Car=Car,Car=Van",
            "DontCare=X",
            "Car=-",
            "=Car",
            "*=-,*=A",
        ] {
            assert!(ClassMap::parse(bad).is_err(), "{bad} should be refused");
        }
    }
}
