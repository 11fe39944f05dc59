//! GPU time per pass from timestamp queries, where the adapter has them: each named pass gets
//! a begin and an end slot; after the frame the slots are resolved, read back and turned into
//! `gpu:NAME` timings.

use crate::gpu::{GpuContext, GpuError};
use std::time::Duration;

/// The timestamp queries of one frame.
pub struct Timestamps {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
    /// Names of the passes given slots, in slot order (pass k: slots 2k and 2k + 1).
    names: Vec<&'static str>,
    capacity: u32,
}

impl Timestamps {
    /// Room for `passes` passes; None when the adapter has no timestamp queries.
    pub fn new(ctx: &GpuContext, device: &wgpu::Device, passes: u32) -> Option<Timestamps> {
        if !ctx.has_timestamps() {
            return None;
        }
        let count = 2 * passes;
        let size = 8 * u64::from(count);
        Some(Timestamps {
            set: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps"),
                size,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            read: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps read"),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            names: Vec::new(),
            capacity: passes,
        })
    }

    /// Gives pass `name` its two slots; returns the pass's index for [`Self::writes`].
    pub fn pass(&mut self, name: &'static str) -> u32 {
        assert!(
            (self.names.len() as u32) < self.capacity,
            "more passes than slots"
        );
        self.names.push(name);
        self.names.len() as u32 - 1
    }

    /// The timestamp writes of a render pass that begins (`begin`) and/or ends (`end`) pass
    /// `k`: a pass drawn as several render passes (the shadow layers) writes its begin in the
    /// first and its end in the last.
    pub fn writes(&self, k: u32, begin: bool, end: bool) -> wgpu::RenderPassTimestampWrites<'_> {
        wgpu::RenderPassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: begin.then_some(2 * k),
            end_of_pass_write_index: end.then_some(2 * k + 1),
        }
    }

    /// [`Self::writes`] for a compute pass.
    pub fn compute_writes(
        &self,
        k: u32,
        begin: bool,
        end: bool,
    ) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: begin.then_some(2 * k),
            end_of_pass_write_index: end.then_some(2 * k + 1),
        }
    }

    /// Resolves the slots of the passes given (every one of them must have been written).
    pub fn resolve(&self, enc: &mut wgpu::CommandEncoder) {
        let n = 2 * self.names.len() as u32;
        if n == 0 {
            return;
        }
        enc.resolve_query_set(&self.set, 0..n, &self.resolve, 0);
        enc.copy_buffer_to_buffer(&self.resolve, 0, &self.read, 0, 8 * u64::from(n));
    }

    /// After the frame: `gpu:NAME` → GPU time of each pass.
    pub fn read(
        &self,
        ctx: &GpuContext,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Vec<(String, Duration)>, GpuError> {
        if self.names.is_empty() {
            return Ok(Vec::new());
        }
        let bytes = ctx.map_read(device, &self.read)?;
        let ts: &[u64] = bytemuck::cast_slice(&bytes);
        let period = queue.get_timestamp_period() as f64;
        Ok(self
            .names
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let (a, b) = (ts[2 * k], ts[2 * k + 1]);
                let d = Duration::from_nanos((b.saturating_sub(a) as f64 * period) as u64);
                (format!("gpu:{name}"), d)
            })
            .collect())
    }
}
