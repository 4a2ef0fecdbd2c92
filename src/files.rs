//! Errors of the files tandem writes and reads back: trajectories,
//! datasets, episode recordings.

pub mod csv;

use std::path::{Path, PathBuf};
use thiserror::Error;

/// A file that could not be read, written or encoded.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum FileError {
    /// A file that could not be read or written.
    #[error("cannot access {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        #[source]
        /// The underlying error.
        source: std::io::Error,
    },
    /// An encoding error writing a file.
    #[error("cannot write {path}: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

impl FileError {
    /// The `Io` error of `path`, to map an `std::io::Error` with.
    pub fn io(path: &Path) -> impl FnOnce(std::io::Error) -> FileError + '_ {
        move |source| FileError::Io { path: path.into(), source }
    }

    /// The `Format` error of `path` for an encoder's error `e`.
    pub fn format(path: &Path, e: impl std::fmt::Display) -> FileError {
        FileError::Format { path: path.into(), message: e.to_string() }
    }
}

/// Checks, before long work, that `path` can be written: its folder is
/// created when missing and the file opened for writing (an existing file
/// is left as it is; a new one is removed again), so that a run of minutes
/// does not end in "cannot write".
///
/// # Errors
/// [`FileError::Io`] naming the folder or the file.
pub fn check_writable(path: &Path) -> Result<(), FileError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(FileError::io(dir))?;
    }
    let existed = path.exists();
    std::fs::OpenOptions::new().append(true).create(true).open(path).map_err(FileError::io(path))?;
    if !existed {
        std::fs::remove_file(path).map_err(FileError::io(path))?;
    }
    Ok(())
}
