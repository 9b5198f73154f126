//! Host-visible storage buffers.

use std::sync::Arc;

use anyhow::{Context as _, Result, anyhow, bail};
use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};

use super::Context;

/// A storage buffer in host-visible memory: the host writes inputs and reads
/// results directly. Lavapipe has a single memory type, and on discrete GPUs
/// the march is compute-bound, so staging copies would buy nothing here.
pub struct Buffer {
    ctx: Arc<Context>,
    pub handle: vk::Buffer,
    allocation: Option<Allocation>,
    pub size: u64,
}

impl Buffer {
    /// A storage buffer of `size` bytes (at least 16), named for errors.
    pub fn new(ctx: &Arc<Context>, name: &str, size: u64) -> Result<Buffer> {
        Buffer::with_usage(ctx, name, size, vk::BufferUsageFlags::STORAGE_BUFFER)
    }

    /// A host-visible buffer of `size` bytes for `usage` (e.g. the source
    /// of a copy into a swapchain image).
    pub fn with_usage(ctx: &Arc<Context>, name: &str, size: u64, usage: vk::BufferUsageFlags) -> Result<Buffer> {
        let size = size.max(16);
        if size > ctx.info.max_storage_buffer_range {
            bail!(
                "{name}: {size} bytes exceed the device's largest storage buffer ({} bytes, maxStorageBufferRange)",
                ctx.info.max_storage_buffer_range
            );
        }
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        let handle = unsafe { ctx.device.create_buffer(&info, None) }.with_context(|| format!("creating buffer {name}"))?;
        // SAFETY: `handle` was just created on this device.
        let requirements = unsafe { ctx.device.get_buffer_memory_requirements(handle) };
        let allocation = ctx.with_allocator(|a| {
            a.allocate(&AllocationCreateDesc {
                name,
                requirements,
                location: MemoryLocation::CpuToGpu,
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
        Ok(Buffer { ctx: Arc::clone(ctx), handle, allocation: Some(allocation), size })
    }

    /// A buffer holding `data`.
    pub fn with_data<T: bytemuck::Pod>(ctx: &Arc<Context>, name: &str, data: &[T]) -> Result<Buffer> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let mut buffer = Buffer::new(ctx, name, bytes.len() as u64)?;
        buffer.write(0, data)?;
        Ok(buffer)
    }

    fn mapped(&mut self) -> Result<&mut [u8]> {
        self.allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .ok_or_else(|| anyhow!("buffer memory is not host-visible"))
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
        let start = first * size_of::<T>();
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
        // before results are read, and a hung context never gets here).
        unsafe { self.ctx.device.destroy_buffer(self.handle, None) };
    }
}
