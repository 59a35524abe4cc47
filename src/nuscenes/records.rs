//! Reading a nuScenes table (`VERSION/NAME.json`: one JSON array of records) block by block.
//!
//! The tables of a large version hold millions of records (sample_data.json and ego_pose.json
//! near a gigabyte each), so a table is never held whole: the file is read in blocks of
//! `BLOCK` bytes, a scan of the JSON's nesting (strings and escapes respected) cuts each
//! block into its records' texts, and the records of a block go to `select` in parallel
//! (rayon) and then, in the file's order, to `keep`. `select` reads the few fields its filter
//! needs borrowed from the text ([`Loose`]: no allocation, the other fields skipped) and parses
//! the whole record only when it is kept. What `keep` receives, and the first error, do not
//! depend on the thread count.

use crate::error::{Error, Result};
use rayon::prelude::*;
use serde::de::{Deserialize, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
use std::borrow::Cow;
use std::fmt;
use std::io::Read;
use std::ops::Range;
use std::path::Path;

use super::token::Token;

/// Bytes read at once: large enough that the parallel parse of a block dwarfs its hand-over,
/// small enough that a block's records and their results stay a few MB.
const BLOCK: usize = 8 << 20;

/// One record of a table: its text and position.
pub struct Record<'a> {
    /// Its position in the table (0-based).
    pub index: usize,
    text: &'a [u8],
    /// The file offset of its first byte (for the line of an error).
    offset: u64,
    path: &'a Path,
}

impl<'a> Record<'a> {
    /// The record as a `T` (borrowing from the text where `T` does); a JSON or type error
    /// names the file and the line.
    pub fn parse<T: Deserialize<'a>>(&self) -> Result<T> {
        serde_json::from_slice(self.text).map_err(|e| json_error(self.path, self.offset, &e))
    }
}

/// Streams the records of the table at `path`: `select` turns each into an optional `T`
/// (in parallel), `keep` receives the `T`s with their record's position in the file's order.
/// A file that is not a JSON array is an error naming its line; the first error of `select`
/// or `keep`, in the file's order, stops the read and is returned as it is.
pub fn stream<T, S, K>(path: &Path, select: S, mut keep: K) -> Result<()>
where
    T: Send,
    S: Fn(&Record) -> Result<Option<T>> + Sync,
    K: FnMut(usize, T) -> Result<()>,
{
    let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut buf: Vec<u8> = Vec::with_capacity(BLOCK);
    let mut base = 0u64;
    let mut split = Splitter::default();
    loop {
        let eof = fill(&mut file, &mut buf).map_err(|e| Error::io(path, e))?;
        let mut spans = Vec::new();
        let used = split
            .records(&buf, &mut spans)
            .map_err(|(at, message)| structure_error(path, base + at as u64, message))?;
        let records: Vec<Record> = spans
            .into_iter()
            .map(|(index, span)| Record {
                index,
                offset: base + span.start as u64,
                text: &buf[span],
                path,
            })
            .collect();
        let selected: Vec<Result<Option<T>>> = records.par_iter().map(&select).collect();
        for (record, result) in records.iter().zip(selected) {
            if let Some(t) = result? {
                keep(record.index, t)?;
            }
        }
        drop(records);
        buf.drain(..used);
        base += used as u64;
        if eof {
            return split.finish(path, base, &buf);
        }
        if buf.len() == buf.capacity() {
            // One record longer than a block: read on until it is whole.
            buf.reserve(buf.capacity());
        }
    }
}

/// Reads until `buf` is full or the file ends; true at its end.
fn fill(file: &mut std::fs::File, buf: &mut Vec<u8>) -> std::io::Result<bool> {
    let start = buf.len();
    let free = buf.capacity() - start;
    let read = file.take(free as u64).read_to_end(buf)?;
    Ok(read < free)
}

/// What the scan expects next at the array's level.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
enum Expect {
    /// `[`.
    #[default]
    Open,
    /// A record or `]`.
    First,
    /// `,` or `]`.
    Separator,
    /// A record.
    Record,
    /// Nothing but white space.
    End,
}

/// The scan of the array's level, carried across blocks.
#[derive(Default)]
struct Splitter {
    expect: Expect,
    next_index: usize,
}

impl Splitter {
    /// Appends the whole records of `buf` to `spans` (with their positions) and returns the
    /// bytes consumed; an error is the offset in `buf` and a message.
    fn records(
        &mut self,
        buf: &[u8],
        spans: &mut Vec<(usize, Range<usize>)>,
    ) -> std::result::Result<usize, (usize, String)> {
        let mut pos = 0;
        loop {
            while pos < buf.len() && buf[pos].is_ascii_whitespace() {
                pos += 1;
            }
            let Some(&b) = buf.get(pos) else {
                return Ok(pos);
            };
            match (self.expect, b) {
                (Expect::Open, b'[') => self.expect = Expect::First,
                (Expect::Open, _) => {
                    return Err((
                        pos,
                        format!("expected a JSON array of records, found {}", shown(b)),
                    ))
                }
                (Expect::First | Expect::Separator, b']') => self.expect = Expect::End,
                (Expect::Separator, b',') => self.expect = Expect::Record,
                (Expect::Separator, _) => {
                    return Err((pos, format!("expected `,` or `]`, found {}", shown(b))))
                }
                (Expect::First | Expect::Record, _) => match value_end(&buf[pos..]) {
                    None => return Ok(pos),
                    Some(0) => return Err((pos, format!("expected a record, found {}", shown(b)))),
                    Some(len) => {
                        spans.push((self.next_index, pos..pos + len));
                        self.next_index += 1;
                        self.expect = Expect::Separator;
                        pos += len;
                        continue;
                    }
                },
                (Expect::End, _) => {
                    return Err((
                        pos,
                        format!("trailing characters after the array: {}", shown(b)),
                    ))
                }
            }
            pos += 1;
        }
    }

    /// The end of the file, with `rest` (starting at file offset `at`) left unsplit.
    fn finish(&self, path: &Path, at: u64, rest: &[u8]) -> Result<()> {
        if self.expect == Expect::End {
            return Ok(());
        }
        let start = rest.iter().position(|b| !b.is_ascii_whitespace());
        if let Some(start) = start {
            // A record cut short: serde's own account of where it ends.
            let text = &rest[start..];
            if let Err(e) = serde_json::from_slice::<IgnoredAny>(text) {
                return Err(json_error(path, at + start as u64, &e));
            }
        }
        let what = if self.expect == Expect::Open {
            "EOF while parsing: expected a JSON array of records"
        } else {
            "EOF while parsing a list"
        };
        Err(structure_error(path, at + rest.len() as u64, what.into()))
    }
}

/// The length of the JSON value at the start of `b` (a container or string through its
/// closing character; a number or literal up to the next `,`, `]`, `}` or white space), or
/// None when `b` ends first. Only the nesting is checked: the record's parse checks the rest.
fn value_end(b: &[u8]) -> Option<usize> {
    let mut depth = 0usize;
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'"' => {
                i = string_end(b, i + 1)?;
                if depth == 0 {
                    return Some(i);
                }
                continue;
            }
            b'{' | b'[' => depth += 1,
            b'}' | b']' => {
                if depth == 0 {
                    return Some(i);
                }
                depth -= 1;
                if depth == 0 {
                    return Some(i + 1);
                }
            }
            b',' | b' ' | b'\n' | b'\r' | b'\t' if depth == 0 => return Some(i),
            _ => {}
        }
        i += 1;
    }
    None
}

/// The position after the closing quote of the string whose text starts at `b[i]`.
fn string_end(b: &[u8], mut i: usize) -> Option<usize> {
    while i < b.len() {
        match b[i] {
            b'"' => return Some(i + 1),
            b'\\' => i += 2,
            _ => i += 1,
        }
    }
    None
}

fn shown(b: u8) -> String {
    if b.is_ascii_graphic() {
        format!("`{}`", b as char)
    } else {
        format!("byte {b:#04x}")
    }
}

fn table_of(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The 1-based line and column of file offset `at` (counted again from the start: errors
/// only).
fn position(path: &Path, at: u64) -> (usize, usize) {
    let mut line = 1;
    let mut column = 1;
    if let Ok(file) = std::fs::File::open(path) {
        let mut reader = std::io::BufReader::new(file.take(at));
        let mut chunk = vec![0; 1 << 16];
        while let Ok(n) = reader.read(&mut chunk) {
            if n == 0 {
                break;
            }
            for &b in &chunk[..n] {
                if b == b'\n' {
                    line += 1;
                    column = 1;
                } else {
                    column += 1;
                }
            }
        }
    }
    (line, column)
}

fn structure_error(path: &Path, at: u64, message: String) -> Error {
    let (line, column) = position(path, at);
    Error::parse(
        path,
        line,
        table_of(path),
        format!("{message} at line {line} column {column}"),
    )
}

/// serde's error about the text starting at file offset `at`, placed in the file.
fn json_error(path: &Path, at: u64, e: &serde_json::Error) -> Error {
    let text = e.to_string();
    let suffix = format!(" at line {} column {}", e.line(), e.column());
    let message = text.strip_suffix(&suffix).unwrap_or(&text);
    let (line, column) = position(path, at);
    let (line, column) = match e.line() {
        0 => (line, column),
        1 => (line, column + e.column().saturating_sub(1)),
        l => (line + l - 1, e.column()),
    };
    Error::parse(
        path,
        line,
        table_of(path),
        format!("{message} at line {line} column {column}"),
    )
}

/// A field read loosely for a filter, borrowed from the record's text: a string, a boolean, or
/// anything else (skipped unread). A record the filter keeps is then read strictly.
#[derive(Debug)]
pub enum Loose<'a> {
    /// A string (borrowed unless it holds escapes).
    Str(Cow<'a, str>),
    /// A boolean.
    Bool(bool),
    /// A number, an array or an object.
    Other,
}

impl Loose<'_> {
    /// The token a non-empty string writes.
    pub fn token(&self) -> Option<Token> {
        match self {
            Loose::Str(s) if !s.is_empty() => Some(Token::new(s)),
            _ => None,
        }
    }
}

impl<'de: 'a, 'a> Deserialize<'de> for Loose<'a> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        d.deserialize_any(LooseVisitor(std::marker::PhantomData))
    }
}

struct LooseVisitor<'a>(std::marker::PhantomData<&'a ()>);

impl<'de: 'a, 'a> Visitor<'de> for LooseVisitor<'a> {
    type Value = Loose<'a>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any JSON value")
    }
    fn visit_borrowed_str<E>(self, s: &'de str) -> std::result::Result<Self::Value, E> {
        Ok(Loose::Str(Cow::Borrowed(s)))
    }
    fn visit_str<E>(self, s: &str) -> std::result::Result<Self::Value, E> {
        Ok(Loose::Str(Cow::Owned(s.to_owned())))
    }
    fn visit_bool<E>(self, b: bool) -> std::result::Result<Self::Value, E> {
        Ok(Loose::Bool(b))
    }
    fn visit_i64<E>(self, _: i64) -> std::result::Result<Self::Value, E> {
        Ok(Loose::Other)
    }
    fn visit_u64<E>(self, _: u64) -> std::result::Result<Self::Value, E> {
        Ok(Loose::Other)
    }
    fn visit_f64<E>(self, _: f64) -> std::result::Result<Self::Value, E> {
        Ok(Loose::Other)
    }
    fn visit_unit<E>(self) -> std::result::Result<Self::Value, E> {
        Ok(Loose::Other)
    }
    fn visit_seq<A: SeqAccess<'de>>(
        self,
        mut seq: A,
    ) -> std::result::Result<Self::Value, A::Error> {
        while seq.next_element::<IgnoredAny>()?.is_some() {}
        Ok(Loose::Other)
    }
    fn visit_map<A: MapAccess<'de>>(
        self,
        mut map: A,
    ) -> std::result::Result<Self::Value, A::Error> {
        while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
        Ok(Loose::Other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn split_all(text: &str) -> std::result::Result<Vec<String>, String> {
        let mut split = Splitter::default();
        let mut spans = Vec::new();
        let used = split
            .records(text.as_bytes(), &mut spans)
            .map_err(|e| e.1)?;
        if split.expect != Expect::End || !text[used..].trim().is_empty() {
            return Err(format!("unfinished at {used}"));
        }
        Ok(spans.into_iter().map(|(_, r)| text[r].to_owned()).collect())
    }

    #[test]
    fn records_are_cut_at_the_arrays_commas_only() {
        let got = split_all(
            "[\n {\"a\": \"x,]}\\\"{\", \"b\": [1, {\"c\": []}]},\n 5 ,\"s\\\\\",[],{}, true\n]\n",
        )
        .unwrap();
        assert_eq!(
            got,
            [
                "{\"a\": \"x,]}\\\"{\", \"b\": [1, {\"c\": []}]}",
                "5",
                "\"s\\\\\"",
                "[]",
                "{}",
                "true"
            ]
        );
        assert_eq!(split_all(" [ ] ").unwrap(), Vec::<String>::new());
        assert!(split_all("{}").unwrap_err().contains("JSON array"));
        assert!(split_all("[{} {}]").unwrap_err().contains("`,` or `]`"));
        assert!(split_all("[{},]")
            .unwrap_err()
            .contains("expected a record"));
        assert!(split_all("[] x").unwrap_err().contains("trailing"));
    }

    #[test]
    fn a_record_cut_by_the_block_is_left_for_the_next() {
        let text = "[{\"a\": \"b\"}, {\"c\": [1, 2";
        let mut split = Splitter::default();
        let mut spans = Vec::new();
        let used = split.records(text.as_bytes(), &mut spans).unwrap();
        assert_eq!(spans.len(), 1);
        assert_eq!(&text[used..], "{\"c\": [1, 2");
        let rest = format!("{}]}}]", &text[used..]);
        let used = split.records(rest.as_bytes(), &mut spans).unwrap();
        assert_eq!(used, rest.len());
        assert_eq!(spans[1].0, 1);
        assert_eq!(&rest[spans[1].1.clone()], "{\"c\": [1, 2]}");
    }

    #[test]
    fn loose_fields_borrow_strings_and_skip_the_rest() {
        #[derive(serde::Deserialize)]
        struct Key<'a> {
            #[serde(borrow, default)]
            a: Option<Loose<'a>>,
            #[serde(borrow, default)]
            b: Option<Loose<'a>>,
            #[serde(borrow, default)]
            c: Option<Loose<'a>>,
        }
        let k: Key =
            serde_json::from_str(r#"{"x": [1, {"y": 2}], "a": "t", "b": true, "c": [1]}"#).unwrap();
        assert!(matches!(k.a, Some(Loose::Str(Cow::Borrowed("t")))));
        assert!(matches!(k.b, Some(Loose::Bool(true))));
        assert!(matches!(k.c, Some(Loose::Other)));
        let k: Key = serde_json::from_str(r#"{"a": "t\u0041", "b": null}"#).unwrap();
        assert_eq!(k.a.unwrap().token(), Some(Token::new("tA")));
        assert!(k.b.is_none() && k.c.is_none());
    }
}
