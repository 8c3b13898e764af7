//! The GPU backend (feature `vulkan`): burn's wgpu runtime pinned to
//! Vulkan, on the adapter chosen here.
//!
//! burn creates its device lazily and reports a missing adapter as a panic
//! in its worker thread, not as an error, so the adapter is found here
//! first, with wgpu directly: the Vulkan loader must load
//! (`libvulkan.so.1`; Debian: `libvulkan1`) and find a driver (its ICD JSON
//! in `/usr/share/vulkan/icd.d` or `/etc/vulkan/icd.d`, or named by
//! `VK_DRIVER_FILES`). A discrete GPU is preferred, then an integrated,
//! a virtual and finally a CPU implementation (Mesa's lavapipe), which runs
//! the same kernels and serves to check this path on a machine without a
//! GPU. `CUBECL_WGPU_DEFAULT_DEVICE` is not consulted: the choice is made
//! here and passed to burn as that adapter's kind and index.
//!
//! Boundaries: finds the device; the networks are backend-agnostic.

use burn::tensor::Device;

/// The GPU cannot be used, and why.
#[derive(Debug, thiserror::Error)]
pub enum GpuUnavailable {
    #[error(
        "the GPU backend is not built in; rebuild with `--features vulkan` \
         (adds 30 to 45 minutes to a clean build on 2 cores)"
    )]
    NotBuilt,
    #[error(
        "no Vulkan loader: {0}; install it (Debian: `apt install libvulkan1`) \
         and the GPU's Vulkan driver"
    )]
    NoLoader(String),
    #[error(
        "no Vulkan adapter: the loader found no driver; install the GPU's Vulkan driver or \
         name its ICD file with VK_DRIVER_FILES (e.g. \
         /usr/share/vulkan/icd.d/nvidia_icd.json; searched: {searched})"
    )]
    NoAdapter { searched: String },
}

/// The adapter a GPU device runs on.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GpuAdapter {
    /// The adapter's name, as the driver reports it.
    pub name: String,
    /// Its kind (`discrete`, `integrated`, `virtual`, `cpu`) and index
    /// among adapters of that kind.
    pub kind: String,
    pub index: usize,
    /// The driver and its version.
    pub driver: String,
}

impl std::fmt::Display for GpuAdapter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} ({} #{}, Vulkan, {})",
            self.name, self.kind, self.index, self.driver
        )
    }
}

/// Whether this build contains the GPU backend.
pub fn gpu_is_built() -> bool {
    cfg!(feature = "vulkan")
}

/// The device on the preferred Vulkan adapter, and that adapter.
pub fn gpu_device() -> Result<(Device, GpuAdapter), GpuUnavailable> {
    imp::gpu_device()
}

/// Where the loader looks for drivers, for the error message.
#[cfg_attr(not(feature = "vulkan"), allow(dead_code))]
fn icd_search_text() -> String {
    let mut places: Vec<String> = ["VK_DRIVER_FILES", "VK_ICD_FILENAMES"]
        .into_iter()
        .filter_map(|v| std::env::var(v).ok().map(|p| format!("{v}={p}")))
        .collect();
    for dir in ["/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d"] {
        let count = std::fs::read_dir(dir).map_or(0, |d| d.count());
        places.push(format!("{dir} ({count} files)"));
    }
    places.join(", ")
}

/// The preference rank of an adapter kind: lower is better.
#[cfg_attr(not(feature = "vulkan"), allow(dead_code))]
fn rank(kind: &str) -> u8 {
    match kind {
        "discrete" => 0,
        "integrated" => 1,
        "virtual" => 2,
        "cpu" => 3,
        _ => 4,
    }
}

/// The preferred adapter among `(kind, index within kind)` pairs, in
/// enumeration order.
#[cfg_attr(not(feature = "vulkan"), allow(dead_code))]
fn preferred(kinds: &[&str]) -> Option<usize> {
    (0..kinds.len()).min_by_key(|&i| (rank(kinds[i]), i))
}

#[cfg(feature = "vulkan")]
mod imp {
    use super::*;
    use burn::tensor::DeviceKind;

    pub(super) fn gpu_device() -> Result<(Device, GpuAdapter), GpuUnavailable> {
        check_loader()?;
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let infos: Vec<wgpu::AdapterInfo> =
            futures_lite::future::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN))
                .iter()
                .map(wgpu::Adapter::get_info)
                .collect();
        let kinds: Vec<&str> = infos.iter().map(|i| kind_name(i.device_type)).collect();
        let Some(chosen) = preferred(&kinds) else {
            return Err(GpuUnavailable::NoAdapter {
                searched: icd_search_text(),
            });
        };
        let info = &infos[chosen];
        let index = kinds[..chosen]
            .iter()
            .filter(|k| **k == kinds[chosen])
            .count();
        let device_kind = match info.device_type {
            wgpu::DeviceType::DiscreteGpu => DeviceKind::DiscreteGpu(index),
            wgpu::DeviceType::IntegratedGpu => DeviceKind::IntegratedGpu(index),
            wgpu::DeviceType::VirtualGpu => DeviceKind::VirtualGpu(index),
            wgpu::DeviceType::Cpu => DeviceKind::Cpu,
            wgpu::DeviceType::Other => DeviceKind::DefaultDevice,
        };
        let adapter = GpuAdapter {
            name: info.name.clone(),
            kind: kinds[chosen].to_string(),
            index,
            driver: format!("{} {}", info.driver, info.driver_info),
        };
        Ok((Device::vulkan(device_kind), adapter))
    }

    fn kind_name(t: wgpu::DeviceType) -> &'static str {
        match t {
            wgpu::DeviceType::DiscreteGpu => "discrete",
            wgpu::DeviceType::IntegratedGpu => "integrated",
            wgpu::DeviceType::VirtualGpu => "virtual",
            wgpu::DeviceType::Cpu => "cpu",
            wgpu::DeviceType::Other => "other",
        }
    }

    /// The loader must load; wgpu only says "no adapter" when it does not.
    fn check_loader() -> Result<(), GpuUnavailable> {
        let name = c"libvulkan.so.1";
        // SAFETY: a NUL-terminated name; the handle is closed right away
        // (wgpu loads the library again itself), and dlerror's string is
        // copied before any other dl call.
        unsafe {
            let handle = libc::dlopen(name.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL);
            if handle.is_null() {
                let err = libc::dlerror();
                let text = if err.is_null() {
                    "libvulkan.so.1 could not be loaded".to_string()
                } else {
                    std::ffi::CStr::from_ptr(err).to_string_lossy().into_owned()
                };
                return Err(GpuUnavailable::NoLoader(text));
            }
            libc::dlclose(handle);
        }
        Ok(())
    }
}

#[cfg(not(feature = "vulkan"))]
mod imp {
    use super::*;

    pub(super) fn gpu_device() -> Result<(Device, GpuAdapter), GpuUnavailable> {
        Err(GpuUnavailable::NotBuilt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_discrete_gpu_wins_over_integrated_virtual_and_cpu_adapters() {
        assert_eq!(
            preferred(&["cpu", "integrated", "discrete", "virtual"]),
            Some(2)
        );
        assert_eq!(preferred(&["cpu", "virtual", "integrated"]), Some(2));
        assert_eq!(preferred(&["cpu", "virtual"]), Some(1));
        assert_eq!(preferred(&["other", "cpu"]), Some(1));
        assert_eq!(
            preferred(&["discrete", "discrete"]),
            Some(0),
            "first of a kind"
        );
        assert_eq!(preferred(&[]), None);
    }

    #[test]
    fn without_the_feature_the_gpu_names_the_feature_to_build() {
        if gpu_is_built() {
            return;
        }
        let err = gpu_device().map(|_| ()).unwrap_err().to_string();
        assert!(err.contains("--features vulkan"), "{err}");
    }
}
