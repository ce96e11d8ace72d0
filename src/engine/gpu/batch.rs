//! One submission per node run. Between [`Gpu::begin_batch`] and [`Gpu::end_batch`] (the
//! evaluator brackets every node's `run` with them), every command this thread records —
//! dispatches, copies, raster passes — goes into one command encoder, submitted once at the end.
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

thread_local! {
    /// Submissions made by this thread ([`Gpu::thread_submit_count`]).
    static THREAD_SUBMITS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    /// `Some` while batching on this thread: the encoder commands are recorded into (created on
    /// first use).
    static BATCH: RefCell<Option<Option<wgpu::CommandEncoder>>> = const { RefCell::new(None) };
    /// Timers of passes recorded in the batch, read once it is submitted.
    static TIMERS: RefCell<Vec<super::PassTimer>> = const { RefCell::new(Vec::new()) };
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

impl Gpu {
    /// Record this thread's GPU commands into one encoder until [`Gpu::end_batch`]. Already
    /// batching (an evaluation inside a node's run), it keeps the batch it has: nothing recorded
    /// is dropped, and the inner `end_batch` submits it early, which keeps the order.
    pub fn begin_batch(&self) {
        BATCH.with(|b| {
            let mut b = b.borrow_mut();
            if b.is_none() {
                *b = Some(None);
            }
        });
    }

    /// Submit what was recorded since [`Gpu::begin_batch`] (once) and stop batching.
    pub fn end_batch(&self) -> Result<(), GpuError> {
        let pending = BATCH.with(|b| b.borrow_mut().take()).flatten();
        self.submit_pending(pending)
    }

    /// Submit what this thread's batch holds so far and keep batching (before a read-back or a
    /// queue write).
    pub(crate) fn flush(&self) -> Result<(), GpuError> {
        let pending = BATCH.with(|b| b.borrow_mut().as_mut().and_then(Option::take));
        self.submit_pending(pending)
    }

    /// Submit a batch's encoder (if anything was recorded), then return the textures retired
    /// meanwhile to the pool and read the passes' timers.
    fn submit_pending(&self, pending: Option<wgpu::CommandEncoder>) -> Result<(), GpuError> {
        let submitted = match pending {
            Some(enc) => self.scoped(|| self.submit(enc.finish())),
            None => Ok(()),
        };
        release_retired();
        submitted?;
        self.read_timers()
    }

    /// Whether commands are being batched on this thread now. Never on wgpu's GL backend: a
    /// GL submission runs while holding the adapter's one context lock, and another thread
    /// waiting for that lock gives up after one second (wgpu-hal panics "Could not lock adapter
    /// context"), so a whole node's passes in one submission — seconds on llvmpipe — would fail
    /// any thread evaluating beside it; there every pass is submitted alone, as before.
    fn batching(&self) -> bool {
        BATCH.with(|b| b.borrow().is_some()) && !tracing() && self.info.backend != wgpu::Backend::Gl
    }

    /// A pass's timer, resolved in the encoder that recorded it: read now when that encoder
    /// was submitted, else once the batch is.
    pub(crate) fn after_submit(&self, timer: super::PassTimer) -> Result<(), GpuError> {
        if self.batching() {
            TIMERS.with(|t| t.borrow_mut().push(timer));
            Ok(())
        } else {
            self.read_timer(timer)
        }
    }

    fn read_timers(&self) -> Result<(), GpuError> {
        let timers = TIMERS.with(|t| std::mem::take(&mut *t.borrow_mut()));
        timers.into_iter().try_for_each(|t| self.read_timer(t))
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
            .with(|b| b.borrow_mut().as_mut().and_then(Option::take))
            .unwrap_or_else(|| self.device.create_command_encoder(&Default::default()));
        let out = f(&mut enc);
        BATCH.with(|b| {
            if let Some(slot) = b.borrow_mut().as_mut() {
                *slot = Some(enc);
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
