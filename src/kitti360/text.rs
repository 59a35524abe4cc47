//! The plain-text tables of KITTI-360: `key: numbers` lines (`calib_cam_to_pose.txt`,
//! `perspective.txt`), bare rows of numbers (`calib_cam_to_velo.txt`, `poses.txt`). Values are
//! parsed with their line so that every error names file, line and field.

use crate::error::{Error, Result};
use nalgebra::Matrix4;
use std::path::Path;

/// One `key: v1 v2 ...` line.
#[derive(Debug, Clone)]
pub(crate) struct KeyedLine {
    pub key: String,
    pub values: Vec<String>,
    pub line: usize,
}

/// The `key: values` lines of a file (blank lines skipped). A line without a colon is an error.
pub(crate) fn keyed_lines(lines: &[String], path: &Path) -> Result<Vec<KeyedLine>> {
    let mut out = Vec::new();
    for (i, text) in lines.iter().enumerate() {
        let text = text.trim();
        if text.is_empty() {
            continue;
        }
        let Some((key, rest)) = text.split_once(':') else {
            return Err(Error::parse(
                path,
                i + 1,
                "line",
                format!("expected `name: values`, found {text:?}"),
            ));
        };
        out.push(KeyedLine {
            key: key.trim().to_owned(),
            values: rest.split_whitespace().map(str::to_owned).collect(),
            line: i + 1,
        });
    }
    Ok(out)
}

/// Exactly `n` finite numbers; `field` names them in errors (`field[i]` for a bad value).
pub(crate) fn numbers(
    values: &[String],
    n: usize,
    path: &Path,
    line: usize,
    field: &str,
) -> Result<Vec<f64>> {
    if values.len() != n {
        return Err(Error::parse(
            path,
            line,
            field,
            format!("expected {n} numbers, found {}", values.len()),
        ));
    }
    values
        .iter()
        .enumerate()
        .map(|(i, v)| {
            v.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    Error::parse(
                        path,
                        line,
                        format!("{field}[{i}]"),
                        format!("not a finite number: {v:?}"),
                    )
                })
        })
        .collect()
}

/// The value of `key` among `lines`: exactly `n` numbers, or an error naming the missing key.
pub(crate) fn required(lines: &[KeyedLine], key: &str, n: usize, path: &Path) -> Result<Vec<f64>> {
    let found = lines.iter().find(|l| l.key == key).ok_or_else(|| {
        Error::parse(
            path,
            lines.last().map_or(1, |l| l.line),
            key,
            format!("missing `{key}:` line"),
        )
    })?;
    numbers(&found.values, n, path, found.line, key)
}

/// A 3x4 row-major matrix completed to 4x4 with [0 0 0 1].
pub(crate) fn matrix_3x4(v: &[f64]) -> Matrix4<f64> {
    let mut m = Matrix4::identity();
    for r in 0..3 {
        for c in 0..4 {
            m[(r, c)] = v[r * 4 + c];
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(text: &str) -> Vec<String> {
        text.lines().map(str::to_owned).collect()
    }

    #[test]
    fn keyed_values_are_read_with_their_lines() {
        let path = Path::new("calib.txt");
        let l = keyed_lines(&lines("a: 1 2 3\n\nb: 4.5e1 -1\n"), path).unwrap();
        assert_eq!(required(&l, "b", 2, path).unwrap(), vec![45.0, -1.0]);
        let e = required(&l, "a", 4, path).unwrap_err().to_string();
        assert_eq!(e, "calib.txt:1: a: expected 4 numbers, found 3");
        let e = required(&l, "c", 1, path).unwrap_err().to_string();
        assert_eq!(e, "calib.txt:3: c: missing `c:` line");
        let l = keyed_lines(&lines("a: 1 x 3\n"), path).unwrap();
        let e = required(&l, "a", 3, path).unwrap_err().to_string();
        assert_eq!(e, "calib.txt:1: a[1]: not a finite number: \"x\"");
        let e = keyed_lines(&lines("a: 1\nno colon here\n"), path).unwrap_err();
        assert_eq!(
            e.to_string(),
            "calib.txt:2: line: expected `name: values`, found \"no colon here\""
        );
    }

    #[test]
    fn a_3x4_matrix_is_completed() {
        let v: Vec<f64> = (0..12).map(f64::from).collect();
        let m = matrix_3x4(&v);
        assert_eq!(m[(1, 3)], 7.0);
        assert_eq!(m[(2, 0)], 8.0);
        assert_eq!(
            m.row(3).iter().copied().collect::<Vec<_>>(),
            [0.0, 0.0, 0.0, 1.0]
        );
    }
}
