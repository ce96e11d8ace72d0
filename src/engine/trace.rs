//! A trace of what the process did, as Chrome trace-event JSON (Perfetto and `chrome://tracing`
//! open it): `tyndall render|eval|bench --trace FILE`.
//!
//! While [`start`]ed, the engine records complete events (`"ph": "X"`, times in µs since the
//! start): each node run (`cat: "node"`, `name`: the node's id, `args`: kind, frame), each GPU
//! pass from its timestamp queries (`cat: "gpu"`, on the track "GPU"; with `--stats` or a bench,
//! which time passes), each pipeline creation (`cat: "pipeline"`), each read-back
//! (`cat: "readback"`, `args.bytes`) and each file written (`cat: "write"`, `args.frame`,
//! `args.path`). Each CPU thread is a track of its own. A trace crate was not used: the GPU
//! events are placed at times taken from the GPU's clock after the fact, which span-based
//! recorders (`tracing-chrome`, puffin) do not offer; the format itself is a list of JSON
//! objects written with `serde_json`.

use std::cell::Cell;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

static ON: AtomicBool = AtomicBool::new(false);
static EVENTS: Mutex<Vec<Value>> = Mutex::new(Vec::new());
static EPOCH: OnceLock<Instant> = OnceLock::new();
static NEXT_TRACK: AtomicU64 = AtomicU64::new(1);
/// The GPU track's id.
const GPU_TRACK: u64 = 1_000_000;

thread_local! {
    /// This thread's track (0: not named yet).
    static TRACK: Cell<u64> = const { Cell::new(0) };
    /// The frame this thread is evaluating, for the events' `args.frame`.
    static FRAME: Cell<Option<i64>> = const { Cell::new(None) };
}

/// Start recording (events from before are not kept).
pub fn start() {
    let _ = EPOCH.get_or_init(Instant::now);
    if let Ok(mut e) = EVENTS.lock() {
        e.clear();
        e.push(json!({"ph": "M", "name": "thread_name", "pid": 1, "tid": GPU_TRACK, "args": {"name": "GPU"}}));
    }
    ON.store(true, Ordering::Release);
}

/// Whether events are being recorded.
pub fn enabled() -> bool {
    ON.load(Ordering::Acquire)
}

/// The frame this thread evaluates from now on (`None`: a still).
pub fn set_frame(frame: Option<i64>) {
    FRAME.with(|f| f.set(frame));
}

/// The frame this thread evaluates.
pub fn frame() -> Option<i64> {
    FRAME.with(Cell::get)
}

fn micros(t: Instant) -> f64 {
    let epoch = *EPOCH.get_or_init(Instant::now);
    t.checked_duration_since(epoch)
        .map_or(0.0, |d| d.as_secs_f64() * 1e6)
}

/// This thread's track, named after the thread the first time.
fn track() -> u64 {
    TRACK.with(|t| {
        if t.get() == 0 {
            let id = NEXT_TRACK.fetch_add(1, Ordering::Relaxed);
            t.set(id);
            let name = std::thread::current()
                .name()
                .map_or_else(|| format!("thread {id}"), str::to_string);
            push(json!({"ph": "M", "name": "thread_name", "pid": 1, "tid": id, "args": {"name": name}}));
        }
        t.get()
    })
}

fn push(event: Value) {
    if let Ok(mut e) = EVENTS.lock() {
        e.push(event);
    }
}

/// Record a complete event on this thread's track: `cat`, `name`, from `start` for `dur`, with
/// `args` (an object; `frame` is added when this thread has one).
pub fn record(cat: &str, name: &str, start: Instant, dur: Duration, mut args: Value) {
    if !enabled() {
        return;
    }
    if let (Some(f), Some(map)) = (frame(), args.as_object_mut()) {
        map.entry("frame").or_insert(json!(f));
    }
    push(json!({
        "ph": "X", "cat": cat, "name": name, "pid": 1, "tid": track(),
        "ts": micros(start), "dur": dur.as_secs_f64() * 1e6, "args": args,
    }));
}

/// Record a pipeline creation (`cat: "pipeline"`, named by its key) that began at `start`.
pub fn pipeline_created(key: &str, start: Instant) {
    record("pipeline", key, start, start.elapsed(), json!({}));
}

/// Run `write` (a file write of `path`) and record it (`cat: "write"`, `args.path`).
pub fn write<T>(path: &Path, write: impl FnOnce() -> T) -> T {
    let start = Instant::now();
    let out = write();
    record(
        "write",
        "write",
        start,
        start.elapsed(),
        json!({ "path": path.display().to_string() }),
    );
    out
}

/// The GPU clock's offset from the trace's (µs), fixed by the first GPU pass recorded.
static GPU_OFFSET: OnceLock<f64> = OnceLock::new();

/// Record a GPU pass on the GPU track: `name`, ending at `end_ns` on the GPU's clock (its
/// timestamps, in ns) after `dur` of GPU time. The first pass read fixes the offset between
/// the clocks (its end taken as now, just after waiting for it), so later passes fall a little
/// late by that wait at most, and keep their order and gaps.
pub fn record_gpu(name: &str, end_ns: f64, dur: Duration) {
    if !enabled() {
        return;
    }
    let offset = *GPU_OFFSET.get_or_init(|| micros(Instant::now()) - end_ns / 1e3);
    let dur_us = dur.as_secs_f64() * 1e6;
    let mut args = json!({});
    if let (Some(f), Some(map)) = (frame(), args.as_object_mut()) {
        map.insert("frame".into(), json!(f));
    }
    push(json!({
        "ph": "X", "cat": "gpu", "name": name, "pid": 1, "tid": GPU_TRACK,
        "ts": (end_ns / 1e3 + offset - dur_us).max(0.0), "dur": dur_us, "args": args,
    }));
}

/// Stop recording and write what was recorded to `path` (`{"traceEvents": [...]}`).
pub fn finish(path: &Path) -> std::io::Result<()> {
    ON.store(false, Ordering::Release);
    let events = EVENTS
        .lock()
        .map(|mut e| std::mem::take(&mut *e))
        .unwrap_or_default();
    let doc = json!({"traceEvents": events, "displayTimeUnit": "ms"});
    let text = serde_json::to_vec(&doc).map_err(std::io::Error::other)?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(path, text)
}
