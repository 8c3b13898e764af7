//! Errors of reading and writing bundles. Every variant names the file (and
//! the key, where there is one) and says what was expected, so that a user
//! can fix a bundle from the message alone.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum ScanError {
    /// The operating system refused a read or write.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A manifest value breaks a rule of the format.
    #[error("{path}: key `{key}`: {expected}")]
    Invalid {
        path: PathBuf,
        key: String,
        expected: String,
    },
    /// A file is not what its format says it should be (bad TOML, a
    /// corrupt image, non-finite pixels, ...).
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    /// A file the bundle needs is not there.
    #[error("{path}: missing ({needed_by})")]
    Missing { path: PathBuf, needed_by: String },
    /// An image whose size differs from the camera's.
    #[error(
        "{path}: image is {found_width}x{found_height} pixels, expected \
         {expected_width}x{expected_height} (the camera's width x height in scan.toml)"
    )]
    SizeMismatch {
        path: PathBuf,
        expected_width: u32,
        expected_height: u32,
        found_width: u32,
        found_height: u32,
    },
    /// A position, capture or truth map that the manifest does not have.
    #[error("{path}: {message}")]
    NotInManifest { path: PathBuf, message: String },
    /// A publish that would replace an existing folder or file.
    #[error("{path} already exists; refusing to replace it")]
    AlreadyExists { path: PathBuf },
}

impl ScanError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        ScanError::Io {
            path: path.into(),
            source,
        }
    }

    pub(crate) fn format(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        ScanError::Format {
            path: path.into(),
            message: message.into(),
        }
    }
}
