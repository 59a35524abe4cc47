//! [`StreamPeer`]: a rig served by another process over a pair of byte streams (the command's
//! stdin and stdout). Each request is one line of JSON; each answer one line of JSON, then the
//! `bytes` of raw data its header announces (a LiDAR array). docs/python.md has the protocol.

use super::decode;
use super::source::{WorldRig, WorldSource};
use super::world::{frame_error, WorldFrame};
use crate::error::{Error, Result};
use serde_json::{json, Map, Value};
use std::io::{BufRead, Write};
use std::path::PathBuf;

/// The protocol's version, in every request.
pub const PROTOCOL: u32 = 1;

/// Largest payload a frame may announce (a LiDAR of 256 M numbers).
const MAX_PAYLOAD: u64 = 2 << 30;

/// A peer answering over `input`, asked over `output`.
pub struct StreamPeer<R, W> {
    input: R,
    output: W,
    root: PathBuf,
}

impl<R: BufRead + Send, W: Write + Send> StreamPeer<R, W> {
    /// A peer that reads answers from `input` and writes requests to `output`.
    pub fn new(input: R, output: W) -> Self {
        Self {
            input,
            output,
            root: PathBuf::new(),
        }
    }

    /// Asks the peer what it serves: a set-up error names the field the peer got wrong.
    pub fn open(&mut self) -> Result<WorldRig> {
        let setup = |m: String| Error::Setup(format!("rig source: {m}"));
        let (header, _) = self.request(json!({"op": "open"})).map_err(setup)?;
        if let Some(e) = header.get("error").and_then(Value::as_str) {
            return Err(setup(e.to_owned()));
        }
        let rig = decode::rig(&header).map_err(|(f, m)| setup(format!("{f}: {m}")))?;
        self.root = rig.root.clone();
        Ok(rig)
    }

    /// Sends one request and reads its answer; an error says what broke.
    fn request(
        &mut self,
        mut request: Value,
    ) -> std::result::Result<(Map<String, Value>, Vec<u8>), String> {
        request["protocol"] = json!(PROTOCOL);
        let mut line = request.to_string();
        line.push('\n');
        self.output
            .write_all(line.as_bytes())
            .and_then(|()| self.output.flush())
            .map_err(|e| format!("the source process does not listen ({e})"))?;
        let mut answer = String::new();
        match self.input.read_line(&mut answer) {
            Ok(0) => return Err("the source process closed the stream".into()),
            Ok(_) => {}
            Err(e) => return Err(format!("reading the source's answer: {e}")),
        }
        let header: Map<String, Value> = serde_json::from_str(&answer)
            .map_err(|e| format!("the source's answer is not a JSON object ({e})"))?;
        let bytes = header.get("bytes").and_then(Value::as_u64).unwrap_or(0);
        if bytes > MAX_PAYLOAD {
            return Err(format!("the source announces {bytes} bytes"));
        }
        let mut payload = vec![0u8; bytes as usize];
        self.input
            .read_exact(&mut payload)
            .map_err(|e| format!("reading the source's {bytes} bytes: {e}"))?;
        Ok((header, payload))
    }
}

impl<R: BufRead + Send, W: Write + Send> WorldSource for StreamPeer<R, W> {
    fn read(&mut self, id: &str) -> Result<WorldFrame> {
        let root = self.root.clone();
        let fail = |field: &str, m: String| frame_error(&root, id, field, m);
        // a broken stream breaks every later request too: the run stops instead of failing
        // each frame left
        let (header, payload) = self
            .request(json!({"op": "read", "frame": id}))
            .map_err(|m| Error::SourceLost(format!("{}: frame {id}: {m}", root.display())))?;
        if let Some(e) = header.get("error").filter(|e| !e.is_null()) {
            let field = header
                .get("field")
                .and_then(Value::as_str)
                .unwrap_or("read");
            return Err(fail(field, e.as_str().unwrap_or("failed").to_owned()));
        }
        decode::frame(&header, &payload).map_err(|(f, m)| fail(&f, m))
    }
}
