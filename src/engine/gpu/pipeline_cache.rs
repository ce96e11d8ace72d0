//! Pipelines compiled once per machine: wgpu's `PipelineCache` (where the adapter offers it:
//! Vulkan) saved in the user's cache folder and loaded by the next process, with the list of
//! the pipelines it holds, so `--stats` can say how many a run compiled and how many came from
//! the cache.
//!
//! The file (`pipelines-<adapter key>.bin` in [`cache_dir`]) starts with a magic line and an
//! identity line — wgpu's cache key for the adapter, the driver, the driver info and Tyndall's
//! version — then the pipelines' keys, wgpu's data, and a checksum of all of it. A file that is
//! corrupt, truncated or made by another adapter, driver or version is ignored with a warning
//! (and replaced by the next save). Saves write a temporary file and rename it, so processes of
//! a farm sharing the folder never read half a file.

use std::collections::BTreeSet;
use std::hash::{DefaultHasher, Hash, Hasher};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

const MAGIC: &[u8] = b"TYNDALL-PIPELINE-CACHE 1\n";

/// The folder Tyndall keeps caches in: `TYNDALL_CACHE_DIR` when set (empty: no cache on disk),
/// else the user's cache folder (`$XDG_CACHE_HOME` or `~/.cache` on Linux, `~/Library/Caches`
/// on macOS, `%LOCALAPPDATA%` on Windows) + `tyndall`.
pub fn cache_dir() -> Option<PathBuf> {
    match std::env::var_os("TYNDALL_CACHE_DIR") {
        Some(d) if d.is_empty() => None,
        Some(d) => Some(PathBuf::from(d)),
        None => dirs::cache_dir().map(|d| d.join("tyndall")),
    }
}

/// The pipeline cache of one device.
pub(crate) struct DiskCache {
    /// wgpu's cache, when the adapter offers one.
    pub(crate) cache: Option<wgpu::PipelineCache>,
    /// Where it is saved (`None`: not saved).
    path: Option<PathBuf>,
    identity: String,
    /// Pipelines in the loaded file, and those compiled since (by key and source hash).
    known: Mutex<(BTreeSet<String>, BTreeSet<String>)>,
    compiled: AtomicU64,
    cached: AtomicU64,
}

impl DiskCache {
    /// Open the cache for `device` (with the `PIPELINE_CACHE` feature when `enabled`): the
    /// file's data when it is this adapter's, driver's and version's. Returns a warning for a
    /// file that was ignored.
    pub(crate) fn open(
        device: &wgpu::Device,
        info: &wgpu::AdapterInfo,
        enabled: bool,
    ) -> (Self, Option<String>) {
        let key = wgpu::util::pipeline_cache_key(info).filter(|_| enabled);
        let identity = format!(
            "{}|{}|{}|{}",
            key.as_deref().unwrap_or("-"),
            info.driver,
            info.driver_info,
            env!("CARGO_PKG_VERSION")
        );
        let path = key
            .as_ref()
            .and_then(|k| cache_dir().map(|d| d.join(format!("pipelines-{k}.bin"))));
        let mut warning = None;
        let loaded = path.as_ref().and_then(|p| match std::fs::read(p) {
            Ok(bytes) => match parse(&bytes, &identity) {
                Ok(v) => Some(v),
                Err(why) => {
                    warning = Some(format!(
                        "ignoring the pipeline cache {}: {why}; it is rebuilt",
                        p.display()
                    ));
                    None
                }
            },
            Err(_) => None,
        });
        let (names, data) = loaded.unwrap_or_default();
        let cache = key.as_ref().map(|_| {
            // SAFETY: `data` is what `PipelineCache::get_data` returned for an adapter with the
            // same `pipeline_cache_key`, driver and wgpu (checked by `parse`: identity and
            // checksum); with `fallback`, data wgpu cannot use gives an empty cache.
            unsafe {
                device.create_pipeline_cache(&wgpu::PipelineCacheDescriptor {
                    label: Some("tyndall pipelines"),
                    data: (!data.is_empty()).then_some(data.as_slice()),
                    fallback: true,
                })
            }
        });
        let cache_ok = cache.is_some();
        (
            Self {
                cache,
                path: path.filter(|_| cache_ok),
                identity,
                known: Mutex::new((names, BTreeSet::new())),
                compiled: AtomicU64::new(0),
                cached: AtomicU64::new(0),
            },
            warning,
        )
    }

    /// A pipeline is being created under `key` from `source`: count it as compiled, or as from
    /// the cache when the loaded file holds it.
    pub(crate) fn note(&self, key: &str, source: &str) {
        let mut h = DefaultHasher::new();
        source.hash(&mut h);
        let name = format!("{key}#{:016x}", h.finish());
        let mut known = self.known.lock().unwrap_or_else(|e| e.into_inner());
        if known.0.contains(&name) {
            self.cached.fetch_add(1, Ordering::Relaxed);
        } else {
            self.compiled.fetch_add(1, Ordering::Relaxed);
            known.1.insert(name);
        }
    }

    /// Pipelines created so far: (compiled, from the cache).
    pub(crate) fn counts(&self) -> (u64, u64) {
        (
            self.compiled.load(Ordering::Relaxed),
            self.cached.load(Ordering::Relaxed),
        )
    }

    /// Save the cache when pipelines were compiled since the last save.
    pub(crate) fn save(&self) -> Result<(), String> {
        let (Some(path), Some(cache)) = (&self.path, &self.cache) else {
            return Ok(());
        };
        let mut known = self.known.lock().unwrap_or_else(|e| e.into_inner());
        if known.1.is_empty() {
            return Ok(());
        }
        let Some(data) = cache.get_data() else {
            return Ok(());
        };
        let fresh = std::mem::take(&mut known.1);
        known.0.extend(fresh);
        let bytes = serialise(&self.identity, &known.0, &data);
        // Still holding the lock: one save at a time in this process (others rename their own
        // temporary file).
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        let tmp = path.with_extension(format!("tmp{}", std::process::id()));
        std::fs::write(&tmp, &bytes)
            .and_then(|()| std::fs::rename(&tmp, path))
            .map_err(|e| {
                let _ = std::fs::remove_file(&tmp);
                format!("{}: {e}", path.display())
            })
    }
}

fn checksum(bytes: &[u8]) -> u64 {
    let mut h = DefaultHasher::new();
    bytes.hash(&mut h);
    h.finish()
}

/// The file: magic, identity line, the count and the names (one per line), wgpu's data, then the
/// checksum of all that (8 bytes, little-endian).
fn serialise(identity: &str, names: &BTreeSet<String>, data: &[u8]) -> Vec<u8> {
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(identity.as_bytes());
    out.push(b'\n');
    out.extend_from_slice(format!("{}\n", names.len()).as_bytes());
    for n in names {
        out.extend_from_slice(n.as_bytes());
        out.push(b'\n');
    }
    out.extend_from_slice(data);
    let sum = checksum(&out);
    out.extend_from_slice(&sum.to_le_bytes());
    out
}

/// The names and wgpu's data of a file, or why it cannot be used.
fn parse(bytes: &[u8], identity: &str) -> Result<(BTreeSet<String>, Vec<u8>), String> {
    let body_len = bytes.len().checked_sub(8).ok_or("the file is truncated")?;
    let (body, sum) = bytes.split_at(body_len);
    let rest = body
        .strip_prefix(MAGIC)
        .ok_or("not a Tyndall pipeline cache")?;
    let sum: [u8; 8] = sum.try_into().map_err(|_| "the file is truncated")?;
    if u64::from_le_bytes(sum) != checksum(body) {
        return Err("its checksum does not match (corrupt or truncated)".into());
    }
    let mut lines = rest.splitn(3, |b| *b == b'\n');
    let id = lines.next().unwrap_or_default();
    if id != identity.as_bytes() {
        return Err(format!(
            "it was made for another adapter, driver or version ({})",
            String::from_utf8_lossy(id)
        ));
    }
    let count: usize = std::str::from_utf8(lines.next().unwrap_or_default())
        .ok()
        .and_then(|c| c.parse().ok())
        .ok_or("its pipeline count is unreadable")?;
    let mut rest = lines.next().unwrap_or_default();
    let mut names = BTreeSet::new();
    for _ in 0..count {
        let end = rest
            .iter()
            .position(|b| *b == b'\n')
            .ok_or("its pipeline list is truncated")?;
        names.insert(String::from_utf8_lossy(&rest[..end]).into_owned());
        rest = &rest[end + 1..];
    }
    Ok((names, rest.to_vec()))
}

impl super::Gpu {
    /// Pipelines this context created so far: (compiled, taken from the pipeline cache on
    /// disk).
    pub fn pipeline_counts(&self) -> (u64, u64) {
        self.disk.counts()
    }

    /// Save the pipeline cache ([`cache_dir`]) when pipelines were compiled since the last save
    /// (the evaluator calls it after each evaluation); the reason when it could not be written.
    pub fn save_pipeline_cache(&self) -> Result<(), String> {
        self.disk.save()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_round_trips_and_a_changed_byte_or_identity_is_refused() {
        let names: BTreeSet<String> = ["a:main#1".to_string(), "b:x#2".into()].into();
        let bytes = serialise("vk_1_2|drv|info|0.1.0", &names, &[1, 2, 3, 10, 0]);
        assert_eq!(
            parse(&bytes, "vk_1_2|drv|info|0.1.0"),
            Ok((names, vec![1, 2, 3, 10, 0]))
        );
        let foreign = parse(&bytes, "vk_1_3|drv|info|0.1.0").unwrap_err();
        assert!(foreign.contains("another adapter"), "{foreign}");
        for i in [0, MAGIC.len() + 3, bytes.len() - 9, bytes.len() - 1] {
            let mut bad = bytes.clone();
            bad[i] ^= 0x40;
            assert!(parse(&bad, "vk_1_2|drv|info|0.1.0").is_err(), "byte {i}");
        }
        assert!(parse(&bytes[..bytes.len() - 3], "vk_1_2|drv|info|0.1.0").is_err());
        assert!(parse(b"", "x").is_err());
    }
}
