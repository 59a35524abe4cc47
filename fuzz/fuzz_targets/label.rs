//! Label lines: `Label::parse` must return Ok or a tagged error for any text, never panic; the
//! line-splitting of `LabelFile::read` (`read_lines`) is mirrored here on raw bytes. An accepted
//! label must also survive the operations the conversion applies to it.
#![no_main]

use libfuzzer_sys::fuzz_target;
use panoconv::kitti::Label;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("label_2/000000.txt");
    for (i, raw) in data.split(|&b| b == b'\n').enumerate() {
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let Ok(line) = std::str::from_utf8(raw) else {
            continue;
        };
        match Label::parse(path, i + 1, line) {
            Ok(label) => {
                assert!(label.tokens.len() == 15 || label.tokens.len() == 16);
                assert!(label.location.iter().all(|v| v.is_finite()));
                let _ = label.has_box_3d();
                let _ = label.corners();
                let _ = label.to_line_with(label.bbox, Some(label.truncated));
            }
            Err(e) => assert!(e.to_string().starts_with("label_2/000000.txt:")),
        }
    }
});
