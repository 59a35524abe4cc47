//! The checked access to a nuScenes record's fields.
//!
//! A record the selection keeps is read into its table's *raw* struct, whose fields are
//! `serde_json::Value`s (so that another key order, extra keys and integers where floats are
//! meant all load); [`Fields`] then checks each field it is asked for, and an error names the
//! file, the record's token and the field. (The tables are read by `records.rs`.)

use crate::error::{Error, Result};
use serde_json::Value;
use std::fmt;
use std::path::Path;

use super::token::Token;

/// The checked fields of one record: every error names the table file, the record (its token,
/// or its position when it has none) and the field.
pub struct Fields<'a> {
    path: &'a Path,
    record: String,
}

impl<'a> Fields<'a> {
    /// The record at `index` of the table at `path`, with its `token` field (a string).
    pub fn new(path: &'a Path, index: usize, token: &Option<Value>) -> Result<(Self, Token)> {
        let mut fields = Fields {
            path,
            record: format!("record #{index}"),
        };
        let token = fields.token("token", token)?;
        fields.record = format!("record {token}");
        Ok((fields, token))
    }

    /// An error about `field` of this record.
    pub fn error(&self, field: &str, message: impl fmt::Display) -> Error {
        Error::file(self.path, format!("{}: {field}: {message}", self.record))
    }

    fn present<'v>(&self, field: &str, value: &'v Option<Value>) -> Result<&'v Value> {
        match value {
            Some(v) => Ok(v),
            None => Err(self.error(field, "missing (or null)")),
        }
    }

    /// A string field.
    pub fn string(&self, field: &str, value: &Option<Value>) -> Result<String> {
        match self.present(field, value)? {
            Value::String(s) => Ok(s.clone()),
            other => Err(self.error(field, format!("expected a string, found {}", kind(other)))),
        }
    }

    /// A token field (a non-empty string).
    pub fn token(&self, field: &str, value: &Option<Value>) -> Result<Token> {
        let s = self.string(field, value)?;
        if s.is_empty() {
            return Err(self.error(field, "empty token"));
        }
        Ok(Token::new(&s))
    }

    /// A link to another record: a token, or None for `""` or null (the end of a chain).
    pub fn link(&self, field: &str, value: &Option<Value>) -> Result<Option<Token>> {
        match value {
            None | Some(Value::Null) => Ok(None),
            Some(Value::String(s)) if s.is_empty() => Ok(None),
            Some(Value::String(s)) => Ok(Some(Token::new(s))),
            Some(other) => Err(self.error(
                field,
                format!("expected a token or \"\", found {}", kind(other)),
            )),
        }
    }

    /// A non-negative integer (an integral number; nuScenes' timestamps are microseconds).
    pub fn integer(&self, field: &str, value: &Option<Value>) -> Result<u64> {
        let v = self.present(field, value)?;
        if let Some(n) = v.as_u64() {
            return Ok(n);
        }
        match v.as_f64() {
            Some(x) if x >= 0.0 && x.fract() == 0.0 && x < 2f64.powi(63) => Ok(x as u64),
            _ => Err(self.error(
                field,
                format!("expected a non-negative integer, found {}", shown(value)),
            )),
        }
    }

    /// A boolean.
    pub fn boolean(&self, field: &str, value: &Option<Value>) -> Result<bool> {
        match self.present(field, value)? {
            Value::Bool(b) => Ok(*b),
            other => Err(self.error(
                field,
                format!("expected true or false, found {}", kind(other)),
            )),
        }
    }

    /// An array of exactly `N` finite numbers.
    pub fn numbers<const N: usize>(&self, field: &str, value: &Option<Value>) -> Result<[f64; N]> {
        let v = self.present(field, value)?;
        let items = match v {
            Value::Array(items) if items.len() == N => items,
            _ => {
                return Err(self.error(
                    field,
                    format!("expected an array of {N} numbers, found {}", shown(value)),
                ))
            }
        };
        let mut out = [0.0; N];
        for (i, item) in items.iter().enumerate() {
            out[i] = number_of(item).ok_or_else(|| {
                self.error(
                    &format!("{field}[{i}]"),
                    format!("expected a finite number, found {item}"),
                )
            })?;
        }
        Ok(out)
    }

    /// An array of tokens (`[]` allowed).
    pub fn tokens(&self, field: &str, value: &Option<Value>) -> Result<Vec<Token>> {
        match value {
            None | Some(Value::Null) => Ok(Vec::new()),
            Some(Value::Array(items)) => items
                .iter()
                .enumerate()
                .map(|(i, item)| match item {
                    Value::String(s) if !s.is_empty() => Ok(Token::new(s)),
                    other => Err(self.error(
                        &format!("{field}[{i}]"),
                        format!("expected a token, found {other}"),
                    )),
                })
                .collect(),
            Some(other) => Err(self.error(
                field,
                format!("expected an array of tokens, found {}", kind(other)),
            )),
        }
    }

    /// A 3x3 matrix written as three rows of three numbers, or None for `[]` (a sensor
    /// without intrinsics).
    pub fn matrix3(&self, field: &str, value: &Option<Value>) -> Result<Option<[[f64; 3]; 3]>> {
        let rows = match value {
            None | Some(Value::Null) => return Ok(None),
            Some(Value::Array(rows)) if rows.is_empty() => return Ok(None),
            Some(Value::Array(rows)) if rows.len() == 3 => rows,
            _ => {
                return Err(self.error(
                    field,
                    format!("expected [] or 3 rows of 3 numbers, found {}", shown(value)),
                ))
            }
        };
        let mut m = [[0.0; 3]; 3];
        for (r, row) in rows.iter().enumerate() {
            m[r] = self.numbers::<3>(&format!("{field}[{r}]"), &Some(row.clone()))?;
        }
        Ok(Some(m))
    }
}

fn number_of(v: &Value) -> Option<f64> {
    v.as_f64().filter(|x| x.is_finite())
}

fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

fn shown(value: &Option<Value>) -> String {
    match value {
        None => "nothing".into(),
        Some(v) => {
            let s = v.to_string();
            if s.len() > 60 {
                format!("{}...", s.chars().take(57).collect::<String>())
            } else {
                s
            }
        }
    }
}
