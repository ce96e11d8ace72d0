//! GPU timestamp queries around passes, summed per thread, for per-node GPU timings.

use std::cell::Cell;

use super::{Gpu, GpuError};

thread_local! {
    // Per thread, like wgpu's error scopes: evaluations on other threads neither switch this
    // thread's timing on or off nor add to its total.
    static TIMING: Cell<bool> = const { Cell::new(false) };
    static GPU_NS: Cell<u64> = const { Cell::new(0) };
}

/// The queries of one pass: two timestamps resolved into a buffer and copied for reading.
pub struct PassTimer {
    /// Two timestamps: beginning and end of the pass.
    pub query: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    /// What the pass is (`shader:entry`), for the trace.
    label: String,
}

impl Gpu {
    /// Start (or stop) timing passes on this thread (when the adapter has timestamp queries).
    pub fn set_timing(&self, on: bool) {
        TIMING.with(|t| t.set(on));
        GPU_NS.with(|c| c.set(0));
    }

    /// GPU time of this thread's passes since the last call, or `None` without timestamp
    /// queries (or with timing off).
    pub fn take_gpu_time(&self) -> Option<std::time::Duration> {
        let ns = GPU_NS.with(|c| c.replace(0));
        self.timing_active()
            .then(|| std::time::Duration::from_nanos(ns))
    }

    pub(crate) fn timing_active(&self) -> bool {
        TIMING.with(|t| t.get())
            && self
                .device
                .features()
                .contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// Queries for one pass, when timing.
    pub(crate) fn pass_timer(&self, label: &str) -> Option<PassTimer> {
        if !self.timing_active() {
            return None;
        }
        let buffer = |usage| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps"),
                size: 16,
                usage,
                mapped_at_creation: false,
            })
        };
        Some(PassTimer {
            query: self.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolve: buffer(wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC),
            read: buffer(wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ),
            label: label.to_string(),
        })
    }

    /// Record the resolve of a pass's timestamps (after the pass, before `submit`).
    pub(crate) fn resolve_timer(&self, t: &PassTimer, enc: &mut wgpu::CommandEncoder) {
        enc.resolve_query_set(&t.query, 0..2, &t.resolve, 0);
        enc.copy_buffer_to_buffer(&t.resolve, 0, &t.read, 0, 16);
    }

    /// After `submit`: wait for the pass and add its duration to this thread's total.
    pub(crate) fn read_timer(&self, t: PassTimer) -> Result<(), GpuError> {
        let (tx, rx) = std::sync::mpsc::channel();
        t.read.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        super::receive(&rx)?.map_err(|e| GpuError::Readback(e.to_string()))?;
        let view = t
            .read
            .get_mapped_range(..)
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let stamps: &[u64] = bytemuck::cast_slice(&view);
        let ticks = stamps[1].saturating_sub(stamps[0]);
        let period = self.queue.get_timestamp_period() as f64;
        let ns = (ticks as f64 * period) as u64;
        let end_ns = stamps[1] as f64 * period;
        drop(view);
        t.read.unmap();
        crate::trace::record_gpu(&t.label, end_ns, std::time::Duration::from_nanos(ns));
        GPU_NS.with(|c| c.set(c.get() + ns));
        Ok(())
    }
}
