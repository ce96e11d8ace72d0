//! The survey of adapters: every adapter of every backend checked against what Tyndall needs
//! ([`super::adapter::Capabilities::lacks`]), and the choice of one ([`Survey::choose`]:
//! discrete, then integrated, then virtual, then CPU; Vulkan / Metal / DX12 before GL; or the
//! one `--adapter` / `TYNDALL_ADAPTER` names).

use std::fmt;

use super::adapter::Capabilities;

/// One adapter as [`survey`] found it.
#[derive(Debug, Clone)]
pub struct AdapterReport {
    /// Its index in the survey (what `--adapter N` names).
    pub index: usize,
    /// Name, backend, device type, driver.
    pub info: wgpu::AdapterInfo,
    /// What it offers.
    pub caps: Capabilities,
    /// Why it does not qualify (empty: it does).
    pub lacks: Vec<String>,
}

impl AdapterReport {
    /// Whether it qualifies.
    pub fn qualifies(&self) -> bool {
        self.lacks.is_empty()
    }

    /// See [`describe`].
    pub fn describe(&self) -> String {
        describe(&self.info)
    }

    /// The sort key of the preference order (smaller is better).
    fn rank(&self) -> (u8, u8, usize) {
        let ty = match self.info.device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Cpu => 3,
            wgpu::DeviceType::Other => 4,
        };
        let backend = match self.info.backend {
            wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
            _ => 1,
        };
        (ty, backend, self.index)
    }
}

/// An adapter in one line: `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, CPU)`.
pub fn describe(info: &wgpu::AdapterInfo) -> String {
    format!(
        "{} ({}, {})",
        info.name,
        backend_name(info.backend),
        device_type_name(info.device_type)
    )
}

/// A backend's name as a user reads it.
pub fn backend_name(b: wgpu::Backend) -> &'static str {
    match b {
        wgpu::Backend::Vulkan => "Vulkan",
        wgpu::Backend::Metal => "Metal",
        wgpu::Backend::Dx12 => "DX12",
        wgpu::Backend::Gl => "GL",
        wgpu::Backend::BrowserWebGpu => "WebGPU",
        wgpu::Backend::Noop => "no-op",
    }
}

/// A device type's name as a user reads it.
pub fn device_type_name(t: wgpu::DeviceType) -> &'static str {
    match t {
        wgpu::DeviceType::DiscreteGpu => "discrete GPU",
        wgpu::DeviceType::IntegratedGpu => "integrated GPU",
        wgpu::DeviceType::VirtualGpu => "virtual GPU",
        wgpu::DeviceType::Cpu => "CPU",
        wgpu::DeviceType::Other => "other",
    }
}

/// Every adapter of every backend the instance has (narrowed by `WGPU_BACKEND`), checked.
pub struct Survey {
    /// The instance they belong to.
    pub instance: wgpu::Instance,
    adapters: Vec<wgpu::Adapter>,
    /// One report per adapter, in enumeration order.
    pub reports: Vec<AdapterReport>,
}

/// Why no adapter could be used.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NoAdapter {
    /// The reason in a few lines (each adapter seen and what it lacks, what to install).
    pub message: String,
}

impl fmt::Display for NoAdapter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

/// What to install when nothing qualifies.
pub const INSTALL_HINT: &str =
    "install a Vulkan driver (Debian/Ubuntu: `apt-get install mesa-vulkan-drivers` gives a software Vulkan adapter), or a GPU driver";

/// Enumerate and check every adapter of `backends`. `instance` is made by the caller (its
/// flags decide validation; see [`crate::gpu::instance`]).
pub fn survey(instance: wgpu::Instance, backends: wgpu::Backends) -> Survey {
    let adapters = pollster::block_on(instance.enumerate_adapters(backends));
    let reports = adapters
        .iter()
        .enumerate()
        .map(|(index, a)| {
            let caps = Capabilities::of(a);
            AdapterReport {
                index,
                info: a.get_info(),
                lacks: caps.lacks(),
                caps,
            }
        })
        .collect();
    Survey {
        instance,
        adapters,
        reports,
    }
}

/// How the adapter in use was chosen.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Chosen {
    /// By `--adapter` / `TYNDALL_ADAPTER` (the text given).
    ByHand(String),
    /// The best that qualifies by device type and backend.
    Best,
}

impl Survey {
    /// The adapter to use: the one `pick` names (an index into the survey or a case-insensitive
    /// part of its name, optionally with the backend: `llvmpipe`, `1`, `gl`, `llvmpipe/vulkan`),
    /// refused if it does not qualify; without `pick`, the best that qualifies.
    pub fn choose(&self, pick: Option<&str>) -> Result<(usize, Chosen), NoAdapter> {
        if self.reports.is_empty() {
            return Err(NoAdapter {
                message: format!(
                    "no GPU adapter found{}; {INSTALL_HINT}",
                    backend_filter_note()
                ),
            });
        }
        if let Some(pick) = pick.map(str::trim).filter(|p| !p.is_empty()) {
            let r = self.find(pick)?;
            if !r.qualifies() {
                return Err(NoAdapter {
                    message: format!(
                        "adapter [{}] {} (chosen by --adapter/TYNDALL_ADAPTER '{pick}') cannot run Tyndall: it lacks {}",
                        r.index,
                        r.describe(),
                        r.lacks.join("; ")
                    ),
                });
            }
            return Ok((r.index, Chosen::ByHand(pick.to_string())));
        }
        self.reports
            .iter()
            .filter(|r| r.qualifies())
            .min_by_key(|r| r.rank())
            .map(|r| (r.index, Chosen::Best))
            .ok_or_else(|| self.none_qualifies())
    }

    fn find(&self, pick: &str) -> Result<&AdapterReport, NoAdapter> {
        if let Ok(i) = pick.parse::<usize>() {
            return self.reports.get(i).ok_or_else(|| NoAdapter {
                message: format!(
                    "--adapter/TYNDALL_ADAPTER {i}: there are only {} adapters (see `tyndall info`)",
                    self.reports.len()
                ),
            });
        }
        let (name, backend) = match pick.rsplit_once('/') {
            Some((n, b)) => (n.to_lowercase(), Some(b.to_lowercase())),
            None => (pick.to_lowercase(), None),
        };
        let matches = |r: &&AdapterReport| {
            let b = backend_name(r.info.backend).to_lowercase();
            let by_name = name.is_empty() || r.info.name.to_lowercase().contains(&name);
            match &backend {
                Some(want) => by_name && b == *want,
                // A bare word may name a backend (`gl`, `vulkan`) or part of a name.
                None => by_name || b == name,
            }
        };
        let found: Vec<&AdapterReport> = self.reports.iter().filter(matches).collect();
        // Several matches: the best qualifying one of them.
        found
            .iter()
            .filter(|r| r.qualifies())
            .min_by_key(|r| r.rank())
            .or(found.first())
            .copied()
            .ok_or_else(|| NoAdapter {
                message: format!(
                    "--adapter/TYNDALL_ADAPTER '{pick}' names no adapter; found: {}",
                    self.reports
                        .iter()
                        .map(|r| format!("[{}] {}", r.index, r.describe()))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            })
    }

    fn none_qualifies(&self) -> NoAdapter {
        let seen: Vec<String> = self
            .reports
            .iter()
            .map(|r| {
                format!(
                    "  [{}] {}: lacks {}",
                    r.index,
                    r.describe(),
                    r.lacks.join("; ")
                )
            })
            .collect();
        NoAdapter {
            message: format!(
                "no usable GPU adapter{}:\n{}\n{INSTALL_HINT}",
                backend_filter_note(),
                seen.join("\n")
            ),
        }
    }

    /// The wgpu adapter of report `index`.
    pub fn adapter(&self, index: usize) -> Option<&wgpu::Adapter> {
        self.adapters.get(index)
    }
}

/// ` (WGPU_BACKEND=vulkan)` when the environment narrows the backends.
fn backend_filter_note() -> String {
    std::env::var("WGPU_BACKEND")
        .ok()
        .filter(|v| !v.is_empty())
        .map_or(String::new(), |v| format!(" (WGPU_BACKEND={v})"))
}
