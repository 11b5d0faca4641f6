//! Whole-or-nothing file writes: write a temporary file in the target's folder,
//! then rename it over the target, so a failure (bad data found half-way, full
//! disk, Ctrl-C) never leaves a truncated output behind.

use std::io::{BufWriter, Write};
use std::path::Path;

use crate::error::Error;

/// Writes `path` through `fill`; the file appears only if `fill` and the flush succeed.
pub fn write(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), Error> {
    let fail = |source| Error::Write {
        path: path.to_owned(),
        source,
    };
    // The temporary file must be on the same file system for the rename to be atomic.
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let temp = temp_builder().tempfile_in(dir).map_err(fail)?;
    let mut out = BufWriter::new(temp);
    fill(&mut out).map_err(fail)?;
    let temp = out.into_inner().map_err(|e| fail(e.into_error()))?;
    temp.as_file().sync_all().map_err(fail)?;
    temp.persist(path).map_err(|e| fail(e.error))?;
    Ok(())
}

/// A temporary file created like any other output file: on Unix with mode
/// 0666 less the umask (tempfile's own default, 0600, would leave calibrations
/// and reports unreadable to the rest of a lab).
fn temp_builder() -> tempfile::Builder<'static, 'static> {
    let mut builder = tempfile::Builder::new();
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    builder
}
