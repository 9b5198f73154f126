//! An image on the GPU scaled to a window's size (present.comp): nearest
//! neighbour, swizzled to the window's byte order, made opaque, into a
//! buffer that a copy takes into the swapchain image
//! ([`super::Presenter`]). Apart from the window so that the tests check
//! it without one ([`scale_image`]).

use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use ash::vk;

use super::{Buffer, ComputePipeline, Context, Submitter, Transfers};
use crate::layout;

/// present.comp's workgroup: 8x8 window pixels.
const TILE: u32 = 8;

/// The pixel of a row or column of `from` pixels that pixel `x` of `to`
/// shows: the one under its left (top) edge, as present.comp takes it.
pub fn nearest(x: u32, from: u32, to: u32) -> u32 {
    (u64::from(x) * u64::from(from) / u64::from(to)).min(u64::from(from.max(1) - 1)) as u32
}

/// present.comp's pipeline.
pub struct WindowScale {
    pipeline: ComputePipeline,
}

impl WindowScale {
    pub fn new(ctx: &Arc<Context>) -> Result<WindowScale> {
        let spirv = isomarch_shaders::Kernel::Present.spirv().map_err(anyhow::Error::msg)?;
        Ok(WindowScale { pipeline: ComputePipeline::new(ctx, spirv, layout::PRESENT_BINDINGS, 20, &[])? })
    }

    /// Binds `frame` (`from` pixels, RGBA8 words row by row) and `window`
    /// (`to` pixels): call while no submission uses the pipeline's set.
    pub fn bind(&self, frame: &Buffer, from: (u32, u32), window: &Buffer, to: (u32, u32)) -> Result<()> {
        let pixels = |(w, h): (u32, u32)| 4 * u64::from(w) * u64::from(h);
        if from.0 == 0 || from.1 == 0 || frame.size < pixels(from) {
            bail!("an image of {} bytes is not {}x{} pixels", frame.size, from.0, from.1);
        }
        if window.size < pixels(to) {
            bail!("a window buffer of {} bytes holds fewer than {}x{} pixels", window.size, to.0, to.1);
        }
        self.pipeline.bind(&[frame, window])
    }

    /// Records the scaling from the bound frame into the bound window
    /// buffer, with the barriers before (the frame written by earlier
    /// shaders or the host) and after (read by a transfer).
    ///
    /// # Safety
    /// `cmd` is recording, and [`WindowScale::bind`] bound buffers of these
    /// sizes, alive until the commands complete.
    pub unsafe fn record(&self, d: &ash::Device, cmd: vk::CommandBuffer, from: (u32, u32), to: (u32, u32), bgra: bool) {
        let push = [from.0, from.1, to.0, to.1, u32::from(bgra)];
        let shader_write = (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_WRITE);
        // SAFETY: as the caller promises.
        unsafe {
            super::memory_barrier(d, cmd, shader_write, (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_READ));
            let p = &self.pipeline;
            super::bind_compute(d, cmd, (p.pipeline, p.layout, p.set), &push);
            d.cmd_dispatch(cmd, to.0.div_ceil(TILE), to.1.div_ceil(TILE), 1);
            super::memory_barrier(d, cmd, shader_write, (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_READ));
        }
    }
}

/// `image` (`from` pixels, RGBA8, row by row) scaled to `to` on the GPU as
/// a window shows it, read back: what the tests compare with the host's
/// nearest-neighbour scaling.
pub fn scale_image(ctx: &Arc<Context>, image: &[u32], from: (u32, u32), to: (u32, u32), bgra: bool) -> Result<Vec<u32>> {
    let timeout = Duration::from_secs(60);
    let scale = WindowScale::new(ctx)?;
    let frame = Buffer::with_data(ctx, "frame", image)?;
    let window = Buffer::device(ctx, "window pixels", 4 * u64::from(to.0) * u64::from(to.1))?;
    scale.bind(&frame, from, &window, to)?;
    let mut transfers = Transfers::new(ctx);
    let read = transfers.fetch::<u32>(&window, 0, (to.0 * to.1) as usize)?;
    let mut submitter = Submitter::new(ctx)?;
    // SAFETY: the buffers are bound and alive until the wait returns.
    submitter.run_with(Instant::now() + timeout, timeout, &mut transfers, |d, cmd| unsafe { scale.record(d, cmd, from, to, bgra) })?;
    transfers.take::<u32>(read)
}
