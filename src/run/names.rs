//! Every name panoconv gives a file of its own inside an output folder, in one place: the
//! manifest and its shard parts, their journals, the locks, the spools of `--resume` and
//! `merge`, the `ImageSets/` lists, and how the temporaries of atomic writes are recognised.
//! `--overwrite`'s clearing, `verify` and `merge` read a folder by these names, so a new
//! record file is named here and nowhere else.

use crate::run::shard::Shard;
use std::path::{Path, PathBuf};

/// The manifest's file name, at the output's root (an unsharded run's; shards add their
/// index).
pub const MANIFEST: &str = "panoconv.json";

/// The folder of an `--augment` run's view lists (`ImageSets/<split>.txt`).
pub const IMAGE_SETS: &str = "ImageSets";

/// The manifest a run writes: `panoconv.json`, or `panoconv.shard-K-of-N.json` for a shard.
pub fn manifest_name(shard: Option<Shard>) -> String {
    match shard {
        Some(s) => format!("panoconv.shard-{}-of-{}.json", s.index, s.count),
        None => MANIFEST.to_owned(),
    }
}

/// The journal beside a manifest: `panoconv.json` → `panoconv.journal`.
pub fn journal_path(manifest: &Path) -> PathBuf {
    manifest.with_extension("journal")
}

/// The output folder's lock: `panoconv.lock`, or `panoconv.shard-K-of-N.lock` for a shard
/// (each shard locks on its own).
pub fn lock_name(shard: Option<Shard>) -> String {
    match shard {
        Some(s) => format!("panoconv.shard-{}-of-{}.lock", s.index, s.count),
        None => "panoconv.lock".into(),
    }
}

/// A spool file of this process (`what`: `resume`, `merge`): hidden and named like an atomic
/// write's temporary, so a killed run's spool is removed as one.
pub fn spool_name(what: &str) -> String {
    format!(".panoconv.{what}.tmp-{}", std::process::id())
}

/// `panoconv.shard-K-of-N.EXT` → (K, N).
pub fn shard_part(name: &str, ext: &str) -> Option<(u32, u32)> {
    let rest = name
        .strip_prefix("panoconv.shard-")?
        .strip_suffix(ext)?
        .strip_suffix('.')?;
    let (k, n) = rest.split_once("-of-")?;
    Some((k.parse().ok()?, n.parse().ok()?))
}

/// A record file at the output's root: the manifest, a shard's part, or their journals.
pub fn is_record(name: &str) -> bool {
    name.strip_prefix("panoconv")
        .is_some_and(|rest| rest.ends_with(".json") || rest.ends_with(".journal"))
}

/// A lock file at the output's root.
pub fn is_lock(name: &str) -> bool {
    name.starts_with("panoconv.") && name.ends_with(".lock")
}

/// The pid of a temporary of an atomic write (`.NAME.tmp-PID`, see
/// [`crate::fs::temporary_path`]) or of a spool, which only panoconv names so; None for any
/// other file name. `Some(None)`: a temporary whose pid is out of range.
fn temporary_pid(name: &str) -> Option<Option<u32>> {
    let (_, pid) = name.strip_prefix('.')?.rsplit_once(".tmp-")?;
    if pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some(pid.parse().ok())
}

/// Whether a path relative to the output (its last component) is a temporary.
pub fn is_temporary(rel: &str) -> bool {
    temporary_pid(rel.rsplit('/').next().unwrap_or(rel)).is_some()
}

/// The process that made a temporary, when the name is one with a valid pid.
pub fn temporary_owner(name: &str) -> Option<u32> {
    temporary_pid(name).flatten()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        let s = Some(Shard { index: 1, count: 4 });
        assert_eq!(manifest_name(s), "panoconv.shard-1-of-4.json");
        assert_eq!(shard_part(&manifest_name(s), "json"), Some((1, 4)));
        assert_eq!(shard_part(&lock_name(s), "lock"), Some((1, 4)));
        assert_eq!(shard_part("panoconv.shard-1-of-4.json", "lock"), None);
        assert!(is_record(&manifest_name(s)));
        assert!(is_record(&manifest_name(None)));
        assert!(is_record("panoconv.journal"));
        assert!(!is_record(&lock_name(None)));
        assert!(is_lock(&lock_name(s)));
        let spool = spool_name("resume");
        assert_eq!(temporary_owner(&spool), Some(std::process::id()));
        assert!(is_temporary(&format!("training/image_2/{spool}")));
        assert!(!is_temporary("training/image_2/000001.png.tmp-123"));
        assert!(!is_temporary(".x.tmp-"));
        assert!(!is_temporary(".x.tmp-12a"));
    }
}
