//! Vulkan, one concern per file. Every wrapper owns its objects and holds
//! the [`Context`], so the device outlives them all.

mod buffer;
mod context;
mod pipeline;
mod present;
pub mod scale;
mod submit;
mod transfer;

pub use buffer::{Buffer, Role};
pub use context::{Context, ContextOptions, DeviceInfo, list_devices};
pub use pipeline::{ComputePipeline, bind_compute, specialises_on_host};
pub use present::{Presented, Presenter};
pub use submit::{GpuError, Submitter};
pub use transfer::{Fetch, TransferStats, Transfers, memory_barrier};
