//! Errors of rendering and of writing simulated bundles.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// Reading or writing a bundle, a mesh or an image failed.
    #[error(transparent)]
    Scan(#[from] matscan_scan::ScanError),
    #[error("{path}: environment map: {message}")]
    EnvironmentMap { path: PathBuf, message: String },
    #[error("scene has no position {index} (it has {count})")]
    NoSuchPosition { index: usize, count: usize },
    #[error("position `{position}` has no rig light named `{light}`")]
    NoSuchLight { position: String, light: String },
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("invalid render options: {0}")]
    Options(String),
    /// A scene description could not be made.
    #[error("{}: {message}", path.display())]
    Description { path: PathBuf, message: String },
}
