//! Buffers that persist across frames: reallocated only when a frame needs
//! more than they hold, so a camera or TF change re-renders without
//! allocation.

use crate::gpu_types::PARAM_STRIDE;
use crate::{GpuContext, GpuError};
use std::num::NonZeroU64;

/// A buffer that grows (to the next power of two of what was asked, at
/// least 4 KiB) and never shrinks.
pub(crate) struct Grow {
    label: &'static str,
    usage: wgpu::BufferUsages,
    buf: Option<wgpu::Buffer>,
}

impl Grow {
    pub(crate) fn new(label: &'static str, usage: wgpu::BufferUsages) -> Grow {
        Grow { label, usage, buf: None }
    }

    /// Storage buffer that can be cleared and copied from.
    pub(crate) fn storage(label: &'static str) -> Grow {
        Grow::new(label, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC)
    }

    /// Makes the buffer hold at least `bytes`; returns whether it was
    /// (re)allocated. `limit` caps the rounded-up size (the binding limit).
    pub(crate) fn ensure(&mut self, ctx: &GpuContext, bytes: u64, limit: u64) -> Result<bool, GpuError> {
        let bytes = bytes.max(16);
        if self.buf.as_ref().is_some_and(|b| b.size() >= bytes) {
            return Ok(false);
        }
        if bytes > limit {
            return Err(GpuError::TooLarge { what: self.label, bytes, limit });
        }
        let size = bytes.next_power_of_two().max(4096).min(limit.max(bytes)).next_multiple_of(16);
        self.buf = None;
        let buf = ctx.checked(|| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(self.label),
                size,
                usage: self.usage,
                mapped_at_creation: false,
            })
        })?;
        self.buf = Some(buf);
        Ok(true)
    }

    pub(crate) fn get(&self) -> &wgpu::Buffer {
        self.buf.as_ref().expect("Grow::ensure before get")
    }
}

/// Uniform arena: one 256-byte slot per dispatch's parameters, bound with
/// dynamic offsets; filled while encoding, written before the submit.
pub(crate) struct Params {
    buf: wgpu::Buffer,
    data: Vec<u8>,
}

/// Slots in the arena (dispatches per submit).
const PARAM_SLOTS: u64 = 512;

impl Params {
    pub(crate) fn new(ctx: &GpuContext) -> Params {
        let buf = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("params"),
            size: PARAM_SLOTS * PARAM_STRIDE,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Params { buf, data: Vec::new() }
    }

    /// Appends `v`; returns its dynamic offset.
    pub(crate) fn push<T: bytemuck::Pod>(&mut self, v: &T) -> Result<u32, GpuError> {
        let off = self.data.len() as u64;
        if off + PARAM_STRIDE > PARAM_SLOTS * PARAM_STRIDE {
            return Err(GpuError::Input(format!("more than {PARAM_SLOTS} dispatches in one submit")));
        }
        self.data.extend_from_slice(bytemuck::bytes_of(v));
        self.data.resize((off + PARAM_STRIDE) as usize, 0);
        Ok(off as u32)
    }

    /// Writes what was pushed (executed before the next submit) and starts over.
    pub(crate) fn flush(&mut self, ctx: &GpuContext) {
        if !self.data.is_empty() {
            ctx.queue.write_buffer(&self.buf, 0, &self.data);
            self.data.clear();
        }
    }

    /// The binding of one slot (a struct of at most 256 bytes).
    pub(crate) fn binding(&self, size: u64) -> wgpu::BindingResource<'_> {
        wgpu::BindingResource::Buffer(wgpu::BufferBinding { buffer: &self.buf, offset: 0, size: NonZeroU64::new(size) })
    }
}

/// 2D dispatch of `groups` workgroups (x at most 65535).
pub(crate) fn split_groups(groups: u32) -> (u32, u32) {
    let gx = groups.clamp(1, 65535);
    (gx, groups.div_ceil(gx).max(1))
}
