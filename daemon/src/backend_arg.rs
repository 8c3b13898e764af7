//! `--backend`: which device the networks run on, for `estimate` and
//! `train`: `cpu` (the build's default CPU backend, flex), `flex`, `ndarray`
//! or `gpu` (Vulkan, with the `vulkan` feature).

use anyhow::{bail, Result};
use burn::tensor::Device;
use matscan_estimate::{cpu_device, gpu_device, CpuBackend};

/// The names `--backend` takes.
pub const BACKENDS: &str = "cpu, flex, ndarray or gpu";

/// The device `name` selects; a GPU's adapter is logged.
pub fn device(name: &str) -> Result<Device> {
    Ok(match name {
        "cpu" => cpu_device(),
        "flex" => CpuBackend::Flex.device()?,
        "ndarray" => CpuBackend::NdArray.device()?,
        "gpu" => {
            let (device, adapter) = gpu_device()?;
            tracing::info!("networks on the GPU: {adapter}");
            device
        }
        other => bail!("--backend {other}: expected {BACKENDS}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unknown_backend_lists_the_known_ones() {
        let e = device("tpu").unwrap_err().to_string();
        assert!(e.contains("--backend tpu") && e.contains(BACKENDS), "{e}");
    }

    #[test]
    fn the_cpu_backends_of_this_build_give_devices_and_the_gpu_says_what_it_needs() {
        assert!(device("cpu").is_ok());
        assert!(device("flex").is_ok(), "flex is the default feature");
        if !matscan_estimate::gpu_is_built() {
            let e = device("gpu").unwrap_err().to_string();
            assert!(e.contains("--features vulkan"), "{e}");
        }
    }
}
