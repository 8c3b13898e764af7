//! Which CPU backend runs the networks, chosen explicitly.
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
