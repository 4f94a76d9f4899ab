//! Variant sweeps for a render farm: a sweep file names a base scene and the
//! values to vary; `drape sweep` writes one resolved scene per variant with
//! a key (a hash of everything its bake depends on) and a manifest; farm
//! tasks bake the variants (any scheduler runs them: Slurm job arrays, or
//! this machine), and `collect` gathers one table and a contact sheet.
//!
//! Layout of a sweep folder:
//!
//! ```text
//! DIR/manifest.csv        index, folder, key, label, one column per varied key
//! DIR/sweep.toml          the sweep file, as read
//! DIR/v0000/scene.toml    the variant's resolved scene (asset paths absolute)
//! DIR/v0000/key           its key
//! DIR/v0000/bake/         its bake folder, once complete (with `key` inside, and
//!                         `reference_error.json` when the sweep asks for the error)
//! DIR/v0000/bake.partial/ a bake in progress (resumed by the next task)
//! DIR/v0000/failed.txt    why its simulation stopped, if it did
//! ```

pub mod layout;
pub mod reference;
pub mod report;
pub mod sweep;
pub mod variant;

use std::path::{Path, PathBuf};

/// What can go wrong with a sweep or a sweep folder.
#[derive(Debug, thiserror::Error)]
pub enum FarmError {
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The sweep file is malformed.
    #[error("sweep {}: {problem}", file.display())]
    Sweep {
        /// The sweep file.
        file: PathBuf,
        /// What is wrong (with the line, for syntax).
        problem: String,
    },
    /// A variant does not make a valid scene.
    #[error("variant {index} ({label}): {problem}")]
    Variant {
        /// Its index.
        index: usize,
        /// Its label.
        label: String,
        /// What is wrong.
        problem: String,
    },
    /// The folder is not a sweep folder, or its manifest is damaged.
    #[error("{}: {problem}", dir.display())]
    Folder {
        /// The sweep folder.
        dir: PathBuf,
        /// What is wrong.
        problem: String,
    },
}

impl FarmError {
    /// An I/O error on `path`.
    pub fn io(path: &Path, source: std::io::Error) -> FarmError {
        FarmError::Io { path: path.to_owned(), source }
    }
}
