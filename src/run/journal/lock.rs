//! One writer per output: a conversion holds `OUT/panoconv.lock` (a shard
//! `OUT/panoconv.shard-K-of-N.lock`, so distinct shards share a folder) for as long as it runs.
//!
//! The lock is an advisory file lock (`flock`), which the kernel releases when its process
//! ends however it ends, so a lock left by a killed run is never mistaken for a live one; the
//! file names its holder (host and pid) for the refusal message. Where the file system cannot
//! lock files, the holder's pid is checked instead (on the same host only).

use crate::error::{Error, Result};
use crate::run::names::lock_name;
use crate::run::shard::Shard;
use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

/// The held lock; removed (and released) when dropped, at the end of the run.
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
    _file: File,
    /// The output folder, when taking the lock created it: removed again if the run wrote
    /// nothing (a set-up error leaves no folder behind).
    pub(crate) created: Option<PathBuf>,
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        // Removed while still held: a process that opened the old file finds it unlinked and
        // tries again (see `acquire`).
        let _ = std::fs::remove_file(&self.path);
        if let Some(dir) = &self.created {
            let _ = std::fs::remove_dir(dir); // only if empty
        }
    }
}

fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|h| h.trim().to_owned())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "unknown-host".into())
}

pub(crate) fn pid_alive(pid: u32) -> bool {
    pid == std::process::id() || Path::new(&format!("/proc/{pid}")).exists()
}

/// The holder a lock file names, `(host, pid)`.
fn holder(file: &mut File) -> Option<(String, u32)> {
    let mut text = String::new();
    file.rewind().ok()?;
    file.read_to_string(&mut text).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    Some((
        v.get("host")?.as_str()?.to_owned(),
        u32::try_from(v.get("pid")?.as_u64()?).ok()?,
    ))
}

fn refusal(output: &Path, path: &Path, who: Option<(String, u32)>) -> Error {
    let who = who.map_or("another process".into(), |(host, pid)| {
        format!("pid {pid} on host {host}")
    });
    Error::OutputLocked {
        output: output.to_path_buf(),
        lock: path.to_path_buf(),
        holder: who,
    }
}

/// Refuses early, naming the holder, when a live process holds the lock of `output`; writes
/// nothing. (Before the output checks, so the refusal names the holder rather than calling
/// the folder non-empty.)
pub fn refuse_if_held(output: &Path, shard: Option<Shard>) -> Result<()> {
    let path = output.join(lock_name(shard));
    let Ok(mut file) = File::open(&path) else {
        return Ok(());
    };
    match file.try_lock() {
        Err(TryLockError::WouldBlock) => Err(refusal(output, &path, wait_for_holder(&mut file))),
        _ => Ok(()),
    }
}

/// The holder writes its name just after it takes the lock: give it a moment.
fn wait_for_holder(file: &mut File) -> Option<(String, u32)> {
    for _ in 0..20 {
        if let Some(h) = holder(file) {
            return Some(h);
        }
        std::thread::sleep(std::time::Duration::from_millis(25));
    }
    None
}

/// Takes the lock of `output` (which exists), or refuses (exit 2) naming the live holder. A
/// lock left by a process that ended is taken over, with a note on stderr.
pub fn acquire(output: &Path, shard: Option<Shard>) -> Result<OutputLock> {
    let path = output.join(lock_name(shard));
    let me = (host_name(), std::process::id());
    loop {
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(|e| Error::io(&path, e))?;
        let previous = match file.try_lock() {
            Ok(()) => holder(&mut file),
            Err(TryLockError::WouldBlock) => {
                return Err(refusal(output, &path, wait_for_holder(&mut file)))
            }
            // No file locks here (some network file systems): trust a live pid on this host.
            Err(TryLockError::Error(_)) => {
                let h = holder(&mut file);
                if let Some((host, pid)) = &h {
                    if *host == me.0 && pid_alive(*pid) && *pid != me.1 {
                        return Err(refusal(output, &path, h));
                    }
                }
                h
            }
        };
        // The previous holder may have removed the file between our open and our lock.
        if !same_file(&file, &path) {
            continue;
        }
        if let Some((host, pid)) = previous.filter(|h| *h != me) {
            let state = if host == me.0 && !pid_alive(pid) {
                "no longer running"
            } else {
                "it ended: its lock was released"
            };
            // Printed here: a set-up note, before any progress bar, that no caller would omit.
            eprintln!(
                "panoconv: taking over {} left by pid {pid} on host {host} ({state})",
                path.display()
            );
        }
        let text = serde_json::json!({"host": me.0, "pid": me.1}).to_string();
        file.set_len(0).map_err(|e| Error::io(&path, e))?;
        file.rewind().map_err(|e| Error::io(&path, e))?;
        file.write_all(text.as_bytes())
            .map_err(|e| Error::io(&path, e))?;
        return Ok(OutputLock {
            path,
            _file: file,
            created: None,
        });
    }
}

#[cfg(unix)]
fn same_file(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_file(_: &File, path: &Path) -> bool {
    path.exists()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_is_refused_naming_the_holder_and_released_on_drop() {
        let dir = tempfile::tempdir().unwrap();
        let held = acquire(dir.path(), None).unwrap();
        let err = acquire(dir.path(), None).unwrap_err().to_string();
        assert!(
            err.contains(&format!("pid {}", std::process::id())) && err.contains(&host_name()),
            "{err}"
        );
        assert!(refuse_if_held(dir.path(), None).is_err());
        // distinct shards do not collide
        let shard = Shard { index: 1, count: 4 };
        let _other = acquire(dir.path(), Some(shard)).unwrap();
        drop(held);
        assert!(!dir.path().join("panoconv.lock").exists());
        assert!(refuse_if_held(dir.path(), None).is_ok());
        let _again = acquire(dir.path(), None).unwrap();
    }
}
