//! Frames made on the GPU: the camera's rays, the march, shadows and
//! ambient occlusion, the look of each sample, their mean and the 8-bit
//! image, and the statistics, recorded into one submission with one fence,
//! so that the host reads back 4 bytes a pixel and a few words
//! (shaders/look.comp).
//!
//! The camera's rays are made in f64 as the host makes them
//! (`camera_rays_through`), so they are the host's bit for bit where the
//! device rounds f64 as IEEE asks (lavapipe does); the shadow and occlusion
//! rays are spawned from the march's results as `render::light::spawn`
//! spawns them, the shadow rays in f64 too, and marched batch by batch (a
//! light, or an occlusion sample, for every hit at once) in the same
//! submission, reusing the march's buffers: what the camera rays' results
//! are still needed for is kept aside first (`LOOK_PASS_SURFACE`).
//!
//! The march's slices are recorded back to back without a flag read in
//! between: after each slice a one-invocation gate writes the next
//! slice's workgroup count for an indirect dispatch, none once every ray
//! is done, so the slices a frame does not need cost a dispatch of
//! nothing. A march records slices for [`FIRST_TURNS`] loop turns, or as
//! many as the renderer's last frame needed; a frame whose rays are still marching
//! after them (the last gate raises a flag) is made again with four times
//! as many, up to what the step budget allows (a second fence, rare).
//!
//! The host's path ([`crate::render::offscreen::march_image`]) stays for
//! what this one does not make yet: transparency, reflection and
//! refraction, clipping planes, a transparent background, and every caller
//! that reads each ray's result (AOVs, heatmaps, Python's arrays).

use std::time::Instant;

use anyhow::{Result, bail};
use ash::vk;

use super::{MarchOptions, Renderer, WORKGROUP, light};
use crate::gpu::{Buffer, ComputePipeline, Context, Role};
use crate::layout::{self, GpuLook, GpuMarchState, GpuRay, GpuResult};
use crate::method::Method;
use crate::output::MarchStats;
use crate::render::offscreen::{DepthCue, Effects, SAMPLE_SEED};
use crate::render::rays::{ImagePlane, PIXEL_TILE};
use crate::scene::Scene;

/// What a frame's submission read back: the image (where read), the
/// statistics' words, the last sample's rays and results where kept, the
/// GPU time.
type FrameRead = (Vec<u32>, Vec<u32>, Option<(Vec<GpuRay>, Vec<GpuResult>)>, Option<f64>);

/// What a GPU frame reads back besides its statistics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Readback {
    /// Nothing more: the image stays on the GPU, where a window presents it
    /// from ([`Renderer::frame_image`]).
    Statistics,
    /// The image, 4 bytes a pixel (`render`, batch frames).
    Image,
    /// The image and the last sample's rays and results (tests: what the
    /// GPU reduced, from what).
    ImageAndRays,
}

/// One march of a frame: its pipeline, the turns of a slice, the slices
/// recorded and the most the step budget allows.
#[derive(Clone, Copy)]
struct Marcher {
    handles: (vk::Pipeline, vk::PipelineLayout, vk::DescriptorSet),
    slice_steps: u32,
    slices: u64,
    most: u64,
}

/// What a frame's submission records.
#[derive(Clone, Copy)]
struct FramePlan {
    camera: Marcher,
    /// The shadow and occlusion rays' march, where the scene casts them,
    /// in `batches` batches a sample.
    any_hit: Option<Marcher>,
    batches: u32,
    rays: usize,
    pixels: usize,
    samples: u32,
    reads: Readback,
}

/// Loop turns a march's slices cover in a renderer's first frame (and one
/// slice more). On lavapipe a recorded slice costs two dispatches even
/// when the gate lets no workgroup run; camera rays through the tile lists
/// mostly end in their first slice, shadow and occlusion rays through the
/// grid (shorter slices) in a few.
const FIRST_TURNS: u64 = 256;

/// look.comp's pipelines, one per pass (`LOOK_PASS_*`, specialised:
/// lavapipe runs every branch a shader holds, taken or not, so one
/// pipeline of all the passes cost each pass all their work), and the
/// buffers they alone use, sized for a frame.
pub(super) struct LookPass {
    pipelines: Vec<ComputePipeline>,
    look: Buffer,
    samples: Buffer,
    accum: Buffer,
    image: Buffer,
    stats: Buffer,
    indirect: Buffer,
    surfaces: Buffer,
    shadows: Buffer,
    camera_rays: Buffer,
    pixels: u64,
    rays: u64,
}

impl LookPass {
    fn new(ctx: &std::sync::Arc<Context>, rays: u64, pixels: u64) -> Result<LookPass> {
        let spirv = isomarch_shaders::Kernel::Look.spirv().map_err(anyhow::Error::msg)?;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        Ok(LookPass {
            pipelines: (0..layout::LOOK_PASSES)
                .map(|pass| ComputePipeline::new(ctx, spirv, layout::LOOK_BINDINGS, 16, &[(layout::LOOK_PASS_CONSTANT, pass)]))
                .collect::<Result<_>>()?,
            look: Buffer::uniform(ctx, "look", &[GpuLook::default()])?,
            samples: Buffer::device(ctx, "sample pixels", 16 * pixels)?,
            accum: Buffer::device(ctx, "sample sums", 16 * pixels)?,
            image: Buffer::device(ctx, "image", 4 * pixels)?,
            stats: Buffer::device(ctx, "frame statistics", 4 * u64::from(layout::LOOK_STAT_WORDS))?,
            indirect: Buffer::with_usage(ctx, "next slice", 16, storage | vk::BufferUsageFlags::INDIRECT_BUFFER, Role::Device)?,
            surfaces: Buffer::device(ctx, "hit surfaces", 16 * rays)?,
            shadows: Buffer::device(ctx, "shadows and occlusion", 16 * rays)?,
            camera_rays: Buffer::device(ctx, "camera rays", 32 * rays)?,
            pixels,
            rays,
        })
    }

    /// Binds look.comp's buffers and the march's rays, results, counter
    /// and lights.
    pub(super) fn bind(&self, rays: &Buffer, results: &Buffer, active: &Buffer, lights: &Buffer) -> Result<()> {
        let own = [&self.look, rays, results, &self.samples, &self.accum, &self.image, &self.stats, active, &self.indirect];
        let lit = [lights, &self.surfaces, &self.shadows, &self.camera_rays];
        let buffers: Vec<&Buffer> = own.into_iter().chain(lit).collect();
        self.pipelines.iter().try_for_each(|p| p.bind(&buffers))
    }
}

/// A frame made on the GPU: its image and its march's statistics.
pub struct GpuFrame {
    /// 8-bit sRGB and alpha (coverage where the background is
    /// transparent, else 255), row-major, top row first; empty where the
    /// image stayed on the GPU ([`Readback::Statistics`]).
    pub rgba: Vec<u8>,
    pub stats: MarchStats,
    /// The last sample's rays and results, in tile order, where asked
    /// ([`Readback::ImageAndRays`]).
    pub last: Option<(Vec<GpuRay>, Vec<GpuResult>)>,
}

/// Every ray's origin and direction, from `scene`'s camera, as look.comp
/// makes them (`camera_rays_through`'s arithmetic), with the look.
fn look_of(scene: &Scene, (width, height): (u32, u32), samples: u32, effects: &Effects) -> GpuLook {
    let cam = &scene.camera;
    let ImagePlane { forward, right, up, ortho, half_w, half_h } = ImagePlane::of(cam, width, height);
    let depths = DepthCue::range(&scene.bounds, cam);
    let (cue_start, cue_end) =
        effects.depth_cue.map_or((0.0, 0.0), |c| (depths.0 + c.start * (depths.1 - depths.0), depths.0 + c.end * (depths.1 - depths.0)));
    let v = |a: glam::DVec3, w: f64| [a.x as f32, a.y as f32, a.z as f32, w as f32];
    let (outline_color, threshold, outline_width) =
        effects.outline.map_or(([0.0; 3], 0.0, 0), |o| (o.color, o.jump * (depths.1 - depths.0), o.width));
    GpuLook {
        eye: v(cam.eye, 0.0),
        right: v(right, 0.0),
        up: v(up, f64::from(u8::from(ortho.is_some()))),
        forward: v(forward, 0.0),
        box_min: v(scene.bounds.min, cue_start),
        box_max: v(scene.bounds.max, cue_end),
        background: v(scene.background, 0.0),
        outline: [outline_color[0] as f32, outline_color[1] as f32, outline_color[2] as f32, threshold as f32],
        dims: [width, height, width.div_ceil(PIXEL_TILE), samples.max(1)],
        flags: [u32::from(effects.depth_cue.is_some()), outline_width, SAMPLE_SEED, 0],
        ambient: v(scene.ambient, 0.0),
        reach: [light::start_offset(scene) as f32, scene.ao.map_or(0.0, |a| a.distance) as f32, 0.0, 0.0],
        lighting: [scene.lights.len() as u32, u32::from(scene.shadows), scene.ao.map_or(0, |a| a.samples), 0],
        eye64: bits(cam.eye.x, cam.eye.y),
        eye64_z: bits(cam.eye.z, half_w),
        right64: bits(right.x, right.y),
        right64_z: bits(right.z, half_h),
        up64: bits(up.x, up.y),
        up64_z: bits(up.z, 0.0),
        forward64: bits(forward.x, forward.y),
        forward64_z: bits(forward.z, 0.0),
        min64: bits(scene.bounds.min.x, scene.bounds.min.y),
        min64_z: bits(scene.bounds.min.z, light::start_offset(scene)),
        max64: bits(scene.bounds.max.x, scene.bounds.max.y),
        max64_z: bits(scene.bounds.max.z, 0.0),
    }
}

/// Two f64 as the shader reads them (`packDouble2x32`): each as its low
/// word, then its high.
pub(super) fn bits(a: f64, b: f64) -> [u32; 4] {
    let (a, b) = (a.to_bits(), b.to_bits());
    [a as u32, (a >> 32) as u32, b as u32, (b >> 32) as u32]
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
        // Their GPU time is in the frame's, not apart.
        any_hit: light::LightStats {
            shadow_rays: u64::from(words[layout::LOOK_STAT_SHADOW_RAYS as usize]),
            shadow_steps: wide(layout::LOOK_STAT_SHADOW_STEPS),
            ao_rays: u64::from(words[layout::LOOK_STAT_AO_RAYS as usize]),
            ao_steps: wide(layout::LOOK_STAT_AO_STEPS),
            gpu_ns: None,
        }
        .summary(),
    }
}

/// `ISOMARCH_GPU_FRAME=off` makes every frame on the host's path (to
/// compare the two).
pub const GPU_FRAME_SWITCH: &str = "ISOMARCH_GPU_FRAME";

impl Renderer {
    /// Whether [`Renderer::gpu_frame`] makes this frame: opaque, without
    /// clipping planes, every ray in one dispatch, on a device with 64-bit
    /// floats in shaders (the camera rays are made in f64) and subgroup
    /// sums (the statistics).
    pub fn gpu_frame_applies(&self, options: &MarchOptions, scene: &Scene, (width, height): (u32, u32)) -> bool {
        let rays = u64::from(width.div_ceil(PIXEL_TILE) * height.div_ceil(PIXEL_TILE)) * u64::from(PIXEL_TILE * PIXEL_TILE);
        options.shade
            && !options.transparent
            && !options.any_hit
            && !options.secondary
            && scene.transparency.is_none()
            && scene.camera.clip.is_empty()
            && self.ctx.info.float64
            && self.ctx.info.subgroup_arithmetic
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
        self.gpu_frame_reading(method, options, scene, (width, height), samples, effects, Readback::Image)
    }

    /// [`Renderer::gpu_frame`], reading back what `reads` says.
    #[allow(clippy::too_many_arguments)]
    pub fn gpu_frame_reading(
        &mut self,
        method: Method,
        options: MarchOptions,
        scene: &Scene,
        (width, height): (u32, u32),
        samples: u32,
        effects: &Effects,
        reads: Readback,
    ) -> Result<GpuFrame> {
        let tiles_x = width.div_ceil(PIXEL_TILE);
        let rays = (tiles_x * height.div_ceil(PIXEL_TILE) * PIXEL_TILE * PIXEL_TILE) as usize;
        let pixels = u64::from(width) * u64::from(height);
        self.ensure_frame_buffers(rays, pixels)?;
        let look = self.look.as_mut().expect("made above");
        look.look.write(0, &[look_of(scene, (width, height), samples, effects)])?;
        let through = self.through_tiles(method, &options);
        let deadline = Instant::now() + self.timeout;
        let lit = light::wanted(scene, &options);
        if lit {
            light::check_method(scene, method)?;
        }
        // Both pipelines before the index's build, which warms them up
        // with look.comp's.
        let any_hit_options = light::any_hit_options(options);
        self.pipeline(super::EntryPoint::March, method, &options, through)?;
        if lit {
            self.pipeline(super::EntryPoint::March, method, &any_hit_options, false)?;
        }
        let camera = self.march_setup(method, &options, through)?;
        let any_hit = if lit { Some(self.march_setup(method, &any_hit_options, false)?) } else { None };
        // What the shadow and occlusion rays answer for: a light each, then
        // each occlusion sample.
        let batches = if lit { scene.lights.len() as u32 + scene.ao.map_or(0, |a| a.samples) } else { 0 };
        // Slices for FIRST_TURNS turns, or as many as the last frame needed.
        let mut k = 0;
        let mut marchers = [camera, any_hit.unwrap_or(camera)].map(|(handles, slice_steps, most)| {
            let from = (FIRST_TURNS.div_ceil(u64::from(slice_steps)) + 1).max(self.frame_slices[k]);
            k += 1;
            Marcher { handles, slice_steps, slices: from.min(most), most }
        });
        loop {
            let plan = FramePlan {
                camera: marchers[0],
                any_hit: any_hit.map(|_| marchers[1]),
                batches,
                rays,
                pixels: pixels as usize,
                samples: samples.max(1),
                reads,
            };
            let (image, words, last, gpu_ns) = self.record_frame(&plan, deadline)?;
            if words[layout::LOOK_STAT_UNFINISHED as usize] == 0 {
                self.frame_slices = marchers.map(|m| m.slices);
                return Ok(GpuFrame { rgba: bytemuck::cast_slice(&image).to_vec(), stats: stats_of(&words, gpu_ns), last });
            }
            if marchers.iter().all(|m| m.slices >= m.most) {
                bail!(
                    "rays still marching after {} slices of {} turns: a marcher ignores its step budget",
                    marchers[0].slices,
                    marchers[0].slice_steps
                );
            }
            // Made again with four times the slices (rare: a frame's rays
            // mostly end in their first slice).
            for m in &mut marchers {
                m.slices = (4 * m.slices).min(m.most);
            }
        }
    }

    /// The last GPU frame's image as it lies on the GPU: 4 bytes a pixel
    /// (8-bit sRGB and alpha), row-major, top row first, as many pixels as
    /// that frame had. A window presents it from there
    /// ([`crate::gpu::Presenter::present_image`]).
    pub fn frame_image(&self) -> Option<&Buffer> {
        self.look.as_ref().map(|l| &l.image)
    }

    /// The first `pixels` pixels of [`Renderer::frame_image`] read back
    /// (RGBA8): a window's screenshot of a frame it presented from the GPU.
    pub fn read_frame_image(&mut self, pixels: usize) -> Result<Vec<u8>> {
        let Some(look) = self.look.as_ref() else { bail!("no frame was made on the GPU") };
        if pixels as u64 > look.pixels {
            bail!("{pixels} pixels asked of a frame image of {}", look.pixels);
        }
        let image = self.transfers.fetch::<u32>(&look.image, 0, pixels)?;
        self.submitter.run_with(Instant::now() + self.timeout, self.timeout, &mut self.transfers, |_, _| {})?;
        Ok(bytemuck::cast_slice(&self.transfers.take::<u32>(image)?).to_vec())
    }

    /// Rays, results and states for `rays` rays, and look.comp's buffers for
    /// `rays` rays and `pixels` pixels.
    fn ensure_frame_buffers(&mut self, rays: usize, pixels: u64) -> Result<()> {
        let mut rebind = false;
        if self.rays.size < (rays * size_of::<GpuRay>()) as u64 {
            let n = rays.next_power_of_two();
            self.rays = Buffer::device(&self.ctx, "rays", (n * size_of::<GpuRay>()) as u64)?;
            self.results = Buffer::device(&self.ctx, "results", (n * size_of::<GpuResult>()) as u64)?;
            self.states = Buffer::device(&self.ctx, "march states", (n * size_of::<GpuMarchState>()) as u64)?;
            rebind = true;
        }
        let fresh = self.look.as_ref().is_none_or(|l| l.pixels < pixels || l.rays < rays as u64);
        if fresh {
            let started = Instant::now();
            if let Some(old) = self.look.take() {
                // Not warmed up yet, it is no more.
                self.cold.retain(|((p, _, _), _)| !old.pipelines.iter().any(|o| o.pipeline == *p));
            }
            let look = LookPass::new(&self.ctx, (rays as u64).next_power_of_two(), pixels.next_power_of_two())?;
            // lavapipe compiles a pipeline at its first dispatch: outside
            // the frame's GPU time, as the march's are. A pass of no
            // invocation touches nothing.
            for p in &look.pipelines {
                self.warm_up_with((p.pipeline, p.layout, p.set), [0, 0, 0, 0])?;
            }
            self.look = Some(look);
            self.pipeline_ns += started.elapsed().as_secs_f64() * 1e9;
            rebind = true;
        }
        if rebind {
            self.rebind()?;
        }
        Ok(())
    }

    /// One submission: every sample's rays made, marched in gated slices,
    /// their shadow and occlusion rays spawned and marched batch by batch,
    /// the sample looked at; then the image finished and read back with
    /// the statistics.
    fn record_frame(&mut self, plan: &FramePlan, deadline: Instant) -> Result<FrameRead> {
        self.warm_cold()?;
        let FramePlan { camera, any_hit, batches, rays, pixels, samples, reads } = *plan;
        let look = self.look.as_ref().expect("made by ensure_frame_buffers");
        let image = if reads == Readback::Statistics { None } else { Some(self.transfers.fetch::<u32>(&look.image, 0, pixels)?) };
        let words = self.transfers.fetch::<u32>(&look.stats, 0, layout::LOOK_STAT_WORDS as usize)?;
        let kept = if reads == Readback::ImageAndRays {
            Some((self.transfers.fetch::<GpuRay>(&self.rays, 0, rays)?, self.transfers.fetch::<GpuResult>(&self.results, 0, rays)?))
        } else {
            None
        };
        let passes: Vec<_> = look.pipelines.iter().map(|p| (p.pipeline, p.layout, p.set)).collect();
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
            let look_pass = |pass: u32, sample: u32, count: u32, batch: u32| {
                let invocations = if pass == layout::LOOK_PASS_GATE { 1 } else { count as usize };
                // SAFETY: look.comp's pipeline for `pass`, bound to live
                // buffers.
                unsafe {
                    crate::gpu::bind_compute(d, cmd, passes[pass as usize], &[pass, sample, count, batch]);
                    d.cmd_dispatch(cmd, groups(invocations), 1, 1);
                }
                after_compute(shader.0 | vk::PipelineStageFlags::DRAW_INDIRECT, shader.1 | vk::AccessFlags::INDIRECT_COMMAND_READ);
            };
            // A march of every ray in `rays`: a first slice, gated slices,
            // and the check that none is still marching.
            let march = |m: &Marcher| {
                for slice in 0..m.slices {
                    if slice > 0 {
                        look_pass(layout::LOOK_PASS_GATE, 0, n_rays, 0);
                    }
                    // SAFETY: the march's pipeline, bound to live buffers
                    // sized for `rays`; the indirect buffer was written by
                    // the gate.
                    unsafe {
                        crate::gpu::bind_compute(d, cmd, m.handles, &[n_rays, u32::from(slice == 0), m.slice_steps, 0]);
                        if slice > 0 {
                            d.cmd_dispatch_indirect(cmd, indirect, 0);
                        } else {
                            d.cmd_dispatch(cmd, groups(rays), 1, 1);
                        }
                    }
                    after_compute(shader.0, shader.1);
                }
                look_pass(layout::LOOK_PASS_GATE, 1, n_rays, 0);
            };
            // SAFETY: recording on `cmd`; the counters are device buffers.
            unsafe {
                d.cmd_fill_buffer(cmd, stats, 0, vk::WHOLE_SIZE, 0);
                d.cmd_fill_buffer(cmd, active, 0, 16, 0);
                crate::gpu::memory_barrier(d, cmd, (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE), shader);
            }
            for s in 0..samples {
                look_pass(layout::LOOK_PASS_CAMERA, s, n_rays, 0);
                march(&camera);
                look_pass(layout::LOOK_PASS_SURFACE, s, n_rays, 0);
                if let Some(any_hit) = &any_hit {
                    for b in 0..batches {
                        look_pass(layout::LOOK_PASS_SPAWN, s, n_rays, b);
                        march(any_hit);
                        look_pass(layout::LOOK_PASS_OCCLUDE, s, n_rays, b);
                    }
                }
                look_pass(layout::LOOK_PASS_SAMPLE, s, n_rays, 0);
                look_pass(layout::LOOK_PASS_ACCUMULATE, s, pixels as u32, 0);
            }
            look_pass(layout::LOOK_PASS_FINISH, 0, pixels as u32, 0);
        })?;
        let image = match image {
            Some(image) => self.transfers.take::<u32>(image)?,
            None => Vec::new(),
        };
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
        self.warm_cold()?;
        let look = self.look.as_mut().expect("made above");
        look.look.write(0, &[look_of(scene, (width, height), samples, &Effects::default())])?;
        let camera = &look.pipelines[layout::LOOK_PASS_CAMERA as usize];
        let handles = (camera.pipeline, camera.layout, camera.set);
        let read = self.transfers.fetch::<GpuRay>(&self.rays, 0, rays)?;
        let deadline = Instant::now() + self.timeout;
        self.submitter.run_with(deadline, self.timeout, &mut self.transfers, |d, cmd| {
            // SAFETY: look.comp's pipeline, bound to live buffers sized for
            // the rays.
            unsafe {
                crate::gpu::bind_compute(d, cmd, handles, &[layout::LOOK_PASS_CAMERA, sample, rays as u32, 0]);
                d.cmd_dispatch(cmd, rays.div_ceil(WORKGROUP) as u32, 1, 1);
            }
        })?;
        self.transfers.take::<GpuRay>(read)
    }
}
