//! Where the tests and benchmarks find the repository and the real data outside it. The
//! benchmarks include this file alone (`#[path]`), so it depends on nothing else in tests/.

use std::path::{Path, PathBuf};

/// The repository root.
pub fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The real KITTI frames (read only; never copied into the repo): `$PANOCONV_KITTI`, else
/// `../shared/kitti`; a relative path is taken from the repository root.
pub fn real_kitti() -> PathBuf {
    let dir = std::env::var_os("PANOCONV_KITTI")
        .filter(|v| !v.is_empty())
        .map_or_else(|| PathBuf::from("../shared/kitti"), PathBuf::from);
    repo().join(dir)
}

/// The panoramas of `../shared/pano` (read only).
pub fn real_panos() -> PathBuf {
    repo().join("../shared/pano")
}
