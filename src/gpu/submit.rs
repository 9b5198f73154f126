//! One command buffer at a time, waited with a deadline and timed on the GPU.

use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result};
use ash::vk;

use super::Context;
use super::transfer::Transfers;

/// Errors a caller may want to tell apart from the rest.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "the GPU did not finish within the deadline ({0:.1} s); work in flight cannot be cancelled, so its memory is left to the OS (raise --timeout for heavy scenes)"
    )]
    DeadlineExceeded(f64),
    #[error("the Vulkan device was lost while {0}")]
    DeviceLost(&'static str),
}

/// Records, submits and waits for one command buffer at a time, with a pair
/// of timestamp queries around its work.
pub struct Submitter {
    ctx: Arc<Context>,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    queries: vk::QueryPool,
}

fn map_vk(e: vk::Result, doing: &'static str) -> anyhow::Error {
    match e {
        vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost(doing).into(),
        vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
            anyhow::anyhow!("out of memory while {doing} ({e})")
        }
        other => anyhow::anyhow!("Vulkan error while {doing}: {other}"),
    }
}

impl Submitter {
    pub fn new(ctx: &Arc<Context>) -> Result<Submitter> {
        let d = &ctx.device;
        // SAFETY: plain object creation on a valid device; partial failures
        // leak a pool or fence at most, before any work exists.
        unsafe {
            let pool = d
                .create_command_pool(
                    &vk::CommandPoolCreateInfo::default()
                        .queue_family_index(ctx.queue_family)
                        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
                    None,
                )
                .context("creating command pool")?;
            let cmd = d
                .allocate_command_buffers(
                    &vk::CommandBufferAllocateInfo::default().command_pool(pool).level(vk::CommandBufferLevel::PRIMARY).command_buffer_count(1),
                )
                .context("allocating command buffer")?[0];
            let fence = d.create_fence(&vk::FenceCreateInfo::default(), None).context("creating fence")?;
            let queries = if ctx.info.timestamps {
                d.create_query_pool(&vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(2), None)
                    .context("creating timestamp query pool")?
            } else {
                vk::QueryPool::null()
            };
            Ok(Submitter { ctx: Arc::clone(ctx), pool, cmd, fence, queries })
        }
    }

    /// Records `record` into a fresh command buffer, submits it and waits
    /// until `deadline`. Returns GPU nanoseconds between the timestamps
    /// (`None` without timestamp support).
    ///
    /// On a passed deadline the context is marked hung (nothing is freed
    /// afterwards) and [`GpuError::DeadlineExceeded`] is returned.
    pub fn run(&mut self, deadline: Instant, timeout_total: Duration, record: impl FnOnce(&ash::Device, vk::CommandBuffer)) -> Result<Option<f64>> {
        self.submit(deadline, timeout_total, |_, _| {}, record, |_, _| {})
    }

    /// [`Submitter::run`] with `transfers`' uploads recorded before
    /// `record` and its reads after, outside the timed span: the time is
    /// the work's alone. The reads may be taken once this returns `Ok`.
    pub fn run_with(
        &mut self,
        deadline: Instant,
        timeout_total: Duration,
        transfers: &mut Transfers,
        record: impl FnOnce(&ash::Device, vk::CommandBuffer),
    ) -> Result<Option<f64>> {
        transfers.prepare()?;
        let t = &*transfers;
        // SAFETY: prepare ran; the buffers staged for belong to the caller,
        // who keeps them alive across this call, which waits for the GPU.
        let result =
            self.submit(deadline, timeout_total, |d, cmd| unsafe { t.record_before(d, cmd) }, record, |d, cmd| unsafe { t.record_after(d, cmd) });
        match result {
            Ok(_) => transfers.completed(),
            Err(_) => transfers.abandon(),
        }
        result
    }

    fn submit(
        &mut self,
        deadline: Instant,
        timeout_total: Duration,
        before: impl FnOnce(&ash::Device, vk::CommandBuffer),
        record: impl FnOnce(&ash::Device, vk::CommandBuffer),
        after: impl FnOnce(&ash::Device, vk::CommandBuffer),
    ) -> Result<Option<f64>> {
        let d = &self.ctx.device;
        let cmd = self.cmd;
        // SAFETY: the previous submission (if any) was waited for, so the
        // command buffer and fence are free to reset.
        unsafe {
            d.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty()).map_err(|e| map_vk(e, "resetting a command buffer"))?;
            d.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT))
                .map_err(|e| map_vk(e, "beginning a command buffer"))?;
            let timed = self.queries != vk::QueryPool::null();
            if timed {
                d.cmd_reset_query_pool(cmd, self.queries, 0, 2);
            }
            before(d, cmd);
            if timed {
                // Written once the uploads before it completed: the span
                // is the work's.
                d.cmd_write_timestamp(cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, self.queries, 0);
            }
            record(d, cmd);
            if timed {
                d.cmd_write_timestamp(cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, self.queries, 1);
            }
            after(d, cmd);
            d.end_command_buffer(cmd).map_err(|e| map_vk(e, "ending a command buffer"))?;
            d.reset_fences(&[self.fence]).map_err(|e| map_vk(e, "resetting a fence"))?;
            let cmds = [cmd];
            let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
            {
                let _queue = self.ctx.lock_queue();
                d.queue_submit(self.ctx.queue, &submit, self.fence).map_err(|e| map_vk(e, "submitting work"))?;
            }

            let remaining = deadline.saturating_duration_since(Instant::now());
            match d.wait_for_fences(&[self.fence], true, remaining.as_nanos().min(u64::MAX as u128) as u64) {
                Ok(()) => {}
                Err(vk::Result::TIMEOUT) => {
                    self.ctx.mark_hung();
                    return Err(GpuError::DeadlineExceeded(timeout_total.as_secs_f64()).into());
                }
                Err(e) => return Err(map_vk(e, "waiting for the GPU")),
            }
            if !timed {
                return Ok(None);
            }
            let mut stamps = [0u64; 2];
            d.get_query_pool_results(self.queries, 0, &mut stamps, vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT)
                .map_err(|e| map_vk(e, "reading timestamps"))?;
            let ticks = stamps[1].wrapping_sub(stamps[0]);
            Ok(Some(ticks as f64 * f64::from(self.ctx.info.timestamp_period_ns)))
        }
    }
}

impl Drop for Submitter {
    fn drop(&mut self) {
        if self.ctx.is_hung() {
            return;
        }
        // SAFETY: every submission was waited for.
        unsafe {
            let d = &self.ctx.device;
            d.destroy_query_pool(self.queries, None);
            d.destroy_fence(self.fence, None);
            d.destroy_command_pool(self.pool, None);
        }
    }
}
