//! Where each frame's line is in a file of JSON lines (a journal, or the spool of `merge`):
//! all that a long run keeps in memory per frame. The lines are read back one at a time, in
//! manifest order, to stream the manifest.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

struct Entry {
    /// Index into `LineIndex::splits` (a run has a handful of splits and many frames).
    split: u32,
    id: Box<str>,
    offset: u64,
    /// With the newline.
    len: u32,
    /// The shard part a merged frame came from.
    part: u32,
}

#[derive(Default)]
pub(super) struct LineIndex {
    entries: Vec<Entry>,
    splits: Vec<String>,
    failed: usize,
}

impl LineIndex {
    pub fn push(&mut self, split: &str, id: &str, failed: bool, at: (u64, usize), part: u32) {
        let split = match self.splits.iter().position(|x| x == split) {
            Some(i) => i,
            None => {
                self.splits.push(split.to_owned());
                self.splits.len() - 1
            }
        };
        self.entries.push(Entry {
            split: split as u32,
            id: id.into(),
            offset: at.0,
            len: at.1 as u32,
            part,
        });
        self.failed += usize::from(failed);
    }

    /// (frames, failed)
    pub fn counts(&self) -> (usize, usize) {
        (self.entries.len(), self.failed)
    }

    /// Manifest order: split, then id.
    pub fn sort(&mut self) {
        let splits = &self.splits;
        self.entries.sort_by(|a, b| {
            (&splits[a.split as usize], &a.id).cmp(&(&splits[b.split as usize], &b.id))
        });
    }

    /// After `sort`: a frame listed twice, as (split, id, part, other part).
    pub fn duplicate(&self) -> Option<(String, String, u32, u32)> {
        self.entries.windows(2).find_map(|w| {
            (w[0].split == w[1].split && w[0].id == w[1].id).then(|| {
                let split = self.splits[w[0].split as usize].clone();
                (split, w[0].id.to_string(), w[0].part, w[1].part)
            })
        })
    }

    /// The lines of `path`, in the index's order, without their newline.
    pub fn lines<'a>(
        &'a self,
        path: &'a Path,
    ) -> Result<impl Iterator<Item = Result<Vec<u8>>> + 'a> {
        let mut reader = File::open(path).map_err(|e| Error::io(path, e))?;
        Ok(self.entries.iter().map(move |e| {
            let mut line = vec![0u8; e.len as usize - 1];
            reader
                .seek(SeekFrom::Start(e.offset))
                .and_then(|_| reader.read_exact(&mut line))
                .map_err(|err| Error::io(path, err))?;
            Ok(line)
        }))
    }
}
