//! Where the tests and benchmarks find the repository and what lies outside it: the real data
//! of `../shared` and the ONNX Runtime library. The benchmarks include this file alone
//! (`#[path]`), so it depends on nothing else in tests/.
//!
//! A test that needs one of these on a machine without it fails with one line saying what is
//! missing and how to get it, rather than with an unreadable I/O error deep inside the test.

use std::path::{Path, PathBuf};

/// The repository root.
pub fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The real KITTI frames (read only; never copied into the repo): `$PANOCONV_KITTI`, else
/// `../shared/kitti`; a relative path is taken from the repository root.
#[track_caller]
pub fn real_kitti() -> PathBuf {
    let dir = std::env::var_os("PANOCONV_KITTI")
        .filter(|v| !v.is_empty())
        .map_or_else(|| shared().join("kitti"), PathBuf::from);
    require_dir(
        repo().join(dir),
        "the real KITTI frames",
        "set PANOCONV_KITTI to a KITTI object root, or put the project's shared/ folder beside the repository",
    )
}

/// The panoramas of `../shared/pano` (read only).
#[track_caller]
pub fn real_panos() -> PathBuf {
    require_dir(
        repo().join(shared()).join("pano"),
        "the real panoramas",
        "put the project's shared/ folder beside the repository",
    )
}

/// The real PandaSet sequence of `../shared/pandaset/002` (read only; never copied).
#[track_caller]
pub fn real_pandaset() -> PathBuf {
    require_dir(
        repo().join(shared()).join("pandaset/002"),
        "the real PandaSet frames",
        "put the project's shared/ folder beside the repository",
    )
}

/// The ONNX Runtime library the style tests load: `$ORT_DYLIB_PATH`, else what
/// `scripts/install_ort.sh` installs into `<repo>/.ort/`.
#[track_caller]
pub fn ort_lib() -> PathBuf {
    let (lib, from) = match std::env::var_os("ORT_DYLIB_PATH").filter(|v| !v.is_empty()) {
        Some(v) => (PathBuf::from(v), "ORT_DYLIB_PATH="),
        None => (repo().join(".ort/libonnxruntime.so.1.31.1"), ""),
    };
    assert!(
        lib.is_file(),
        "ONNX Runtime library missing ({from}{}): run scripts/install_ort.sh, or scripts/test.sh, which installs it",
        lib.display()
    );
    lib
}

/// The shared data beside the repository: `$PANOCONV_SHARED`, else `../shared`.
fn shared() -> PathBuf {
    std::env::var_os("PANOCONV_SHARED")
        .filter(|v| !v.is_empty())
        .map_or_else(|| PathBuf::from("../shared"), PathBuf::from)
}

#[track_caller]
fn require_dir(dir: PathBuf, what: &str, fix: &str) -> PathBuf {
    assert!(
        dir.is_dir(),
        "{what} are not at {}: {fix} (a test that reads them is listed in tests/needs_shared.txt, so that scripts/test.sh skips it without them)",
        dir.display()
    );
    dir
}
