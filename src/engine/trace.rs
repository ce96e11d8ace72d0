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
    if let Ok(mut p) = GPU_PASSES.lock() {
        p.clear();
    }
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

/// A GPU pass read from its timestamps, placed on the trace's clock when the trace is written.
struct GpuPass {
    name: String,
    /// Its end on the GPU's clock, µs.
    end_us: f64,
    dur_us: f64,
    frame: Option<i64>,
    /// When its timestamps were read, on the trace's clock (µs): after it ended.
    read_us: f64,
}

static GPU_PASSES: Mutex<Vec<GpuPass>> = Mutex::new(Vec::new());

/// Record a GPU pass on the GPU track: `name`, ending at `end_ns` on the GPU's clock (its
/// timestamps, in ns) after `dur` of GPU time. Passes are placed when the trace is written:
/// each was read after it ended, so the offset between the clocks is at most the smallest
/// (read time − end) over all passes — taken as the offset, which places the pass read soonest
/// after its end (the last of an evaluation, read once its work is done) at its read time and
/// every other pass by its own timestamps, in order and with their gaps. (Fixing the offset by
/// the first pass read placed a pipelined evaluation's passes late by up to the evaluation's
/// whole GPU time: its first pass is read only when the last one is done.)
pub fn record_gpu(name: &str, end_ns: f64, dur: Duration) {
    if !enabled() {
        return;
    }
    let pass = GpuPass {
        name: name.to_string(),
        end_us: end_ns / 1e3,
        dur_us: dur.as_secs_f64() * 1e6,
        frame: frame(),
        read_us: micros(Instant::now()),
    };
    if let Ok(mut p) = GPU_PASSES.lock() {
        p.push(pass);
    }
}

/// The GPU passes recorded so far as trace events, placed on the trace's clock.
fn gpu_events() -> Vec<Value> {
    let passes = GPU_PASSES
        .lock()
        .map(|mut p| std::mem::take(&mut *p))
        .unwrap_or_default();
    let offset = passes
        .iter()
        .map(|p| p.read_us - p.end_us)
        .fold(f64::INFINITY, f64::min);
    passes
        .into_iter()
        .map(|p| {
            let args = match p.frame {
                Some(f) => json!({ "frame": f }),
                None => json!({}),
            };
            json!({
                "ph": "X", "cat": "gpu", "name": p.name, "pid": 1, "tid": GPU_TRACK,
                "ts": (p.end_us + offset - p.dur_us).max(0.0), "dur": p.dur_us, "args": args,
            })
        })
        .collect()
}

/// Stop recording and write what was recorded to `path` (`{"traceEvents": [...]}`).
pub fn finish(path: &Path) -> std::io::Result<()> {
    ON.store(false, Ordering::Release);
    let mut events = EVENTS
        .lock()
        .map(|mut e| std::mem::take(&mut *e))
        .unwrap_or_default();
    events.extend(gpu_events());
    let doc = json!({"traceEvents": events, "displayTimeUnit": "ms"});
    let text = serde_json::to_vec(&doc).map_err(std::io::Error::other)?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(path, text)
}
