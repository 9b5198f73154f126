//! Presenting frames to a window: surface, swapchain, and per frame one
//! compute pass and one copy on the GPU.
//!
//! What a window shows is an image on the GPU: the frame look.comp made
//! ([`Presenter::present_image`], nothing read back), or pixels the host
//! made (a frame marched ray by ray, the steps heatmap), uploaded first
//! ([`Presenter::present`]). present.comp scales the image to the
//! swapchain's size (nearest neighbour, as the viewer's canvas scales) and
//! writes it in the swapchain's byte order into a device buffer, which a
//! transfer copies into the acquired image: no graphics pipeline, no format
//! conversion (the bytes are sRGB-encoded either way), and only
//! `TRANSFER_DST` asked of the swapchain. One frame is in flight at a time:
//! each present waits for the previous one with a deadline, like every
//! other wait in isomarch.

use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, anyhow, bail};
use ash::vk;
use raw_window_handle::{RawDisplayHandle, RawWindowHandle};

use super::scale::WindowScale;
use super::{Buffer, Context, GpuError, Role};

/// What a present achieved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Presented {
    Yes,
    /// The swapchain no longer matches the window (resized): call
    /// [`Presenter::resize`] and render again.
    OutOfDate,
    /// Shown, but the swapchain no longer matches the window exactly:
    /// rebuild it before the next frame.
    Suboptimal,
}

/// A window's surface and swapchain, and what copying into it needs.
pub struct Presenter {
    ctx: Arc<Context>,
    surface_loader: ash::khr::surface::Instance,
    swapchain_loader: ash::khr::swapchain::Device,
    surface: vk::SurfaceKHR,
    swapchain: vk::SwapchainKHR,
    images: Vec<vk::Image>,
    format: vk::Format,
    extent: vk::Extent2D,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    /// Waited by the copy: the image is ours.
    acquired: vk::Semaphore,
    /// One per image, waited by the present: the copy is done.
    copied: Vec<vk::Semaphore>,
    /// present.comp.
    scale: WindowScale,
    /// The window's pixels in the swapchain's byte order (device-local).
    window: Option<Buffer>,
    /// Host pixels uploaded for [`Presenter::present`].
    upload: Option<Buffer>,
    timeout: Duration,
}

impl Presenter {
    /// Creates the surface of `window` and a swapchain of `size` pixels.
    /// `ctx` must have been opened with `ContextOptions::present`.
    pub fn new(ctx: &Arc<Context>, display: RawDisplayHandle, window: RawWindowHandle, size: (u32, u32), timeout: Duration) -> Result<Presenter> {
        // SAFETY: the handles come from a live window that outlives the
        // presenter (the viewer drops the presenter before the window).
        let surface = unsafe { ash_window::create_surface(ctx.entry(), &ctx.instance, display, window, None) }
            .context("creating the window's Vulkan surface")?;
        let surface_loader = ash::khr::surface::Instance::new(ctx.entry(), &ctx.instance);
        let swapchain_loader = ash::khr::swapchain::Device::new(&ctx.instance, &ctx.device);
        let d = &ctx.device;
        // SAFETY: plain object creation and queries on live objects; on an
        // early error the few objects made so far are leaked, once.
        let (pool, cmd, fence, acquired) = unsafe {
            let supported = surface_loader
                .get_physical_device_surface_support(ctx.physical_device, ctx.queue_family, surface)
                .context("asking whether the queue can present")?;
            if !supported {
                surface_loader.destroy_surface(surface, None);
                bail!("{}'s compute queue cannot present to this window", ctx.info.name);
            }
            let pool = d.create_command_pool(
                &vk::CommandPoolCreateInfo::default().queue_family_index(ctx.queue_family).flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
                None,
            )?;
            let cmd = d.allocate_command_buffers(
                &vk::CommandBufferAllocateInfo::default().command_pool(pool).level(vk::CommandBufferLevel::PRIMARY).command_buffer_count(1),
            )?[0];
            // Signalled: the first frame has nothing to wait for.
            let fence = d.create_fence(&vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED), None)?;
            let acquired = d.create_semaphore(&vk::SemaphoreCreateInfo::default(), None)?;
            (pool, cmd, fence, acquired)
        };
        let scale = WindowScale::new(ctx)?;
        let mut p = Presenter {
            ctx: Arc::clone(ctx),
            surface_loader,
            swapchain_loader,
            surface,
            swapchain: vk::SwapchainKHR::null(),
            images: Vec::new(),
            format: vk::Format::UNDEFINED,
            extent: vk::Extent2D::default(),
            pool,
            cmd,
            fence,
            acquired,
            copied: Vec::new(),
            scale,
            window: None,
            upload: None,
            timeout,
        };
        if !p.resize(size)? {
            bail!("the window has no area to present to");
        }
        Ok(p)
    }

    /// The swapchain's size in pixels (what [`Presenter::present`] takes).
    pub fn extent(&self) -> (u32, u32) {
        (self.extent.width, self.extent.height)
    }

    /// Waits until the previous frame's present is done, within the
    /// deadline: before the image it took may be written or freed (a
    /// renderer making its next frame).
    pub fn wait_idle_frame(&self) -> Result<()> {
        // SAFETY: the fence belongs to this device.
        match unsafe { self.ctx.device.wait_for_fences(&[self.fence], true, self.timeout.as_nanos() as u64) } {
            Ok(()) => Ok(()),
            Err(vk::Result::TIMEOUT) => {
                self.ctx.mark_hung();
                Err(GpuError::DeadlineExceeded(self.timeout.as_secs_f64()).into())
            }
            Err(e) => Err(anyhow!("waiting for the previous frame: {e}")),
        }
    }

    /// (Re)creates the swapchain for a window of `size` pixels. The
    /// surface's current extent wins where the platform fixes it. `false`:
    /// the window has no area now (minimised); nothing changed.
    pub fn resize(&mut self, size: (u32, u32)) -> Result<bool> {
        self.wait_idle_frame()?;
        let pd = self.ctx.physical_device;
        // SAFETY: queries on live objects.
        let (caps, formats) = unsafe {
            (
                self.surface_loader.get_physical_device_surface_capabilities(pd, self.surface)?,
                self.surface_loader.get_physical_device_surface_formats(pd, self.surface)?,
            )
        };
        if !caps.supported_usage_flags.contains(vk::ImageUsageFlags::TRANSFER_DST) {
            bail!("this window's swapchain images cannot be copied into (no TRANSFER_DST usage)");
        }
        // 8-bit BGRA or RGBA; the bytes copied in are already sRGB-encoded,
        // which is how the presentation engine reads either flavour.
        let wanted = [vk::Format::B8G8R8A8_UNORM, vk::Format::R8G8B8A8_UNORM, vk::Format::B8G8R8A8_SRGB, vk::Format::R8G8B8A8_SRGB];
        let format = wanted
            .iter()
            .find_map(|w| formats.iter().find(|f| f.format == *w))
            .copied()
            .ok_or_else(|| anyhow!("no 8-bit RGBA or BGRA swapchain format among {formats:?}"))?;
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: size.0.clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: size.1.clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        if extent.width == 0 || extent.height == 0 {
            return Ok(false);
        }
        let alpha = [
            vk::CompositeAlphaFlagsKHR::OPAQUE,
            vk::CompositeAlphaFlagsKHR::INHERIT,
            vk::CompositeAlphaFlagsKHR::PRE_MULTIPLIED,
            vk::CompositeAlphaFlagsKHR::POST_MULTIPLIED,
        ]
        .into_iter()
        .find(|a| caps.supported_composite_alpha.contains(*a))
        .ok_or_else(|| anyhow!("the surface supports no composite alpha mode"))?;
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let old = self.swapchain;
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface)
            .min_image_count(count)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::TRANSFER_DST)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(alpha)
            .present_mode(vk::PresentModeKHR::FIFO)
            .clipped(true)
            .old_swapchain(old);
        // SAFETY: the previous frame is done (waited above); the old
        // swapchain is retired by the new one and destroyed after it.
        unsafe {
            let swapchain = self.swapchain_loader.create_swapchain(&info, None).context("creating the swapchain")?;
            if old != vk::SwapchainKHR::null() {
                // Presents queued on the old swapchain may still use its
                // semaphores: wait for the queue before reusing them.
                let queue = self.ctx.lock_queue();
                self.ctx.device.queue_wait_idle(self.ctx.queue)?;
                drop(queue);
                self.swapchain_loader.destroy_swapchain(old, None);
            }
            self.swapchain = swapchain;
            self.images = self.swapchain_loader.get_swapchain_images(swapchain)?;
            for s in self.copied.drain(..) {
                self.ctx.device.destroy_semaphore(s, None);
            }
            for _ in 0..self.images.len() {
                self.copied.push(self.ctx.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None)?);
            }
        }
        self.format = format.format;
        self.extent = extent;
        let bytes = u64::from(extent.width) * u64::from(extent.height) * 4;
        if self.window.as_ref().is_none_or(|b| b.size < bytes) {
            self.window = None;
            self.window = Some(Buffer::device(&self.ctx, "window pixels", bytes)?);
        }
        Ok(true)
    }

    /// Shows `rgb` (row-major, top row first, `extent()` pixels, 3 bytes
    /// each, sRGB-encoded), made on the host, in the window: uploaded, then
    /// presented as [`Presenter::present_image`] presents.
    pub fn present(&mut self, rgb: &[u8]) -> Result<Presented> {
        let (w, h) = self.extent();
        if rgb.len() != (w * h * 3) as usize {
            bail!("present: {} bytes for a {w}x{h} swapchain", rgb.len());
        }
        self.wait_idle_frame()?;
        let pixels: Vec<[u8; 4]> = rgb.chunks_exact(3).map(|c| [c[0], c[1], c[2], 255]).collect();
        let bytes = 4 * pixels.len() as u64;
        if self.upload.as_ref().is_none_or(|b| b.size < bytes) {
            self.upload = None;
            self.upload =
                Some(Buffer::with_usage(&self.ctx, "window pixels made on the host", bytes, vk::BufferUsageFlags::STORAGE_BUFFER, Role::Upload)?);
        }
        let upload = self.upload.as_mut().expect("made above");
        upload.write(0, &pixels)?;
        let upload = self.upload.as_ref().expect("made above");
        self.submit(upload, (w, h))
    }

    /// Shows `image`, an image on the GPU of `size` pixels (4 bytes each,
    /// RGBA8, sRGB-encoded, row-major, top row first: look.comp's, see
    /// [`crate::render::Renderer::frame_image`]), in the window, scaled to
    /// it by nearest neighbour. Nothing is read back or uploaded.
    pub fn present_image(&mut self, image: &Buffer, size: (u32, u32)) -> Result<Presented> {
        self.wait_idle_frame()?;
        self.submit(image, size)
    }

    /// Records and submits present.comp from `frame` (`size` pixels) into
    /// the window's buffer, its copy into the acquired image, and the
    /// present. The previous frame is done (the caller waited).
    fn submit(&self, frame: &Buffer, size: (u32, u32)) -> Result<Presented> {
        let (w, h) = self.extent();
        let window = self.window.as_ref().ok_or_else(|| anyhow!("no swapchain"))?;
        self.scale.bind(frame, size, window, (w, h)).context("present")?;
        let bgra = matches!(self.format, vk::Format::B8G8R8A8_UNORM | vk::Format::B8G8R8A8_SRGB);
        let d = &self.ctx.device;
        // SAFETY: the previous frame's commands are complete (fence waited),
        // so the command buffer, fence, semaphores and descriptor set are
        // free; the image index comes from the swapchain; the window buffer
        // holds w*h pixels and `frame` size.0*size.1 (checked by bind).
        unsafe {
            let timeout = self.timeout.as_nanos() as u64;
            let index = match self.swapchain_loader.acquire_next_image(self.swapchain, timeout, self.acquired, vk::Fence::null()) {
                Ok((index, _suboptimal)) => index,
                Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => return Ok(Presented::OutOfDate),
                Err(vk::Result::TIMEOUT | vk::Result::NOT_READY) => bail!("no swapchain image became available within the deadline"),
                Err(e) => return Err(anyhow!("acquiring a swapchain image: {e}")),
            };
            let image = self.images[index as usize];
            let range = vk::ImageSubresourceRange::default().aspect_mask(vk::ImageAspectFlags::COLOR).level_count(1).layer_count(1);
            d.reset_command_buffer(self.cmd, vk::CommandBufferResetFlags::empty())?;
            d.begin_command_buffer(self.cmd, &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT))?;
            self.scale.record(d, self.cmd, size, (w, h), bgra);
            let transition = |old, new, src_access, dst_access, dst_stage| {
                let barrier = vk::ImageMemoryBarrier::default()
                    .src_access_mask(src_access)
                    .dst_access_mask(dst_access)
                    .old_layout(old)
                    .new_layout(new)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .image(image)
                    .subresource_range(range);
                d.cmd_pipeline_barrier(self.cmd, vk::PipelineStageFlags::TRANSFER, dst_stage, vk::DependencyFlags::empty(), &[], &[], &[barrier]);
            };
            // Whatever the image held is discarded; the copy writes it all.
            transition(
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::AccessFlags::empty(),
                vk::AccessFlags::TRANSFER_WRITE,
                vk::PipelineStageFlags::TRANSFER,
            );
            let region = vk::BufferImageCopy::default()
                .image_subresource(vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::COLOR).layer_count(1))
                .image_extent(vk::Extent3D { width: w, height: h, depth: 1 });
            d.cmd_copy_buffer_to_image(self.cmd, window.handle, image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &[region]);
            transition(
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::ImageLayout::PRESENT_SRC_KHR,
                vk::AccessFlags::TRANSFER_WRITE,
                vk::AccessFlags::empty(),
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
            );
            d.end_command_buffer(self.cmd)?;
            d.reset_fences(&[self.fence])?;
            let waits = [self.acquired];
            let stages = [vk::PipelineStageFlags::TRANSFER];
            let signals = [self.copied[index as usize]];
            let cmds = [self.cmd];
            let submit =
                vk::SubmitInfo::default().wait_semaphores(&waits).wait_dst_stage_mask(&stages).command_buffers(&cmds).signal_semaphores(&signals);
            // The copy and the present go to the queue together.
            let _queue = self.ctx.lock_queue();
            d.queue_submit(self.ctx.queue, &[submit], self.fence).context("submitting the copy to the window")?;
            let swapchains = [self.swapchain];
            let indices = [index];
            let present = vk::PresentInfoKHR::default().wait_semaphores(&signals).swapchains(&swapchains).image_indices(&indices);
            match self.swapchain_loader.queue_present(self.ctx.queue, &present) {
                Ok(false) => Ok(Presented::Yes),
                Ok(true) | Err(vk::Result::SUBOPTIMAL_KHR) => Ok(Presented::Suboptimal),
                Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(Presented::OutOfDate),
                Err(e) => Err(anyhow!("presenting: {e}")),
            }
        }
    }
}

impl Drop for Presenter {
    fn drop(&mut self) {
        if self.ctx.is_hung() {
            return;
        }
        let d = &self.ctx.device;
        // SAFETY: waiting for the queue makes every copy and present done.
        unsafe {
            let deadline = Instant::now() + self.timeout;
            let _ = d.wait_for_fences(&[self.fence], true, deadline.saturating_duration_since(Instant::now()).as_nanos() as u64);
            {
                let _queue = self.ctx.lock_queue();
                let _ = d.queue_wait_idle(self.ctx.queue);
            }
            self.window = None;
            self.upload = None;
            for s in self.copied.drain(..) {
                d.destroy_semaphore(s, None);
            }
            d.destroy_semaphore(self.acquired, None);
            d.destroy_fence(self.fence, None);
            d.destroy_command_pool(self.pool, None);
            self.swapchain_loader.destroy_swapchain(self.swapchain, None);
            self.surface_loader.destroy_surface(self.surface, None);
        }
    }
}
