//! The wgpu context: a headless device on any adapter (lavapipe included), a texture pool,
//! a pipeline cache, one compute-dispatch helper and the one row-padded readback helper.

pub mod adapter;
mod dispatch;
mod layout;
mod logger;
mod options;
mod params;
mod pipeline_cache;
mod pool;
mod prepare;
pub use prepare::{Preparing, MAX_WORKERS};
mod raster;
mod raster_bits;
mod recorder;
pub use pipeline_cache::cache_dir;
pub use recorder::{Recorder, CHUNK_PASSES};
mod readback;
pub use readback::{PendingRead, TexelRead};
mod resources;
mod shader;
mod shader_needs;
mod survey;
mod timer;
mod volume;

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use thiserror::Error;

pub use layout::{check_uniform_layout, UniformLayout};
use logger::{CAPTURING, LOGGED_ERRORS};
pub use options::{
    adapter_choice, env_backends, instance, instance_flags, instance_on, set_adapter_choice,
    GpuOptions,
};
pub use params::PARAMS_IN_STORAGE_BELOW;
use pool::{narrow, widen};
pub use pool::{GpuTexture, TexFormat, TexturePool};
pub use raster::{MeshDraw, MeshVertex, RasterTarget};
pub use raster_bits::bits_module;
pub use shader::{compose, Shader, ShaderFiles};
pub use timer::PassTimer;
pub use volume::{mip_count, mip_size, row_pitch, rows_source, GpuVolume};

/// Errors from the GPU layer.
#[derive(Debug, Error, Clone)]
pub enum GpuError {
    /// No adapter qualifies (no driver, none matching `WGPU_BACKEND`, or none offering what
    /// Tyndall needs), or the one chosen by hand does not: the message names each adapter seen,
    /// what it lacks and what to install.
    #[error("{0}")]
    NoAdapter(String),
    /// The adapter in use cannot give a node's shader what it needs (e.g. more storage textures
    /// per stage than a GL driver allows); every other node still runs.
    #[error("this adapter ({adapter}) lacks {lacks}")]
    Unsupported {
        /// The adapter, as [`Gpu::describe`] says it.
        adapter: String,
        /// What is missing, `; `-separated.
        lacks: String,
    },
    /// The device could not be created.
    #[error("cannot create a GPU device: {0}")]
    Device(String),
    /// wgpu reported a validation or out-of-memory error.
    #[error("GPU error: {0}")]
    Validation(String),
    /// Reading a texture back failed.
    #[error("GPU readback failed: {0}")]
    Readback(String),
    /// Samples handed to the GPU do not fit the texture asked for (a channel count other than
    /// 1 or 4, or a length other than width × height × channels).
    #[error("texture data: {0}")]
    BadData(String),
    /// The device was lost (driver reset, GPU removed, or destroyed): nothing more can run on it.
    #[error("the GPU device was lost ({0}); this run cannot continue")]
    Lost(String),
    /// Submitted work did not finish within the watchdog time (`TYNDALL_GPU_TIMEOUT` seconds,
    /// default 600; 0 waits forever): treated as a lost device instead of waiting forever.
    #[error("the GPU did not finish its work within {0} s (TYNDALL_GPU_TIMEOUT); treating the device as lost")]
    Hung(u64),
    /// A requested texture is larger than the device allows.
    #[error("texture {width}x{height} exceeds the device limit of {limit} texels per side")]
    TooLarge {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// The device's `max_texture_dimension_2d`.
        limit: u32,
    },
}

/// The watchdog time of [`Gpu::wait`] and readbacks: `TYNDALL_GPU_TIMEOUT` seconds, default 600
/// (0: wait forever).
fn watchdog_secs() -> u64 {
    static SECS: std::sync::OnceLock<u64> = std::sync::OnceLock::new();
    *SECS.get_or_init(|| {
        std::env::var("TYNDALL_GPU_TIMEOUT")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(600)
    })
}

/// The result of a `map_async` callback after [`Gpu::wait`]: a callback wgpu never calls (a lost
/// device) is an error after the watchdog time, not a hang.
pub(crate) fn receive<T>(rx: &std::sync::mpsc::Receiver<T>) -> Result<T, GpuError> {
    let secs = watchdog_secs();
    if secs == 0 {
        rx.recv().map_err(|e| GpuError::Readback(e.to_string()))
    } else {
        rx.recv_timeout(std::time::Duration::from_secs(secs))
            .map_err(|e| GpuError::Readback(e.to_string()))
    }
}

/// Whether `TYNDALL_TRACE_PASSES` is set (and not `0`): every 2D compute pass then waits for the
/// device before and after it and prints `pass STEM:ENTRY WxH: MS ms` on stderr — a per-pass
/// profile of a node (it serialises the GPU, so whole-node times grow).
fn tracing() -> bool {
    static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *ON.get_or_init(|| std::env::var_os("TYNDALL_TRACE_PASSES").is_some_and(|v| v != "0"))
}

/// One binding of a compute dispatch (paired with its WGSL variable name in group 0).
#[derive(Clone, Copy)]
pub enum Bind<'a> {
    /// A uniform buffer with these bytes.
    Uniform(&'a [u8]),
    /// A texture read with `textureLoad` (`texture_2d<f32>`, unfilterable).
    Texture(&'a GpuTexture),
    /// A write-only storage texture (`texture_storage_2d<FORMAT, write>`).
    Storage(&'a GpuTexture),
    /// A read-write storage buffer of 32-bit words (`array<atomic<i32>>`, `array<i32>`…).
    Buffer(&'a GpuBuffer),
    /// A volume read with `textureLoad` at any level (`texture_3d<f32>`, unfilterable).
    Volume(&'a GpuVolume),
    /// One level of a volume, written (`texture_storage_3d<r32float, write>`).
    VolumeLevel(&'a GpuVolume, u32),
    /// One level of a volume, read (`texture_3d<f32>`, level 0 of the view is that level): for
    /// passes that build one level from another of the same volume.
    VolumeLevelRead(&'a GpuVolume, u32),
}

/// A storage buffer of 32-bit words (for passes that accumulate with integer atomics: WGSL
/// has no float atomics).
pub struct GpuBuffer {
    raw: wgpu::Buffer,
    /// Number of 32-bit words.
    pub words: u32,
}

/// The headless GPU context shared by all nodes.
pub struct Gpu {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Adapter description (name, backend, device type).
    pub info: wgpu::AdapterInfo,
    /// Device limits (all the adapter offers; the same as `caps.limits`, which
    /// [`Gpu::supports`] checks shaders against).
    pub limits: wgpu::Limits,
    /// What the adapter offers, and the substitutes chosen where it offers less.
    pub caps: adapter::Capabilities,
    /// Its index in the survey of adapters (`tyndall info`, `--adapter N`).
    pub adapter_index: usize,
    /// How it was chosen.
    pub chosen: adapter::Chosen,
    /// What each shader needs, by stem (read once per stem with naga), against `caps`.
    shader_lacks: Mutex<HashMap<&'static str, Vec<String>>>,
    /// What each shader's entry points use, by stem (read once per stem with naga).
    shader_needs: Mutex<HashMap<&'static str, Arc<adapter::ShaderNeeds>>>,
    /// Command buffers submitted so far ([`Gpu::submit_count`]).
    submits: std::sync::atomic::AtomicU64,
    /// Read-backs so far and their bytes ([`Gpu::readbacks`]).
    readbacks: [std::sync::atomic::AtomicU64; 2],
    /// Staging buffers of earlier read-backs, unmapped, for the next ones.
    staging: Arc<Mutex<Vec<wgpu::Buffer>>>,
    /// Staging buffers created ([`Gpu::staging_buffers_created`]).
    staging_created: std::sync::atomic::AtomicU64,
    /// Values made once per content key while someone holds them ([`Gpu::shared_by_key`]).
    keyed: Mutex<HashMap<u64, std::sync::Weak<dyn std::any::Any + Send + Sync>>>,
    pool: Arc<TexturePool>,
    /// Compute pipelines by key ([`prepare::Recipe::key`]), each made once (a worker of
    /// [`Gpu::prepare_pipelines`] may be making it).
    pipelines: Mutex<HashMap<String, Arc<PipelineCell>>>,
    /// The pipelines each node kind used ([`Gpu::prepare_pipelines`]).
    recipes: prepare::Recipes,
    render_pipelines: Mutex<HashMap<String, Arc<wgpu::RenderPipeline>>>,
    /// Pipelines compiled once per machine ([`Gpu::pipeline_counts`]).
    disk: pipeline_cache::DiskCache,
    errors: Arc<Mutex<Vec<String>>>,
    /// Why the device was lost, once it was (set by wgpu's device-lost callback).
    lost: Arc<Mutex<Option<String>>>,
}

impl std::fmt::Debug for Gpu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Gpu({} on {:?})", self.info.name, self.info.backend)
    }
}

/// The features Tyndall asks of a device (those of its wishes `adapter` offers: filterable
/// 32-bit floats, timestamps, adapter-specific format features, a pipeline cache) and the limits
/// (all that `adapter` offers) — for [`Gpu::with_options`], and for a device made elsewhere that
/// [`Gpu::on_device`] wraps.
pub fn device_request(adapter: &wgpu::Adapter) -> (wgpu::Features, wgpu::Limits) {
    let wanted = wgpu::Features::FLOAT32_FILTERABLE
        | wgpu::Features::TIMESTAMP_QUERY
        | wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES
        | wgpu::Features::PIPELINE_CACHE;
    (adapter.features() & wanted, adapter.limits())
}

/// A compute pipeline, once made (or why it could not be).
type PipelineCell = std::sync::OnceLock<Result<Arc<wgpu::ComputePipeline>, GpuError>>;

/// The process-wide context of [`Gpu::shared`] (or the error that made it fail).
static SHARED: Mutex<Option<Result<Arc<Gpu>, GpuError>>> = Mutex::new(None);

impl Gpu {
    /// Create a headless context on the adapter [`adapter::Survey::choose`] picks: the one
    /// named by [`set_adapter_choice`] or `TYNDALL_ADAPTER`, else the best that qualifies.
    /// `validation` turns on backend validation layers (`InstanceFlags::VALIDATION`);
    /// `WGPU_BACKEND` and the other wgpu environment variables are honoured.
    pub fn new(validation: bool) -> Result<Gpu, GpuError> {
        Gpu::with_options(&GpuOptions {
            validation,
            ..GpuOptions::from_env()
        })
    }

    /// Create a headless context as `options` say (backends, adapter, GL substitutes).
    pub fn with_options(options: &GpuOptions) -> Result<Gpu, GpuError> {
        let survey = adapter::survey(
            instance_on(options.validation, options.backends),
            options.backends,
        );
        let (index, chosen) = survey
            .choose(options.adapter.as_deref())
            .map_err(|e| GpuError::NoAdapter(e.message))?;
        let report = &survey.reports[index];
        let adapter = survey
            .adapter(index)
            .ok_or_else(|| GpuError::NoAdapter(format!("adapter {index} vanished")))?;
        let mut caps = report.caps.clone();
        if options.emulate_gl {
            caps = caps.emulating_gl();
        }
        if let Some(storage) = options.params_in_storage {
            caps.params_in_storage_below = if storage { u64::MAX } else { 0 };
        }
        let (features, limits) = device_request(adapter);
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("tyndall"),
            required_features: features,
            required_limits: limits,
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        // Messages logged while backends were probed (e.g. an EGL driver that fails to load
        // before Vulkan is chosen) are not errors of our work.
        LOGGED_ERRORS.with(|v| v.borrow_mut().clear());
        Ok(Gpu::assemble(adapter, device, queue, caps, index, chosen))
    }

    /// A context on a device created elsewhere from `adapter` with [`device_request`]'s
    /// features and limits — the editor's window: eframe creates the device it draws with, and
    /// the evaluation moves onto it, so a picture is drawn from the texture it is evaluated
    /// into.
    /// `like` is the context it stands in for (its adapter index and how it was chosen).
    pub fn on_device(
        adapter: &wgpu::Adapter,
        device: wgpu::Device,
        queue: wgpu::Queue,
        like: &Gpu,
    ) -> Gpu {
        // The same adapter keeps the substitutes chosen for it (`GpuOptions`); another gets its own.
        let i = adapter.get_info();
        let caps = if i.name == like.info.name && i.backend == like.info.backend {
            like.caps.clone()
        } else {
            adapter::Capabilities::of(adapter)
        };
        Gpu::assemble(
            adapter,
            device,
            queue,
            caps,
            like.adapter_index,
            like.chosen.clone(),
        )
    }

    /// The context around a device: error and loss callbacks, the pipeline cache on disk, the
    /// texture pool.
    fn assemble(
        adapter: &wgpu::Adapter,
        device: wgpu::Device,
        queue: wgpu::Queue,
        caps: adapter::Capabilities,
        index: usize,
        chosen: adapter::Chosen,
    ) -> Gpu {
        let features = device.features();
        let limits = device.limits();
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        let info = adapter.get_info();
        let recipes = prepare::Recipes::open(&info);
        let (disk, warning) = pipeline_cache::DiskCache::open(
            &device,
            &info,
            features.contains(wgpu::Features::PIPELINE_CACHE),
        );
        if let Some(w) = warning {
            eprintln!("warning: {w}");
        }
        let lost = Arc::new(Mutex::new(None));
        let flag = lost.clone();
        device.set_device_lost_callback(move |reason, message| {
            if let Ok(mut l) = flag.lock() {
                *l = Some(format!("{reason:?}: {message}"));
            }
        });
        Gpu {
            pool: Arc::new(TexturePool::new(device.clone(), 64, caps.clone())),
            device,
            queue,
            info,
            limits,
            caps,
            adapter_index: index,
            chosen,
            shader_lacks: Mutex::new(HashMap::new()),
            shader_needs: Mutex::new(HashMap::new()),
            submits: std::sync::atomic::AtomicU64::new(0),
            readbacks: Default::default(),
            staging: Arc::default(),
            staging_created: Default::default(),
            keyed: Mutex::default(),
            pipelines: Mutex::new(HashMap::new()),
            recipes,
            render_pipelines: Mutex::new(HashMap::new()),
            disk,
            errors,
            lost,
        }
    }

    /// The process-wide context (created on first use; validation on when
    /// `TYNDALL_GPU_VALIDATION=1` or in debug builds). Once its device is lost, the next call
    /// creates a new one (the editor restarts its evaluation on it); holders of the old one
    /// keep getting [`GpuError::Lost`]. Without an adapter, the first call's error is kept.
    pub fn shared() -> Result<Arc<Gpu>, GpuError> {
        let mut cell = SHARED.lock().unwrap_or_else(|e| e.into_inner());
        match &*cell {
            Some(Ok(gpu)) if gpu.check_lost().is_ok() => return Ok(gpu.clone()),
            Some(Err(e)) => return Err(e.clone()),
            _ => {}
        }
        let made = Gpu::with_options(&GpuOptions::from_env()).map(Arc::new);
        // A failed renewal (the adapter went away with the device) is not cached: the next
        // call tries again.
        if made.is_ok() || cell.is_none() {
            *cell = Some(made.clone());
        }
        made
    }

    /// Wait for the process-wide context's queued work to finish, if one was made (errors
    /// ignored: this runs on the way out). Call it before the process exits: Mesa's CPU drivers
    /// compile shaders on their queue thread while it runs the queued work, and a process that
    /// exits meanwhile tears LLVM down under that thread (`tyndall render` crashed at exit in
    /// 3 of 10 runs after an evaluation error left submitted passes behind it).
    pub fn settle_shared() {
        let gpu = match &*SHARED.lock().unwrap_or_else(|e| e.into_inner()) {
            Some(Ok(gpu)) => gpu.clone(),
            _ => return,
        };
        let _ = gpu.wait();
    }

    /// One line describing the adapter ([`adapter::describe`]).
    pub fn describe(&self) -> String {
        adapter::describe(&self.info)
    }

    /// Whether the adapter runs on the CPU (Mesa's lavapipe and llvmpipe, WARP…): for a node
    /// with a form of a pass for CPUs and one for GPUs (workgroup memory and barriers cost more
    /// than they save on a CPU), chosen by what the benchmarks measure on each.
    pub fn is_cpu(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// `Err(Unsupported)` when this adapter cannot give `shader` what its entry points need
    /// (read from the WGSL once per stem and kept).
    pub fn supports(&self, shader: Shader) -> Result<(), GpuError> {
        let mut known = self.shader_lacks.lock().unwrap_or_else(|e| e.into_inner());
        let lacks = known.entry(shader.stem).or_insert_with(|| {
            shader
                .wgsl()
                .and_then(adapter::ShaderNeeds::of)
                .map(|n| self.caps.lacks_for(&n))
                .unwrap_or_default()
        });
        if lacks.is_empty() {
            Ok(())
        } else {
            Err(GpuError::Unsupported {
                adapter: self.describe(),
                lacks: lacks.join("; "),
            })
        }
    }

    /// Errors wgpu reported since the last call (API validation, out of memory, and with
    /// validation on, the Vulkan validation layer's errors), as an error.
    pub fn take_errors(&self) -> Result<(), GpuError> {
        let mut v = self
            .errors
            .lock()
            .map_err(|e| GpuError::Validation(e.to_string()))?;
        LOGGED_ERRORS.with(|logged| v.append(&mut logged.borrow_mut()));
        if v.is_empty() {
            Ok(())
        } else {
            let msg = v.join("; ");
            v.clear();
            Err(GpuError::Validation(msg))
        }
    }

    /// Run `f` inside validation and out-of-memory error scopes (thread-local in wgpu, so
    /// errors are attributed to this call even when several threads share the device), then
    /// report them with anything logged or uncaptured meanwhile.
    pub fn scoped<T>(&self, f: impl FnOnce() -> T) -> Result<T, GpuError> {
        let out = self.scoped_here(f);
        let logged = self.take_errors();
        match (out, logged) {
            (Ok(out), Ok(())) => Ok(out),
            (Err(GpuError::Validation(a)), Err(GpuError::Validation(b))) => {
                Err(GpuError::Validation(format!("{a}; {b}")))
            }
            (Err(e), _) | (Ok(_), Err(e)) => Err(e),
        }
    }

    /// [`Gpu::scoped`] without the errors wgpu reported outside any scope: only what `f`
    /// caused (for work on a thread beside the evaluation's, which must not take its errors).
    fn scoped_here<T>(&self, f: impl FnOnce() -> T) -> Result<T, GpuError> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        CAPTURING.with(|c| c.set(c.get() + 1));
        let out = f();
        CAPTURING.with(|c| c.set(c.get().saturating_sub(1)));
        let v = pollster::block_on(validation.pop());
        let o = pollster::block_on(oom.pop());
        self.check_lost()?;
        let msgs: Vec<String> = [v, o]
            .into_iter()
            .flatten()
            .map(|e| e.to_string())
            .collect();
        if msgs.is_empty() {
            Ok(out)
        } else {
            Err(GpuError::Validation(msgs.join("; ")))
        }
    }

    /// Block until all submitted work has finished — at most the watchdog time
    /// (`TYNDALL_GPU_TIMEOUT` seconds, default 600, 0: no limit), so a hung or lost device ends
    /// the run with an error instead of hanging it.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.check_lost()?;
        let secs = watchdog_secs();
        let timeout = (secs > 0).then(|| std::time::Duration::from_secs(secs));
        let polled = self.device.poll(wgpu::PollType::Wait {
            submission_index: None,
            timeout,
        });
        self.check_lost()?;
        match polled {
            Ok(_) => Ok(()),
            Err(wgpu::PollError::Timeout) => Err(GpuError::Hung(secs)),
            Err(e) => Err(GpuError::Validation(e.to_string())),
        }
    }

    /// The largest single texture or buffer a node may allocate, and where the figure comes
    /// from: `TYNDALL_GPU_MEMORY_MB` (MiB) when set, else the adapter's `max_buffer_size` (wgpu
    /// reports no device memory size; that limit is the adapter's own ceiling for one
    /// allocation).
    pub fn allocation_limit(&self) -> (u64, &'static str) {
        match std::env::var("TYNDALL_GPU_MEMORY_MB")
            .ok()
            .and_then(|v| v.parse::<u64>().ok())
        {
            Some(mb) => (mb.saturating_mul(1 << 20), "TYNDALL_GPU_MEMORY_MB"),
            None => (self.limits.max_buffer_size, "max_buffer_size"),
        }
    }

    /// `Err(Lost)` once the device has been lost.
    pub fn check_lost(&self) -> Result<(), GpuError> {
        match self.lost.lock() {
            Ok(l) => l.clone().map_or(Ok(()), |why| Err(GpuError::Lost(why))),
            Err(e) => Err(GpuError::Lost(e.to_string())),
        }
    }

    /// Destroy the device on purpose, as a driver reset would: every later call fails with
    /// [`GpuError::Lost`]. For tests of the lost-device path; never called by Tyndall itself.
    pub fn simulate_loss(&self) {
        self.device.destroy();
        // wgpu reports the loss from its next poll; record it now so that no call races it.
        if let Ok(mut l) = self.lost.lock() {
            l.get_or_insert_with(|| "Destroyed: simulated".into());
        }
    }
}
