//! Float depth predictions as NumPy writes them: `.npy` (one array) and `.npz` (a zip of
//! `.npy` files, stored or deflated, as `np.savez` and `np.savez_compressed` write them).
//!
//! The array holds metres, `float32` or `float64` of either byte order, shaped `(H, W)` or with
//! extra axes of length 1 (`(1, H, W)`, `(H, W, 1)`, `(1, 1, H, W)`: a network's batch and
//! channel axes). A `.npz` must hold exactly one array, so that no key has to be guessed.

use crate::error::{Error, Result};
use std::path::Path;

/// A depth map read from a `.npy` or `.npz` file: width, height, metres row by row.
pub fn read_depth_array(path: &Path) -> Result<(u32, u32, Vec<f64>)> {
    let bytes = crate::fs::read_file(path)?;
    let npz = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("npz"));
    if npz {
        let npy = only_member(&bytes).map_err(|m| Error::file(path, m))?;
        parse_npy(&npy).map_err(|m| Error::file(path, m))
    } else {
        parse_npy(&bytes).map_err(|m| Error::file(path, m))
    }
}

/// An `.npy` file's array.
fn parse_npy(bytes: &[u8]) -> std::result::Result<(u32, u32, Vec<f64>), String> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err("not a .npy array (no \\x93NUMPY magic)".into());
    }
    let (header_len, start) = match bytes[6] {
        1 => (usize::from(u16::from_le_bytes([bytes[8], bytes[9]])), 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(format!(".npy format version {v} is not supported")),
    };
    let header = bytes
        .get(start..start + header_len)
        .and_then(|h| std::str::from_utf8(h).ok())
        .ok_or("truncated or unreadable .npy header")?;
    let descr = dict_value(header, "descr").ok_or("the .npy header has no 'descr'")?;
    let descr = descr
        .get(1..)
        .and_then(|d| d.split(['\'', '"']).next())
        .unwrap_or("");
    let (little, size) = match descr {
        "<f4" | "=f4" => (true, 4),
        "<f8" | "=f8" => (true, 8),
        ">f4" => (false, 4),
        ">f8" => (false, 8),
        other => {
            return Err(format!(
                "dtype {other} is not a float depth (float32 or float64 metres)"
            ))
        }
    };
    let fortran = dict_value(header, "fortran_order").is_some_and(|v| v.starts_with("True"));
    let (h, w) = npy_plane(header)?;
    let data = &bytes[start + header_len..];
    let n = w * h;
    if data.len() < n * size {
        return Err(format!(
            "{} bytes of data for a {h}x{w} array of {size}-byte floats",
            data.len()
        ));
    }
    let value = |i: usize| -> f64 {
        let b = &data[i * size..(i + 1) * size];
        match (size, little) {
            (4, true) => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            (4, false) => f64::from(f32::from_be_bytes([b[0], b[1], b[2], b[3]])),
            (_, true) => f64::from_le_bytes(b.try_into().expect("8 bytes")),
            (_, false) => f64::from_be_bytes(b.try_into().expect("8 bytes")),
        }
    };
    let values = (0..n)
        .map(|i| {
            // Fortran order stores columns one after another.
            let src = if fortran { (i % w) * h + i / w } else { i };
            let d = value(src);
            // No prediction (NaN, infinite, negative) is the PNG's 0: clamped like it.
            if d.is_finite() && d > 0.0 {
                d
            } else {
                0.0
            }
        })
        .collect();
    let dim = |n: usize| u32::try_from(n).map_err(|_| format!("{n} pixels is too large"));
    Ok((dim(w)?, dim(h)?, values))
}

/// The (height, width) of the one depth map an `.npy` header's shape holds (batch and
/// channel axes of 1 aside).
fn npy_plane(header: &str) -> std::result::Result<(usize, usize), String> {
    let shape_text = dict_value(header, "shape").ok_or("the .npy header has no 'shape'")?;
    let shape: Vec<usize> = shape_text
        .trim_start_matches('(')
        .split(')')
        .next()
        .unwrap_or("")
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<usize>()
                .map_err(|_| format!("bad shape {shape_text}"))
        })
        .collect::<std::result::Result<_, _>>()?;
    let plane: Vec<usize> = shape.iter().copied().filter(|&n| n != 1).collect();
    let (h, w) = match (plane.as_slice(), shape.len()) {
        ([h, w], _) => (*h, *w),
        // A 1-pixel-wide or -high map keeps its ones: take the last two axes.
        (_, n) if n >= 2 && plane.len() < 2 => (shape[n - 2], shape[n - 1]),
        _ => {
            return Err(format!(
                "shape {shape:?} is not one depth map (H, W), with batch or channel axes of 1"
            ))
        }
    };
    Ok((h, w))
}

/// The text after `'key':` in a .npy header dict, up to the end of the dict.
fn dict_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let at = header
        .find(&format!("'{key}'"))
        .or_else(|| header.find(&format!("\"{key}\"")))?;
    let rest = &header[at + key.len() + 2..];
    Some(rest.trim_start().strip_prefix(':')?.trim_start())
}

/// The one `.npy` member of a zip archive, inflated.
fn only_member(zip: &[u8]) -> std::result::Result<Vec<u8>, String> {
    let u16_at = |i: usize| -> Option<usize> {
        zip.get(i..i + 2)
            .map(|b| usize::from(u16::from_le_bytes([b[0], b[1]])))
    };
    let u32_at = |i: usize| -> Option<usize> {
        zip.get(i..i + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    // The end-of-central-directory record: the entry count and where the directory starts.
    let eocd = (0..zip.len().saturating_sub(21))
        .rev()
        .find(|&i| zip[i..].starts_with(b"PK\x05\x06"))
        .ok_or("not a .npz (zip) archive")?;
    let entries = u16_at(eocd + 10).ok_or("truncated zip")?;
    if entries != 1 {
        return Err(format!(
            "the archive holds {entries} arrays; save the depth map alone (np.savez(f, depth))"
        ));
    }
    let dir = u32_at(eocd + 16).ok_or("truncated zip")?;
    if zip.get(dir..dir + 4) != Some(b"PK\x01\x02") {
        return Err("damaged zip central directory".into());
    }
    let method = u16_at(dir + 10).ok_or("truncated zip")?;
    let compressed = u32_at(dir + 20).ok_or("truncated zip")?;
    let local = u32_at(dir + 42).ok_or("truncated zip")?;
    if zip.get(local..local + 4) != Some(b"PK\x03\x04") {
        return Err("damaged zip local header".into());
    }
    let data_at = local
        + 30
        + u16_at(local + 26).ok_or("truncated zip")?
        + u16_at(local + 28).ok_or("truncated zip")?;
    let data = zip
        .get(data_at..data_at + compressed)
        .ok_or("truncated zip member")?;
    match method {
        0 => Ok(data.to_vec()),
        8 => miniz_oxide::inflate::decompress_to_vec(data)
            .map_err(|e| format!("cannot inflate the array: {e:?}")),
        m => Err(format!(
            "zip compression method {m} is not supported (stored or deflate)"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn npy(descr: &str, shape: &str, fortran: bool, data: &[u8]) -> Vec<u8> {
        let mut header = format!(
            "{{'descr': '{descr}', 'fortran_order': {}, 'shape': {shape}, }}",
            if fortran { "True" } else { "False" }
        );
        while (10 + header.len() + 1) % 64 != 0 {
            header.push(' ');
        }
        header.push('\n');
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend((header.len() as u16).to_le_bytes());
        out.extend(header.as_bytes());
        out.extend(data);
        out
    }

    #[test]
    fn float_arrays_of_every_supported_layout_read_row_by_row() {
        let f4: Vec<u8> = [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let (w, h, v) = parse_npy(&npy("<f4", "(2, 3)", false, &f4)).unwrap();
        assert_eq!((w, h, v), (3, 2, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
        let (w, h, _) = parse_npy(&npy("<f4", "(1, 2, 3)", false, &f4)).unwrap();
        assert_eq!((w, h), (3, 2));
        // Column-major: the columns (1, 2), (3, 4), (5, 6) of a 2x3 array.
        let (_, _, v) = parse_npy(&npy("<f4", "(2, 3)", true, &f4)).unwrap();
        assert_eq!(v, vec![1.0, 3.0, 5.0, 2.0, 4.0, 6.0]);
        let f8: Vec<u8> = [7.5f64, f64::NAN]
            .iter()
            .flat_map(|v| v.to_be_bytes())
            .collect();
        let (_, _, v) = parse_npy(&npy(">f8", "(1, 2)", false, &f8)).unwrap();
        assert_eq!(v, vec![7.5, 0.0]);
    }

    #[test]
    fn integer_and_short_arrays_are_refused_by_what_is_wrong() {
        let e = parse_npy(&npy("<u2", "(1, 2)", false, &[0; 4])).unwrap_err();
        assert!(e.contains("dtype <u2"), "{e}");
        let e = parse_npy(&npy("<f4", "(2, 2)", false, &[0; 8])).unwrap_err();
        assert!(e.contains("8 bytes of data"), "{e}");
        let e = parse_npy(&npy("<f4", "(2, 2, 2)", false, &[0; 32])).unwrap_err();
        assert!(e.contains("not one depth map"), "{e}");
        assert!(parse_npy(b"PK\x03\x04 not npy").is_err());
    }
}
