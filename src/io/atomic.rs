//! Files written whole or not at all: the content goes to a hidden temporary
//! file beside the target, which is renamed over the target only once complete.
//! A crash, a full disk or Ctrl-C never leaves a half-written file under the
//! real name.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// A file that could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}: {source}")]
pub struct WriteError {
    /// The file that was being written.
    pub path: PathBuf,
    /// The I/O error.
    pub source: std::io::Error,
}

/// Writes `path` through `fill`, atomically (temporary file + rename).
pub fn write_file(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), WriteError> {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let temporary = path.with_file_name(format!(".{name}.partial"));
    let attempt = || -> std::io::Result<()> {
        let mut out = BufWriter::new(File::create(&temporary)?);
        fill(&mut out)?;
        out.into_inner().map_err(|e| e.into_error())?.sync_data()?;
        std::fs::rename(&temporary, path)
    };
    attempt().map_err(|source| {
        let _ = std::fs::remove_file(&temporary);
        WriteError { path: path.to_owned(), source }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn a_failed_write_leaves_neither_the_file_nor_the_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frame.obj");
        write_file(&path, |w| w.write_all(b"old")).unwrap();
        let err = write_file(&path, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("disk full"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("frame.obj") && err.to_string().contains("disk full"));
        assert_eq!(std::fs::read(&path).unwrap(), b"old", "the previous file is untouched");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temporary left");
    }

    #[test]
    fn a_missing_folder_is_a_clear_error() {
        let err = write_file(Path::new("/nonexistent/drape/out.obj"), |w| w.write_all(b"x")).unwrap_err();
        assert!(err.to_string().starts_with("cannot write /nonexistent/drape/out.obj"));
    }
}
