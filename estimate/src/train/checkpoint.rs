//! Checkpoints a training run can be resumed from after a kill.
//!
//! A checkpoint is a folder `checkpoint-<step>/` holding the network
//! (`net.weights`, the ordinary weight format), the Adam state
//! (`optimizer.bpk`, burn's `OptimizerRecord`), the network's parameter ids
//! in visiting order (`param_ids.txt`) and `state.txt` (step, seconds).
//! It is written under a temporary name and renamed, then the one-line
//! file `latest` is replaced (temporary file + rename) to name it, and only
//! then are older checkpoints removed: a kill at any moment leaves `latest`
//! naming a complete checkpoint.
//!
//! Why the parameter ids: burn keys the optimizer state by `ParamId`, and a
//! network loaded from a weight file gets fresh ids; on resume the loaded
//! network's parameters are given back their saved ids (in the same
//! visiting order), so the Adam moments attach to the right tensors.
//!
//! Out of scope: what is trained (see the module root).

use super::error::TrainError;
use crate::net::network::{NetConfig, ParamNet};
use crate::net::weights;
use burn::module::{Module, ModuleMapper, ModuleVisitor, Param, ParamId};
use burn::optim::OptimizerRecord;
use burn::tensor::{Device, Tensor};
use std::path::{Path, PathBuf};

/// What a checkpoint restores.
pub struct Restored {
    /// The network, with its saved parameter ids.
    pub net: ParamNet,
    /// The optimizer state.
    pub optimizer: OptimizerRecord,
    /// Steps done.
    pub step: usize,
    /// Training seconds spent before.
    pub seconds: f64,
}

#[derive(Default)]
struct Ids(Vec<ParamId>);

impl ModuleVisitor for Ids {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        self.0.push(param.id);
    }
}

struct SetIds {
    ids: std::vec::IntoIter<ParamId>,
    missing: bool,
}

impl ModuleMapper for SetIds {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        let (id, value, mapper) = param.consume();
        let id = match self.ids.next() {
            Some(saved) => saved,
            None => {
                self.missing = true;
                id
            }
        };
        Param::from_mapped_value(id, value, mapper)
    }
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> TrainError + '_ {
    move |source| TrainError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes `bytes` to `path` through a temporary file and a rename
/// ([`matscan_scan::atomic::write_atomic`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), TrainError> {
    Ok(matscan_scan::atomic::write_atomic(path, bytes)?)
}

/// Saves a checkpoint of `net` and `optimizer` after `step` steps into `out`.
pub fn save(
    out: &Path,
    net: &ParamNet,
    optimizer: OptimizerRecord,
    step: usize,
    seconds: f64,
) -> Result<PathBuf, TrainError> {
    let name = format!("checkpoint-{step:08}");
    let dir = out.join(&name);
    let temp = out.join(format!("{name}.partial"));
    if temp.exists() {
        std::fs::remove_dir_all(&temp).map_err(io(&temp))?;
    }
    std::fs::create_dir_all(&temp).map_err(io(&temp))?;
    weights::save_file(net, &temp.join("net.weights"))?;
    optimizer
        .save(temp.join("optimizer.bpk"))
        .map_err(|e| TrainError::Checkpoint(format!("optimizer state: {e:?}")))?;
    let mut ids = Ids::default();
    net.visit(&mut ids);
    let ids: Vec<String> = ids.0.iter().map(|id| id.val().to_string()).collect();
    let ids_path = temp.join("param_ids.txt");
    std::fs::write(&ids_path, ids.join("\n")).map_err(io(&ids_path))?;
    let state_path = temp.join("state.txt");
    std::fs::write(&state_path, format!("step {step}\nseconds {seconds}\n"))
        .map_err(io(&state_path))?;
    if dir.exists() {
        std::fs::remove_dir_all(&dir).map_err(io(&dir))?;
    }
    std::fs::rename(&temp, &dir).map_err(io(&dir))?;
    write_atomic(&out.join("latest"), name.as_bytes())?;
    // Older checkpoints are no longer needed.
    if let Ok(entries) = std::fs::read_dir(out) {
        for entry in entries.flatten() {
            let file = entry.file_name();
            let file = file.to_string_lossy();
            if file.starts_with("checkpoint-") && *file != name {
                let _ = std::fs::remove_dir_all(entry.path());
            }
        }
    }
    Ok(dir)
}

/// Loads the checkpoint `latest` names, if any, for a network of `config`.
pub fn load(
    out: &Path,
    config: NetConfig,
    device: &Device,
) -> Result<Option<Restored>, TrainError> {
    let latest = out.join("latest");
    let name = match std::fs::read_to_string(&latest) {
        Ok(name) => name.trim().to_string(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(io(&latest)(e)),
    };
    let dir = out.join(&name);
    let bad = |what: String| TrainError::Checkpoint(format!("{}: {what}", dir.display()));
    let net = weights::load_file(&dir.join("net.weights"), config, device)?;
    let ids_path = dir.join("param_ids.txt");
    let ids_text = std::fs::read_to_string(&ids_path).map_err(io(&ids_path))?;
    let ids: Vec<ParamId> = ids_text
        .lines()
        .map(|l| {
            l.trim()
                .parse::<u64>()
                .map(ParamId::from)
                .map_err(|e| bad(format!("parameter id `{l}`: {e}")))
        })
        .collect::<Result<_, _>>()?;
    let count = ids.len();
    let mut mapper = SetIds {
        ids: ids.into_iter(),
        missing: false,
    };
    let net = net.map(&mut mapper);
    if mapper.missing || mapper.ids.next().is_some() {
        return Err(bad(format!(
            "{count} saved parameter ids do not match the network"
        )));
    }
    let optimizer = OptimizerRecord::load(dir.join("optimizer.bpk"))
        .map_err(|e| bad(format!("optimizer state: {e:?}")))?;
    let state_path = dir.join("state.txt");
    let state = std::fs::read_to_string(&state_path).map_err(io(&state_path))?;
    let field = |key: &str| -> Option<&str> {
        state
            .lines()
            .find_map(|l| l.strip_prefix(key).map(str::trim))
    };
    let step = field("step ")
        .and_then(|v| v.parse::<usize>().ok())
        .ok_or_else(|| bad("state.txt has no step".into()))?;
    let seconds = field("seconds ")
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(0.0);
    Ok(Some(Restored {
        net,
        optimizer,
        step,
        seconds,
    }))
}
