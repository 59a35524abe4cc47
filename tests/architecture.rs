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

/// The library file that holds module `path` (`["run", "journal"]` → src/run/journal/mod.rs),
/// if there is one.
fn module_file(src: &Path, path: &[String]) -> Option<PathBuf> {
    if path.is_empty() {
        return Some(src.join("lib.rs"));
    }
    let joined: PathBuf = path.iter().collect();
    [
        src.join(&joined).with_extension("rs"),
        src.join(&joined).join("mod.rs"),
    ]
    .into_iter()
    .find(|p| p.is_file())
}

/// The module path of a library file (src/run/frames.rs → ["run", "frames"]).
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut path: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(path.last().map(String::as_str), Some("mod" | "lib")) {
        path.pop();
    }
    path
}

/// The paths a `crate::` or `super::` path names, groups expanded (`a::{b, c::{d, e}}`), as
/// segments after the prefix.
fn expand_paths(text: &str) -> Vec<Vec<String>> {
    let ident = |s: &str| -> usize {
        s.find(|c: char| !(c.is_alphanumeric() || c == '_'))
            .unwrap_or(s.len())
    };
    let mut out = Vec::new();
    let mut prefix = Vec::new();
    let mut rest = text;
    loop {
        let n = ident(rest);
        if n == 0 {
            break;
        }
        prefix.push(rest[..n].to_owned());
        rest = &rest[n..];
        match rest.strip_prefix("::") {
            Some(r) if r.starts_with('{') => {
                // the group's items at its top level, each expanded
                let body = &r[1..];
                let (mut depth, mut start) = (0usize, 0usize);
                for (i, c) in body.char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' | ',' if depth == 0 => {
                            for mut p in expand_paths(body[start..i].trim()) {
                                let mut full = prefix.clone();
                                full.append(&mut p);
                                out.push(full);
                            }
                            if c == '}' {
                                return out;
                            }
                            start = i + 1;
                        }
                        '}' => depth -= 1,
                        _ => {}
                    }
                }
                return out;
            }
            Some(r) => rest = r,
            None => break,
        }
    }
    if !prefix.is_empty() {
        out.push(prefix);
    }
    out
}

/// The library files a library file imports through `crate::` and `super::` paths (not its
/// tests, not its comments).
fn file_imports(src: &Path, file: &Path) -> Vec<PathBuf> {
    let text = std::fs::read_to_string(file).unwrap();
    let code = text.split("#[cfg(test)]").next().unwrap();
    let code: String = code
        .lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n");
    let own = module_of(src, file);
    let mut out = Vec::new();
    for (at, _) in code.match_indices("::") {
        let before = &code[..at];
        let word_start = before
            .rfind(|c: char| !(c.is_alphanumeric() || c == '_'))
            .map_or(0, |i| i + 1);
        let word = &before[word_start..];
        // the start of a path only: `crate::`, `super::` (not `a::super::`)
        if word_start >= 2 && &before[word_start - 2..word_start] == "::" {
            continue;
        }
        let mut base = match word {
            "crate" => Vec::new(),
            "super" => own[..own.len().saturating_sub(1)].to_vec(),
            _ => continue,
        };
        let mut tail = &code[at + 2..];
        while let Some(t) = tail.strip_prefix("super::") {
            base.pop();
            tail = t;
        }
        for path in expand_paths(tail) {
            if let Some(f) = resolve(src, base.clone(), &path, 0).filter(|f| f != file) {
                out.push(f);
            }
        }
    }
    out.sort();
    out.dedup();
    out
}

/// The library file that defines what `path` names from module `module`: the deepest module
/// file on the path, and where that is a module's `mod.rs` (or `lib.rs`) and the rest of the
/// path an item it re-exports (`pub use child::Item`), the file the re-export leads to, so
/// that a circle through a `mod.rs`'s re-exports is seen.
fn resolve(src: &Path, mut module: Vec<String>, path: &[String], depth: usize) -> Option<PathBuf> {
    let mut found = module_file(src, &module);
    for seg in path {
        module.push(seg.clone());
        if let Some(f) = module_file(src, &module) {
            found = Some(f);
            continue;
        }
        module.pop();
        let holder = found.clone()?;
        let is_module_root = matches!(
            holder.file_name().and_then(|n| n.to_str()),
            Some("mod.rs" | "lib.rs")
        );
        if is_module_root && depth < 8 {
            if let Some(f) = reexport(src, &holder, &module, seg, depth) {
                return Some(f);
            }
        }
        break;
    }
    found
}

/// The file that `holder` (the module root of `module`) re-exports `item` from, if it does.
fn reexport(
    src: &Path,
    holder: &Path,
    module: &[String],
    item: &str,
    depth: usize,
) -> Option<PathBuf> {
    let text = std::fs::read_to_string(holder).ok()?;
    let code = text.split("#[cfg(test)]").next()?;
    for statement in code.split(';') {
        let statement = statement.trim();
        let Some(at) = statement.find("use ") else {
            continue;
        };
        if !statement[..at].trim_start().starts_with("pub") {
            continue;
        }
        let tail = statement[at + 4..].trim();
        let (base, tail) = if let Some(t) = tail.strip_prefix("crate::") {
            (Vec::new(), t)
        } else if let Some(t) = tail.strip_prefix("self::") {
            (module.to_vec(), t)
        } else if let Some(t) = tail.strip_prefix("super::") {
            (module[..module.len().saturating_sub(1)].to_vec(), t)
        } else {
            (module.to_vec(), tail)
        };
        for path in expand_paths(tail) {
            if path.last().map(String::as_str) == Some(item) {
                if let Some(f) = resolve(src, base.clone(), &path, depth + 1) {
                    return Some(f);
                }
            }
        }
    }
    None
}

#[test]
fn the_path_expander_sees_nested_groups() {
    let paths = expand_paths("run::{names::MANIFEST, frames::{A, b::C}}, x");
    let joined: Vec<String> = paths.iter().map(|p| p.join("::")).collect();
    assert_eq!(
        joined,
        [
            "run::names::MANIFEST",
            "run::frames::A",
            "run::frames::b::C"
        ]
    );
}

#[test]
fn an_import_through_a_reexport_leads_to_the_defining_file() {
    let src = repo().join("src");
    let path = |p: &str| p.split("::").map(str::to_owned).collect::<Vec<_>>();
    // `camera::Equirect` is `camera/mod.rs`'s `pub use equirect::Equirect`
    assert_eq!(
        resolve(&src, Vec::new(), &path("camera::Equirect"), 0),
        Some(src.join("camera/equirect.rs"))
    );
    // an item defined in a module's own root stays there
    assert_eq!(
        resolve(&src, Vec::new(), &path("source::Frame"), 0),
        Some(src.join("source/mod.rs"))
    );
}

#[test]
fn no_circle_of_imports_between_library_files() {
    let src = repo().join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.retain(|f| {
        let rel = f.strip_prefix(&src).unwrap();
        !rel.starts_with("cli") && rel != Path::new("main.rs")
    });
    let graph: BTreeMap<PathBuf, Vec<PathBuf>> = files
        .iter()
        .map(|f| (f.clone(), file_imports(&src, f)))
        .collect();
    let circles = circles(&graph);
    assert!(
        circles.is_empty(),
        "circles of imports between files:\n{}",
        circles.join("\n")
    );
}

/// The circles of imports in `graph` (a file → the files it imports), each with the files on
/// it: a depth-first search, a back edge closing a circle.
fn circles(graph: &BTreeMap<PathBuf, Vec<PathBuf>>) -> Vec<String> {
    fn visit(
        f: &PathBuf,
        graph: &BTreeMap<PathBuf, Vec<PathBuf>>,
        state: &mut BTreeMap<PathBuf, u8>,
        stack: &mut Vec<PathBuf>,
        circles: &mut Vec<String>,
    ) {
        state.insert(f.clone(), 1);
        stack.push(f.clone());
        for g in graph.get(f).into_iter().flatten() {
            match state.get(g).copied().unwrap_or(0) {
                0 => visit(g, graph, state, stack, circles),
                1 => {
                    let at = stack.iter().position(|s| s == g).unwrap();
                    let names: Vec<String> = stack[at..]
                        .iter()
                        .chain([g])
                        .map(|p| p.strip_prefix(repo()).unwrap().display().to_string())
                        .collect();
                    circles.push(names.join(" -> "));
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(f.clone(), 2);
    }
    let (mut state, mut stack, mut circles) = (BTreeMap::new(), Vec::new(), Vec::new());
    for f in graph.keys() {
        if state.get(f).copied().unwrap_or(0) == 0 {
            visit(f, graph, &mut state, &mut stack, &mut circles);
        }
    }
    circles
}

/// What breaks the command line's floor under `src`: a command file (`cli/NAME.rs`) importing
/// its parent (`cli/mod.rs`) or another command's file (only `cli/shared/` and, for the rig
/// commands, `cli/rig.rs` are below it), a file of `cli/shared/` importing anything outside
/// it, and any circle between the binary's files (through `mod.rs` re-exports too).
fn cli_floor_breaks(src: &Path) -> Vec<String> {
    let (cli, shared) = (src.join("cli"), src.join("cli/shared"));
    let mut files = Vec::new();
    rust_files(&cli, &mut files);
    let graph: BTreeMap<PathBuf, Vec<PathBuf>> = files
        .iter()
        .map(|f| (f.clone(), file_imports(src, f)))
        .collect();
    let mut breaks = circles(&graph);
    for (f, imports) in &graph {
        if *f == cli.join("mod.rs") {
            continue;
        }
        for g in imports {
            let allowed = if f.starts_with(&shared) {
                g.starts_with(&shared)
            } else {
                g.starts_with(&shared) || *g == cli.join("rig.rs")
            };
            if !allowed {
                let rel = |p: &Path| p.strip_prefix(src).unwrap().display().to_string();
                breaks.push(format!("{} imports {}", rel(f), rel(g)));
            }
        }
    }
    breaks
}

#[test]
fn the_command_line_has_a_floor() {
    let breaks = cli_floor_breaks(&repo().join("src"));
    assert!(
        breaks.is_empty(),
        "the CLI's files must import only cli/shared/ (and cli/rig.rs):\n{}",
        breaks.join("\n")
    );
}
