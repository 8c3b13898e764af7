//! How a training run fails.

use crate::net::network::{ConfigError, InputError};
use crate::net::weights::WeightsError;
use crate::pipeline::truth_fed::SceneError;
use matscan_scan::{Param, ScanError};
use std::path::PathBuf;

/// A training run that failed.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// A file or folder could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A data folder could not be listed.
    #[error(transparent)]
    Scan(#[from] ScanError),
    /// A scene could not be prepared (training needs simulated bundles
    /// with ground truth).
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// No scene of the data folder is usable for this network.
    #[error("{}: no usable scene for the {kind} network", dir.display())]
    NoScenes {
        /// The folder.
        dir: PathBuf,
        /// The network.
        kind: Param,
    },
    /// Bad network width.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The network refused a sample.
    #[error(transparent)]
    Network(#[from] InputError),
    /// Weights could not be written or read.
    #[error(transparent)]
    Weights(#[from] WeightsError),
    /// A checkpoint is unusable.
    #[error("checkpoint: {0}")]
    Checkpoint(String),
    /// The loss became non-finite too often.
    #[error("the loss was not finite in {0} consecutive steps; lower the learning rate")]
    Diverged(usize),
    /// The backend failed to give data back.
    #[error("backend: {0}")]
    Backend(String),
}
