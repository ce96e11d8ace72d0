//! How a context is made: backends, validation, the adapter chosen by hand, GL's substitutes.

use std::sync::Mutex;

use super::logger::LOGGER;

/// How [`Gpu::with_options`](super::Gpu::with_options) makes a context.
#[derive(Debug, Clone)]
pub struct GpuOptions {
    /// Backend validation layers (default: on in debug builds or with
    /// `TYNDALL_GPU_VALIDATION=1`).
    pub validation: bool,
    /// Backends to look at (default: `WGPU_BACKEND`, else all).
    pub backends: wgpu::Backends,
    /// The adapter by hand (default: [`adapter_choice`]); `None`: the best that qualifies.
    pub adapter: Option<String>,
    /// Take GL's substitutes on any adapter (default: `TYNDALL_GPU_EMULATE=gl`).
    pub emulate_gl: bool,
    /// Pass every pass's parameter block as a uniform (`Some(false)`) or a read-only storage
    /// buffer (`Some(true)`) whatever the adapter and the pass's size; `None` (the default):
    /// as [`Capabilities::params_in_storage_below`](super::adapter::Capabilities::params_in_storage_below)
    /// decides. From `TYNDALL_GPU_PARAMS=uniform|storage`.
    pub params_in_storage: Option<bool>,
}

impl GpuOptions {
    /// The defaults, from the environment.
    pub fn from_env() -> Self {
        Self {
            validation: cfg!(debug_assertions)
                || std::env::var("TYNDALL_GPU_VALIDATION").is_ok_and(|v| v == "1"),
            backends: env_backends(),
            adapter: adapter_choice(),
            emulate_gl: std::env::var("TYNDALL_GPU_EMULATE").is_ok_and(|v| v == "gl"),
            params_in_storage: match std::env::var("TYNDALL_GPU_PARAMS").as_deref() {
                Ok("uniform") => Some(false),
                Ok("storage") => Some(true),
                _ => None,
            },
        }
    }
}

/// The backends `WGPU_BACKEND` names (`vulkan`, `gl`, `metal`, `dx12`, comma-separated), else
/// all.
pub fn env_backends() -> wgpu::Backends {
    wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all())
}

/// A wgpu instance on every backend `WGPU_BACKEND` allows, with validation layers when asked
/// (then wgpu's error log records become failures: see [`Gpu::take_errors`](super::Gpu::take_errors)).
pub fn instance(validation: bool) -> wgpu::Instance {
    instance_on(validation, env_backends())
}

/// [`instance`] on the given backends.
pub fn instance_on(validation: bool, backends: wgpu::Backends) -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.flags = instance_flags(validation);
    if validation {
        // Another logger may already be installed (an application's); then it sees them.
        if log::set_logger(&LOGGER).is_ok() {
            log::set_max_level(log::LevelFilter::Warn);
        }
    }
    let mut desc = desc.with_env();
    desc.backends = backends;
    wgpu::Instance::new(desc)
}

/// The instance flags of a Tyndall context — and of an editor window's instance, whose device
/// the evaluation may share: without validation none at all (wgpu's default in debug builds
/// would turn the validation layer on anyway); with it `VALIDATION` only (`DEBUG` makes naga
/// emit `OpSource WGSL`, which Debian 12's validation layer, 1.3.239, does not know and reports
/// as invalid SPIR-V).
pub fn instance_flags(validation: bool) -> wgpu::InstanceFlags {
    if validation {
        wgpu::InstanceFlags::VALIDATION
    } else {
        wgpu::InstanceFlags::empty()
    }
}

static ADAPTER_CHOICE: Mutex<Option<String>> = Mutex::new(None);

/// Choose the adapter by hand for this process (`--adapter`): an index of `tyndall info` or a
/// part of its name, optionally `/backend`; it wins over `TYNDALL_ADAPTER`. Call it before the
/// first [`Gpu::shared`](super::Gpu::shared).
pub fn set_adapter_choice(pick: Option<String>) {
    *ADAPTER_CHOICE.lock().unwrap_or_else(|e| e.into_inner()) = pick;
}

/// The adapter chosen by hand: [`set_adapter_choice`], else `TYNDALL_ADAPTER`, else none.
pub fn adapter_choice() -> Option<String> {
    ADAPTER_CHOICE
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .clone()
        .or_else(|| std::env::var("TYNDALL_ADAPTER").ok())
        .filter(|v| !v.trim().is_empty())
}
