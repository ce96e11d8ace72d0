//! Submissions in chunks, not per pass or per node. Between [`Gpu::begin_batch`] and
//! [`Gpu::end_batch`] (the evaluator brackets a whole evaluation, and inside it every node's
//! `run`, with them), every command this thread records — dispatches, copies, raster passes —
//! goes into one command encoder. When a node's batch ends and the encoder holds
//! [`CHUNK_PASSES`] passes, it is finished and submitted, and a new one begins; the outermost
//! `end_batch` submits the rest. So an evaluation neither waits for the GPU between nodes nor
//! pays a submission (and a command buffer) per node — on lavapipe a submission wakes the
//! driver's queue thread, ~60 % of a 3,000-node chain's evaluation when each node submitted —
//! while the GPU still starts on the first chunk as later nodes are recorded.
//!
//! A read-back submits what is recorded first (it needs the results), and so does a queue write
//! into an existing texture (`upload`, `zeroed`): queue writes run before the submission they
//! precede, and a recycled texture may still be read by a recorded pass. With GPU timing on,
//! each pass's timestamps are resolved in the batch and read after its submission; with pass
//! tracing on, every pass is submitted alone (tracing waits for each).
//!
//! The batch is per thread, like wgpu's error scopes: the editor evaluates on one thread while
//! drawing on another, and neither sees the other's batch. On wgpu's GL backend nothing is
//! batched (see [`Gpu::batching`]'s doc: GL's context lock).

use std::cell::RefCell;
use std::sync::atomic::Ordering;

use super::{tracing, Gpu, GpuError};

/// Passes recorded before the encoder is submitted (checked when a node's batch ends, so a
/// node's passes are never split): enough that a submission's cost is spread over many nodes,
/// few enough that the GPU starts early. On lavapipe, the 10,000-node chain of
/// `tyndall bench documents` evaluated in 1.3–1.5 s submitting per node, 0.64–0.71 s at 64, and
/// 19–26 s in one submission for the whole evaluation (the driver had nothing to do until the
/// end, then one enormous command buffer).
pub const CHUNK_PASSES: u32 = 64;

/// This thread's batch.
#[derive(Default)]
struct Batch {
    /// Nested `begin_batch` calls not yet ended.
    depth: u32,
    /// The encoder commands are recorded into (created on first use).
    encoder: Option<wgpu::CommandEncoder>,
    /// Passes recorded since the last submission.
    passes: u32,
}

thread_local! {
    /// Submissions made by this thread ([`Gpu::thread_submit_count`]).
    static THREAD_SUBMITS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    /// `Some` while batching on this thread.
    static BATCH: RefCell<Option<Batch>> = const { RefCell::new(None) };
    /// Textures dropped while batching, returned to the pool once the batch is submitted.
    static RETIRED: RefCell<Vec<Box<dyn FnOnce()>>> = const { RefCell::new(Vec::new()) };
}

/// Return a dropped texture to its pool (`release`): now, or — while this thread batches —
/// once the batch is submitted. A pooled texture a recorded pass still reads or writes must not
/// be handed to another thread, whose work could reach the queue before this batch.
pub(crate) fn release_after_batch(release: Box<dyn FnOnce()>) {
    let batching = BATCH.try_with(|b| b.borrow().is_some()).unwrap_or(false);
    if batching {
        RETIRED.with(|r| r.borrow_mut().push(release));
    } else {
        release();
    }
}

/// After a submission: the textures retired since the last one go back to their pools.
fn release_retired() {
    let retired = RETIRED.with(|r| std::mem::take(&mut *r.borrow_mut()));
    retired.into_iter().for_each(|release| release());
}

/// Ends a batch when dropped (an early return or a panic in what it brackets), unless
/// [`BatchScope::end`] ended it first; either way the batches begun inside it and not ended (a
/// node that panicked between its `begin_batch` and `end_batch`) end with it.
pub struct BatchScope<'a> {
    gpu: &'a Gpu,
    /// The nesting depth this scope's `begin_batch` made.
    depth: u32,
    ended: bool,
}

impl BatchScope<'_> {
    /// End the batch: [`Gpu::end_batch`].
    pub fn end(mut self) -> Result<(), GpuError> {
        self.ended = true;
        self.close()
    }

    fn close(&self) -> Result<(), GpuError> {
        BATCH.with(|b| {
            if let Some(batch) = b.borrow_mut().as_mut() {
                batch.depth = batch.depth.min(self.depth);
            }
        });
        self.gpu.end_batch()
    }
}

impl Drop for BatchScope<'_> {
    fn drop(&mut self) {
        if !self.ended {
            // Already failing: what is recorded is submitted (it may hold earlier nodes'
            // work that later evaluations reuse), its error is the first error's consequence.
            let _ = self.close();
        }
    }
}

impl Gpu {
    /// Record this thread's GPU commands into one encoder until the matching
    /// [`Gpu::end_batch`]. Calls nest: an evaluation's batch holds its nodes' batches (and an
    /// evaluation inside a node's run holds its own nodes'); nothing recorded is dropped and the
    /// order is kept.
    pub fn begin_batch(&self) {
        BATCH.with(|b| b.borrow_mut().get_or_insert_with(Batch::default).depth += 1);
    }

    /// [`Gpu::begin_batch`], ended when the returned scope is ended or dropped.
    pub fn batch_scope(&self) -> BatchScope<'_> {
        self.begin_batch();
        BatchScope {
            gpu: self,
            depth: BATCH.with(|b| b.borrow().as_ref().map_or(1, |b| b.depth)),
            ended: false,
        }
    }

    /// End the innermost [`Gpu::begin_batch`]. Its commands stay in the open encoder, which is
    /// finished and submitted once it holds [`CHUNK_PASSES`] passes, or here when this was the
    /// outermost batch.
    pub fn end_batch(&self) -> Result<(), GpuError> {
        let (outermost, full) = BATCH.with(|b| match b.borrow_mut().as_mut() {
            Some(batch) => {
                batch.depth = batch.depth.saturating_sub(1);
                (batch.depth == 0, batch.passes >= CHUNK_PASSES)
            }
            None => (true, false),
        });
        let submitted = if outermost || full {
            self.flush()
        } else {
            Ok(())
        };
        if outermost {
            BATCH.with(|b| b.borrow_mut().take());
            release_retired();
        }
        submitted
    }

    /// Submit what this thread's batch has recorded so far and keep batching — before a
    /// read-back or a queue write, and when a chunk is full. Then the textures retired meanwhile
    /// go back to the pool. An encoding error surfaces here (wgpu
    /// reports a pass's errors when its encoder is finished): it is reported to the node whose
    /// batch ended the chunk, though any pass of the chunk may have caused it.
    pub(crate) fn flush(&self) -> Result<(), GpuError> {
        let encoder = BATCH.with(|b| {
            b.borrow_mut().as_mut().and_then(|batch| {
                batch.passes = 0;
                batch.encoder.take()
            })
        });
        let submitted = match encoder {
            Some(enc) => self.scoped(|| self.submit(enc.finish())),
            None => Ok(()),
        };
        release_retired();
        submitted
    }

    /// Whether commands are being batched on this thread now. Never on wgpu's GL backend: a
    /// GL submission runs while holding the adapter's one context lock, and another thread
    /// waiting for that lock gives up after one second (wgpu-hal panics "Could not lock adapter
    /// context"), so a whole node's passes in one submission — seconds on llvmpipe — would fail
    /// any thread evaluating beside it; there every pass is submitted alone, as before.
    fn batching(&self) -> bool {
        BATCH.with(|b| b.borrow().is_some()) && !tracing() && self.info.backend != wgpu::Backend::Gl
    }

    /// Record commands with `f`: into this thread's batch, or into an encoder submitted at once.
    /// `f` must not call back into `Gpu` methods that record.
    pub(crate) fn encode<T>(&self, f: impl FnOnce(&mut wgpu::CommandEncoder) -> T) -> T {
        if !self.batching() {
            let mut enc = self.device.create_command_encoder(&Default::default());
            let out = f(&mut enc);
            self.submit(enc.finish());
            return out;
        }
        let mut enc = BATCH
            .with(|b| b.borrow_mut().as_mut().and_then(|b| b.encoder.take()))
            .unwrap_or_else(|| self.device.create_command_encoder(&Default::default()));
        let out = f(&mut enc);
        BATCH.with(|b| {
            if let Some(batch) = b.borrow_mut().as_mut() {
                batch.encoder = Some(enc);
                batch.passes += 1;
            }
        });
        out
    }

    /// Submit one command buffer, counted (for the context and for this thread).
    pub(crate) fn submit(&self, commands: wgpu::CommandBuffer) {
        self.submits.fetch_add(1, Ordering::Relaxed);
        THREAD_SUBMITS.with(|n| n.set(n.get() + 1));
        self.queue.submit([commands]);
    }

    /// Command buffers this thread has submitted (to any context) so far: what one node run
    /// submitted is the difference across it, whatever other threads submit meanwhile.
    pub fn thread_submit_count(&self) -> u64 {
        THREAD_SUBMITS.with(std::cell::Cell::get)
    }

    /// Command buffers submitted by this context so far (all threads): the evaluator reports
    /// them per node (`--stats`).
    pub fn submit_count(&self) -> u64 {
        self.submits.load(Ordering::Relaxed)
    }
}
