//! Errors of reading and writing bundles. Every variant names the file (and
//! the key, where there is one) and says what was expected.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum ScanError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: key `{key}`: {expected}")]
    Invalid {
        path: PathBuf,
        key: String,
        expected: String,
    },
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
}
