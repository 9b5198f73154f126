//! Compute pipelines over buffers (storage buffers and texel views of
//! them), specialised by constants.

use std::sync::Arc;

use anyhow::{Context as _, Result, bail};
use ash::vk;

use super::context::{PipelineRecipe, SharedPipeline};
use super::{Buffer, Context};
use crate::layout::{Binding, Resource};

/// The descriptor type of a binding.
fn descriptor_type(b: &Binding) -> vk::DescriptorType {
    match b.resource {
        Resource::Buffer(_) => vk::DescriptorType::STORAGE_BUFFER,
        Resource::Uniform(_) => vk::DescriptorType::UNIFORM_BUFFER,
        Resource::Texels { .. } => vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
        Resource::Image { .. } => vk::DescriptorType::STORAGE_TEXEL_BUFFER,
    }
}

/// A compute pipeline over the bindings `bindings` (storage buffers and
/// texel buffers), with a push-constant block of `push_constant_bytes`, and
/// one descriptor set. The pipeline and its layout belong to the context,
/// which shares them between every `ComputePipeline` of the same recipe;
/// the descriptor set is this one's own.
pub struct ComputePipeline {
    ctx: Arc<Context>,
    pub pipeline: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    pool: vk::DescriptorPool,
    pub set: vk::DescriptorSet,
    types: Vec<vk::DescriptorType>,
}

impl ComputePipeline {
    /// Builds the pipeline from SPIR-V, specialising `(constant_id, value)`
    /// pairs: the code paths they rule out are removed on the host before
    /// the driver sees the module ([`specialise_on_host`]). The
    /// pipeline and its layouts are the context's, made once per recipe
    /// ([`Context::shared_pipeline`]); the descriptor set is this one's.
    pub fn new(
        ctx: &Arc<Context>,
        spirv: &[u32],
        bindings: &[Binding],
        push_constant_bytes: u32,
        specialization: &[(u32, u32)],
    ) -> Result<ComputePipeline> {
        let device = &ctx.device;
        let types: Vec<vk::DescriptorType> = bindings.iter().map(descriptor_type).collect();
        let numbered: Vec<(u32, vk::DescriptorType)> = bindings.iter().map(|b| b.index).zip(types.iter().copied()).collect();
        let recipe = PipelineRecipe::new(spirv, &numbered, push_constant_bytes, specialization);
        let shared =
            ctx.shared_pipeline(recipe, || make_pipeline(device, ctx.pipeline_cache, spirv, &numbered, push_constant_bytes, specialization))?;
        let mut this = ComputePipeline {
            ctx: Arc::clone(ctx),
            pipeline: shared.pipeline,
            layout: shared.layout,
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            types: types.clone(),
        };
        let mut sizes: Vec<vk::DescriptorPoolSize> = Vec::new();
        for &ty in &types {
            match sizes.iter_mut().find(|s| s.ty == ty) {
                Some(s) => s.descriptor_count += 1,
                None => sizes.push(vk::DescriptorPoolSize { ty, descriptor_count: 1 }),
            }
        }
        // SAFETY: create infos reference live locals only; on an error
        // `this` owns what was made and Drop destroys it.
        unsafe {
            this.pool = device
                .create_descriptor_pool(&vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes), None)
                .context("creating descriptor pool")?;
            let set_layouts = [shared.set_layout];
            this.set = device
                .allocate_descriptor_sets(&vk::DescriptorSetAllocateInfo::default().descriptor_pool(this.pool).set_layouts(&set_layouts))
                .context("allocating descriptor set")?[0];
        }
        Ok(this)
    }

    /// Points every binding at its buffer (binding i gets `buffers[i]`, or
    /// its texel view for a texel binding).
    pub fn bind(&self, buffers: &[&Buffer]) -> Result<()> {
        if buffers.len() != self.types.len() {
            bail!("pipeline has {} bindings, {} buffers given", self.types.len(), buffers.len());
        }
        let infos: Vec<[vk::DescriptorBufferInfo; 1]> =
            buffers.iter().map(|b| [vk::DescriptorBufferInfo { buffer: b.handle, offset: 0, range: vk::WHOLE_SIZE }]).collect();
        let views: Vec<[vk::BufferView; 1]> = buffers.iter().map(|b| [b.view]).collect();
        let mut writes = Vec::with_capacity(buffers.len());
        for (i, &ty) in self.types.iter().enumerate() {
            let write = vk::WriteDescriptorSet::default().dst_set(self.set).dst_binding(i as u32).descriptor_type(ty);
            writes.push(if ty == vk::DescriptorType::STORAGE_BUFFER || ty == vk::DescriptorType::UNIFORM_BUFFER {
                write.buffer_info(&infos[i])
            } else {
                if views[i][0] == vk::BufferView::null() {
                    bail!("binding {i} is a texel buffer, and its buffer has no texel view");
                }
                write.descriptor_count(1).texel_buffer_view(&views[i])
            });
        }
        // SAFETY: the set is not in use by pending work when rebinding (the
        // renderer waits for each submission before changing buffers).
        unsafe { self.ctx.device.update_descriptor_sets(&writes, &[]) };
        Ok(())
    }
}

/// Whether a pipeline's specialisation constants are applied on the host
/// (`isomarch_shaders::specialise`: the default, `ISOMARCH_SPECIALISE=host`)
/// or handed to the driver (`ISOMARCH_SPECIALISE=driver`). Both make the
/// same frames (tests/specialise.rs); on the host the driver and the
/// validation layer read a module of only what the pipeline runs
/// (docs/performance.md, "Specialised on the host").
fn specialise_on_host() -> Result<bool> {
    match std::env::var("ISOMARCH_SPECIALISE").as_deref() {
        Err(_) | Ok("" | "host") => Ok(true),
        Ok("driver") => Ok(false),
        Ok(other) => bail!("ISOMARCH_SPECIALISE={other:?}: expected host or driver"),
    }
}

/// Whether this process's pipelines have their constants applied on the
/// host: this build can (its shaderc's SPIRV-Tools is linked) and
/// `ISOMARCH_SPECIALISE` does not say `driver`.
pub fn specialises_on_host() -> Result<bool> {
    Ok(isomarch_shaders::can_specialise() && specialise_on_host()?)
}

/// Makes a compute pipeline and its layouts from SPIR-V: one descriptor
/// set of `bindings`, `push_constant_bytes` of push constants, and the
/// `(constant_id, value)` specialisation.
fn make_pipeline(
    device: &ash::Device,
    cache: vk::PipelineCache,
    spirv: &[u32],
    bindings: &[(u32, vk::DescriptorType)],
    push_constant_bytes: u32,
    specialization: &[(u32, u32)],
) -> Result<SharedPipeline> {
    let specialised = if specialization.is_empty() || !specialise_on_host()? {
        None
    } else {
        isomarch_shaders::specialise(spirv, specialization).map_err(|e| anyhow::anyhow!("specialising a kernel: {e}"))?
    };
    let (spirv, specialization) = match &specialised {
        Some(words) => (&words[..], &[][..]),
        None => (spirv, specialization),
    };
    let module_info = vk::ShaderModuleCreateInfo::default().code(spirv);
    // SAFETY: valid SPIR-V compiled by shaderc (isomarch-shaders).
    let module = unsafe { device.create_shader_module(&module_info, None) }.context("creating shader module")?;
    let layout_bindings: Vec<_> = bindings
        .iter()
        .map(|&(index, ty)| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(index)
                .descriptor_type(ty)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
        })
        .collect();
    let mut made = SharedPipeline { pipeline: vk::Pipeline::null(), layout: vk::PipelineLayout::null(), set_layout: vk::DescriptorSetLayout::null() };
    // SAFETY (whole block): create infos reference live locals only.
    let result = (|| -> Result<()> {
        unsafe {
            made.set_layout = device
                .create_descriptor_set_layout(&vk::DescriptorSetLayoutCreateInfo::default().bindings(&layout_bindings), None)
                .context("creating descriptor set layout")?;
            let ranges = [vk::PushConstantRange::default().stage_flags(vk::ShaderStageFlags::COMPUTE).offset(0).size(push_constant_bytes)];
            let set_layouts = [made.set_layout];
            let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
            if push_constant_bytes > 0 {
                layout_info = layout_info.push_constant_ranges(&ranges);
            }
            made.layout = device.create_pipeline_layout(&layout_info, None).context("creating pipeline layout")?;
            let entries: Vec<_> = specialization
                .iter()
                .enumerate()
                .map(|(i, &(id, _))| vk::SpecializationMapEntry { constant_id: id, offset: 4 * i as u32, size: 4 })
                .collect();
            let data: Vec<u8> = specialization.iter().flat_map(|&(_, v)| v.to_ne_bytes()).collect();
            let spec = vk::SpecializationInfo::default().map_entries(&entries).data(&data);
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main")
                .specialization_info(&spec);
            let info = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(made.layout)];
            made.pipeline = device.create_compute_pipelines(cache, &info, None).map_err(|(_, e)| e).context("creating compute pipeline")?[0];
        }
        Ok(())
    })();
    // SAFETY: the module is only needed during pipeline creation; on an
    // error nothing made was handed out (null handles are no-ops).
    unsafe {
        device.destroy_shader_module(module, None);
        if result.is_err() {
            device.destroy_pipeline(made.pipeline, None);
            device.destroy_pipeline_layout(made.layout, None);
            device.destroy_descriptor_set_layout(made.set_layout, None);
        }
    }
    result.map(|()| made)
}

/// Records the binding of a compute pipeline and its one descriptor set
/// (`handles`), and `push` as its push constants.
///
/// # Safety
/// `cmd` is recording on `d`; the pipeline, its layout and set are alive,
/// and the layout's push range holds `push`.
pub unsafe fn bind_compute(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    (pipeline, layout, set): (vk::Pipeline, vk::PipelineLayout, vk::DescriptorSet),
    push: &[u32],
) {
    // SAFETY: as the caller promises.
    unsafe {
        d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, pipeline);
        d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, layout, 0, &[set], &[]);
        d.cmd_push_constants(cmd, layout, vk::ShaderStageFlags::COMPUTE, 0, bytemuck::cast_slice(push));
    }
}

impl Drop for ComputePipeline {
    fn drop(&mut self) {
        if self.ctx.is_hung() {
            return;
        }
        // SAFETY: no pending work uses the set (see Buffer's Drop);
        // destroying a null handle is a no-op. The pipeline and its
        // layouts are the context's, destroyed with it.
        unsafe { self.ctx.device.destroy_descriptor_pool(self.pool, None) };
    }
}
