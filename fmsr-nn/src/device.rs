//! Devices by name: the strings of an experiment's `device` key and of
//! `fmsr train --device`, parsed into a burn [`Device`].
//!
//! | string | device | cargo feature |
//! |---|---|---|
//! | `cpu`, `flex` | burn's `flex` backend (pure Rust, all cores) | always |
//! | `wgpu` | the best adapter wgpu finds (kernels in WGSL) | `wgpu` |
//! | `wgpu:N` | the `N`-th discrete GPU | `wgpu` |
//! | `wgpu:cpu` | a CPU Vulkan driver such as Mesa's lavapipe (for CI) | `wgpu` |
//! | `wgpu:integrated:N`, `wgpu:virtual:N` | the `N`-th integrated / virtual GPU | `wgpu` |
//! | `vulkan`, `vulkan:N`, `vulkan:cpu`, ... | as `wgpu`, pinned to Vulkan, kernels in SPIR-V | `vulkan` |
//! | `cuda`, `cuda:N` | the first / the `N`-th CUDA device (kernels through cubecl's LLVM backend) | `cuda` |
//!
//! A build with `vulkan` compiles every Vulkan kernel to SPIR-V, `wgpu:` devices
//! included; lavapipe cannot run those, so test on `wgpu:cpu` from a build
//! without `vulkan` (docs/design.md, "Devices").
//!
//! [`DeviceSpec::device`] checks that the build has the backend and that the
//! machine has the adapter, and otherwise returns [`NnError::Device`] listing
//! the devices that exist, so a run can fail before it creates anything. A
//! machine without NVIDIA's `libcuda` lists no CUDA device (the library is
//! looked for before anything is asked of it).
//!
//! ```
//! use fmsr_nn::{Adapter, DeviceSpec};
//! let spec: DeviceSpec = "wgpu:cpu".parse()?;
//! assert_eq!(spec, DeviceSpec::Wgpu(Adapter::Cpu));
//! assert_eq!(spec.to_string(), "wgpu:cpu");
//! assert_eq!("vulkan:1".parse::<DeviceSpec>()?, DeviceSpec::Vulkan(Adapter::Discrete(1)));
//! assert_eq!("cuda:1".parse::<DeviceSpec>()?, DeviceSpec::Cuda(Some(1)));
//! assert_eq!("cuda".parse::<DeviceSpec>()?.to_string(), "cuda");
//! assert!(DeviceSpec::Flex.device().is_ok());
//! assert!("tpu".parse::<DeviceSpec>().is_err());
//! # Ok::<(), fmsr_nn::NnError>(())
//! ```

use std::fmt;
use std::str::FromStr;

use burn::tensor::Device;

use crate::error::NnError;

/// One adapter of a wgpu or Vulkan backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Adapter {
    /// The adapter wgpu prefers (a high-power GPU first).
    Default,
    /// The `N`-th discrete GPU.
    Discrete(usize),
    /// The `N`-th integrated GPU.
    Integrated(usize),
    /// The `N`-th virtual GPU.
    Virtual(usize),
    /// A CPU driver (Mesa's lavapipe).
    Cpu,
}

/// A device named by a string; see the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DeviceSpec {
    /// burn's `flex` CPU backend.
    Flex,
    /// burn's wgpu backend (WGSL kernels).
    Wgpu(Adapter),
    /// burn's wgpu backend pinned to Vulkan (SPIR-V kernels).
    Vulkan(Adapter),
    /// burn's CUDA backend: the device of that index, or the first (`None`).
    Cuda(Option<usize>),
}

impl fmt::Display for Adapter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Adapter::Default => Ok(()),
            Adapter::Discrete(n) => write!(f, ":{n}"),
            Adapter::Integrated(n) => write!(f, ":integrated:{n}"),
            Adapter::Virtual(n) => write!(f, ":virtual:{n}"),
            Adapter::Cpu => write!(f, ":cpu"),
        }
    }
}

impl fmt::Display for DeviceSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DeviceSpec::Flex => write!(f, "cpu"),
            DeviceSpec::Wgpu(a) => write!(f, "wgpu{a}"),
            DeviceSpec::Vulkan(a) => write!(f, "vulkan{a}"),
            DeviceSpec::Cuda(None) => write!(f, "cuda"),
            DeviceSpec::Cuda(Some(n)) => write!(f, "cuda:{n}"),
        }
    }
}

fn syntax(device: &str, reason: &str) -> NnError {
    NnError::Device { device: device.to_owned(), reason: reason.to_owned(), available: available().join(", ") }
}

fn adapter(device: &str, rest: &[&str]) -> Result<Adapter, NnError> {
    let index =
        |s: &str| s.parse::<usize>().map_err(|_| syntax(device, &format!("`{s}` is not an adapter index (0, 1, ...)")));
    match rest {
        [] => Ok(Adapter::Default),
        ["cpu"] => Ok(Adapter::Cpu),
        ["integrated", n] => index(n).map(Adapter::Integrated),
        ["virtual", n] => index(n).map(Adapter::Virtual),
        [n] => index(n).map(Adapter::Discrete),
        _ => Err(syntax(device, "expected `<backend>`, `<backend>:N`, `<backend>:cpu` or `<backend>:integrated:N`")),
    }
}

impl FromStr for DeviceSpec {
    type Err = NnError;

    fn from_str(s: &str) -> Result<Self, NnError> {
        let parts: Vec<&str> = s.trim().split(':').collect();
        match parts.as_slice() {
            ["cpu" | "flex"] => Ok(DeviceSpec::Flex),
            ["wgpu", rest @ ..] => adapter(s, rest).map(DeviceSpec::Wgpu),
            ["vulkan", rest @ ..] => adapter(s, rest).map(DeviceSpec::Vulkan),
            ["cuda"] => Ok(DeviceSpec::Cuda(None)),
            ["cuda", n] => n
                .parse::<usize>()
                .map(|n| DeviceSpec::Cuda(Some(n)))
                .map_err(|_| syntax(s, &format!("`{n}` is not a CUDA device index (0, 1, ...)"))),
            ["cuda", ..] => Err(syntax(s, "expected `cuda` or `cuda:N`")),
            _ => Err(syntax(s, "unknown backend (known: cpu, flex, wgpu, vulkan, cuda)")),
        }
    }
}

/// Written as its name (`"cpu"`, `"wgpu:0"`, ...), as configs name it.
impl serde::Serialize for DeviceSpec {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// Read from its name, refusing one that does not parse ([`DeviceSpec::from_str`]).
impl<'de> serde::Deserialize<'de> for DeviceSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        name.parse().map_err(serde::de::Error::custom)
    }
}

impl DeviceSpec {
    /// The burn device, after checking that this build has its backend and
    /// this machine its adapter.
    ///
    /// # Errors
    /// [`NnError::Device`], listing the devices that exist.
    pub fn device(&self) -> Result<Device, NnError> {
        match self {
            DeviceSpec::Flex => Ok(Device::flex()),
            DeviceSpec::Wgpu(a) => Backend::Wgpu.device(*a, self),
            DeviceSpec::Vulkan(a) => Backend::Vulkan.device(*a, self),
            DeviceSpec::Cuda(index) => cuda_device(index.unwrap_or(0), self),
        }
    }
}

/// The CUDA devices the driver reports (none without `libcuda`, or in a
/// build without `cuda`).
fn cuda_found() -> Vec<Device> {
    #[cfg(feature = "cuda")]
    return Device::enumerate(burn::tensor::DeviceType::Cuda).into_iter().collect();
    #[cfg(not(feature = "cuda"))]
    Vec::new()
}

fn cuda_device(index: usize, spec: &DeviceSpec) -> Result<Device, NnError> {
    let error = |reason: &str| NnError::Device {
        device: spec.to_string(),
        reason: reason.to_owned(),
        available: available().join(", "),
    };
    #[cfg(feature = "cuda")]
    {
        let device = Device::cuda(index);
        if cuda_found().contains(&device) {
            return Ok(device);
        }
        Err(error("this machine has no such CUDA device (is NVIDIA's driver, libcuda, installed?)"))
    }
    #[cfg(not(feature = "cuda"))]
    {
        let _ = index;
        Err(error("this build has no `cuda` backend (build with `scripts/build_cuda.sh`)"))
    }
}

/// The device strings this build and machine can use: `cpu`, then every
/// adapter of the compiled GPU backends. Enumerating asks the drivers; with no
/// Vulkan loader installed the GPU backends list nothing.
#[must_use]
pub fn available() -> Vec<String> {
    let mut out = vec![DeviceSpec::Flex.to_string()];
    for backend in [Backend::Wgpu, Backend::Vulkan] {
        out.extend(backend.adapters().into_iter().map(|a| backend.spec(a).to_string()));
    }
    let cuda = cuda_found().len();
    if cuda > 0 {
        out.push(DeviceSpec::Cuda(None).to_string());
        out.extend((0..cuda).map(|n| DeviceSpec::Cuda(Some(n)).to_string()));
    }
    out
}

/// Whether burn's default device can be created, which loading an optimiser
/// state needs: burn-optim 0.22.1's `ModuleOptimizer::load_record` makes the
/// state's tensors on `Device::default()` (the first compiled GPU backend's
/// default adapter, or what `BURN_DEVICE` names) and moves them to the
/// parameters' device at the next step. In a build with a GPU backend on a
/// machine without an adapter, burn panics there; this is the typed error
/// instead. `BURN_DEVICE=flex` (which the `fmsr` binary sets unless given)
/// keeps that state on the CPU until the next step.
pub(crate) fn check_load_device() -> Result<(), NnError> {
    let default = Device::default();
    if default == Device::flex() {
        return Ok(());
    }
    // burn prefers CUDA when it is built; otherwise the default is a wgpu one.
    #[cfg(feature = "cuda")]
    let exists = if default == Device::cuda(0) {
        !cuda_found().is_empty()
    } else {
        !(Backend::Wgpu.found().is_empty() && Backend::Vulkan.found().is_empty())
    };
    #[cfg(not(feature = "cuda"))]
    let exists = !(Backend::Wgpu.found().is_empty() && Backend::Vulkan.found().is_empty());
    if !exists {
        return Err(NnError::Device {
            device: "burn's default device".into(),
            reason: "loading optimiser state creates its tensors there first, and this machine has no GPU adapter; \
                     set BURN_DEVICE=flex"
                .into(),
            available: available().join(", "),
        });
    }
    Ok(())
}

/// The adapters to look for when listing a backend's devices.
const CANDIDATES: [Adapter; 10] = [
    Adapter::Discrete(0),
    Adapter::Discrete(1),
    Adapter::Discrete(2),
    Adapter::Discrete(3),
    Adapter::Integrated(0),
    Adapter::Integrated(1),
    Adapter::Virtual(0),
    Adapter::Virtual(1),
    Adapter::Cpu,
    Adapter::Default,
];

/// The GPU backends, each present when its cargo feature is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Backend {
    Wgpu,
    Vulkan,
}

impl Backend {
    fn feature(self) -> &'static str {
        match self {
            Backend::Wgpu => "wgpu",
            Backend::Vulkan => "vulkan",
        }
    }

    fn spec(self, a: Adapter) -> DeviceSpec {
        match self {
            Backend::Wgpu => DeviceSpec::Wgpu(a),
            Backend::Vulkan => DeviceSpec::Vulkan(a),
        }
    }

    /// The (lazy) device of adapter `a`; `None` when this build lacks the backend.
    #[allow(unused_variables)]
    fn make(self, a: Adapter) -> Option<Device> {
        match self {
            #[cfg(feature = "wgpu")]
            Backend::Wgpu => Some(Device::wgpu(kind(a))),
            #[cfg(feature = "vulkan")]
            Backend::Vulkan => Some(Device::vulkan(kind(a))),
            #[allow(unreachable_patterns)]
            _ => None,
        }
    }

    /// Every device of the backend that the drivers report.
    fn found(self) -> Vec<Device> {
        match self {
            #[cfg(feature = "wgpu")]
            Backend::Wgpu => Device::enumerate(burn::tensor::DeviceType::Wgpu).into_iter().collect(),
            #[cfg(feature = "vulkan")]
            Backend::Vulkan => Device::enumerate(burn::tensor::DeviceType::Vulkan).into_iter().collect(),
            #[allow(unreachable_patterns)]
            _ => Vec::new(),
        }
    }

    /// The candidates among the devices found (`Default` when anything is).
    fn adapters(self) -> Vec<Adapter> {
        if self.make(Adapter::Default).is_none() {
            return Vec::new();
        }
        let found = self.found();
        let present = |a: Adapter| match a {
            Adapter::Default => !found.is_empty(),
            a => self.make(a).is_some_and(|d| found.contains(&d)),
        };
        CANDIDATES.into_iter().filter(|&a| present(a)).collect()
    }

    fn device(self, a: Adapter, spec: &DeviceSpec) -> Result<Device, NnError> {
        let error =
            |reason: String| NnError::Device { device: spec.to_string(), reason, available: available().join(", ") };
        let Some(device) = self.make(a) else {
            let feature = self.feature();
            return Err(error(format!("this build has no `{feature}` backend (build with `--features {feature}`)")));
        };
        if self.adapters().contains(&a) {
            Ok(device)
        } else {
            Err(error("this machine has no such adapter (is a Vulkan driver installed?)".into()))
        }
    }
}

#[cfg(feature = "wgpu")]
fn kind(a: Adapter) -> burn::tensor::DeviceKind {
    use burn::tensor::DeviceKind;
    match a {
        Adapter::Default => DeviceKind::DefaultDevice,
        Adapter::Discrete(n) => DeviceKind::DiscreteGpu(n),
        Adapter::Integrated(n) => DeviceKind::IntegratedGpu(n),
        Adapter::Virtual(n) => DeviceKind::VirtualGpu(n),
        Adapter::Cpu => DeviceKind::Cpu,
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn adapter() -> impl Strategy<Value = Adapter> {
        prop_oneof![
            Just(Adapter::Default),
            Just(Adapter::Cpu),
            (0usize..64).prop_map(Adapter::Discrete),
            (0usize..64).prop_map(Adapter::Integrated),
            (0usize..64).prop_map(Adapter::Virtual),
        ]
    }

    fn spec() -> impl Strategy<Value = DeviceSpec> {
        prop_oneof![
            Just(DeviceSpec::Flex),
            adapter().prop_map(DeviceSpec::Wgpu),
            adapter().prop_map(DeviceSpec::Vulkan),
            proptest::option::of(0usize..64).prop_map(DeviceSpec::Cuda)
        ]
    }

    proptest! {
        // Guards the device strings: every device prints as a string that parses back to it.
        #[test]
        fn display_parses_back(d in spec()) {
            prop_assert_eq!(d.to_string().parse::<DeviceSpec>().unwrap(), d);
        }

        // Guards bad input: any string is a device or a typed error, never a panic.
        #[test]
        fn any_string_is_a_device_or_an_error(s in "\\PC{0,24}") {
            if let Err(e) = s.parse::<DeviceSpec>() {
                let typed = matches!(e, NnError::Device { .. });
                prop_assert!(typed, "{e}");
            }
        }
    }

    #[test]
    fn bad_strings_name_what_is_wrong() {
        let err = |s: &str| s.parse::<DeviceSpec>().unwrap_err().to_string();
        assert!(err("tpu").contains("unknown backend"), "{}", err("tpu"));
        assert!(err("wgpu:x").contains("`x` is not an adapter index"), "{}", err("wgpu:x"));
        assert!(err("wgpu:1:2:3").contains("expected"), "{}", err("wgpu:1:2:3"));
        assert!(err("cpu:0").contains("unknown backend"), "{}", err("cpu:0"));
        assert!(err("cuda:x").contains("`x` is not a CUDA device index"), "{}", err("cuda:x"));
        assert!(err("cuda:integrated:0").contains("expected `cuda` or `cuda:N`"), "{}", err("cuda:integrated:0"));
    }

    #[cfg(not(feature = "cuda"))]
    #[test]
    fn cuda_not_built_is_an_error_naming_the_build_script() {
        let e = "cuda:0".parse::<DeviceSpec>().unwrap().device().unwrap_err().to_string();
        assert!(e.contains("scripts/build_cuda.sh"), "{e}");
    }

    #[cfg(not(feature = "wgpu"))]
    #[test]
    fn a_backend_not_built_is_an_error_listing_what_exists() {
        let e = DeviceSpec::Wgpu(Adapter::Discrete(0)).device().unwrap_err().to_string();
        assert!(e.contains("--features wgpu") && e.contains("devices here: cpu"), "{e}");
        let e = "vulkan:0".parse::<DeviceSpec>().unwrap().device().unwrap_err().to_string();
        assert!(e.contains("--features vulkan"), "{e}");
        assert_eq!(available(), vec!["cpu".to_string()]);
    }
}
