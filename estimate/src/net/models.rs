//! The parameter networks a run uses, each with a model id for the record.
//!
//! Weights come from a directory holding `<param>.weights` per network
//! (only the networks a plan runs are loaded, so a directory may lack the
//! others), from the weights embedded in the binary, or, for tests and
//! benchmarks, from fresh random networks built from a seed.
//!
//! A model id is `<param>-w<width>-<checksum>` for a file (the file's own
//! trailing FNV-1a checksum, so two different files never share an id) and
//! `<param>-w<width>-seed<seed>` for a seeded network.
//!
//! Out of scope: the file format (see `weights`).

use crate::net::network::{NetConfig, ParamNet};
use crate::net::weights::{self, WeightsError};
use burn::tensor::Device;
use matscan_scan::Param;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// File name of `kind`'s weights in a weights directory.
pub fn weights_file_name(kind: Param) -> String {
    format!("{}.weights", kind.name())
}

/// Where the networks come from.
#[derive(Debug)]
pub enum ModelSource {
    /// `<dir>/<param>.weights`.
    Dir(PathBuf),
    /// The weights compiled into the binary.
    Embedded,
    /// Networks already in memory.
    Loaded(Models),
}

/// One network and its id.
#[derive(Debug)]
pub struct Model {
    /// The network.
    pub net: ParamNet,
    /// What produced it, for `result.toml`.
    pub id: String,
}

/// Networks by parameter.
#[derive(Debug, Default)]
pub struct Models {
    models: BTreeMap<Param, Model>,
}

/// A network the run needs is not available.
#[derive(Debug, thiserror::Error)]
pub enum ModelsError {
    /// The weights file (or embedded weights) could not be used.
    #[error("{kind} weights: {source}")]
    Weights {
        /// The network.
        kind: Param,
        /// Why.
        #[source]
        source: WeightsError,
    },
    /// In-memory models lack a network the plan runs.
    #[error("no {0} network was provided")]
    NotProvided(Param),
}

impl Models {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds (or replaces) a network.
    pub fn insert(&mut self, net: ParamNet, id: impl Into<String>) {
        let kind = net.config().kind();
        self.models.insert(kind, Model { net, id: id.into() });
    }

    /// Fresh random networks of `width` (tracks of a quarter) for `kinds`,
    /// reproducible from `seed`.
    pub fn seeded(
        kinds: &[Param],
        width: usize,
        seed: u64,
        device: &Device,
    ) -> Result<Self, crate::net::network::ConfigError> {
        let mut models = Models::new();
        for (i, &kind) in kinds.iter().enumerate() {
            let config = NetConfig::new(kind, width)?;
            device.seed(seed.wrapping_add(i as u64));
            models.insert(
                ParamNet::new(config, device),
                format!("{kind}-w{width}-seed{seed}"),
            );
        }
        Ok(models)
    }

    /// Loads `<dir>/<param>.weights` for each of `kinds`.
    pub fn load_dir(dir: &Path, kinds: &[Param], device: &Device) -> Result<Self, ModelsError> {
        let mut models = Models::new();
        for &kind in kinds {
            let path = dir.join(weights_file_name(kind));
            let origin = path.display().to_string();
            let wrap = |source| ModelsError::Weights { kind, source };
            let bytes = std::fs::read(&path).map_err(|e| {
                wrap(match e.kind() {
                    std::io::ErrorKind::NotFound => WeightsError::Missing {
                        origin: origin.clone(),
                    },
                    _ => WeightsError::Io {
                        origin: origin.clone(),
                        source: e,
                    },
                })
            })?;
            let net = weights::from_bytes(&bytes, &origin, kind, device).map_err(wrap)?;
            let id = file_id(&net, &bytes);
            models.insert(net, id);
        }
        Ok(models)
    }

    /// Loads the embedded weights of each of `kinds`.
    pub fn load_embedded(kinds: &[Param], device: &Device) -> Result<Self, ModelsError> {
        let mut models = Models::new();
        for &kind in kinds {
            let net = weights::load_embedded(kind, device)
                .map_err(|source| ModelsError::Weights { kind, source })?;
            let bytes = weights::EMBEDDED
                .iter()
                .find(|(k, _)| *k == kind)
                .map_or(&[][..], |(_, b)| *b);
            let id = file_id(&net, bytes);
            models.insert(net, id);
        }
        Ok(models)
    }

    /// Saves every network as `<dir>/<param>.weights`.
    pub fn save_dir(&self, dir: &Path) -> Result<(), WeightsError> {
        std::fs::create_dir_all(dir).map_err(|source| WeightsError::Io {
            origin: dir.display().to_string(),
            source,
        })?;
        for (kind, model) in &self.models {
            weights::save_file(&model.net, &dir.join(weights_file_name(*kind)))?;
        }
        Ok(())
    }

    /// The network of `kind`, if present.
    pub fn get(&self, kind: Param) -> Option<&Model> {
        self.models.get(&kind)
    }

    /// Checks that every one of `kinds` is present.
    pub fn require(&self, kinds: &[Param]) -> Result<(), ModelsError> {
        match kinds.iter().find(|k| !self.models.contains_key(k)) {
            Some(&kind) => Err(ModelsError::NotProvided(kind)),
            None => Ok(()),
        }
    }
}

impl ModelSource {
    /// The networks of `kinds` from this source.
    pub fn resolve(self, kinds: &[Param], device: &Device) -> Result<Models, ModelsError> {
        let models = match self {
            ModelSource::Dir(dir) => Models::load_dir(&dir, kinds, device)?,
            ModelSource::Embedded => Models::load_embedded(kinds, device)?,
            ModelSource::Loaded(models) => models,
        };
        models.require(kinds)?;
        Ok(models)
    }
}

/// `<param>-w<width>-<checksum>`: the file's trailing checksum in hex.
fn file_id(net: &ParamNet, bytes: &[u8]) -> String {
    let config = net.config();
    let tail = bytes.len().saturating_sub(8);
    let checksum: String = bytes[tail..]
        .iter()
        .rev()
        .map(|b| format!("{b:02x}"))
        .collect();
    format!("{}-w{}-{checksum}", config.kind(), config.width())
}
