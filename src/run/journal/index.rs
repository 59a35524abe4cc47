//! Where each frame's line is in a file of JSON lines (a journal, or the spool of `merge`):
//! all that a long run keeps in memory per frame. The lines are read back one at a time, in
//! manifest order, to stream the manifest.
//!
//! The ids live in one buffer and the entries in one vector, both reserved for the run's
//! selection up front: no allocation per frame. A small block that lives as long as the run,
//! carved from a worker's malloc arena between the frame's megabytes of temporaries, pins the
//! space around it; a run of 100 000 frames grew its memory by about 2 KB a frame that way.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

struct Entry {
    /// Index into `LineIndex::splits` (a run has a handful of splits and many frames).
    split: u32,
    /// With the newline.
    len: u32,
    /// The id: `ids[id_at..id_at + id_len]`.
    id_len: u32,
    id_at: u64,
    offset: u64,
    /// The shard part a merged frame came from.
    part: u32,
}

/// Ids reserved per expected frame (KITTI's are 6 bytes; a KITTI-360 or nuScenes id is longer).
const ID_BYTES: usize = 16;

#[derive(Default)]
pub(super) struct LineIndex {
    entries: Vec<Entry>,
    ids: String,
    splits: Vec<String>,
    failed: usize,
}

impl LineIndex {
    /// An index with room for `frames` frames.
    pub fn with_capacity(frames: usize) -> Self {
        Self {
            entries: Vec::with_capacity(frames),
            ids: String::with_capacity(frames.saturating_mul(ID_BYTES)),
            ..Self::default()
        }
    }

    pub fn push(&mut self, split: &str, id: &str, failed: bool, at: (u64, usize), part: u32) {
        let split = match self.splits.iter().position(|x| x == split) {
            Some(i) => i,
            None => {
                self.splits.push(split.to_owned());
                self.splits.len() - 1
            }
        };
        let id_at = self.ids.len() as u64;
        self.ids.push_str(id);
        self.entries.push(Entry {
            split: split as u32,
            id_at,
            id_len: id.len() as u32,
            len: at.1 as u32,
            offset: at.0,
            part,
        });
        self.failed += usize::from(failed);
    }

    fn id(&self, e: &Entry) -> &str {
        let at = e.id_at as usize;
        &self.ids[at..at + e.id_len as usize]
    }

    /// (frames, failed)
    pub fn counts(&self) -> (usize, usize) {
        (self.entries.len(), self.failed)
    }

    /// Manifest order: split, then id.
    pub fn sort(&mut self) {
        let mut entries = std::mem::take(&mut self.entries);
        entries.sort_by(|a, b| {
            (&self.splits[a.split as usize], self.id(a))
                .cmp(&(&self.splits[b.split as usize], self.id(b)))
        });
        self.entries = entries;
    }

    /// After `sort`: a frame listed twice, as (split, id, part, other part).
    pub fn duplicate(&self) -> Option<(String, String, u32, u32)> {
        self.entries.windows(2).find_map(|w| {
            (w[0].split == w[1].split && self.id(&w[0]) == self.id(&w[1])).then(|| {
                let split = self.splits[w[0].split as usize].clone();
                (split, self.id(&w[0]).to_string(), w[0].part, w[1].part)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sorts_by_split_then_id_and_finds_a_duplicate() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("lines");
        let text = "b/2\na/9\nb/10\na/1\nb/2\n";
        std::fs::write(&path, text).unwrap();
        let mut index = LineIndex::with_capacity(2);
        let mut offset = 0u64;
        for (k, line) in text.lines().enumerate() {
            let (split, id) = line.split_once('/').unwrap();
            index.push(split, id, k == 1, (offset, line.len() + 1), k as u32);
            offset += line.len() as u64 + 1;
        }
        assert_eq!(index.counts(), (5, 1));
        index.sort();
        let lines: Vec<String> = index
            .lines(&path)
            .unwrap()
            .map(|l| String::from_utf8(l.unwrap()).unwrap())
            .collect();
        // ids compare as text, as the manifest orders them
        assert_eq!(lines, ["a/1", "a/9", "b/10", "b/2", "b/2"]);
        assert_eq!(index.duplicate(), Some(("b".into(), "2".into(), 0, 4)));
    }
}
