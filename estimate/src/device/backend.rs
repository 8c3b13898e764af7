//! Which backend runs the networks, chosen explicitly: one of the CPU
//! backends built in, or the Vulkan GPU ([`Backend`], the one choice every
//! command and the benchmark share).
//!
//! burn 0.22 dispatches on a runtime [`Device`]; `Device::default()` picks
//! the first backend compiled in, GPUs first, so this crate never calls it.
//! Flex (feature `flex`, the default) is burn's own SIMD CPU backend; ndarray
//! (feature `ndarray`) is deprecated upstream and kept for comparison.

use burn::tensor::Device;
use std::fmt;

#[cfg(not(any(feature = "flex", feature = "ndarray")))]
compile_error!("matscan-estimate needs a CPU backend: enable feature `flex` or `ndarray`");

/// A CPU backend this crate can run on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CpuBackend {
    /// burn-flex: pure Rust, SIMD, multi-threaded.
    Flex,
    /// burn-ndarray (deprecated upstream).
    NdArray,
}

/// The backend was not compiled into this build.
#[derive(Debug, thiserror::Error)]
#[error("the {backend} backend is not built in; rebuild with feature `{feature}` (`cargo build --release -p matscan --features {feature}`)")]
pub struct BackendMissing {
    backend: CpuBackend,
    feature: &'static str,
}

impl CpuBackend {
    /// Every backend, built in or not.
    pub const ALL: [CpuBackend; 2] = [CpuBackend::Flex, CpuBackend::NdArray];

    /// The Cargo feature that builds it in.
    pub fn feature(self) -> &'static str {
        match self {
            CpuBackend::Flex => "flex",
            CpuBackend::NdArray => "ndarray",
        }
    }

    /// Whether this build contains it.
    pub fn is_built(self) -> bool {
        match self {
            CpuBackend::Flex => cfg!(feature = "flex"),
            CpuBackend::NdArray => cfg!(feature = "ndarray"),
        }
    }

    /// The device of this backend.
    pub fn device(self) -> Result<Device, BackendMissing> {
        let missing = BackendMissing {
            backend: self,
            feature: self.feature(),
        };
        match self {
            #[cfg(feature = "flex")]
            CpuBackend::Flex => Ok(Device::flex()),
            #[cfg(feature = "ndarray")]
            #[allow(deprecated)] // kept on purpose, for comparison with flex
            CpuBackend::NdArray => Ok(Device::ndarray()),
            #[allow(unreachable_patterns)]
            _ => Err(missing),
        }
    }
}

impl fmt::Display for CpuBackend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.feature())
    }
}

/// The preferred CPU backend of this build: flex when built in, else ndarray.
pub fn default_cpu_backend() -> CpuBackend {
    if CpuBackend::Flex.is_built() {
        CpuBackend::Flex
    } else {
        CpuBackend::NdArray
    }
}

/// The device of [`default_cpu_backend`].
pub fn cpu_device() -> Device {
    match default_cpu_backend().device() {
        Ok(device) => device,
        // The compile_error above guarantees one backend is built in.
        Err(missing) => unreachable!("{missing}"),
    }
}

/// What runs the networks: a CPU backend, or the GPU (feature `vulkan`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    Cpu(CpuBackend),
    Gpu,
}

/// A backend that cannot run in this build or on this machine.
#[derive(Debug, thiserror::Error)]
pub enum BackendError {
    #[error(transparent)]
    Cpu(#[from] BackendMissing),
    #[error(transparent)]
    Gpu(#[from] crate::device::gpu::GpuUnavailable),
}

impl Backend {
    /// The names [`Backend::from_str`](std::str::FromStr) takes: `cpu` is
    /// this build's default CPU backend.
    pub const NAMES: &'static str = "cpu, flex, ndarray or gpu";

    /// The device, and for the GPU the adapter it runs on.
    pub fn device(self) -> Result<(Device, Option<crate::device::gpu::GpuAdapter>), BackendError> {
        Ok(match self {
            Backend::Cpu(b) => (b.device()?, None),
            Backend::Gpu => {
                let (device, adapter) = crate::device::gpu::gpu_device()?;
                (device, Some(adapter))
            }
        })
    }

    /// `cpu flex`, `cpu ndarray` or `gpu`: how tables name it.
    pub fn label(self) -> String {
        match self {
            Backend::Cpu(b) => format!("cpu {b}"),
            Backend::Gpu => "gpu".to_string(),
        }
    }
}

impl Default for Backend {
    fn default() -> Backend {
        Backend::Cpu(default_cpu_backend())
    }
}

impl std::str::FromStr for Backend {
    type Err = String;
    fn from_str(s: &str) -> Result<Backend, String> {
        match s {
            "cpu" => Ok(Backend::default()),
            "flex" => Ok(Backend::Cpu(CpuBackend::Flex)),
            "ndarray" => Ok(Backend::Cpu(CpuBackend::NdArray)),
            "gpu" => Ok(Backend::Gpu),
            other => Err(format!(
                "unknown backend `{other}`: expected {}",
                Backend::NAMES
            )),
        }
    }
}

/// `device` with gradient tracking, for training.
#[cfg(feature = "train")]
pub fn training_device(device: Device) -> Device {
    device.autodiff()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_backend_is_built_and_gives_a_device() {
        let backend = default_cpu_backend();
        assert!(backend.is_built());
        assert!(backend.device().is_ok());
    }

    #[test]
    fn backend_names_parse_and_an_unknown_one_lists_the_known_ones() {
        assert_eq!("cpu".parse::<Backend>(), Ok(Backend::default()));
        assert_eq!(
            "flex".parse::<Backend>(),
            Ok(Backend::Cpu(CpuBackend::Flex))
        );
        assert_eq!(
            "ndarray".parse::<Backend>(),
            Ok(Backend::Cpu(CpuBackend::NdArray))
        );
        assert_eq!("gpu".parse::<Backend>(), Ok(Backend::Gpu));
        let e = "tpu".parse::<Backend>().unwrap_err();
        assert!(e.contains("tpu") && e.contains(Backend::NAMES), "{e}");
        assert!(Backend::default().device().is_ok());
        if !crate::device::gpu::gpu_is_built() {
            let e = Backend::Gpu.device().unwrap_err().to_string();
            assert!(e.contains("--features vulkan"), "{e}");
        }
    }

    #[test]
    fn a_missing_backend_names_its_feature() {
        for backend in CpuBackend::ALL {
            match backend.device() {
                Ok(_) => assert!(backend.is_built()),
                Err(missing) => {
                    assert!(!backend.is_built());
                    let text = missing.to_string();
                    assert!(text.contains(backend.feature()), "{text}");
                }
            }
        }
    }
}
