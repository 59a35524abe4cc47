//! The manifest streamed to disk: the bytes `serde_json::to_vec_pretty` gives for the whole
//! document, written one frame at a time from the frames' compact JSON, so no tree of all the
//! frames is ever built.

use crate::error::{Error, Result};
use serde_json::{Map, Value};
use std::io::Write;
use std::path::Path;

/// Copies compact JSON (as `serde_json::to_vec` writes it: no whitespace) to `out`, laid out as
/// serde_json's pretty printer lays out the same value nested `depth` levels deep: two spaces
/// per level, `": "` after keys, `{}` and `[]` for empty containers. Only whitespace is added;
/// numbers and strings are copied as they are, so the bytes match without parsing them.
pub fn reindent(compact: &[u8], depth: usize, out: &mut Vec<u8>) {
    let newline = |out: &mut Vec<u8>, level: usize| {
        out.push(b'\n');
        out.extend(std::iter::repeat_n(b' ', 2 * level));
    };
    let mut level = depth;
    let mut in_string = false;
    let mut escaped = false;
    let mut i = 0;
    while i < compact.len() {
        let c = compact[i];
        i += 1;
        if in_string {
            out.push(c);
            match (escaped, c) {
                (true, _) => escaped = false,
                (false, b'\\') => escaped = true,
                (false, b'"') => in_string = false,
                _ => {}
            }
            continue;
        }
        match c {
            b'"' => {
                in_string = true;
                out.push(c);
            }
            b'{' | b'[' => {
                out.push(c);
                let close = if c == b'{' { b'}' } else { b']' };
                if compact.get(i) == Some(&close) {
                    out.push(close);
                    i += 1;
                } else {
                    level += 1;
                    newline(out, level);
                }
            }
            b'}' | b']' => {
                level = level.saturating_sub(1);
                newline(out, level);
                out.push(c);
            }
            b',' => {
                out.push(c);
                newline(out, level);
            }
            b':' => out.extend_from_slice(b": "),
            _ => out.push(c),
        }
    }
}

/// The manifest's `summary`.
#[derive(Debug, Clone, Copy)]
pub struct Counts {
    /// Items recorded, failed ones included.
    pub frames: usize,
    /// Of those, the failed ones.
    pub failed: usize,
    /// Items the run was to take, written for an unfinished run only.
    pub selected: Option<usize>,
}

/// Writes the manifest `header + summary + complete + frames + after` to `path` through a
/// temporary and a rename (on disk before the rename: it is the run's commit point). `frames`
/// yields each frame's compact JSON in manifest order; `after` holds keys that follow them
/// (`derived`).
pub fn write_manifest(
    path: &Path,
    header: &Map<String, Value>,
    counts: Counts,
    complete: bool,
    frames: impl Iterator<Item = Result<Vec<u8>>>,
    after: &Map<String, Value>,
) -> Result<()> {
    let (total, failed) = (counts.frames, counts.failed);
    let mut doc = header.clone();
    let mut summary =
        serde_json::json!({"frames": total, "converted": total - failed, "failed": failed});
    if let Some(selected) = counts.selected {
        summary["selected"] = selected.into();
    }
    doc.insert("summary".into(), summary);
    doc.insert("complete".into(), Value::Bool(complete));
    doc.insert("frames".into(), Value::Array(Vec::new()));
    let head = serde_json::to_vec_pretty(&Value::Object(doc)).expect("manifest serialises");
    // `..."frames": []\n}`: the frames go between the brackets.
    let open = head.len() - "]\n}".len();
    debug_assert!(head.ends_with(b"[]\n}"));
    // `{\n  "derived": ...\n}` less its braces: the keys after the frames, as nested in `doc`.
    let tail = if after.is_empty() {
        Vec::new()
    } else {
        let text = serde_json::to_vec_pretty(&Value::Object(after.clone())).expect("serialises");
        let mut t = b",\n".to_vec();
        t.extend_from_slice(&text[2..text.len() - 2]);
        t
    };

    let tmp = crate::fs::temporary_path(path);
    let write = || -> Result<()> {
        let file = std::fs::File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
        let mut w = std::io::BufWriter::with_capacity(1 << 20, file);
        let io = |e| Error::io(&tmp, e);
        w.write_all(&head[..open]).map_err(io)?;
        let mut pretty = Vec::new();
        let mut first = true;
        for compact in frames {
            pretty.clear();
            pretty.extend_from_slice(if first { b"\n    " } else { b",\n    " });
            first = false;
            reindent(&compact?, 2, &mut pretty);
            w.write_all(&pretty).map_err(io)?;
        }
        w.write_all(if first { b"]" } else { b"\n  ]" })
            .map_err(io)?;
        w.write_all(&tail).map_err(io)?;
        w.write_all(b"\n}\n").map_err(io)?;
        let file = w
            .into_inner()
            .map_err(|e| Error::io(&tmp, e.into_error()))?;
        file.sync_data().map_err(io)?;
        std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))
    };
    write().inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn nested(value: &Value, depth: usize) -> Vec<u8> {
        let mut v = value.clone();
        for _ in 0..depth {
            v = Value::Array(vec![v]);
        }
        serde_json::to_vec_pretty(&v).unwrap()
    }

    fn arb_json() -> impl Strategy<Value = Value> {
        let leaf = prop_oneof![
            Just(Value::Null),
            any::<bool>().prop_map(Value::Bool),
            any::<i64>().prop_map(Value::from),
            any::<f64>().prop_map(Value::from),
            "[ -~\\n\\t\"\\\\é{}:,\\[\\]]{0,12}".prop_map(Value::String),
        ];
        leaf.prop_recursive(4, 40, 6, |inner| {
            prop_oneof![
                prop::collection::vec(inner.clone(), 0..5).prop_map(Value::Array),
                prop::collection::vec(("[a-z{}:,\"]{0,6}", inner), 0..5)
                    .prop_map(|kv| Value::Object(kv.into_iter().collect())),
            ]
        })
    }

    proptest! {
        /// Nested two levels deep (as a frame in `frames`), the re-indented compact text is
        /// what the pretty printer writes there, byte for byte.
        #[test]
        fn reindent_matches_the_pretty_printer(v in arb_json()) {
            let mut out = b"[\n  [\n    ".to_vec();
            reindent(&serde_json::to_vec(&v).unwrap(), 2, &mut out);
            out.extend_from_slice(b"\n  ]\n]");
            prop_assert_eq!(String::from_utf8(out).unwrap(), String::from_utf8(nested(&v, 2)).unwrap());
        }
    }

    #[test]
    fn streamed_manifest_equals_the_pretty_document() {
        let dir = tempfile::tempdir().unwrap();
        let mut header = Map::new();
        header.insert("tool".into(), "panoconv".into());
        header.insert(
            "parameters".into(),
            serde_json::json!({"a": [1.5, {}], "b": null}),
        );
        let frames = [
            serde_json::json!({"split": "training", "id": "000001", "outputs": [["x", "y"]], "views": []}),
            serde_json::json!({"split": "", "id": "z\"\n", "status": "failed", "error": "e: f"}),
        ];
        for n in [0, 1, 2] {
            let path = dir.path().join("m.json");
            let compact = frames[..n]
                .iter()
                .map(|f| Ok(serde_json::to_vec(f).unwrap()));
            let counts = Counts {
                frames: n,
                failed: 0,
                selected: None,
            };
            let mut after = Map::new();
            if n == 1 {
                after.insert(
                    "derived".into(),
                    serde_json::json!([{"outputs": [["a", "b"]]}]),
                );
            }
            write_manifest(&path, &header, counts, n == 2, compact, &after).unwrap();
            let mut doc = header.clone();
            doc.insert(
                "summary".into(),
                serde_json::json!({"frames": n, "converted": n, "failed": 0}),
            );
            doc.insert("complete".into(), Value::Bool(n == 2));
            doc.insert("frames".into(), Value::Array(frames[..n].to_vec()));
            doc.extend(after);
            let mut expected = serde_json::to_vec_pretty(&Value::Object(doc)).unwrap();
            expected.push(b'\n');
            assert_eq!(
                String::from_utf8(std::fs::read(&path).unwrap()).unwrap(),
                String::from_utf8(expected).unwrap(),
                "{n} frames"
            );
        }
    }
}
