//! `--shard K/N`: which frames one of N processes converts into a shared output folder.

/// `--shard K/N`: this process converts the frames whose key hashes to K modulo N (K from 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Shard {
    /// K: which shard this process converts, from 0 to `count` − 1.
    pub index: u32,
    /// N: the number of shards (at least 1).
    pub count: u32,
}

impl Shard {
    /// Whether a frame belongs to this shard. A hash of the frame's own key, so the split is
    /// stable when frames are added or removed.
    pub fn owns(&self, split: &str, id: &str) -> bool {
        let h = blake3::hash(format!("{split}/{id}").as_bytes());
        let v = u64::from_le_bytes(h.as_bytes()[..8].try_into().expect("8 bytes"));
        v % self.count as u64 == self.index as u64
    }
}
