//! Copies between the host and device-local buffers, recorded into a
//! submission around its work (the rule of memory by role: `buffer.rs`).
//!
//! The host stages what it uploads and names what it will read; the
//! submission records the uploads (and fills) before its work and the
//! reads after it, into one host-writable and one host-cached staging
//! buffer, each grown to fit and reused; after the fence the host takes
//! what it asked for. Nothing else of a device buffer crosses to the host,
//! and [`TransferStats`] counts what did.

use std::sync::Arc;

use anyhow::{Result, bail};
use ash::vk;

use super::Context;
use super::buffer::{Buffer, Role};

/// Bytes that crossed between host and GPU, and the submissions waited for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct TransferStats {
    /// Bytes copied from device buffers into the host's staging.
    pub readback_bytes: u64,
    /// Bytes staged by the host and copied into device buffers.
    pub upload_bytes: u64,
    /// Submissions waited on with a fence.
    pub submits: u64,
}

/// What crossed between two readings of the counts (a frame's share).
impl std::ops::Sub for TransferStats {
    type Output = TransferStats;

    fn sub(self, o: TransferStats) -> TransferStats {
        TransferStats {
            readback_bytes: self.readback_bytes - o.readback_bytes,
            upload_bytes: self.upload_bytes - o.upload_bytes,
            submits: self.submits - o.submits,
        }
    }
}

/// A read asked for before a submission: its bytes once the fence passed
/// ([`Transfers::take`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[must_use = "a fetch is read with Transfers::take"]
pub struct Fetch {
    offset: u64,
    size: u64,
}

#[derive(Clone, Copy, Debug)]
struct Region {
    buffer: vk::Buffer,
    src: u64,
    dst: u64,
    size: u64,
}

/// Uploads and reads waiting for the next submission, and their staging.
pub struct Transfers {
    ctx: Arc<Context>,
    /// Bytes to upload, in order; `uploads` copy them out of `upload`.
    staged: Vec<u8>,
    uploads: Vec<Region>,
    fills: Vec<(vk::Buffer, u64, u64, u32)>,
    upload: Option<Buffer>,
    reads: Vec<Region>,
    read_bytes: u64,
    readback: Option<Buffer>,
    /// The reads of the last submission may be taken.
    ready: bool,
    pub stats: TransferStats,
}

/// Copies keep 16-byte offsets in the staging buffers (any element type).
const ALIGN: u64 = 16;

impl Transfers {
    pub fn new(ctx: &Arc<Context>) -> Transfers {
        Transfers {
            ctx: Arc::clone(ctx),
            staged: Vec::new(),
            uploads: Vec::new(),
            fills: Vec::new(),
            upload: None,
            reads: Vec::new(),
            read_bytes: 0,
            readback: None,
            ready: false,
            stats: TransferStats::default(),
        }
    }

    /// Uploads `data` into `dst` from byte `offset` at the start of the
    /// next submission.
    pub fn upload<T: bytemuck::Pod>(&mut self, dst: &Buffer, offset: u64, data: &[T]) -> Result<()> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        if bytes.is_empty() {
            return Ok(());
        }
        if offset + bytes.len() as u64 > dst.size {
            bail!("an upload of {} bytes at {offset} overflows a {}-byte buffer", bytes.len(), dst.size);
        }
        let src = (self.staged.len() as u64).next_multiple_of(ALIGN);
        self.staged.resize(src as usize, 0);
        self.staged.extend_from_slice(bytes);
        self.uploads.push(Region { buffer: dst.handle, src, dst: offset, size: bytes.len() as u64 });
        Ok(())
    }

    /// Fills `size` bytes of `dst` from `offset` (both multiples of 4) with
    /// the word `value` at the start of the next submission.
    pub fn fill(&mut self, dst: &Buffer, offset: u64, size: u64, value: u32) -> Result<()> {
        if !offset.is_multiple_of(4) || !size.is_multiple_of(4) || offset + size > dst.size {
            bail!("a fill of {size} bytes at {offset} of a {}-byte buffer (whole words within it)", dst.size);
        }
        self.fills.push((dst.handle, offset, size, value));
        Ok(())
    }

    /// Reads `count` elements of `T` of `src` from element `first` at the
    /// end of the next submission.
    pub fn fetch<T: bytemuck::Pod>(&mut self, src: &Buffer, first: usize, count: usize) -> Result<Fetch> {
        let (offset, size) = ((first * size_of::<T>()) as u64, (count * size_of::<T>()) as u64);
        if offset + size > src.size {
            bail!("a read of bytes {offset}..{} overflows a {}-byte buffer", offset + size, src.size);
        }
        if self.ready {
            // The previous submission's reads were not all taken: forget them.
            self.reads.clear();
            self.read_bytes = 0;
            self.ready = false;
        }
        let dst = self.read_bytes.next_multiple_of(ALIGN);
        self.read_bytes = dst + size;
        if size > 0 {
            self.reads.push(Region { buffer: src.handle, src: offset, dst, size });
        }
        Ok(Fetch { offset: dst, size })
    }

    /// Writes the staged uploads and sizes the read staging: call before
    /// recording a submission.
    pub fn prepare(&mut self) -> Result<()> {
        if self.ready {
            self.reads.clear();
            self.read_bytes = 0;
            self.ready = false;
        }
        let grow = |have: &Option<Buffer>, need: u64| have.as_ref().is_none_or(|b| b.size < need);
        if !self.staged.is_empty() {
            if grow(&self.upload, self.staged.len() as u64) {
                let size = (self.staged.len() as u64).next_power_of_two();
                self.upload = Some(Buffer::with_usage(&self.ctx, "upload staging", size, vk::BufferUsageFlags::empty(), Role::Upload)?);
            }
            self.upload.as_mut().expect("made above").write(0, &self.staged)?;
        }
        if self.read_bytes > 0 && grow(&self.readback, self.read_bytes) {
            let size = self.read_bytes.next_power_of_two();
            self.readback = Some(Buffer::with_usage(&self.ctx, "readback staging", size, vk::BufferUsageFlags::empty(), Role::Readback)?);
        }
        Ok(())
    }

    /// Records the fills and uploads, and a barrier that makes them visible
    /// to compute shaders and later copies.
    ///
    /// # Safety
    /// `cmd` is recording on `d`, [`Transfers::prepare`] ran since the last
    /// staging, and the destination buffers live until the submission ends.
    pub unsafe fn record_before(&self, d: &ash::Device, cmd: vk::CommandBuffer) {
        if self.fills.is_empty() && self.uploads.is_empty() {
            return;
        }
        // SAFETY: as the caller promises; regions were checked when staged.
        unsafe {
            for &(buffer, offset, size, value) in &self.fills {
                d.cmd_fill_buffer(cmd, buffer, offset, size, value);
            }
            if let Some(upload) = self.upload.as_ref().filter(|_| !self.uploads.is_empty()) {
                for r in &self.uploads {
                    let region = vk::BufferCopy { src_offset: r.src, dst_offset: r.dst, size: r.size };
                    d.cmd_copy_buffer(cmd, upload.handle, r.buffer, &[region]);
                }
            }
            memory_barrier(
                d,
                cmd,
                (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE),
                (
                    vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                    vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_READ,
                ),
            );
        }
    }

    /// Records the reads after the submission's work: a barrier from the
    /// compute shaders' writes, the copies, and a barrier to the host.
    ///
    /// # Safety
    /// As [`Transfers::record_before`].
    pub unsafe fn record_after(&self, d: &ash::Device, cmd: vk::CommandBuffer) {
        let Some(readback) = self.readback.as_ref().filter(|_| !self.reads.is_empty()) else {
            return;
        };
        // SAFETY: as the caller promises; the staging was sized in prepare.
        unsafe {
            memory_barrier(
                d,
                cmd,
                (
                    vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                    vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE,
                ),
                (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_READ),
            );
            for r in &self.reads {
                let region = vk::BufferCopy { src_offset: r.src, dst_offset: r.dst, size: r.size };
                d.cmd_copy_buffer(cmd, r.buffer, readback.handle, &[region]);
            }
            memory_barrier(
                d,
                cmd,
                (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE),
                (vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ),
            );
        }
    }

    /// The submission recorded with these transfers completed: the staged
    /// uploads are spent and the reads may be taken.
    pub fn completed(&mut self) {
        self.stats.upload_bytes += self.uploads.iter().map(|r| r.size).sum::<u64>();
        self.stats.readback_bytes += self.reads.iter().map(|r| r.size).sum::<u64>();
        self.staged.clear();
        self.uploads.clear();
        self.fills.clear();
        self.ready = true;
        self.stats.submits += 1;
    }

    /// The submission failed: nothing staged or asked is kept.
    pub fn abandon(&mut self) {
        self.staged.clear();
        self.uploads.clear();
        self.fills.clear();
        self.reads.clear();
        self.read_bytes = 0;
        self.ready = false;
    }

    /// What `fetch` asked for, once the submission completed.
    pub fn take<T: bytemuck::Pod>(&mut self, fetch: Fetch) -> Result<Vec<T>> {
        if !self.ready {
            bail!("a read taken before its submission completed");
        }
        if fetch.size == 0 {
            return Ok(Vec::new());
        }
        let readback = self.readback.as_mut().ok_or_else(|| anyhow::anyhow!("a read with no staging"))?;
        readback.read_at::<T>(fetch.offset, fetch.size as usize / size_of::<T>())
    }
}

/// Records a global memory barrier: `src` stages' `src_access` writes made
/// available and visible to `dst` stages' `dst_access`.
///
/// # Safety
/// `cmd` is recording on `d`.
pub unsafe fn memory_barrier(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    (src, src_access): (vk::PipelineStageFlags, vk::AccessFlags),
    (dst, dst_access): (vk::PipelineStageFlags, vk::AccessFlags),
) {
    let barrier = vk::MemoryBarrier::default().src_access_mask(src_access).dst_access_mask(dst_access);
    // SAFETY: as the caller promises.
    unsafe { d.cmd_pipeline_barrier(cmd, src, dst, vk::DependencyFlags::empty(), &[barrier], &[], &[]) };
}
