//! Pipelines created up front, in parallel. Every compute pipeline is described by a
//! [`Recipe`] — shader, entry point, where the parameter block lives, constants, binding
//! signature — whose text is the pipeline's cache key. While a node runs, the recipes of the
//! pipelines it uses are recorded under its kind ([`super::Recorder::set_node`]) and saved, per
//! adapter, driver and Tyndall version, in [`cache_dir`] (`recipes-<hash>.txt`, one
//! `kind<TAB>recipe` line each). The next evaluation — in this process or the next — first
//! asks for the pipelines of the kinds it will run ([`Gpu::prepare_pipelines`]): worker
//! threads create them while the evaluating thread loads scenes and records the first nodes,
//! and a node that needs a pipeline a worker is creating waits for that one instead of
//! compiling it again. A kind seen for the first time is created when it runs, as before.
//!
//! Raster pipelines (G-buffer, shadow maps) are not prepared: they are created on first use.
//! On wgpu's GL backend one worker is used (every GL call holds the one context lock); on
//! other backends up to one fewer than the machine's cores (at least one), never more than
//! [`MAX_WORKERS`].

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::hash::{DefaultHasher, Hash, Hasher};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use super::pipeline_cache::cache_dir;
use super::shader_needs::BindingKind;
use super::{Bind, Gpu, Shader};

/// At most this many threads create pipelines up front.
pub const MAX_WORKERS: usize = 8;

const HEADER: &str = "TYNDALL-PIPELINE-RECIPES 1";

/// What one binding of a pipeline's layout is, without its resource.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Slot {
    /// The parameter block.
    Uniform,
    /// A 2D texture read with `textureLoad`.
    Texture,
    /// A 2D storage texture written, stored in this format.
    Storage(StoredFormat),
    /// A storage buffer of 32-bit words.
    Buffer,
    /// A volume (or one level of it) read.
    Volume,
    /// One level of a volume, written.
    VolumeLevel,
}

/// The formats storage textures are stored in (see `TexFormat` and `Capabilities::stored`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum StoredFormat {
    R32,
    Rg32,
    Rgba32,
}

impl StoredFormat {
    pub(crate) fn wgpu(self) -> wgpu::TextureFormat {
        match self {
            StoredFormat::R32 => wgpu::TextureFormat::R32Float,
            StoredFormat::Rg32 => wgpu::TextureFormat::Rg32Float,
            StoredFormat::Rgba32 => wgpu::TextureFormat::Rgba32Float,
        }
    }
}

impl Slot {
    /// The slot `b` fills.
    pub(crate) fn of(b: &Bind) -> Slot {
        match b {
            Bind::Uniform(_) => Slot::Uniform,
            Bind::Texture(_) => Slot::Texture,
            Bind::Storage(t) => Slot::Storage(match t.stored_channels() {
                1 => StoredFormat::R32,
                2 => StoredFormat::Rg32,
                _ => StoredFormat::Rgba32,
            }),
            Bind::Buffer(_) => Slot::Buffer,
            Bind::Volume(_) | Bind::VolumeLevelRead(..) => Slot::Volume,
            Bind::VolumeLevel(..) => Slot::VolumeLevel,
        }
    }

    /// The WGSL binding kind it fills (what the entry point's declaration is checked against).
    pub(crate) fn kind(self) -> BindingKind {
        match self {
            Slot::Uniform => BindingKind::Uniform,
            Slot::Texture => BindingKind::Texture2d,
            Slot::Storage(_) => BindingKind::StorageTexture2d,
            Slot::Buffer => BindingKind::StorageBuffer,
            Slot::Volume => BindingKind::Texture3d,
            Slot::VolumeLevel => BindingKind::StorageTexture3d,
        }
    }

    fn code(self) -> &'static str {
        match self {
            Slot::Uniform => "u",
            Slot::Texture => "t",
            Slot::Storage(StoredFormat::R32) => "s1",
            Slot::Storage(StoredFormat::Rg32) => "s2",
            Slot::Storage(StoredFormat::Rgba32) => "s4",
            Slot::Buffer => "b",
            Slot::Volume => "v",
            Slot::VolumeLevel => "vs",
        }
    }

    fn parse(code: &str) -> Option<Slot> {
        Some(match code {
            "u" => Slot::Uniform,
            "t" => Slot::Texture,
            "s1" => Slot::Storage(StoredFormat::R32),
            "s2" => Slot::Storage(StoredFormat::Rg32),
            "s4" => Slot::Storage(StoredFormat::Rgba32),
            "b" => Slot::Buffer,
            "v" => Slot::Volume,
            "vs" => Slot::VolumeLevel,
            _ => return None,
        })
    }
}

/// How to create one compute pipeline. Its text ([`Recipe::key`]) is the pipeline's cache key:
/// `stem:entry[:params-storage][:NAME=value…][:binding:slot…]`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Recipe {
    /// The shader's path under `shaders/` ([`Shader::stem`]).
    pub stem: String,
    pub entry: String,
    /// The parameter block is a read-only storage buffer, not a uniform (see `params.rs`).
    pub params_in_storage: bool,
    /// Values of the shader's overridable constants.
    pub constants: Vec<(String, f64)>,
    /// Binding number and slot, in the order given.
    pub slots: Vec<(u32, Slot)>,
}

impl Recipe {
    /// The recipe of a dispatch of `entry` of `shader` with `binds` (numbered).
    pub(crate) fn of(
        shader: Shader,
        entry: &str,
        binds: &[(u32, Bind)],
        constants: &[(&str, f64)],
        params_in_storage: bool,
    ) -> Recipe {
        Recipe {
            stem: shader.stem.to_string(),
            entry: entry.to_string(),
            params_in_storage,
            constants: constants.iter().map(|(n, v)| (n.to_string(), *v)).collect(),
            slots: binds.iter().map(|(n, b)| (*n, Slot::of(b))).collect(),
        }
    }

    /// The cache key (and the recipe's saved form).
    pub(crate) fn key(&self) -> String {
        let mut key = format!("{}:{}", self.stem, self.entry);
        if self.params_in_storage {
            key.push_str(":params-storage");
        }
        for (name, value) in &self.constants {
            key.push_str(&format!(":{name}={value}"));
        }
        for (n, s) in &self.slots {
            key.push_str(&format!(":{n}:{}", s.code()));
        }
        key
    }

    /// The recipe a key describes (`None` for text that is not one).
    pub(crate) fn parse(key: &str) -> Option<Recipe> {
        let mut parts = key.split(':').peekable();
        let stem = parts.next().filter(|s| !s.is_empty())?.to_string();
        let entry = parts.next().filter(|s| !s.is_empty())?.to_string();
        let params_in_storage = parts.next_if_eq(&"params-storage").is_some();
        let mut constants = Vec::new();
        while let Some(c) = parts.next_if(|p| p.contains('=')) {
            let (name, value) = c.split_once('=')?;
            constants.push((name.to_string(), value.parse().ok()?));
        }
        let mut slots = Vec::new();
        while let Some(n) = parts.next() {
            slots.push((n.parse().ok()?, Slot::parse(parts.next()?)?));
        }
        Some(Recipe {
            stem,
            entry,
            params_in_storage,
            constants,
            slots,
        })
    }
}

/// The recipes each node kind used, kept for the next evaluation and the next process.
pub(crate) struct Recipes {
    /// The file (`None`: nothing on disk).
    path: Option<PathBuf>,
    /// Adapter, driver and version: the file's first line after the header.
    identity: String,
    /// Kind → recipes (their keys), and whether some were added since the last save.
    by_kind: Mutex<(BTreeMap<String, BTreeSet<String>>, bool)>,
    /// Pipelines created by workers ([`Gpu::pipelines_prepared`]).
    prepared: AtomicU64,
}

impl Recipes {
    /// The recipes saved for this adapter, driver and version (none when there is no file, or
    /// it is another's or unreadable: recipes only save time, nothing needs them).
    pub(crate) fn open(info: &wgpu::AdapterInfo) -> Recipes {
        let identity = format!(
            "{:?}|{}|{}|{}|{}|{}",
            info.backend,
            info.vendor,
            info.device,
            info.driver,
            info.driver_info,
            env!("CARGO_PKG_VERSION")
        );
        let mut h = DefaultHasher::new();
        identity.hash(&mut h);
        let path = cache_dir().map(|d| d.join(format!("recipes-{:016x}.txt", h.finish())));
        let by_kind = path
            .as_ref()
            .map_or_else(BTreeMap::new, |p| read(p, &identity));
        Recipes {
            path,
            identity,
            by_kind: Mutex::new((by_kind, false)),
            prepared: AtomicU64::new(0),
        }
    }

    /// The pipeline `key` is used by a node of kind `kind`: remember it under that kind.
    pub(crate) fn used(&self, kind: &str, key: &str) {
        let mut by_kind = self.by_kind.lock().unwrap_or_else(|e| e.into_inner());
        let known = by_kind.0.get(kind).is_some_and(|k| k.contains(key));
        if !known {
            by_kind
                .0
                .entry(kind.to_string())
                .or_default()
                .insert(key.to_string());
            by_kind.1 = true;
        }
    }

    /// The recipes (keys) remembered for `kind`.
    fn of_kind(&self, kind: &str) -> Vec<String> {
        let by_kind = self.by_kind.lock().unwrap_or_else(|e| e.into_inner());
        by_kind
            .0
            .get(kind)
            .map_or_else(Vec::new, |k| k.iter().cloned().collect())
    }

    /// Save them when some were added since the last save, merged with what other processes
    /// saved meanwhile (a temporary file renamed over the old one).
    pub(crate) fn save(&self) -> Result<(), String> {
        let Some(path) = &self.path else {
            return Ok(());
        };
        let mut by_kind = self.by_kind.lock().unwrap_or_else(|e| e.into_inner());
        if !by_kind.1 {
            return Ok(());
        }
        by_kind.1 = false;
        let mut all = read(path, &self.identity);
        for (kind, keys) in &by_kind.0 {
            all.entry(kind.clone())
                .or_default()
                .extend(keys.iter().cloned());
        }
        let mut text = format!("{HEADER}\n{}\n", self.identity);
        for (kind, keys) in &all {
            for key in keys {
                text.push_str(&format!("{kind}\t{key}\n"));
            }
        }
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        let tmp = path.with_extension(format!("tmp{}", std::process::id()));
        std::fs::write(&tmp, text)
            .and_then(|()| std::fs::rename(&tmp, path))
            .map_err(|e| {
                let _ = std::fs::remove_file(&tmp);
                format!("{}: {e}", path.display())
            })
    }
}

/// The recipes of the file at `path` when it is this identity's (else none).
fn read(path: &std::path::Path, identity: &str) -> BTreeMap<String, BTreeSet<String>> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let mut lines = text.lines();
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    if lines.next() != Some(HEADER) || lines.next() != Some(identity) {
        return out;
    }
    for line in lines {
        if let Some((kind, key)) = line.split_once('\t') {
            if Recipe::parse(key).is_some() {
                out.entry(kind.to_string())
                    .or_default()
                    .insert(key.to_string());
            }
        }
    }
    out
}

/// Pipelines being created up front ([`Gpu::prepare_pipelines`]). [`Preparing::finish`] (or
/// dropping it) drops what no worker has started and waits for the workers, so no thread
/// creates pipelines after the evaluation that asked for them.
pub struct Preparing {
    queue: Arc<Mutex<VecDeque<(Shader, Recipe)>>>,
    stop: Arc<AtomicBool>,
    workers: Vec<std::thread::JoinHandle<()>>,
}

impl Preparing {
    /// Worker threads started (0: nothing to make).
    pub fn workers(&self) -> usize {
        self.workers.len()
    }

    /// Stop: what no worker has started is dropped; wait for the workers.
    pub fn finish(mut self) {
        self.stop_and_join();
    }

    fn stop_and_join(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        self.queue.lock().unwrap_or_else(|e| e.into_inner()).clear();
        for w in self.workers.drain(..) {
            let _ = w.join();
        }
    }
}

impl Drop for Preparing {
    fn drop(&mut self) {
        self.stop_and_join();
    }
}

/// Whether pipelines are prepared up front: not when `TYNDALL_PIPELINES_UP_FRONT=0` (to
/// measure what it saves).
fn enabled() -> bool {
    std::env::var("TYNDALL_PIPELINES_UP_FRONT").map_or(true, |v| v != "0")
}

impl Gpu {
    /// Start creating, on worker threads, the pipelines the node kinds in `kinds` (kind, its
    /// shaders; in the order they will run) used before — in this process or, through the file
    /// in [`cache_dir`], an earlier one — and that this context has not created yet. A node
    /// needing one of them while a worker creates it waits for it. Nothing is started when there
    /// is nothing to create (an evaluation after the first) or `TYNDALL_PIPELINES_UP_FRONT=0`.
    pub fn prepare_pipelines(self: &Arc<Self>, kinds: &[(&str, &'static [Shader])]) -> Preparing {
        let mut jobs = VecDeque::new();
        if enabled() {
            let mut seen = BTreeSet::new();
            for (kind, shaders) in kinds {
                for key in self.recipes.of_kind(kind) {
                    let Some(recipe) = Recipe::parse(&key) else {
                        continue;
                    };
                    let shader = shaders.iter().find(|s| s.stem == recipe.stem);
                    if let Some(shader) = shader {
                        if !self.has_pipeline(&key) && seen.insert(key) {
                            jobs.push_back((*shader, recipe));
                        }
                    }
                }
            }
        }
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let workers = if self.info.backend == wgpu::Backend::Gl {
            1
        } else {
            cores.saturating_sub(1).clamp(1, MAX_WORKERS)
        }
        .min(jobs.len());
        let queue = Arc::new(Mutex::new(jobs));
        let stop = Arc::new(AtomicBool::new(false));
        let workers = (0..workers)
            .map(|_| {
                let (gpu, queue, stop) = (self.clone(), queue.clone(), stop.clone());
                std::thread::spawn(move || {
                    while !stop.load(Ordering::Relaxed) {
                        let job = queue.lock().unwrap_or_else(|e| e.into_inner()).pop_front();
                        let Some((shader, recipe)) = job else {
                            break;
                        };
                        // A recipe that no longer builds is forgotten here; the node that
                        // needs it reports the error when it runs.
                        if let Ok((_, true)) = gpu.obtain_pipeline(shader, &recipe, &recipe.key()) {
                            gpu.recipes.prepared.fetch_add(1, Ordering::Relaxed);
                        }
                    }
                })
            })
            .collect();
        Preparing {
            queue,
            stop,
            workers,
        }
    }

    /// Pipelines created up front by workers so far ([`Gpu::prepare_pipelines`]).
    pub fn pipelines_prepared(&self) -> u64 {
        self.recipes.prepared.load(Ordering::Relaxed)
    }

    /// Save the recipes of the pipelines used since the last save, for the next process
    /// (the evaluator calls it after each evaluation); the reason when it could not be written.
    pub fn save_pipeline_recipes(&self) -> Result<(), String> {
        self.recipes.save()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_recipe_is_its_key_and_back() {
        let r = Recipe {
            stem: "single_scattering/min_max".into(),
            entry: "build_level".into(),
            params_in_storage: true,
            constants: vec![("EXTINCTION".into(), 1.0), ("STEPS".into(), 0.25)],
            slots: vec![
                (0, Slot::Uniform),
                (1, Slot::Texture),
                (2, Slot::Storage(StoredFormat::Rg32)),
                (3, Slot::Buffer),
                (4, Slot::Volume),
                (5, Slot::VolumeLevel),
                (6, Slot::Storage(StoredFormat::R32)),
                (7, Slot::Storage(StoredFormat::Rgba32)),
            ],
        };
        let key = r.key();
        assert_eq!(
            key,
            "single_scattering/min_max:build_level:params-storage:EXTINCTION=1:STEPS=0.25\
             :0:u:1:t:2:s2:3:b:4:v:5:vs:6:s1:7:s4"
        );
        assert_eq!(Recipe::parse(&key), Some(r));
        let plain = Recipe::parse("tonemap:tonemap:0:u:1:t:2:s4").expect("plain");
        assert!(!plain.params_in_storage && plain.constants.is_empty());
        assert_eq!(plain.key(), "tonemap:tonemap:0:u:1:t:2:s4");
        for bad in [
            "",
            "tonemap",
            "tonemap:tonemap:0",
            "tonemap:tonemap:0:q",
            "a:b:X=y",
        ] {
            assert_eq!(Recipe::parse(bad), None, "{bad}");
        }
    }
}
