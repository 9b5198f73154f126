//! Offscreen frames: march camera rays, then write the requested files.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Result;
use serde::Serialize;

use super::index::IndexStats;
use super::rays::{camera_rays_through, subpixel};
use super::{MarchOptions, Renderer};
use crate::gpu::Context;
use crate::layout::FLAG_HIT;
use crate::method::Method;
use crate::output::{self, Aov, FileFormat, Frame, MarchStats};
use crate::scene::Scene;

/// What to render and where to put it.
#[derive(Clone, Debug)]
pub struct RenderJob {
    pub scene: Scene,
    pub method: Method,
    pub width: u32,
    pub height: u32,
    /// The shaded image: PNG, or the linear image as OpenEXR (`.exr`).
    pub output: PathBuf,
    pub heatmap: Option<PathBuf>,
    pub steps_max: Option<u32>,
    pub aovs: Vec<Aov>,
    pub aov_output: Option<PathBuf>,
    pub stats: Option<PathBuf>,
    pub timeout: Duration,
    /// Anti-aliasing: rays per pixel, averaged ([`march_image`]).
    pub samples: u32,
    /// A colour key drawn under the image (PNG only).
    pub legend: Option<output::ColorBar>,
    /// Write the background transparent: alpha the pixels' coverage.
    pub transparent_background: bool,
    /// Depth cueing and outlines, drawn on each sample.
    pub effects: Effects,
    /// Every ray's result read back, for whoever reads a frame's pixels
    /// (depth, normals, steps: Python, tests). Off, a frame that needs no
    /// more than its image is made whole on the GPU and only its 8-bit
    /// image read back ([`RenderJob::image_only`]).
    pub results: bool,
}

/// What is drawn on each sample's pixels after the march and the lights:
/// depth cueing, then outlines.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Effects {
    pub depth_cue: Option<DepthCue>,
    pub outline: Option<Outline>,
}

impl Effects {
    /// The effects a user asks for (the command line's `--depth-cue`,
    /// `--outline`, `--outline-color` (parsed by `checks::color`),
    /// `--outline-jump`; Python's keywords of the same names), checked, each
    /// problem one line naming its flag.
    pub fn from_choices(
        depth_cue: Option<&str>,
        outline: Option<u32>,
        outline_color: Option<[f64; 3]>,
        outline_jump: Option<f64>,
    ) -> Result<Effects> {
        let depth_cue = depth_cue.map(DepthCue::parse).transpose()?;
        if outline.is_none() && (outline_color.is_some() || outline_jump.is_some()) {
            anyhow::bail!("--outline-color and --outline-jump shape the outlines of --outline, which was not given");
        }
        let outline = match outline {
            None => None,
            Some(width) => {
                if !(1..=64).contains(&width) {
                    anyhow::bail!("--outline takes a width of 1 to 64 pixels, got {width}");
                }
                let jump = outline_jump.unwrap_or(0.03);
                if !(jump.is_finite() && jump > 0.0 && jump < 1.0) {
                    anyhow::bail!("--outline-jump is a fraction of the scene's depth range, in (0, 1), got {jump}");
                }
                let color = outline_color.unwrap_or([0.0; 3]);
                Some(Outline { width, color, jump })
            }
        };
        Ok(Effects { depth_cue, outline })
    }
}

/// Outlines (ChimeraX's `graphics silhouettes`): a hit pixel is drawn in
/// `color` when a pixel at most `width` pixels away (in x and in y) is
/// farther by more than `jump` times the scene's depth range, or missed
/// (a ray that leaves the surface): a line `width` pixels wide on the
/// near side of every jump in depth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outline {
    pub width: u32,
    /// Linear RGB.
    pub color: [f64; 3],
    pub jump: f64,
}

impl Outline {
    /// Which pixels of a `w` x `h` view-depth map (row-major, infinite
    /// where the ray missed) the outline covers, the depth range being
    /// `range` long.
    pub fn mask(&self, depth: &[f64], w: u32, h: u32, range: f64) -> Vec<bool> {
        let threshold = self.jump * range;
        let (w, h, r) = (w as usize, h as usize, self.width as usize);
        // A pixel is outlined when the farthest depth within `width` of it
        // (a box, taken as a max along rows, then along columns) is beyond
        // its own by more than the threshold.
        let mut rows = vec![f64::NEG_INFINITY; depth.len()];
        for y in 0..h {
            for x in 0..w {
                rows[y * w + x] = depth[y * w + x.saturating_sub(r)..=y * w + (x + r).min(w - 1)].iter().copied().fold(f64::NEG_INFINITY, f64::max);
            }
        }
        (0..depth.len())
            .map(|i| {
                let (x, y, z) = (i % w, i / w, depth[i]);
                z.is_finite() && (y.saturating_sub(r)..=(y + r).min(h - 1)).map(|v| rows[v * w + x]).fold(f64::NEG_INFINITY, f64::max) - z > threshold
            })
            .collect()
    }
}

/// Depth cueing (ChimeraX's `lighting depthCue`): a hit's colour is blended
/// toward the background linearly from no blend at `start` to all
/// background at `end`, fractions of the scene's depth range, the span of
/// its bounds along the view direction (from the eye's plane on).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthCue {
    pub start: f64,
    pub end: f64,
}

impl DepthCue {
    /// `START:END`, fractions with 0 <= START < END <= 1 (ChimeraX's
    /// defaults are 0.5 and 1).
    pub fn parse(text: &str) -> Result<DepthCue> {
        let bad = || anyhow::anyhow!("--depth-cue takes START:END, fractions of the scene's depth range with 0 <= START < END <= 1, got {text:?}");
        let (a, b) = text.split_once(':').ok_or_else(bad)?;
        let (start, end): (f64, f64) = (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
        if !(start >= 0.0 && start < end && end <= 1.0) {
            return Err(bad());
        }
        Ok(DepthCue { start, end })
    }

    /// The scene's depth range seen by `camera`: the least and greatest
    /// distance of the bounds' corners along the view direction, the
    /// nearer one no closer than the eye's plane.
    pub fn range(bounds: &crate::scene::Aabb, camera: &crate::scene::Camera) -> (f64, f64) {
        let forward = (camera.target - camera.eye).normalize();
        let (mut near, mut far) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in 0..8 {
            let c = glam::DVec3::new(
                if k & 1 == 0 { bounds.min.x } else { bounds.max.x },
                if k & 2 == 0 { bounds.min.y } else { bounds.max.y },
                if k & 4 == 0 { bounds.min.z } else { bounds.max.z },
            );
            let z = (c - camera.eye).dot(forward);
            near = near.min(z);
            far = far.max(z);
        }
        (near.max(0.0), far.max(0.0))
    }

    /// The background's share at view depth `z` in the range `(near, far)`.
    pub fn blend(&self, z: f64, (near, far): (f64, f64)) -> f64 {
        let (a, b) = (near + self.start * (far - near), near + self.end * (far - near));
        if b > a { ((z - a) / (b - a)).clamp(0.0, 1.0) } else { f64::from(u8::from(z >= b)) }
    }
}

impl RenderJob {
    /// A job that writes only the shaded image to `output`, at `width` x
    /// `height` with `method` and the scene camera's rays per pixel,
    /// within `timeout`.
    pub fn new(scene: Scene, method: Method, (width, height): (u32, u32), output: PathBuf, timeout: Duration) -> RenderJob {
        RenderJob {
            samples: scene.camera.samples,
            scene,
            method,
            width,
            height,
            output,
            heatmap: None,
            legend: None,
            transparent_background: false,
            effects: Effects::default(),
            steps_max: None,
            aovs: vec![],
            aov_output: None,
            stats: None,
            timeout,
            results: true,
        }
    }

    /// Whether the job needs no more than the frame's 8-bit image: no
    /// per-ray results asked for, no heatmap, AOVs or OpenEXR, an opaque
    /// background; a PNG, or a movie's frame (made as the PNGs of the
    /// same batch are, so that `encode` of them gives the same movie).
    /// [`march_image`] then makes the frame on the GPU where it can
    /// (render::frame).
    pub fn image_only(&self) -> bool {
        !self.results
            && self.heatmap.is_none()
            && self.aovs.is_empty()
            && !self.transparent_background
            && (self.outputs().is_ok_and(|o| o.image == FileFormat::Png) || crate::movie::Container::of(&self.output).is_some())
    }
}

/// The formats and paths a [`RenderJob`] writes, checked from the
/// extensions before any work.
#[derive(Clone, Debug)]
pub struct JobOutputs {
    /// The shaded image's format (`-o`): PNG, or EXR for the linear image.
    pub image: FileFormat,
    /// Where the AOVs go, if any are asked for.
    pub aovs: Option<PathBuf>,
}

impl RenderJob {
    /// Checks every output path's extension (one-line errors naming the
    /// flag) and says what will be written where: `-o` PNG or EXR,
    /// `--heatmap` PNG, `--aov-output` EXR (default: `-o` with `.exr`, the
    /// same file when `-o` is EXR), `--stats` JSON.
    /// How the shaded image is written: its legend and background.
    pub fn look(&self) -> output::Look<'_> {
        let bg = self.scene.background;
        output::Look { legend: self.legend.as_ref(), transparent: self.transparent_background.then_some([bg.x as f32, bg.y as f32, bg.z as f32]) }
    }

    pub fn outputs(&self) -> Result<JobOutputs> {
        let image = FileFormat::of("-o", &self.output, FileFormat::IMAGE)?;
        if self.legend.is_some() && self.transparent_background {
            anyhow::bail!("--legend and --transparent-background cannot be drawn together: the bar needs a background");
        }
        if self.legend.is_some() && image != FileFormat::Png {
            anyhow::bail!("--legend draws the colour bar on a PNG image; -o {} is not one", self.output.display());
        }
        if let Some(path) = &self.heatmap {
            FileFormat::of("--heatmap", path, &[FileFormat::Png])?;
        }
        if let Some(path) = &self.aov_output {
            FileFormat::of("--aov-output", path, &[FileFormat::Exr])?;
        }
        if let Some(path) = &self.stats {
            FileFormat::of("--stats", path, &[FileFormat::Json])?;
        }
        let aovs = (!self.aovs.is_empty()).then(|| match &self.aov_output {
            Some(path) => path.clone(),
            None if image == FileFormat::Exr => self.output.clone(),
            None => self.output.with_extension("exr"),
        });
        if let Some(path) = aovs.as_ref().filter(|p| p.is_dir()) {
            anyhow::bail!("--aov-output {}: is a folder, not a file: give the AOVs' file with --aov-output", path.display());
        }
        Ok(JobOutputs { image, aovs })
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct RenderStats {
    pub scene: String,
    pub method: String,
    pub device: String,
    pub width: u32,
    pub height: u32,
    /// Camera rays per pixel (`--samples`); the statistics count them all.
    pub samples: u32,
    /// Wall-clock time spent creating the frame's pipelines and compiling
    /// their code (a warm-up dispatch each), which `gpu_ms` and the index's
    /// `build_ns` leave out; near zero when the driver's shader cache
    /// already holds them.
    pub pipeline_ms: f64,
    #[serde(flatten)]
    pub march: MarchStats,
    /// What gave the camera rays their candidates: `tiles` (the camera's
    /// screen-space lists), `grid` (the spatial index) or `flat` (every
    /// primitive, culled per ray: scenes of at most 64 primitives).
    pub acceleration: &'static str,
    /// The camera's tile lists (`null` unless `acceleration` is `tiles`).
    pub tiles: Option<super::TileStats>,
    /// The spatial index (`null` in JSON for scenes of at most 64
    /// primitives, which march without one); with tiles, the shadow and
    /// occlusion rays walk it.
    pub index: Option<IndexStats>,
    /// Memory when the frame was marched.
    pub memory: Memory,
    /// What the frame cost around the GPU's work.
    #[serde(flatten)]
    pub cost: FrameCost,
}

/// What a frame cost outside the GPU's work: time on the host, bytes
/// between host and GPU, and fence waits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FrameCost {
    /// Wall time of the frame: upload, march, light, look and readback,
    /// not the files' encoding.
    pub frame_ms: f64,
    /// `frame_ms` less the GPU's time (the camera rays' and the shadow and
    /// occlusion rays') and less `pipeline_ms`: what the host spent.
    pub host_ms: f64,
    /// Bytes copied from the GPU's buffers to the host, uploads to them,
    /// and submissions waited on (gpu::TransferStats).
    #[serde(flatten)]
    pub transfers: crate::gpu::TransferStats,
}

/// Memory in use, MiB.
#[derive(Clone, Debug, Serialize)]
pub struct Memory {
    /// The process's peak resident set (VmHWM; `null` off Linux).
    pub peak_rss_mib: Option<f64>,
    /// GPU memory allocated for buffers and images, and the blocks
    /// reserved to hold them.
    pub gpu_allocated_mib: Option<f64>,
    pub gpu_reserved_mib: Option<f64>,
}

impl Memory {
    pub fn now(ctx: &Context) -> Memory {
        let gpu = ctx.gpu_memory();
        let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
        Memory { peak_rss_mib: crate::stats::peak_rss_mib(), gpu_allocated_mib: gpu.map(|g| mib(g.0)), gpu_reserved_mib: gpu.map(|g| mib(g.1)) }
    }
}

/// Marches the job's camera rays and returns the frame.
pub fn render_frame(ctx: &Arc<Context>, job: &RenderJob) -> Result<(Frame, MarchStats)> {
    render_frame_indexed(ctx, job).map(|r| (r.frame, r.march))
}

/// A frame and what making it took beyond the march's statistics.
pub struct FrameReport {
    pub frame: Frame,
    pub march: MarchStats,
    /// What the build of the spatial index made (`None` without one).
    pub index: Option<IndexStats>,
    /// The camera's tile lists, where the camera rays took them.
    pub tiles: Option<super::TileStats>,
    /// The memory in use while the renderer held the scene.
    pub memory: Memory,
    /// Wall-clock milliseconds of pipeline creation and compilation
    /// ([`Renderer::pipeline_ms`]), outside every GPU time.
    pub pipeline_ms: f64,
    pub cost: FrameCost,
}

/// [`render_frame`], with the rest of a [`FrameReport`].
pub fn render_frame_indexed(ctx: &Arc<Context>, job: &RenderJob) -> Result<FrameReport> {
    let started = std::time::Instant::now();
    let scene = job.scene.recentred_on_camera();
    let mut renderer = Renderer::for_camera(ctx, &scene, job.timeout)?;
    let options = MarchOptions::for_scene(&scene);
    let tiled = renderer.prepare_camera(job.method, &options, &scene.camera, job.width, job.height)?;
    let (frame, march) =
        march_image(&mut renderer, job.method, options, &scene, (job.width, job.height), job.samples, job.effects, job.image_only())?;
    let memory = Memory::now(ctx);
    let tiles = renderer.tile_stats().filter(|_| tiled);
    let frame_ms = started.elapsed().as_secs_f64() * 1e3;
    let gpu_ms = march.gpu_ms.unwrap_or(0.0) + march.any_hit.as_ref().and_then(|a| a.gpu_ms).unwrap_or(0.0);
    let pipeline_ms = renderer.pipeline_ms();
    let cost = FrameCost { frame_ms, host_ms: (frame_ms - gpu_ms - pipeline_ms).max(0.0), transfers: renderer.transfer_stats() };
    Ok(FrameReport { frame, march, index: renderer.index_stats(), tiles, memory, pipeline_ms, cost })
}

/// `n` rays per pixel, checked as `--samples` (1 to `scene::MAX_SAMPLES`).
pub fn check_samples(n: u32) -> Result<u32> {
    let most = crate::scene::MAX_SAMPLES;
    anyhow::ensure!((1..=most).contains(&n), "--samples must be 1 to {most} rays per pixel, got {n}");
    Ok(n)
}

/// The seed of the sub-pixel samples' permutations ([`subpixel`]).
pub const SAMPLE_SEED: u32 = 1;

/// Marches `scene`'s camera view (the scene the renderer holds, posed and
/// recentred) at `width` x `height` with `samples` rays per pixel: one
/// through each pixel's centre, or more at [`subpixel`] positions, whose
/// colours are averaged in linear light (a box filter over the pixel).
/// Steps, evaluations and turns are summed over a pixel's samples; its
/// depth and normal are its first sample's. Statistics count every
/// camera ray; the shadow and occlusion rays are counted apart
/// (`MarchStats::any_hit`).
///
/// With `image_only` (the caller reads the frame's image and statistics,
/// not its pixels' results), a frame the GPU can make whole
/// ([`Renderer::gpu_frame_applies`]) is made there, and only its 8-bit
/// image read back ([`Frame::encoded`]).
#[allow(clippy::too_many_arguments)]
pub fn march_image(
    renderer: &mut Renderer,
    method: Method,
    options: MarchOptions,
    scene: &Scene,
    (width, height): (u32, u32),
    samples: u32,
    effects: Effects,
    image_only: bool,
) -> Result<(Frame, MarchStats)> {
    if image_only && renderer.gpu_frame_applies(&options, scene, (width, height)) {
        renderer.prepare_camera(method, &options, &scene.camera, width, height)?;
        let made = renderer.gpu_frame(method, options, scene, (width, height), samples, &effects)?;
        return Ok((Frame::encoded(width, height, made.rgba), made.stats));
    }
    let Effects { depth_cue, outline } = effects;
    let forward = (scene.camera.target - scene.camera.eye).normalize();
    let depths = DepthCue::range(&scene.bounds, &scene.camera);
    let n = samples.max(1);
    let mut image: Option<Frame> = None;
    // Only several samples need the sums and every ray's results.
    // Colour and coverage (the fraction of samples that hit a surface).
    let mut sums = if n > 1 { vec![[0f64; 4]; (width * height) as usize] } else { Vec::new() };
    let mut marched = Vec::new();
    let mut gpu_ns = Some(0.0);
    let mut light = super::light::LightStats { gpu_ns: Some(0.0), ..Default::default() };
    // One build of the tile lists serves every sample: they hold what any
    // ray through any point of a tile's pixels meets.
    renderer.prepare_camera(method, &options, &scene.camera, width, height)?;
    for s in 0..n {
        let (rays, pixels) = camera_rays_through(&scene.camera, width, height, &scene.bounds, |p| subpixel(p, s, n, SAMPLE_SEED));
        let mut out = march_camera_frame(renderer, method, options, &rays, 0)?;
        // Each ray's view depth (infinite on a miss), for the effects.
        let view_depth: Vec<f64> = if depth_cue.is_some() || outline.is_some() {
            out.results
                .iter()
                .zip(&rays)
                .map(|(r, ray)| {
                    if r.counts[3] & FLAG_HIT == 0 {
                        return f64::INFINITY;
                    }
                    let ray = super::rays::Ray::from_gpu(ray);
                    (ray.o + f64::from(r.hit[3]) * ray.d - scene.camera.eye).dot(forward)
                })
                .collect()
        } else {
            Vec::new()
        };
        // Depth cueing, per sample (so anti-aliased edges blend as their
        // samples do), after the lights: toward the background with the
        // hit's depth along the view direction.
        if let Some(cue) = depth_cue {
            let bg = scene.background.to_array();
            for (r, &z) in out.results.iter_mut().zip(&view_depth).filter(|(_, z)| z.is_finite()) {
                let f = cue.blend(z, depths);
                for (c, b) in r.color.iter_mut().zip(bg) {
                    *c = (f64::from(*c) * (1.0 - f) + b * f) as f32;
                }
            }
        }
        gpu_ns = gpu_ns.zip(out.gpu_ns).map(|(a, b)| a + b);
        light.add(&out.light);
        let mut frame = Frame::from_results(width, height, &out.results, &pixels);
        if let Some(outline) = outline {
            // View depth per pixel.
            let mut depth = vec![f64::INFINITY; (width * height) as usize];
            for (&z, p) in view_depth.iter().zip(&pixels) {
                if let Some(p) = p {
                    depth[*p as usize] = z;
                }
            }
            for (px, on) in frame.pixels.iter_mut().zip(outline.mask(&depth, width, height, depths.1 - depths.0)) {
                if on {
                    for (c, o) in px.color.iter_mut().zip(outline.color) {
                        *c = o as f32;
                    }
                }
            }
        }
        for (sum, p) in sums.iter_mut().zip(&frame.pixels) {
            for (s, c) in sum.iter_mut().zip(&p.color[..3]) {
                *s += f64::from(*c);
            }
            sum[3] += f64::from(u8::from(p.counts[3] & FLAG_HIT != 0));
        }
        if n > 1 {
            marched.extend(out.results.iter().zip(&pixels).filter(|(_, p)| p.is_some()).map(|(r, _)| *r));
        }
        match &mut image {
            None => image = Some(frame),
            Some(first) => {
                for (a, b) in first.pixels.iter_mut().zip(&frame.pixels) {
                    for k in 0..3 {
                        a.counts[k] += b.counts[k];
                    }
                    a.crossings[1] += b.crossings[1];
                    a.crossings[2] += b.crossings[2];
                }
            }
        }
    }
    let mut image = image.unwrap_or_else(|| Frame::from_results(width, height, &[], &[]));
    if n == 1 {
        for p in &mut image.pixels {
            p.color[3] = f32::from(u8::from(p.counts[3] & FLAG_HIT != 0));
        }
    } else {
        for (p, sum) in image.pixels.iter_mut().zip(&sums) {
            for (c, s) in p.color.iter_mut().zip(sum) {
                *c = (s / f64::from(n)) as f32;
            }
        }
    }
    // One sample: the frame's pixels are its rays' results.
    let mut stats = if n > 1 { MarchStats::of(marched.iter(), gpu_ns) } else { MarchStats::of(image.pixels.iter(), gpu_ns) };
    stats.any_hit = light.summary();
    Ok((image, stats))
}

/// Statistics of a frame's march over its pixels (not the padding rays
/// that fill the last 8x8 tiles).
pub fn pixel_stats(out: &super::MarchOutput, pixels: &[Option<u32>]) -> MarchStats {
    MarchStats::of(out.results.iter().zip(pixels).filter(|(_, p)| p.is_some()).map(|(r, _)| r), out.gpu_ns)
}

/// Marches a frame's camera rays with `options`. A dielectric scene
/// (transparency with an index of refraction) is traced through its
/// reflections and refractions (`optics::trace`): each pixel's colour is the
/// traced one, and its steps and evaluations count every ray spawned for it.
pub fn march_frame(renderer: &mut Renderer, method: Method, options: MarchOptions, rays: &[crate::layout::GpuRay]) -> Result<super::MarchOutput> {
    march_rays(renderer, method, options, rays, None)
}

/// [`march_frame`] for camera rays in tile order, from ray `first_ray` of
/// the frame the renderer prepared ([`Renderer::prepare_camera`]): through
/// its tile lists where they apply.
pub fn march_camera_frame(
    renderer: &mut Renderer,
    method: Method,
    options: MarchOptions,
    rays: &[crate::layout::GpuRay],
    first_ray: usize,
) -> Result<super::MarchOutput> {
    march_rays(renderer, method, options, rays, Some(first_ray))
}

/// Cut faces capped: a camera ray that starts inside the surface at a
/// clipping plane hits at its start, where the field's gradient is no
/// normal of the cut; it is shaded again (as shade.glsl shades) with the
/// plane's normal, which the lights' shadow and occlusion rays then take.
fn cap(scene: &crate::scene::Scene, rays: &[crate::layout::GpuRay], results: &mut [crate::layout::GpuResult]) {
    let camera = &scene.camera;
    if camera.clip.is_empty() {
        return;
    }
    for (ray, r) in rays.iter().zip(results.iter_mut()) {
        if r.counts[3] & FLAG_HIT == 0 || r.hit[3] != ray.o[3] {
            continue;
        }
        let g = super::rays::Ray::from_gpu(ray);
        let Some((_, _, Some(normal))) = camera.clip.interval(camera, g.o, g.d, (g.t0 - 1e-5 * g.t0.abs().max(1.0), g.t1)) else { continue };
        let n = if normal.dot(g.d) > 0.0 { -normal } else { normal };
        let base = super::light::unpack_base(r.crossings[3]);
        let mut color = base * scene.ambient;
        for l in &scene.lights {
            color += super::light::light_terms(base, n, g.d, l.direction, l.color);
        }
        r.color[..3].copy_from_slice(&color.as_vec3().to_array());
        r.hit[..3].copy_from_slice(&n.as_vec3().to_array());
    }
}

fn march_rays(
    renderer: &mut Renderer,
    method: Method,
    options: MarchOptions,
    rays: &[crate::layout::GpuRay],
    camera_from: Option<usize>,
) -> Result<super::MarchOutput> {
    let dielectric = renderer.scene().transparency.and_then(|t| {
        t.ior.map(|ior| super::optics::Dielectric { ior, absorption: t.absorption, max_depth: t.max_depth, reflectivity: t.reflectivity })
    });
    let Some(material) = dielectric else {
        let mut out = match camera_from {
            Some(first) => renderer.march_camera(method, options, rays, first)?,
            None => renderer.march(method, options, rays, |_| {})?,
        };
        if camera_from.is_some() && options.shade {
            cap(renderer.scene(), rays, &mut out.results);
        }
        out.light = super::light::apply(renderer, method, options, rays, &mut out)?;
        return Ok(out);
    };
    let traced = super::optics::trace(renderer, method, options, rays, material)?;
    let mut results = traced.first;
    for (i, r) in results.iter_mut().enumerate() {
        let c = traced.color[i];
        r.color = [c.x as f32, c.y as f32, c.z as f32, 1.0];
        r.counts[0] = traced.steps[i];
        r.counts[1] = traced.evals[i];
        r.crossings[1] = traced.visits[i];
        r.crossings[2] = traced.turns[i];
    }
    Ok(super::MarchOutput { results, crossings: Vec::new(), gpu_ns: traced.gpu_ns, light: Default::default() })
}

/// Renders and writes every requested file. All files are encoded before
/// the first is written, and each is written atomically.
pub fn render_to_files(ctx: &Arc<Context>, job: &RenderJob) -> Result<RenderStats> {
    let FrameReport { frame, march, index, tiles, memory, pipeline_ms, cost } = render_frame_indexed(ctx, job)?;
    let stats = RenderStats {
        scene: job.scene.source.clone(),
        method: job.method.to_string(),
        device: ctx.info.name.clone(),
        width: job.width,
        height: job.height,
        samples: job.samples,
        pipeline_ms,
        march,
        acceleration: if tiles.is_some() {
            "tiles"
        } else if index.is_some() {
            "grid"
        } else {
            "flat"
        },
        tiles,
        index,
        memory,
        cost,
    };
    let outputs = job.outputs()?;
    // An EXR image with AOVs that go to the same file holds both.
    let (aovs_inside, aovs_apart) = match &outputs.aovs {
        Some(path) if *path == job.output => (&job.aovs[..], None),
        other => (&[][..], other.as_ref()),
    };
    let mut files = vec![(job.output.clone(), output::shaded_bytes(&frame, outputs.image, aovs_inside, job.look())?)];
    if let Some(path) = &job.heatmap {
        let img = output::heatmap_image(frame.width, frame.height, &frame.steps(), job.steps_max);
        files.push((path.clone(), output::png_bytes(&img)?));
    }
    if let Some(path) = aovs_apart {
        files.push((path.clone(), output::exr_bytes(&frame, &job.aovs)?));
    }
    if let Some(path) = &job.stats {
        files.push((path.clone(), serde_json::to_vec_pretty(&stats)?));
    }
    for (path, bytes) in files {
        output::write_atomic(&path, &bytes)?;
    }
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two planes seen face on, the left half of a 12x4 view at depth 10,
    /// the right half at 10 + jump: an outline of width w covers the w
    /// columns of the near plane next to the jump when the jump is above
    /// the threshold (3% of a depth range of 100), and nothing below it.
    #[test]
    fn an_outline_follows_depth_jumps_above_the_threshold_at_its_width() {
        let (w, h) = (12u32, 4u32);
        let planes = |jump: f64| -> Vec<f64> { (0..w * h).map(|i| if i % w < 6 { 10.0 } else { 10.0 + jump }).collect() };
        for width in [1u32, 2, 3] {
            let outline = Outline { width, color: [0.0; 3], jump: 0.03 };
            let above = outline.mask(&planes(3.5), w, h, 100.0);
            let columns: Vec<u32> = (0..w).filter(|&x| above[x as usize]).collect();
            assert_eq!(columns, (6 - width..6).collect::<Vec<_>>(), "width {width}: the line's columns");
            assert!((0..h).all(|y| (0..w).all(|x| above[(y * w + x) as usize] == above[x as usize])), "every row alike");
            assert!(!outline.mask(&planes(2.5), w, h, 100.0).contains(&true), "width {width}: a jump below the threshold drew a line");
        }
        // A miss is a jump of any size: the surface's edge.
        let mut edge = planes(0.0);
        edge.iter_mut().enumerate().filter(|(i, _)| *i as u32 % w >= 6).for_each(|(_, z)| *z = f64::INFINITY);
        let mask = Outline { width: 2, color: [0.0; 3], jump: 0.5 }.mask(&edge, w, h, 100.0);
        assert_eq!((0..w).filter(|&x| mask[x as usize]).collect::<Vec<_>>(), [4, 5]);
    }
}
