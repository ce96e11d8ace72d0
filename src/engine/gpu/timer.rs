//! GPU timestamp queries around passes, for per-node GPU timings. Each pass's timer is tagged
//! with the node being run ([`super::Recorder::set_node`]) and kept by the recorder;
//! [`super::Recorder::resolve_timings`] reads them all once, after the evaluation's last
//! submission — nothing waits for the GPU between nodes to time them.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::{Gpu, GpuError};

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
    /// Queries for one pass of `node`, where the adapter has timestamp queries.
    pub(crate) fn pass_timer(&self, label: &str, node: String) -> Option<PassTimer> {
        if !self
            .device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
        {
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
            node,
        })
    }

    /// Record the resolve of a pass's timestamps (after the pass, before `submit`).
    pub(crate) fn resolve_timer(&self, t: &PassTimer, enc: &mut wgpu::CommandEncoder) {
        enc.resolve_query_set(&t.query, 0..2, &t.resolve, 0);
        enc.copy_buffer_to_buffer(&t.resolve, 0, &t.read, 0, 16);
    }

    /// Read `timers` (their passes submitted) — one wait for the GPU — and sum their
    /// durations per node; each pass also goes to the trace's GPU track.
    pub(crate) fn read_timers(
        &self,
        timers: Vec<PassTimer>,
    ) -> Result<BTreeMap<String, Duration>, GpuError> {
        let mut per_node = BTreeMap::new();
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
}
