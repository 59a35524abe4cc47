//! Files a tool writes inside a converted dataset, recorded in its manifest.

use anyhow::Result;
use std::path::PathBuf;

/// Records files a tool wrote inside a converted dataset in its manifest, so that `verify`
/// checks them (see `panoconv::run::derived`), and says so.
pub(crate) fn record_derived(
    command: &str,
    target: &std::path::Path,
    files: &[PathBuf],
) -> Result<()> {
    if let Some(root) = panoconv::run::derived::record_if_inside(command, target, files)? {
        eprintln!(
            "panoconv: recorded in {} (checked by `panoconv verify`)",
            root.join(panoconv::run::manifest::MANIFEST).display()
        );
    }
    Ok(())
}
