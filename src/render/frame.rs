//! Frames made on the GPU: the camera's rays, the march, the look of each
//! sample, their mean and the 8-bit image, and the march's statistics,
//! recorded into one submission with one fence, so that the host reads
//! back 4 bytes a pixel and a few words (shaders/look.comp).
//!
//! The march's slices are recorded back to back without a flag read in
//! between: after each slice a one-invocation gate writes the next
//! slice's workgroup count for an indirect dispatch, none once every ray
//! is done, so the slices a frame does not need cost a dispatch of
//! nothing. A sample's recorded slices start at [`FIRST_SLICES`]; a frame
//! whose rays are still marching after them is made again with every slice
//! the step budget allows (a second fence, rare).
//!
//! The host's path ([`crate::render::offscreen::march_image`]) stays for
//! what this one does not make yet: shadows and occlusion, transparency,
//! reflection and refraction, clipping planes, and every caller that reads
//! each ray's result (AOVs, heatmaps, Python's arrays).

use std::time::Instant;

use anyhow::{Result, bail};
use ash::vk;

use super::{MarchOptions, Renderer, WORKGROUP, light};
use crate::gpu::{Buffer, ComputePipeline, Context, Role};
use crate::layout::{self, GpuLook, GpuMarchState, GpuRay, GpuResult};
use crate::method::Method;
use crate::output::MarchStats;
use crate::render::offscreen::{DepthCue, Effects, SAMPLE_SEED};
use crate::render::rays::PIXEL_TILE;
use crate::scene::{Projection, Scene};

/// What a frame's submission read back: the image, the statistics' words,
/// the last sample's rays and results where kept, the GPU time.
type FrameRead = (Vec<u32>, Vec<u32>, Option<(Vec<GpuRay>, Vec<GpuResult>)>, Option<f64>);

/// Slices recorded per sample in a frame's first submission.
const FIRST_SLICES: u64 = 16;

/// look.comp's pipeline and the buffers it alone uses, sized for a frame.
pub(super) struct LookPass {
    pipeline: ComputePipeline,
    look: Buffer,
    samples: Buffer,
    accum: Buffer,
    image: Buffer,
    stats: Buffer,
    indirect: Buffer,
    pixels: u64,
}

impl LookPass {
    fn new(ctx: &std::sync::Arc<Context>, pixels: u64) -> Result<LookPass> {
        let spirv = isomarch_shaders::Kernel::Look.spirv().map_err(anyhow::Error::msg)?;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        Ok(LookPass {
            pipeline: ComputePipeline::new(ctx, spirv, layout::LOOK_BINDINGS, 16, &[])?,
            look: Buffer::uniform(ctx, "look", &[GpuLook::default()])?,
            samples: Buffer::device(ctx, "sample pixels", 16 * pixels)?,
            accum: Buffer::device(ctx, "sample sums", 16 * pixels)?,
            image: Buffer::device(ctx, "image", 4 * pixels)?,
            stats: Buffer::device(ctx, "frame statistics", 4 * u64::from(layout::LOOK_STAT_WORDS))?,
            indirect: Buffer::with_usage(ctx, "next slice", 16, storage | vk::BufferUsageFlags::INDIRECT_BUFFER, Role::Device)?,
            pixels,
        })
    }

    /// Binds look.comp's buffers and the march's rays, results and counter.
    pub(super) fn bind(&self, rays: &Buffer, results: &Buffer, active: &Buffer) -> Result<()> {
        self.pipeline.bind(&[&self.look, rays, results, &self.samples, &self.accum, &self.image, &self.stats, active, &self.indirect])
    }
}

/// A frame made on the GPU: its image and its march's statistics.
pub struct GpuFrame {
    /// 8-bit sRGB and alpha (coverage where the background is
    /// transparent, else 255), row-major, top row first.
    pub rgba: Vec<u8>,
    pub stats: MarchStats,
    /// The last sample's rays and results, in tile order, where asked
    /// ([`Renderer::gpu_frame_keeping`]).
    pub last: Option<(Vec<GpuRay>, Vec<GpuResult>)>,
}

/// Every ray's origin and direction, from `scene`'s camera, as look.comp
/// makes them (`camera_rays_through`'s arithmetic), with the look.
fn look_of(scene: &Scene, (width, height): (u32, u32), samples: u32, effects: &Effects) -> GpuLook {
    let cam = &scene.camera;
    let forward = (cam.target - cam.eye).normalize();
    let right = forward.cross(cam.up).normalize();
    let up = right.cross(forward);
    let ortho = match cam.projection {
        Projection::Perspective => None,
        Projection::Orthographic { height } => Some(height),
    };
    let half_h = ortho.map_or_else(|| (0.5 * cam.fov_y_deg.to_radians()).tan(), |h| 0.5 * h);
    let half_w = half_h * f64::from(width) / f64::from(height);
    let depths = DepthCue::range(&scene.bounds, cam);
    let (cue_start, cue_end) =
        effects.depth_cue.map_or((0.0, 0.0), |c| (depths.0 + c.start * (depths.1 - depths.0), depths.0 + c.end * (depths.1 - depths.0)));
    let v = |a: glam::DVec3, w: f64| [a.x as f32, a.y as f32, a.z as f32, w as f32];
    let (outline_color, threshold, outline_width) =
        effects.outline.map_or(([0.0; 3], 0.0, 0), |o| (o.color, o.jump * (depths.1 - depths.0), o.width));
    GpuLook {
        eye: v(cam.eye, half_w),
        right: v(right, half_h),
        up: v(up, f64::from(u8::from(ortho.is_some()))),
        forward: v(forward, 0.0),
        box_min: v(scene.bounds.min, cue_start),
        box_max: v(scene.bounds.max, cue_end),
        background: v(scene.background, 0.0),
        outline: [outline_color[0] as f32, outline_color[1] as f32, outline_color[2] as f32, threshold as f32],
        dims: [width, height, width.div_ceil(PIXEL_TILE), samples.max(1)],
        flags: [u32::from(effects.depth_cue.is_some()), outline_width, SAMPLE_SEED, 0],
    }
}

/// The statistics look.comp reduced ([`layout::LOOK_STAT_WORDS`] words).
fn stats_of(words: &[u32], gpu_ns: Option<f64>) -> MarchStats {
    let wide = |k: u32| u64::from(words[k as usize]) | (u64::from(words[k as usize + 1]) << 32);
    let rays = words[layout::LOOK_STAT_RAYS as usize] as usize;
    let n = rays.max(1) as f64;
    let (evals, turns) = (wide(layout::LOOK_STAT_EVALS), wide(layout::LOOK_STAT_TURNS));
    MarchStats {
        rays,
        hit_rate: f64::from(words[layout::LOOK_STAT_HITS as usize]) / n,
        steps_per_ray: wide(layout::LOOK_STAT_STEPS) as f64 / n,
        evals_per_ray: evals as f64 / n,
        refine_per_ray: wide(layout::LOOK_STAT_REFINE) as f64 / n,
        out_of_steps_rate: f64::from(words[layout::LOOK_STAT_OUT_OF_STEPS as usize]) / n,
        max_steps_taken: words[layout::LOOK_STAT_MAX_STEPS as usize],
        gpu_ms: gpu_ns.map(|ns| ns * 1e-6),
        ns_per_ray: gpu_ns.map(|ns| ns / n),
        turns_per_ray: turns as f64 / n,
        visits_per_ray: wide(layout::LOOK_STAT_VISITS) as f64 / n,
        ns_per_eval: gpu_ns.filter(|_| evals > 0).map(|ns| ns / evals as f64),
        ns_per_turn: gpu_ns.filter(|_| turns > 0).map(|ns| ns / turns as f64),
        any_hit: None,
    }
}

/// `ISOMARCH_GPU_FRAME=off` makes every frame on the host's path (to
/// compare the two).
pub const GPU_FRAME_SWITCH: &str = "ISOMARCH_GPU_FRAME";

impl Renderer {
    /// Whether [`Renderer::gpu_frame`] makes this frame: opaque, without
    /// shadows, occlusion or clipping planes, every ray in one dispatch.
    pub fn gpu_frame_applies(&self, options: &MarchOptions, scene: &Scene, (width, height): (u32, u32)) -> bool {
        let rays = u64::from(width.div_ceil(PIXEL_TILE) * height.div_ceil(PIXEL_TILE)) * u64::from(PIXEL_TILE * PIXEL_TILE);
        options.shade
            && !options.transparent
            && !options.any_hit
            && !options.secondary
            && scene.transparency.is_none()
            && !light::wanted(scene, options)
            && scene.camera.clip.is_empty()
            && rays / WORKGROUP as u64 <= u64::from(self.ctx.info.max_compute_workgroup_count[0])
            && rays * size_of::<GpuMarchState>() as u64 <= self.ctx.info.max_storage_buffer_range
            && super::env_switch(GPU_FRAME_SWITCH).unwrap_or(true)
    }

    /// Makes `scene`'s camera view at `width` x `height` with `samples`
    /// rays per pixel on the GPU, as [`crate::render::offscreen::march_image`]
    /// makes it on the host, for a frame [`Renderer::gpu_frame_applies`] to
    /// (the camera's tile lists built for it where they apply,
    /// [`Renderer::prepare_camera`]). Statistics count every camera ray;
    /// the GPU time is the whole frame's, the look's passes included.
    pub fn gpu_frame(
        &mut self,
        method: Method,
        options: MarchOptions,
        scene: &Scene,
        (width, height): (u32, u32),
        samples: u32,
        effects: &Effects,
    ) -> Result<GpuFrame> {
        self.gpu_frame_keeping(method, options, scene, (width, height), samples, effects, false)
    }

    /// [`Renderer::gpu_frame`], with the last sample's rays and results
    /// read back too when `keep` (tests: what the GPU reduced, from what).
    #[allow(clippy::too_many_arguments)]
    pub fn gpu_frame_keeping(
        &mut self,
        method: Method,
        options: MarchOptions,
        scene: &Scene,
        (width, height): (u32, u32),
        samples: u32,
        effects: &Effects,
        keep: bool,
    ) -> Result<GpuFrame> {
        let tiles_x = width.div_ceil(PIXEL_TILE);
        let rays = (tiles_x * height.div_ceil(PIXEL_TILE) * PIXEL_TILE * PIXEL_TILE) as usize;
        let pixels = u64::from(width) * u64::from(height);
        self.ensure_frame_buffers(rays, pixels)?;
        let look = self.look.as_mut().expect("made above");
        look.look.write(0, &[look_of(scene, (width, height), samples, effects)])?;
        let through = self.tiles.as_ref().is_some_and(|t| t.frame.is_some()) && self.tiles_apply(method, &options);
        let deadline = Instant::now() + self.timeout;
        let (march, slice_steps, max_slices) = self.march_setup(method, &options, through)?;
        let mut slices = FIRST_SLICES.min(max_slices);
        loop {
            let (image, words, last, gpu_ns) =
                self.record_frame(march, slice_steps, slices, (rays, pixels as usize), samples.max(1), deadline, keep)?;
            if words[layout::LOOK_STAT_UNFINISHED as usize] == 0 {
                return Ok(GpuFrame { rgba: bytemuck::cast_slice(&image).to_vec(), stats: stats_of(&words, gpu_ns), last });
            }
            if slices >= max_slices {
                bail!("rays still marching after {slices} slices of {slice_steps} turns: a marcher ignores its step budget");
            }
            slices = max_slices;
        }
    }

    /// Rays, results and states for `rays` rays, and look.comp's buffers for
    /// `pixels` pixels.
    fn ensure_frame_buffers(&mut self, rays: usize, pixels: u64) -> Result<()> {
        let mut rebind = false;
        if self.rays.size < (rays * size_of::<GpuRay>()) as u64 {
            let n = rays.next_power_of_two();
            self.rays = Buffer::device(&self.ctx, "rays", (n * size_of::<GpuRay>()) as u64)?;
            self.results = Buffer::device(&self.ctx, "results", (n * size_of::<GpuResult>()) as u64)?;
            self.states = Buffer::device(&self.ctx, "march states", (n * size_of::<GpuMarchState>()) as u64)?;
            rebind = true;
        }
        let fresh = self.look.as_ref().is_none_or(|l| l.pixels < pixels);
        let started = Instant::now();
        if fresh {
            self.look = Some(LookPass::new(&self.ctx, pixels.next_power_of_two())?);
            rebind = true;
        }
        if rebind {
            self.rebind()?;
        }
        if fresh {
            // lavapipe compiles a pipeline at its first dispatch: outside
            // the frame's GPU time, as the march's are. The finish pass of
            // no pixels touches nothing.
            let p = &self.look.as_ref().expect("made above").pipeline;
            self.warm_up_with((p.pipeline, p.layout, p.set), [layout::LOOK_PASS_FINISH, 0, 0, 0])?;
            self.pipeline_ns += started.elapsed().as_secs_f64() * 1e9;
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    /// One submission: every sample's rays made, marched in `slices`
    /// gated slices and looked at, then the image finished and read back
    /// with the statistics.
    fn record_frame(
        &mut self,
        (pipeline, layout, set): (vk::Pipeline, vk::PipelineLayout, vk::DescriptorSet),
        slice_steps: u32,
        slices: u64,
        (rays, pixels): (usize, usize),
        samples: u32,
        deadline: Instant,
        keep: bool,
    ) -> Result<FrameRead> {
        let look = self.look.as_ref().expect("made by ensure_frame_buffers");
        let image = self.transfers.fetch::<u32>(&look.image, 0, pixels)?;
        let words = self.transfers.fetch::<u32>(&look.stats, 0, layout::LOOK_STAT_WORDS as usize)?;
        let kept = if keep {
            Some((self.transfers.fetch::<GpuRay>(&self.rays, 0, rays)?, self.transfers.fetch::<GpuResult>(&self.results, 0, rays)?))
        } else {
            None
        };
        let (lp, ll, ls) = (look.pipeline.pipeline, look.pipeline.layout, look.pipeline.set);
        let (stats, active, indirect) = (look.stats.handle, self.active.handle, look.indirect.handle);
        let groups = |n: usize| n.div_ceil(WORKGROUP) as u32;
        let n_rays = rays as u32;
        let gpu_ns = self.submitter.run_with(deadline, self.timeout, &mut self.transfers, |d, cmd| {
            let after_compute = |dst_stage: vk::PipelineStageFlags, dst_access: vk::AccessFlags| {
                // SAFETY: recording on `cmd`.
                unsafe {
                    crate::gpu::memory_barrier(
                        d,
                        cmd,
                        (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_WRITE),
                        (dst_stage, dst_access),
                    )
                }
            };
            let shader = (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE);
            // `count` invocations, but the gate's one (its count is the rays').
            let look_pass = |pass: u32, sample: u32, count: u32| {
                let invocations = if pass == layout::LOOK_PASS_GATE { 1 } else { count as usize };
                // SAFETY: look.comp's pipeline, bound to live buffers.
                unsafe {
                    d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, lp);
                    d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, ll, 0, &[ls], &[]);
                    d.cmd_push_constants(cmd, ll, vk::ShaderStageFlags::COMPUTE, 0, bytemuck::cast_slice(&[pass, sample, count, 0]));
                    d.cmd_dispatch(cmd, groups(invocations), 1, 1);
                }
                after_compute(shader.0 | vk::PipelineStageFlags::DRAW_INDIRECT, shader.1 | vk::AccessFlags::INDIRECT_COMMAND_READ);
            };
            let march = |first: bool, indirect_groups: bool| {
                // SAFETY: the march's pipeline, bound to live buffers sized
                // for `rays`; the indirect buffer was written by the gate.
                unsafe {
                    d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, pipeline);
                    d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, layout, 0, &[set], &[]);
                    let push = [n_rays, u32::from(first), slice_steps, 0];
                    d.cmd_push_constants(cmd, layout, vk::ShaderStageFlags::COMPUTE, 0, bytemuck::cast_slice(&push));
                    if indirect_groups {
                        d.cmd_dispatch_indirect(cmd, indirect, 0);
                    } else {
                        d.cmd_dispatch(cmd, groups(rays), 1, 1);
                    }
                }
                after_compute(shader.0, shader.1);
            };
            // SAFETY: recording on `cmd`; the counters are device buffers.
            unsafe {
                d.cmd_fill_buffer(cmd, stats, 0, vk::WHOLE_SIZE, 0);
                d.cmd_fill_buffer(cmd, active, 0, 16, 0);
                crate::gpu::memory_barrier(d, cmd, (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE), shader);
            }
            for s in 0..samples {
                look_pass(layout::LOOK_PASS_CAMERA, s, n_rays);
                march(true, false);
                for _ in 1..slices {
                    look_pass(layout::LOOK_PASS_GATE, 0, n_rays);
                    march(false, true);
                }
                look_pass(layout::LOOK_PASS_GATE, 1, n_rays);
                look_pass(layout::LOOK_PASS_SAMPLE, s, n_rays);
                look_pass(layout::LOOK_PASS_ACCUMULATE, s, pixels as u32);
            }
            look_pass(layout::LOOK_PASS_FINISH, 0, pixels as u32);
        })?;
        let image = self.transfers.take::<u32>(image)?;
        let words = self.transfers.take::<u32>(words)?;
        let last = match kept {
            Some((r, m)) => Some((self.transfers.take::<GpuRay>(r)?, self.transfers.take::<GpuResult>(m)?)),
            None => None,
        };
        Ok((image, words, last, gpu_ns))
    }

    /// Sample `sample` of `samples`' camera rays of `scene` at `width` x
    /// `height` as look.comp makes them, in tile order (tests compare them
    /// with the host's `camera_rays_through`).
    pub fn gpu_camera_rays(&mut self, scene: &Scene, (width, height): (u32, u32), sample: u32, samples: u32) -> Result<Vec<GpuRay>> {
        let rays = (width.div_ceil(PIXEL_TILE) * height.div_ceil(PIXEL_TILE) * PIXEL_TILE * PIXEL_TILE) as usize;
        self.ensure_frame_buffers(rays, u64::from(width) * u64::from(height))?;
        let look = self.look.as_mut().expect("made above");
        look.look.write(0, &[look_of(scene, (width, height), samples, &Effects::default())])?;
        let (lp, ll, ls) = (look.pipeline.pipeline, look.pipeline.layout, look.pipeline.set);
        let read = self.transfers.fetch::<GpuRay>(&self.rays, 0, rays)?;
        let deadline = Instant::now() + self.timeout;
        self.submitter.run_with(deadline, self.timeout, &mut self.transfers, |d, cmd| {
            // SAFETY: look.comp's pipeline, bound to live buffers sized for
            // the rays.
            unsafe {
                d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, lp);
                d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, ll, 0, &[ls], &[]);
                d.cmd_push_constants(
                    cmd,
                    ll,
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    bytemuck::cast_slice(&[layout::LOOK_PASS_CAMERA, sample, rays as u32, 0]),
                );
                d.cmd_dispatch(cmd, rays.div_ceil(WORKGROUP) as u32, 1, 1);
            }
        })?;
        self.transfers.take::<GpuRay>(read)
    }
}
