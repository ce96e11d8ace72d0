//! GPU timestamp queries around passes, for per-node GPU timings. Each pass's timer is tagged
//! with the node being run ([`Gpu::set_timed_node`]) and kept; [`Gpu::resolve_timings`] reads
//! them all once, after the evaluation's last submission — nothing waits for the GPU between
//! nodes to time them.

use std::cell::{Cell, RefCell};
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::{Gpu, GpuError};

thread_local! {
    // Per thread, like wgpu's error scopes: evaluations on other threads neither switch this
    // thread's timing on or off nor add to its timers.
    static TIMING: Cell<bool> = const { Cell::new(false) };
    /// The node whose passes are being recorded.
    static TIMED_NODE: RefCell<String> = const { RefCell::new(String::new()) };
    /// Timers of passes recorded, resolved by `resolve_timings`.
    static TIMERS: RefCell<Vec<PassTimer>> = const { RefCell::new(Vec::new()) };
    /// Times resolved but not taken (an evaluation inside a node's run resolved its outer
    /// evaluation's timers too): added to the next `resolve_timings`.
    static UNCLAIMED: RefCell<BTreeMap<String, Duration>> = const { RefCell::new(BTreeMap::new()) };
}

/// The queries of one pass: two timestamps resolved into a buffer and copied for reading.
pub struct PassTimer {
    /// Two timestamps: beginning and end of the pass.
    pub query: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    /// What the pass is (`shader:entry`), for the trace.
    label: String,
    /// The node that recorded it.
    node: String,
}

impl Gpu {
    /// Start (or stop) timing passes on this thread (when the adapter has timestamp queries).
    pub fn set_timing(&self, on: bool) {
        TIMING.with(|t| t.set(on));
    }

    /// The node whose passes this thread records next (their GPU time is that node's).
    pub fn set_timed_node(&self, id: &str) {
        TIMED_NODE.with(|n| {
            let mut n = n.borrow_mut();
            n.clear();
            n.push_str(id);
        });
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
            node: TIMED_NODE.with(|n| n.borrow().clone()),
        })
    }

    /// Record the resolve of a pass's timestamps (after the pass, before `submit`).
    pub(crate) fn resolve_timer(&self, t: &PassTimer, enc: &mut wgpu::CommandEncoder) {
        enc.resolve_query_set(&t.query, 0..2, &t.resolve, 0);
        enc.copy_buffer_to_buffer(&t.resolve, 0, &t.read, 0, 16);
    }

    /// Keep a pass's timer (its resolve recorded in the encoder that recorded the pass) for
    /// [`Gpu::resolve_timings`].
    pub(crate) fn after_submit(&self, timer: PassTimer) -> Result<(), GpuError> {
        TIMERS.with(|t| t.borrow_mut().push(timer));
        Ok(())
    }

    /// Submit what this thread recorded, then read every timer kept since the last call — one
    /// wait for the GPU — and sum their durations per node (each pass also goes to the trace's
    /// GPU track). Empty without timestamp queries or with timing off.
    pub fn resolve_timings(&self) -> Result<BTreeMap<String, Duration>, GpuError> {
        let timers = TIMERS.with(|t| std::mem::take(&mut *t.borrow_mut()));
        let mut per_node = UNCLAIMED.with(|u| std::mem::take(&mut *u.borrow_mut()));
        if timers.is_empty() {
            return Ok(per_node);
        }
        self.flush()?;
        let pending = Arc::new(Mutex::new(timers.len()));
        let failed = Arc::new(Mutex::new(None));
        for t in &timers {
            let (pending, failed) = (pending.clone(), failed.clone());
            t.read.map_async(wgpu::MapMode::Read, .., move |r| {
                if let Err(e) = r {
                    if let Ok(mut f) = failed.lock() {
                        *f = Some(e.to_string());
                    }
                }
                if let Ok(mut p) = pending.lock() {
                    *p = p.saturating_sub(1);
                }
            });
        }
        self.wait()?;
        if let Some(e) = failed.lock().ok().and_then(|f| f.clone()) {
            return Err(GpuError::Readback(e));
        }
        let period = self.queue.get_timestamp_period() as f64;
        for t in timers {
            let (ticks, end) = {
                let view = t
                    .read
                    .get_mapped_range(..)
                    .map_err(|e| GpuError::Readback(e.to_string()))?;
                let stamps: &[u64] = bytemuck::cast_slice(&view);
                (stamps[1].saturating_sub(stamps[0]), stamps[1])
            };
            t.read.unmap();
            let d = Duration::from_nanos((ticks as f64 * period) as u64);
            crate::trace::record_gpu(&t.label, end as f64 * period, d);
            *per_node.entry(t.node).or_insert(Duration::ZERO) += d;
        }
        Ok(per_node)
    }

    /// Give back times [`Gpu::resolve_timings`] returned that the caller has no node for (an
    /// outer evaluation's): the next call returns them.
    pub fn unclaimed_timings(&self, times: BTreeMap<String, Duration>) {
        UNCLAIMED.with(|u| {
            let mut u = u.borrow_mut();
            for (node, d) in times {
                *u.entry(node).or_insert(Duration::ZERO) += d;
            }
        });
    }
}
