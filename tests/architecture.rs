//! The layering of docs/architecture.md, checked on the source: the table of layers is read from
//! the document itself, so the document and the code cannot drift apart silently.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Module name → layer, from the rows `| N | `a`, `b` | ... |` of docs/architecture.md.
fn layers() -> BTreeMap<String, u32> {
    let text = std::fs::read_to_string(repo().join("docs/architecture.md")).unwrap();
    let mut out = BTreeMap::new();
    for line in text.lines() {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 4 {
            continue;
        }
        let Ok(layer) = cells[1].parse::<u32>() else {
            continue;
        };
        for module in cells[2].split(',') {
            let name = module.trim().trim_matches('`');
            assert!(
                out.insert(name.to_owned(), layer).is_none(),
                "{name} is in two rows"
            );
        }
    }
    assert!(
        out.len() > 5,
        "no layer table found in docs/architecture.md"
    );
    out
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The top-level modules a source text names through `crate::` paths (`crate::a::b`,
/// `crate::{a::b, c}`, nested groups), with the line of each.
fn crate_imports(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut rest = text;
    let mut offset = 0;
    while let Some(at) = rest.find("crate::") {
        let start = offset + at + "crate::".len();
        let line = text[..start].matches('\n').count() + 1;
        let tail = &text[start..];
        if let Some(group) = tail.strip_prefix('{') {
            // the names that open each item of the group at its top level
            let mut depth = 0;
            let mut item_start = true;
            let mut name = String::new();
            for c in group.chars() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        if item_start && !name.is_empty() {
                            out.push((line, std::mem::take(&mut name)));
                        }
                        break;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => item_start = true,
                    c if item_start && (c.is_alphanumeric() || c == '_') => name.push(c),
                    _ if item_start && !name.is_empty() => {
                        out.push((line, std::mem::take(&mut name)));
                        item_start = false;
                    }
                    _ => {}
                }
            }
        } else {
            let name: String = tail
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            out.push((line, name));
        }
        offset = start;
        rest = &text[start..];
    }
    out
}

#[test]
fn the_import_scanner_sees_paths_and_groups() {
    let text = "use crate::fs::read_file;\nuse crate::{camera::{A, B}, kitti::Calib, image};\n let x = crate::warp::build();";
    let found: Vec<String> = crate_imports(text).into_iter().map(|(_, n)| n).collect();
    assert_eq!(found, ["fs", "camera", "kitti", "image", "warp"]);
}

#[test]
fn no_module_imports_from_its_own_layer_or_above() {
    let layers = layers();
    let src = repo().join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut broken = Vec::new();
    for file in &files {
        let rel = file.strip_prefix(&src).unwrap();
        let top = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_owned();
        if matches!(top.as_str(), "main" | "lib" | "cli") {
            continue;
        }
        let own = *layers
            .get(&top)
            .unwrap_or_else(|| panic!("src/{top} is not in docs/architecture.md's table"));
        let text = std::fs::read_to_string(file).unwrap();
        for (line, module) in crate_imports(&text) {
            if module == top {
                continue;
            }
            match layers.get(&module) {
                Some(&layer) if layer < own => {}
                Some(&layer) => broken.push(format!(
                    "src/{}:{line}: {top} (layer {own}) imports {module} (layer {layer})",
                    rel.display()
                )),
                None => broken.push(format!(
                    "src/{}:{line}: crate::{module} is not in the table",
                    rel.display()
                )),
            }
        }
    }
    assert!(
        broken.is_empty(),
        "imports against the layers:\n{}",
        broken.join("\n")
    );
}

#[test]
fn every_library_module_is_in_the_table() {
    let layers = layers();
    let lib = std::fs::read_to_string(repo().join("src/lib.rs")).unwrap();
    let modules: Vec<&str> = lib
        .lines()
        .filter_map(|l| {
            let l = l.trim();
            l.strip_prefix("pub mod ")
                .or_else(|| l.strip_prefix("mod "))
                .map(|m| m.trim_end_matches(';'))
        })
        .collect();
    assert!(modules.len() > 5);
    for m in &modules {
        assert!(
            layers.contains_key(*m),
            "src/lib.rs declares {m}, which docs/architecture.md's table lacks"
        );
    }
    for m in layers.keys() {
        assert!(
            modules.contains(&m.as_str()),
            "the table names {m}, which src/lib.rs does not declare"
        );
    }
}

#[test]
fn clap_and_anyhow_stay_in_the_binary() {
    let src = repo().join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    for file in files {
        let rel = file.strip_prefix(&src).unwrap().to_path_buf();
        if rel.starts_with("cli") || rel == Path::new("main.rs") {
            continue;
        }
        let text = std::fs::read_to_string(&file).unwrap();
        for word in ["clap::", "anyhow"] {
            assert!(!text.contains(word), "src/{} uses {word}", rel.display());
        }
    }
}
