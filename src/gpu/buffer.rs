//! Buffers, each made for one role that decides where its memory lives.
//!
//! # The rule: memory by role
//!
//! A buffer says what it is for ([`Role`]) and the role alone picks its
//! memory ([`Role::location`]):
//!
//! - [`Role::Device`]: what the GPU reads and writes during a frame (rays,
//!   results, march states, primitives, the index and the tile lists) lives
//!   in device-local memory (gpu-allocator's `GpuOnly`). The host never maps
//!   it: it reaches it only through copies recorded on the GPU
//!   ([`super::Transfers`]).
//! - [`Role::HostWrite`]: small data the host rewrites between submissions
//!   (the globals, the lights) in memory made for that (`CpuToGpu`: on a GPU
//!   with a resizable BAR, video memory the host writes through a
//!   write-combined mapping; never read back).
//! - [`Role::Upload`]: staging for large uploads (`CpuToGpu`), written once
//!   in order by the host and copied into a `Device` buffer by the GPU.
//! - [`Role::Readback`]: what the host reads, filled by a copy on the GPU
//!   (`GpuToCpu`: host-cached, so the host reads it at memory speed; an
//!   uncached read of video memory runs some 40 times slower).
//!
//! On lavapipe every role lands in the one memory type it has (cached
//! system memory); on a discrete GPU they differ, and reading results out
//! of video memory was the frame's largest cost (issue 51).

use std::sync::Arc;

use anyhow::{Context as _, Result, anyhow, bail};
use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};

use super::Context;
use crate::layout::TexelFormat;

/// What a buffer is for; see the module's rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Role {
    /// Read and written by the GPU only: device-local, never mapped.
    Device,
    /// Small data the host writes between submissions and the GPU reads.
    HostWrite,
    /// Staging the host fills for a copy into a [`Role::Device`] buffer.
    Upload,
    /// Staging a copy on the GPU fills for the host to read.
    Readback,
}

impl Role {
    /// Where a buffer of this role is allocated: the rule of this module.
    pub const fn location(self) -> MemoryLocation {
        match self {
            Role::Device => MemoryLocation::GpuOnly,
            Role::HostWrite | Role::Upload => MemoryLocation::CpuToGpu,
            Role::Readback => MemoryLocation::GpuToCpu,
        }
    }

    /// Usage every buffer of this role has beyond what its maker asks:
    /// device buffers are the ends of copies and fills, staging their
    /// other end.
    const fn usage(self) -> vk::BufferUsageFlags {
        match self {
            Role::Device => vk::BufferUsageFlags::from_raw(vk::BufferUsageFlags::TRANSFER_DST.as_raw() | vk::BufferUsageFlags::TRANSFER_SRC.as_raw()),
            Role::HostWrite => vk::BufferUsageFlags::empty(),
            Role::Upload => vk::BufferUsageFlags::TRANSFER_SRC,
            Role::Readback => vk::BufferUsageFlags::TRANSFER_DST,
        }
    }

    /// Whether the host maps buffers of this role.
    pub const fn mapped(self) -> bool {
        !matches!(self, Role::Device)
    }
}

/// A buffer of one [`Role`], with its memory.
pub struct Buffer {
    ctx: Arc<Context>,
    pub handle: vk::Buffer,
    allocation: Option<Allocation>,
    pub size: u64,
    role: Role,
    /// The view of the whole buffer as texels ([`Buffer::texels`]), null
    /// for a plain storage buffer.
    pub view: vk::BufferView,
}

impl Buffer {
    /// A device-local storage buffer of `size` bytes (at least 16), named
    /// for errors.
    pub fn device(ctx: &Arc<Context>, name: &str, size: u64) -> Result<Buffer> {
        Buffer::with_usage(ctx, name, size, vk::BufferUsageFlags::STORAGE_BUFFER, Role::Device)
    }

    /// A device-local buffer of `size` bytes read and written as texels of
    /// `format` through its [`Buffer::view`] (a uniform or storage texel
    /// buffer), and as a storage buffer when `storage` (then within the
    /// storage range).
    pub fn texels(ctx: &Arc<Context>, name: &str, size: u64, format: TexelFormat, storage: bool) -> Result<Buffer> {
        let texels = size.max(16).div_ceil(format.bytes());
        if texels > ctx.info.max_texel_buffer_elements {
            bail!(
                "{name}: {texels} texels exceed the device's largest texel buffer ({} texels, maxTexelBufferElements)",
                ctx.info.max_texel_buffer_elements
            );
        }
        let mut usage = vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER | vk::BufferUsageFlags::STORAGE_TEXEL_BUFFER;
        if storage {
            usage |= vk::BufferUsageFlags::STORAGE_BUFFER;
        }
        let mut buffer = Buffer::with_usage(ctx, name, texels * format.bytes(), usage, Role::Device)?;
        let vk_format = match format {
            TexelFormat::R32Uint => vk::Format::R32_UINT,
            TexelFormat::Rg32Uint => vk::Format::R32G32_UINT,
            TexelFormat::Rgba32Uint => vk::Format::R32G32B32A32_UINT,
        };
        let info = vk::BufferViewCreateInfo::default().buffer(buffer.handle).format(vk_format).offset(0).range(vk::WHOLE_SIZE);
        // SAFETY: the buffer is alive, made with texel usage, and its size a
        // whole number of texels within the device's limit.
        buffer.view = unsafe { ctx.device.create_buffer_view(&info, None) }.with_context(|| format!("creating the texel view of {name}"))?;
        Ok(buffer)
    }

    /// A buffer of `size` bytes for `usage` in the memory of `role`.
    pub fn with_usage(ctx: &Arc<Context>, name: &str, size: u64, usage: vk::BufferUsageFlags, role: Role) -> Result<Buffer> {
        let size = size.max(16);
        let usage = usage | role.usage();
        if usage.contains(vk::BufferUsageFlags::STORAGE_BUFFER) && size > ctx.info.max_storage_buffer_range {
            bail!(
                "{name}: {size} bytes exceed the device's largest storage buffer ({} bytes, maxStorageBufferRange)",
                ctx.info.max_storage_buffer_range
            );
        }
        let info = vk::BufferCreateInfo::default().size(size).usage(usage).sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        let handle = unsafe { ctx.device.create_buffer(&info, None) }.with_context(|| format!("creating buffer {name}"))?;
        // SAFETY: `handle` was just created on this device.
        let requirements = unsafe { ctx.device.get_buffer_memory_requirements(handle) };
        let allocation = ctx.with_allocator(|a| {
            a.allocate(&AllocationCreateDesc {
                name,
                requirements,
                location: role.location(),
                linear: true,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            })
            .with_context(|| format!("allocating {size} bytes for {name} (out of GPU memory?)"))
        });
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: never bound, never used.
                unsafe { ctx.device.destroy_buffer(handle, None) };
                return Err(e);
            }
        };
        // SAFETY: memory and offset come from the allocator for these requirements.
        if let Err(e) = unsafe { ctx.device.bind_buffer_memory(handle, allocation.memory(), allocation.offset()) } {
            let _ = ctx.with_allocator(|a| Ok(a.free(allocation)?));
            // SAFETY: never used.
            unsafe { ctx.device.destroy_buffer(handle, None) };
            return Err(anyhow!("binding memory for {name}: {e}"));
        }
        Ok(Buffer { ctx: Arc::clone(ctx), handle, allocation: Some(allocation), size, role, view: vk::BufferView::null() })
    }

    /// A storage buffer the host writes ([`Role::HostWrite`]) holding
    /// `data`: small data, rewritten at most between submissions.
    pub fn with_data<T: bytemuck::Pod>(ctx: &Arc<Context>, name: &str, data: &[T]) -> Result<Buffer> {
        Buffer::holding(ctx, name, data, vk::BufferUsageFlags::STORAGE_BUFFER)
    }

    /// A uniform buffer the host writes ([`Role::HostWrite`]) holding
    /// `data`, at most 16 KiB (the least maxUniformBufferRange Vulkan
    /// allows).
    pub fn uniform<T: bytemuck::Pod>(ctx: &Arc<Context>, name: &str, data: &[T]) -> Result<Buffer> {
        let bytes = size_of_val(data);
        if bytes > 16384 {
            bail!("{name}: {bytes} bytes exceed the 16 KiB every device's uniform buffers hold");
        }
        Buffer::holding(ctx, name, data, vk::BufferUsageFlags::UNIFORM_BUFFER)
    }

    fn holding<T: bytemuck::Pod>(ctx: &Arc<Context>, name: &str, data: &[T], usage: vk::BufferUsageFlags) -> Result<Buffer> {
        let mut buffer = Buffer::with_usage(ctx, name, size_of_val(data) as u64, usage, Role::HostWrite)?;
        buffer.write(0, data)?;
        Ok(buffer)
    }

    /// The role the buffer was made for.
    pub fn role(&self) -> Role {
        self.role
    }

    /// The memory's property flags (device-local, host-visible, cached...).
    pub fn memory_properties(&self) -> vk::MemoryPropertyFlags {
        self.allocation.as_ref().map_or(vk::MemoryPropertyFlags::empty(), |a| a.memory_properties())
    }

    fn mapped(&mut self) -> Result<&mut [u8]> {
        if !self.role.mapped() {
            bail!("a device-local buffer is reached by copies on the GPU, not mapped (gpu::Transfers)");
        }
        self.allocation.as_mut().and_then(|a| a.mapped_slice_mut()).ok_or_else(|| anyhow!("buffer memory is not host-visible"))
    }

    /// Writes `data` starting at element `first` (in units of `T`).
    pub fn write<T: bytemuck::Pod>(&mut self, first: usize, data: &[T]) -> Result<()> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let start = first * size_of::<T>();
        let mapped = self.mapped()?;
        let end = start + bytes.len();
        if end > mapped.len() {
            bail!("write of {} bytes at {start} overflows a {}-byte buffer", bytes.len(), mapped.len());
        }
        mapped[start..end].copy_from_slice(bytes);
        Ok(())
    }

    /// Reads `count` elements of `T` starting at element `first`.
    pub fn read<T: bytemuck::Pod>(&mut self, first: usize, count: usize) -> Result<Vec<T>> {
        self.read_at(first as u64 * size_of::<T>() as u64, count)
    }

    /// Reads `count` elements of `T` starting at byte `offset`.
    pub fn read_at<T: bytemuck::Pod>(&mut self, offset: u64, count: usize) -> Result<Vec<T>> {
        let start = offset as usize;
        let end = start + count * size_of::<T>();
        let mapped = self.mapped()?;
        if end > mapped.len() {
            bail!("read of bytes {start}..{end} overflows a {}-byte buffer", mapped.len());
        }
        // The mapping need not be aligned for T: copy through pod_collect.
        Ok(bytemuck::pod_collect_to_vec(&mapped[start..end]))
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        if self.ctx.is_hung() {
            // The GPU may still read or write this memory: leak it.
            std::mem::forget(self.allocation.take());
            return;
        }
        if let Some(allocation) = self.allocation.take() {
            let _ = self.ctx.with_allocator(|a| Ok(a.free(allocation)?));
        }
        // SAFETY: work using this buffer has completed (fences are waited
        // before results are read, and a hung context never gets here);
        // destroying a null view is a no-op.
        unsafe {
            self.ctx.device.destroy_buffer_view(self.view, None);
            self.ctx.device.destroy_buffer(self.handle, None);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rule of this module, role by role: what the GPU works on is
    /// device-local, what the host writes is CpuToGpu, what it reads is
    /// host-cached GpuToCpu.
    #[test]
    fn each_role_asks_for_its_memory() {
        assert_eq!(Role::Device.location(), MemoryLocation::GpuOnly);
        assert_eq!(Role::HostWrite.location(), MemoryLocation::CpuToGpu);
        assert_eq!(Role::Upload.location(), MemoryLocation::CpuToGpu);
        assert_eq!(Role::Readback.location(), MemoryLocation::GpuToCpu);
        assert!(!Role::Device.mapped() && Role::HostWrite.mapped() && Role::Upload.mapped() && Role::Readback.mapped());
        assert!(Role::Device.usage().contains(vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::TRANSFER_SRC));
        assert!(Role::Upload.usage().contains(vk::BufferUsageFlags::TRANSFER_SRC));
        assert!(Role::Readback.usage().contains(vk::BufferUsageFlags::TRANSFER_DST));
    }
}
