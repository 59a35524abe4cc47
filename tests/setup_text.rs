//! The README's set-up text names every package the install scripts that `scripts/test.sh`
//! runs take from PyPI, with its pinned version: what a fresh clone downloads is said, not
//! "nothing else".

use crate::common::*;

/// The `name==version` pins of a script (its quoted requirement lists and wheel names).
fn pins(script: &str) -> Vec<String> {
    let text = read_text(&repo().join("scripts").join(script));
    text.split(|c: char| c == '"' || c.is_whitespace())
        .filter(|t| {
            let parts: Vec<&str> = t.split("==").collect();
            parts.len() == 2
                && !parts[0].is_empty()
                && parts[0]
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
                && parts[1].starts_with(|c: char| c.is_ascii_digit())
        })
        .map(|t| t.trim_end_matches([',', ')', ':']).to_owned())
        .collect()
}

#[test]
fn the_readme_names_every_package_the_test_script_installs() {
    let test_sh = read_text(&repo().join("scripts/test.sh"));
    let readme = read_text(&repo().join("README.md"));
    let mut all = Vec::new();
    for script in [
        "install_ort.sh",
        "install_test_python.sh",
        "install_python_package.sh",
    ] {
        assert!(
            test_sh.contains(script),
            "scripts/test.sh no longer runs {script}"
        );
        all.extend(pins(script));
    }
    for wanted in [
        "nuscenes-devkit==",
        "kitti360Scripts==",
        "pytest==",
        "maturin==",
    ] {
        assert!(
            all.iter().any(|p| p.starts_with(wanted)),
            "{wanted} not found in {all:?}"
        );
    }
    for pin in &all {
        if pin.starts_with("onnxruntime-gpu") || pin.starts_with("nvidia-") {
            continue; // install_ort.sh --gpu only, which scripts/test.sh does not run
        }
        assert!(
            readme.contains(&format!("`{pin}`")),
            "README.md does not name `{pin}`"
        );
    }
    assert!(!readme.contains("Nothing else is downloaded"));
}
