//! Reading only the records of a table that something else names (the ego poses of the
//! samples kept, the instances of their annotations, the annotations their tracks step to):
//! each record's token is checked before the record is parsed, so a large version's tables
//! are not held whole.

use super::records::stream;
use super::tables::key;
use super::token::Token;
use crate::error::Result;
use serde::Deserialize;
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// The records of a table whose token `wanted` holds, read by `read`; every record's token
/// is checked, the others are skipped unread.
pub(super) fn read_listed<R, T>(
    path: &Path,
    wanted: &HashSet<Token>,
    read: fn(&Path, usize, &R) -> Result<(Token, T)>,
) -> Result<HashMap<Token, T>>
where
    R: for<'de> Deserialize<'de>,
    T: Send,
{
    let mut out = HashMap::new();
    stream(
        path,
        |r| {
            let listed = r.parse::<key::Listed>().ok().and_then(|k| k.token?.token());
            if listed.is_some_and(|t| !wanted.contains(&t)) {
                return Ok(None);
            }
            // A wanted record, or one whose token is wrong: read it strictly.
            read(path, r.index, &r.parse::<R>()?).map(Some)
        },
        |_, (token, t)| {
            out.insert(token, t);
            Ok(())
        },
    )?;
    Ok(out)
}
