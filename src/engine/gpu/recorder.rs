//! The command encoder, explicit. A [`Recorder`] is what GPU work is recorded through: the
//! evaluator makes one per evaluation and hands it to every node's `run` as `RunCtx::gpu`, so a
//! node's dispatches, raster passes and copies go into the evaluation's encoder. It derefs to
//! [`Gpu`] for everything that does not record (textures, buffers, pipelines, limits).
//!
//! Submissions in chunks, not per pass or per node: when a node ends
//! ([`Recorder::end_node`]) and the encoder holds [`CHUNK_PASSES`] passes, it is finished and
//! submitted and a new one begins; [`Recorder::finish`] (or dropping the recorder) submits the
//! rest. So an evaluation neither waits for the GPU between nodes nor pays a submission (and a
//! command buffer) per node — on lavapipe a submission wakes the driver's queue thread, ~60 % of
//! a 3,000-node chain's evaluation when each node submitted — while the GPU still starts on the
//! first chunk as later nodes are recorded.
//!
//! A read-back through a recorder submits what it recorded first (it needs the results).
//! Textures a recorded pass uses are marked with the recorder: one dropped before the recorder
//! submits returns to the pool only after that submission ([`Retired`]), so another thread's
//! upload into a recycled texture never reaches the queue before this recorder's passes that
//! read its old contents. With GPU timing on ([`Recorder::set_timing`]), each pass's timestamps
//! are resolved in the encoder and read once per evaluation ([`Recorder::resolve_timings`]).
//!
//! On wgpu's GL backend every pass is submitted alone: a GL submission runs while holding the
//! adapter's one context lock, and another thread waiting for that lock gives up after one
//! second (wgpu-hal panics "Could not lock adapter context"), so a whole chunk in one
//! submission — seconds on llvmpipe — would fail any thread evaluating beside it. With pass
//! tracing on (`TYNDALL_TRACE_PASSES`), too: tracing waits for each pass.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use super::{tracing, Gpu, GpuError, GpuTexture, PassTimer};

/// Passes recorded before the encoder is submitted (checked when a node ends, so a node's
/// passes are never split): enough that a submission's cost is spread over many nodes, few
/// enough that the GPU starts early. On lavapipe, the 10,000-node chain of
/// `tyndall bench documents` evaluated in 1.3–1.5 s submitting per node, 0.64–0.71 s at 64, and
/// 19–26 s in one submission for the whole evaluation (the driver had nothing to do until the
/// end, then one enormous command buffer).
pub const CHUNK_PASSES: u32 = 64;

/// Records GPU commands into one encoder, submitted in chunks (see the module doc). Made by
/// [`Gpu::recorder`]; derefs to the [`Gpu`].
pub struct Recorder<'g> {
    gpu: &'g Gpu,
    /// Submit every pass alone (GL, pass tracing).
    immediate: bool,
    state: Mutex<State>,
    /// Command buffers this recorder submitted.
    submits: AtomicU64,
}

/// What a recorder holds between passes.
struct State {
    /// The encoder commands are recorded into (created on first use).
    encoder: Option<wgpu::CommandEncoder>,
    /// Passes recorded since the last submission.
    passes: u32,
    /// Textures dropped while passes recorded since the last submission use them.
    retired: Arc<Retired>,
    /// Whether passes are timed.
    timing: bool,
    /// The node whose passes are being recorded (their GPU time is its).
    node: String,
    /// Its kind (the pipelines it uses are remembered under it); empty: none.
    kind: String,
    /// Timers of recorded passes, read by [`Recorder::resolve_timings`].
    timers: Vec<PassTimer>,
}

/// Pool returns of textures dropped while an unsubmitted pass uses them. The recorder holds the
/// one strong reference until its next submission; the textures hold weak ones. A return is
/// shared by every recorder whose unsubmitted passes use the texture, and runs when the last of
/// them has submitted.
#[derive(Default)]
pub(crate) struct Retired(Mutex<Vec<Arc<Release>>>);

impl Retired {
    /// Hold `release` until this recorder has submitted.
    pub(crate) fn hold(&self, release: Arc<Release>) {
        self.0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(release);
    }
}

/// A texture's return to its pool, run when the last holder drops it.
pub(crate) struct Release(Mutex<Option<Box<dyn FnOnce() + Send>>>);

impl Release {
    /// `release`, to run once no [`Retired`] list holds it.
    pub(crate) fn new(release: Box<dyn FnOnce() + Send>) -> Arc<Self> {
        Arc::new(Self(Mutex::new(Some(release))))
    }
}

impl Drop for Release {
    fn drop(&mut self) {
        let release = self.0.get_mut().unwrap_or_else(|e| e.into_inner()).take();
        if let Some(release) = release {
            release();
        }
    }
}

impl Gpu {
    /// A recorder for commands: an evaluation's (the evaluator makes it), or one for work
    /// outside an evaluation (a test's passes, a read-back), submitted by
    /// [`Recorder::finish`] or when dropped.
    pub fn recorder(&self) -> Recorder<'_> {
        Recorder {
            gpu: self,
            immediate: tracing() || self.info.backend == wgpu::Backend::Gl,
            state: Mutex::new(State {
                encoder: None,
                passes: 0,
                retired: Arc::default(),
                timing: false,
                node: String::new(),
                kind: String::new(),
                timers: Vec::new(),
            }),
            submits: AtomicU64::new(0),
        }
    }

    /// Submit one command buffer, counted.
    pub(crate) fn submit(&self, commands: wgpu::CommandBuffer) {
        self.submits.fetch_add(1, Ordering::Relaxed);
        self.queue.submit([commands]);
    }

    /// Command buffers submitted by this context so far (all recorders, all threads).
    pub fn submit_count(&self) -> u64 {
        self.submits.load(Ordering::Relaxed)
    }
}

impl std::ops::Deref for Recorder<'_> {
    type Target = Gpu;
    fn deref(&self) -> &Gpu {
        self.gpu
    }
}

impl Drop for Recorder<'_> {
    fn drop(&mut self) {
        // Not finished (an early return, a panic): what is recorded is still submitted — it may
        // hold earlier nodes' work later evaluations reuse; an error here follows the first.
        let _ = self.flush();
    }
}

impl<'g> Recorder<'g> {
    /// The GPU context (with the recorder's lifetime, where a borrow of the recorder is too
    /// short).
    pub fn gpu(&self) -> &'g Gpu {
        self.gpu
    }

    fn state(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Record one pass with `f` into the open encoder (or into one submitted at once, on GL
    /// and when tracing). `f` must not record through this recorder.
    pub(crate) fn encode<T>(&self, f: impl FnOnce(&mut wgpu::CommandEncoder) -> T) -> T {
        if self.immediate {
            let mut enc = self.device.create_command_encoder(&Default::default());
            let out = f(&mut enc);
            self.submit(enc.finish());
            return out;
        }
        let mut st = self.state();
        let enc = st
            .encoder
            .get_or_insert_with(|| self.device.create_command_encoder(&Default::default()));
        let out = f(enc);
        st.passes += 1;
        out
    }

    /// Mark `tex` as used by the passes recorded and not yet submitted: dropped before then, it
    /// returns to the pool after the submission.
    pub(crate) fn uses(&self, tex: &GpuTexture) {
        if !self.immediate {
            tex.used_by(&self.state().retired);
        }
    }

    /// Submit one command buffer, counted for this recorder too.
    pub(crate) fn submit(&self, commands: wgpu::CommandBuffer) {
        self.submits.fetch_add(1, Ordering::Relaxed);
        self.gpu.submit(commands);
    }

    /// Submit what is recorded so far and go on recording: before a read-back, and when a
    /// chunk is full. The textures retired meanwhile then go back to the pool. An encoding
    /// error surfaces here (wgpu reports a pass's errors when its encoder is finished).
    pub fn flush(&self) -> Result<(), GpuError> {
        let (encoder, retired) = {
            let mut st = self.state();
            st.passes = 0;
            (st.encoder.take(), std::mem::take(&mut st.retired))
        };
        let submitted = match encoder {
            Some(enc) => self.scoped(|| self.submit(enc.finish())),
            None => Ok(()),
        };
        drop(retired);
        submitted
    }

    /// A node's passes are recorded: submit the chunk once it holds [`CHUNK_PASSES`] passes.
    pub fn end_node(&self) -> Result<(), GpuError> {
        if self.state().passes >= CHUNK_PASSES {
            self.flush()
        } else {
            Ok(())
        }
    }

    /// Submit the rest.
    pub fn finish(self) -> Result<(), GpuError> {
        self.flush()
    }

    /// Command buffers this recorder has submitted so far: what one node submitted is the
    /// difference across its run.
    pub fn submits(&self) -> u64 {
        self.submits.load(Ordering::Relaxed)
    }

    /// Time the passes recorded from now on (when the adapter has timestamp queries), or stop.
    pub fn set_timing(&self, on: bool) {
        self.state().timing = on;
    }

    /// The node whose passes are recorded next: their GPU time is node `id`'s, the pipelines
    /// they use are remembered under its `kind` (for [`Gpu::prepare_pipelines`] next time).
    /// The evaluator calls it before each node's run.
    pub fn set_node(&self, id: &str, kind: &str) {
        let mut st = self.state();
        st.node.clear();
        st.node.push_str(id);
        st.kind.clear();
        st.kind.push_str(kind);
    }

    /// Remember pipeline `key` under the running node's kind.
    pub(crate) fn used_pipeline(&self, key: &str) {
        let st = self.state();
        if !st.kind.is_empty() {
            self.recipes.used(&st.kind, key);
        }
    }

    /// Queries for one pass, when timing.
    pub(crate) fn pass_timer(&self, label: &str) -> Option<PassTimer> {
        let node = {
            let st = self.state();
            if !st.timing {
                return None;
            }
            st.node.clone()
        };
        self.gpu.pass_timer(label, node)
    }

    /// Keep a pass's timer (its resolve recorded in the encoder that recorded the pass) for
    /// [`Recorder::resolve_timings`].
    pub(crate) fn keep_timer(&self, timer: PassTimer) {
        self.state().timers.push(timer);
    }

    /// Submit what is recorded, then read every timer kept since the last call — one wait for
    /// the GPU — and sum their durations per node (each pass also goes to the trace's GPU
    /// track). Empty without timestamp queries or with timing off.
    pub fn resolve_timings(&self) -> Result<BTreeMap<String, Duration>, GpuError> {
        let timers = std::mem::take(&mut self.state().timers);
        if timers.is_empty() {
            return Ok(BTreeMap::new());
        }
        self.flush()?;
        self.gpu.read_timers(timers)
    }
}
