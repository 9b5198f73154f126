//! The window shell: winit's handler, the window and its swapchain, and
//! each turn's work as the schedule (schedule.rs) decides it.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, anyhow};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow};
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::window::{Window, WindowId};

use super::canvas::Canvas;
use super::controls::{Camera, Control, Controls};
use super::player::{PREFETCH_DEPTH, Player};
use super::schedule::{Phase, Schedule, Work, after_pass, after_preview, next_work};
use super::title::Title;
use super::{PlaybackStats, ViewOptions, ViewSummary};
use isomarch::gpu::{Context, ContextOptions, Presented, Presenter};
use isomarch::layout::GpuRay;
use isomarch::method::Method;
use isomarch::molecule::playback::{Order, Prefetch};
use isomarch::output::{self, LEGEND_HEIGHT};
use isomarch::render::frame::Readback;
use isomarch::render::offscreen::{Effects, SAMPLE_SEED};
use isomarch::render::offscreen::{march_camera_frame, pixel_stats};
use isomarch::render::rays::{PIXEL_TILE, camera_rays, camera_rays_through, subpixel};
use isomarch::render::{MarchOptions, Renderer};
use isomarch::scene::Scene;

/// How long a frame at rest may hold the window when made whole on the GPU
/// in one submission (a window at rest answers its input after it); a
/// frame measured to cost more is marched tile by tile on the host within
/// the preview's budget, as before.
const REST_BUDGET: Duration = Duration::from_secs(1);

/// The full-resolution frame being marched tile by tile.
struct Progressive {
    /// Anti-aliasing: which of `samples` sub-pixel positions this pass
    /// marches (`None`: the pixels' centres).
    sample: Option<u32>,
    scene: Scene,
    /// The frame's size: the rays are its camera rays, in tile order.
    size: (u32, u32),
    rays: Vec<GpuRay>,
    pixels: Vec<Option<u32>>,
    next: usize,
    steps: u64,
    rays_done: u64,
    started: Instant,
}

struct Gpu {
    // Field order is drop order: the presenter and renderer go before the
    // window whose surface they use.
    presenter: Presenter,
    renderer: Renderer,
    window: Window,
}

pub struct App {
    options: ViewOptions,
    player: Option<Player>,
    gpu: Option<Gpu>,
    ctx: Option<Arc<Context>>,
    error: Option<anyhow::Error>,
    controls: Controls,
    canvas: Canvas,
    /// Frames made whole on the GPU ([`App::gpu_frame`]): previews and
    /// resting frames.
    gpu_frames: u64,
    /// Presents of an image on the GPU, and whether the last was one.
    gpu_presents: (u64, bool),
    camera: Camera,
    schedule: Schedule,
    /// The full-resolution pass under way (`Phase::Refining`).
    pass: Option<Progressive>,
}

impl App {
    pub fn new(mut options: ViewOptions) -> Result<App> {
        let now = Instant::now();
        let player = match options.frames.take() {
            Some(p) => {
                let len = p.stager.len();
                let next = (p.start + 1) % len;
                Some(Player {
                    prefetch: Prefetch::spawn(p.stager, Order::Loop(next), PREFETCH_DEPTH)?,
                    len,
                    every_frame: p.every_frame,
                    loops: p.loops,
                    frame: p.start,
                    time_ps: None,
                    scene: options.scene.clone(),
                    expected: next,
                    stats: PlaybackStats { shown: 1, ..Default::default() },
                    taken_at: 0,
                })
            }
            None => None,
        };
        Ok(App {
            controls: Controls::new(&options, now),
            canvas: Canvas::default(),
            gpu_frames: 0,
            gpu_presents: (0, false),
            camera: Camera::new(&options, now),
            schedule: Schedule::new(now),
            pass: None,
            player,
            options,
            gpu: None,
            ctx: None,
            error: None,
        })
    }

    /// What the session did, once the event loop has ended; its error if
    /// it failed.
    pub fn finish(mut self) -> Result<ViewSummary> {
        if let Some(e) = self.error.take() {
            // The GPU objects go first, while the window still exists.
            self.gpu = None;
            return Err(e);
        }
        self.gpu = None;
        Ok(ViewSummary {
            presented: self.schedule.presented,
            full_frames: self.schedule.full_frames,
            gpu_frames: self.gpu_frames,
            gpu_presents: self.gpu_presents.0,
            last_from_gpu: self.gpu_presents.1,
            seconds: self.schedule.started.elapsed().as_secs_f64(),
            method: self.controls.method,
            steps_per_ray: self.schedule.steps_per_ray,
            ctx: self.ctx.take(),
            playback: self.player.as_ref().map(|p| p.stats),
        })
    }

    /// The scene file's name without folder and extension.
    fn scene_name(&self) -> String {
        std::path::Path::new(&self.options.scene.source).file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned())
    }

    fn animated(&self) -> bool {
        !self.options.scene.animation.is_static() || self.player.as_ref().is_some_and(|p| p.len > 1)
    }

    /// The scene as it should look now, for an image of `size`.
    fn posed(&self, size: (u32, u32)) -> Scene {
        self.posed_in_world(size).recentred_on_camera()
    }

    /// [`App::posed`] in the scene's own coordinates (not re-centred on
    /// the eye): its camera is the one the window shows.
    fn posed_in_world(&self, size: (u32, u32)) -> Scene {
        let base = self.player.as_ref().map_or(&self.options.scene, |p| &p.scene);
        let mut s = base.at_time(self.camera.time);
        if !self.controls.transparency {
            s.transparency = None;
        }
        self.camera.orbit.apply(&mut s);
        (s.camera.width, s.camera.height) = size;
        s
    }

    /// Writes the camera the window shows as a RON camera block, beside the
    /// screenshots: `render SCENE --camera FILE` makes this frame.
    fn save_camera(&mut self) -> Result<()> {
        let Some(gpu) = &self.gpu else { return Ok(()) };
        let camera = self.posed_in_world(gpu.presenter.extent()).camera;
        self.controls.cameras += 1;
        let path = self.options.screenshot_dir.join(format!("{}-camera-{}.ron", self.scene_name(), self.controls.cameras));
        output::write_atomic(&path, camera.to_ron().as_bytes())?;
        eprintln!("saved the camera to {} (render SCENE --camera {} makes this view)", path.display(), path.display());
        Ok(())
    }

    fn open(&mut self, el: &ActiveEventLoop) -> Result<()> {
        let (w, h) = self.options.size;
        let attributes =
            Window::default_attributes().with_title(format!("isomarch: {}", self.options.scene.source)).with_inner_size(PhysicalSize::new(w, h));
        let window = el.create_window(attributes).context("creating the window")?;
        let display = el.display_handle().map_err(|e| anyhow!("the display's handle: {e}"))?.as_raw();
        let ctx = Context::new(&ContextOptions { validation: self.options.validation, device: self.options.device.clone(), present: Some(display) })?;
        let size = window.inner_size();
        let window_handle = window.window_handle().map_err(|e| anyhow!("the window's handle: {e}"))?.as_raw();
        let presenter = Presenter::new(&ctx, display, window_handle, (size.width.max(1), size.height.max(1)), self.options.timeout)?;
        let renderer = Renderer::for_camera(&ctx, &self.posed(presenter.extent()), self.options.timeout)?;
        self.ctx = Some(ctx);
        self.gpu = Some(Gpu { presenter, renderer, window });
        self.camera.clock = Instant::now();
        Ok(())
    }

    fn control(&mut self, el: &ActiveEventLoop, control: Control) -> Result<()> {
        match control {
            Control::Quit => el.exit(),
            Control::TogglePlaying => {
                self.camera.toggle_playing();
                // Paused on a preview: draw the frame again, then in full.
                self.schedule.invalidate();
            }
            Control::Step(frames) => {
                self.camera.step(frames, self.options.fps);
                self.schedule.invalidate();
            }
            Control::NextMethod => {
                self.controls.next_method();
                self.schedule.remeasure();
            }
            Control::ToggleHeatmap => {
                self.controls.heatmap = !self.controls.heatmap;
                if self.controls.heatmap && self.canvas.steps.iter().all(|&s| s == 0) {
                    // A preview made on the GPU kept no steps: again, on
                    // the host.
                    self.schedule.invalidate();
                }
                self.show()?;
            }
            Control::ToggleTransparency if self.options.scene.transparency.is_some() => {
                self.controls.transparency = !self.controls.transparency;
                if !self.controls.usable(self.controls.method) {
                    self.controls.method = Method::QuadraticTaylor;
                }
                self.schedule.remeasure();
            }
            Control::ToggleTransparency => {}
            Control::Screenshot => self.save_screenshot(None)?,
            Control::SaveCamera => self.save_camera()?,
            Control::Faster => self.camera.speed = (self.camera.speed * 2.0).min(64.0),
            Control::Slower => self.camera.speed = (self.camera.speed / 2.0).max(1.0 / 64.0),
        }
        self.update_title(true);
        Ok(())
    }

    fn save_screenshot(&mut self, path: Option<PathBuf>) -> Result<()> {
        self.read_back_gpu_frame()?;
        let Some(gpu) = &self.gpu else { return Ok(()) };
        let (w, h) = gpu.presenter.extent();
        if !self.canvas.is_whole(w, h) {
            // Nothing whole to save (the window changed size just now).
            return match path {
                Some(p) => Err(anyhow!("no complete frame to save to {} (the window was resized or never drawn)", p.display())),
                None => Ok(()),
            };
        }
        let path = path.unwrap_or_else(|| {
            self.controls.screenshots += 1;
            let name = format!("{}-{}-{:.3}s-{}.png", self.scene_name(), self.controls.method, self.camera.time, self.controls.screenshots);
            self.options.screenshot_dir.join(name)
        });
        let img = image::RgbImage::from_raw(w, h, self.displayed()).ok_or_else(|| anyhow!("screenshot size"))?;
        output::write_atomic(&path, &output::png_bytes(&img)?)?;
        if self.schedule.finished() {
            eprintln!("saved {}", path.display());
        } else {
            eprintln!(
                "saved {}: a preview ({}), since the view was still changing; pause it (--paused, or Space) for the full frame",
                path.display(),
                if self.schedule.preview_divisor > 1 {
                    format!("1/{} resolution", self.schedule.preview_divisor)
                } else {
                    "the full frame not yet complete".to_string()
                }
            );
        }
        Ok(())
    }

    /// The pixels the window shows: the shaded frame, or its steps through
    /// the heatmap's colour map with its legend along the bottom.
    fn displayed(&self) -> Vec<u8> {
        let Some(gpu) = &self.gpu else { return Vec::new() };
        let (w, h) = gpu.presenter.extent();
        let shown = &self.canvas;
        if !self.controls.heatmap || h <= LEGEND_HEIGHT + 8 || shown.steps.len() != (w * h) as usize {
            return shown.rgb.clone();
        }
        let rows = h - LEGEND_HEIGHT;
        output::heatmap_image(w, rows, &shown.steps[..(w * rows) as usize], None).into_raw()
    }

    /// Where the window shows a frame made on the GPU, its pixels read
    /// back into the canvas (scaled to the window as the GPU scaled them),
    /// for what the host does with them: a screenshot, tiles marched over
    /// it, the heatmap.
    fn read_back_gpu_frame(&mut self) -> Result<()> {
        let (Some(small), Some(gpu)) = (self.canvas.on_gpu, &mut self.gpu) else { return Ok(()) };
        let rgba = gpu.renderer.read_frame_image((small.0 * small.1) as usize)?;
        let rgb: Vec<u8> = rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
        let size = gpu.presenter.extent();
        // No steps: the heatmap marches on the host (gpu_frame).
        self.canvas.upscale(small, &rgb, &vec![0; (small.0 * small.1) as usize], size);
        Ok(())
    }

    /// Shows the canvas: a frame made on the GPU presented from there, or
    /// the host's pixels (or their heatmap) uploaded.
    fn show(&mut self) -> Result<()> {
        let from_gpu = self.canvas.on_gpu.filter(|_| !self.controls.heatmap);
        if from_gpu.is_none() {
            self.read_back_gpu_frame()?;
        }
        let pixels = if from_gpu.is_some() { Vec::new() } else { self.displayed() };
        let Some(gpu) = &mut self.gpu else { return Ok(()) };
        let shown = match from_gpu {
            Some(small) => {
                let image = gpu.renderer.frame_image().ok_or_else(|| anyhow!("no frame made on the GPU to show"))?;
                gpu.presenter.present_image(image, small)?
            }
            None if pixels.is_empty() => return Ok(()),
            None => gpu.presenter.present(&pixels)?,
        };
        if shown != Presented::OutOfDate {
            self.gpu_presents = (self.gpu_presents.0 + u64::from(from_gpu.is_some()), from_gpu.is_some());
            self.schedule.presented += 1;
            self.schedule.fps_window.1 += 1;
        }
        if shown != Presented::Yes {
            // Rebuild the swapchain for the window as it is now.
            let size = gpu.window.inner_size();
            self.resize(size)?;
        }
        Ok(())
    }

    fn resize(&mut self, size: PhysicalSize<u32>) -> Result<()> {
        let schedule = &mut self.schedule;
        schedule.minimised = size.width == 0 || size.height == 0;
        if schedule.minimised {
            return Ok(());
        }
        let Some(gpu) = &mut self.gpu else { return Ok(()) };
        let before = gpu.presenter.extent();
        if !gpu.presenter.resize((size.width, size.height))? {
            schedule.minimised = true;
            return Ok(());
        }
        if gpu.presenter.extent() == before && !self.canvas.is_empty() {
            return Ok(());
        }
        self.canvas.clear();
        self.pass = None;
        schedule.invalidate();
        Ok(())
    }

    /// Marches `rays` of `scene`, the camera rays of its `size` frame from
    /// ray `first` on (whole tiles), updating the measured wall cost per
    /// ray. Camera rays take their candidates as `render`'s do (the tile
    /// lists where they apply).
    fn march(&mut self, scene: &Scene, size: (u32, u32), rays: &[GpuRay], first: usize) -> Result<isomarch::render::MarchOutput> {
        let gpu = self.gpu.as_mut().ok_or_else(|| anyhow!("no window"))?;
        gpu.renderer.set_scene(scene)?;
        let t = Instant::now();
        // Transparent as shown: T takes the posed scene's transparency away.
        let options = MarchOptions::for_scene(scene);
        gpu.renderer.prepare_camera(self.controls.method, &options, &scene.camera, size.0, size.1)?;
        let out = march_camera_frame(&mut gpu.renderer, self.controls.method, options, rays, first)?;
        self.schedule.measured(t.elapsed(), rays.len());
        if let Some(p) = &mut self.player {
            p.stats.march_ms += t.elapsed().as_secs_f64() * 1e3;
        }
        Ok(out)
    }

    /// A frame made whole on the GPU (render::frame: the camera rays, the
    /// march, the look, `samples` samples' mean and the 8-bit image, left
    /// on the GPU for the window to present: the canvas shows it) where it
    /// applies and the steps heatmap is not shown (it needs every ray's
    /// steps): its steps per ray, shadows and occlusion included where the
    /// scene asks, as `render` makes them.
    fn gpu_frame(&mut self, scene: &Scene, size: (u32, u32), samples: u32) -> Result<Option<f64>> {
        let Some(gpu) = self.gpu.as_mut() else { return Ok(None) };
        let options = MarchOptions::for_scene(scene);
        if self.controls.heatmap || !gpu.renderer.gpu_frame_applies(&options, scene, size) {
            return Ok(None);
        }
        // The window may still be reading the last frame's image, which
        // this frame writes (or frees, for a larger one).
        gpu.presenter.wait_idle_frame()?;
        gpu.renderer.set_scene(scene)?;
        let (t, pipelines) = (Instant::now(), gpu.renderer.pipeline_ms());
        let method = self.controls.method;
        gpu.renderer.prepare_camera(method, &options, &scene.camera, size.0, size.1)?;
        let frame = gpu.renderer.gpu_frame_reading(method, options, scene, size, samples, &Effects::default(), Readback::Statistics)?;
        let rays = (size.0.div_ceil(PIXEL_TILE) * size.1.div_ceil(PIXEL_TILE) * PIXEL_TILE * PIXEL_TILE) as usize;
        // The frame's cost without the pipelines made for it (once: the
        // first frame would otherwise price every later one).
        let made = Duration::from_secs_f64(((gpu.renderer.pipeline_ms() - pipelines) * 1e-3).max(0.0));
        self.schedule.measured(t.elapsed().saturating_sub(made), rays * samples as usize);
        if let Some(p) = &mut self.player {
            p.stats.march_ms += t.elapsed().as_secs_f64() * 1e3;
        }
        self.gpu_frames += 1;
        self.canvas.show_gpu(size);
        Ok(Some(frame.stats.steps_per_ray))
    }

    /// At rest, the full-resolution frame made whole on the GPU with all its
    /// anti-aliasing samples (as `render` makes it), where that path
    /// applies and the frame's cost, as measured so far, fits
    /// [`REST_BUDGET`] (or the preview's budget, if longer): the window
    /// then shows the GPU's image and marches no tiles on the host. `false`:
    /// the frame is left to the tiles.
    fn gpu_rest_frame(&mut self, size: (u32, u32)) -> Result<bool> {
        let samples = self.options.samples.max(1);
        let rays = f64::from(size.0) * f64::from(size.1) * f64::from(samples);
        if rays > self.schedule.affordable_rays(self.options.preview.max(REST_BUDGET)) {
            return Ok(false);
        }
        let scene = self.posed(size);
        let started = Instant::now();
        let Some(steps_per_ray) = self.gpu_frame(&scene, size, samples)? else { return Ok(false) };
        let schedule = &mut self.schedule;
        schedule.frame_ms = started.elapsed().as_secs_f64() * 1e3;
        schedule.steps_per_ray = steps_per_ray;
        schedule.full_frames += 1;
        schedule.preview_divisor = 1;
        schedule.phase = Phase::Idle;
        Ok(true)
    }

    /// Renders at a resolution that fits the preview budget and shows it
    /// scaled up to the window; full resolution when that fits.
    fn preview_frame(&mut self, size: (u32, u32)) -> Result<()> {
        let full_rays = f64::from(size.0) * f64::from(size.1);
        let affordable = self.schedule.affordable_rays(self.options.preview);
        let divisor = (full_rays / affordable.max(64.0)).sqrt().ceil().clamp(1.0, 64.0) as u32;
        self.schedule.preview_divisor = divisor;
        let small = (size.0.div_ceil(divisor).max(1), size.1.div_ceil(divisor).max(1));
        let scene = self.posed(small);
        let started = Instant::now();
        if let Some(steps_per_ray) = self.gpu_frame(&scene, small, 1)? {
            let schedule = &mut self.schedule;
            schedule.frame_ms = started.elapsed().as_secs_f64() * 1e3;
            schedule.steps_per_ray = steps_per_ray;
        } else {
            let (rays, pixels) = camera_rays(&scene.camera, small.0, small.1, &scene.bounds);
            let out = self.march(&scene, small, &rays, 0)?;
            let frame = output::Frame::from_results(small.0, small.1, &out.results, &pixels);
            let schedule = &mut self.schedule;
            schedule.frame_ms = started.elapsed().as_secs_f64() * 1e3;
            schedule.steps_per_ray = pixel_stats(&out, &pixels).steps_per_ray;
            // Nearest-neighbour scale-up to the window.
            self.canvas.upscale(small, frame.shaded().as_raw(), &frame.steps(), size);
        }
        let schedule = &mut self.schedule;
        if divisor == 1 {
            schedule.full_frames += 1;
        }
        // Anti-aliasing starts again from its first pass.
        schedule.phase = after_preview(divisor, self.options.samples);
        self.show()
    }

    /// Starts marching the full-resolution frame, tile by tile: through the
    /// pixels' centres, or anti-aliasing pass `sample` of `samples`.
    fn start_pass(&mut self, size: (u32, u32), sample: Option<u32>) -> Result<()> {
        // The first pass at rest: the whole frame on the GPU where it can.
        if sample.is_none_or(|s| s == 0) && self.gpu_rest_frame(size)? {
            return self.show();
        }
        // The tiles are drawn over the frame shown, on the host.
        self.read_back_gpu_frame()?;
        let scene = self.posed(size);
        let n = self.options.samples;
        let (rays, pixels) = match sample {
            None => camera_rays(&scene.camera, size.0, size.1, &scene.bounds),
            Some(s) => camera_rays_through(&scene.camera, size.0, size.1, &scene.bounds, |p| subpixel(p, s, n, SAMPLE_SEED)),
        };
        if sample == Some(0) {
            self.canvas.restart_mean((size.0 * size.1) as usize);
        }
        self.schedule.phase = Phase::Refining(sample);
        self.pass = Some(Progressive { sample, scene, size, rays, pixels, next: 0, steps: 0, rays_done: 0, started: Instant::now() });
        self.progressive_step()
    }

    /// Marches the next tiles of the full-resolution frame (as many as fit
    /// the budget) and shows them over the preview.
    fn progressive_step(&mut self) -> Result<()> {
        let Some(mut job) = self.pass.take() else { return Ok(()) };
        let tile = (PIXEL_TILE * PIXEL_TILE) as usize;
        let count = (self.schedule.affordable_rays(self.options.preview) as usize / tile).max(1) * tile;
        let end = (job.next + count).min(job.rays.len());
        let results = self.march(&job.scene, job.size, &job.rays[job.next..end], job.next)?.results;
        let schedule = &mut self.schedule;
        for (r, p) in results.iter().zip(&job.pixels[job.next..end]) {
            let Some(p) = *p else { continue };
            self.canvas.put(p as usize, [r.color[0], r.color[1], r.color[2]], r.counts[0], job.sample);
            job.steps += u64::from(r.counts[0]);
            job.rays_done += 1;
        }
        job.next = end;
        if job.next < job.rays.len() {
            self.pass = Some(job);
        } else {
            schedule.phase = after_pass(job.sample, self.options.samples);
            schedule.full_frames += 1;
            schedule.preview_divisor = 1;
            schedule.frame_ms = job.started.elapsed().as_secs_f64() * 1e3;
            schedule.steps_per_ray = job.steps as f64 / job.rays_done.max(1) as f64;
        }
        self.show()
    }

    /// One turn of the render loop: what to draw now, if anything.
    fn tick(&mut self, el: &ActiveEventLoop) -> Result<()> {
        if self.gpu.is_none() || self.schedule.minimised {
            el.set_control_flow(ControlFlow::Wait);
            return Ok(());
        }
        if let Some(n) = self.options.exit_after
            && self.schedule.presented >= n
        {
            // A screenshot waits for the whole frame unless the view moves,
            // where every frame is a preview (its line says so).
            let moving = (self.camera.playing && self.animated()) || self.controls.moving();
            if self.options.screenshot.is_none() || moving || self.schedule.finished() {
                el.exit();
                return Ok(());
            }
        }
        if self.player.as_ref().is_some_and(|p| p.done()) && self.schedule.phase != Phase::Stale {
            el.exit();
            return Ok(());
        }
        self.camera.advance();
        if let Some(p) = &mut self.player {
            let playing = self.camera.playing && p.len > 1;
            if p.every_frame && playing {
                // The next frame once this one has been presented, whatever
                // the clock says; scene time follows.
                let next = (p.frame + 1) % p.len;
                if self.schedule.presented > p.taken_at && !p.done() && p.fetch(next, true)? {
                    p.taken_at = self.schedule.presented;
                    self.camera.time = (p.stats.shown - 1) as f64 / self.options.fps;
                    self.schedule.invalidate();
                }
            } else {
                let wanted = p.frame_at(self.camera.time, self.options.fps);
                if p.fetch(wanted, false)? {
                    self.schedule.invalidate();
                }
            }
        }
        let size = self.gpu.as_ref().map(|g| g.presenter.extent()).unwrap_or((1, 1));
        let moving = (self.camera.playing && self.animated()) || self.controls.moving();
        // Scripted runs keep presenting, even a still view.
        let scripted = self.options.exit_after.is_some();
        match next_work(self.schedule.phase, moving, scripted) {
            Work::Preview => {
                self.pass = None;
                self.preview_frame(size)?;
            }
            Work::Refine => self.progressive_step()?,
            // At rest on a preview: march the full frame, tile by tile; at
            // rest on a whole frame: the next anti-aliasing pass.
            Work::StartPass(sample) => self.start_pass(size, sample)?,
            Work::Present => self.show()?,
            Work::Wait => {}
        }
        let waiting = self.player.as_ref().is_some_and(|p| p.frame != p.frame_at(self.camera.time, self.options.fps) && !p.every_frame);
        let busy = moving || self.schedule.phase != Phase::Idle || scripted || waiting;
        // Going idle: the title must show the final state.
        self.update_title(!busy);
        el.set_control_flow(if busy { ControlFlow::Poll } else { ControlFlow::Wait });
        Ok(())
    }

    fn update_title(&mut self, now: bool) {
        let Some(gpu) = &self.gpu else { return };
        let schedule = &mut self.schedule;
        let since = schedule.fps_window.0.elapsed().as_secs_f64();
        if since >= 1.0 {
            schedule.fps = schedule.fps_window.1 as f64 / since;
            schedule.fps_window = (Instant::now(), 0);
        }
        if !now && schedule.title_at.elapsed() < Duration::from_millis(250) {
            return;
        }
        schedule.title_at = Instant::now();
        let name = self.scene_name();
        let (schedule, controls, camera) = (&self.schedule, &self.controls, &self.camera);
        let title = Title {
            name: &name,
            method: controls.method,
            frame_ms: schedule.frame_ms,
            fps: schedule.fps,
            steps_per_ray: schedule.steps_per_ray,
            time: camera.time,
            refining: self.pass.as_ref().map(|job| job.next as f64 / job.rays.len().max(1) as f64),
            preview_divisor: schedule.preview_divisor,
            frame: self.player.as_ref().map(|p| (p.frame, p.len, p.time_ps)),
            speed: camera.speed,
            paused: !camera.playing,
            heatmap: controls.heatmap,
            pass: self.pass.as_ref().and_then(|j| j.sample).map(|s| (s, self.options.samples)),
            opaque: self.options.scene.transparency.is_some() && !controls.transparency,
        };
        gpu.window.set_title(&title.to_string());
    }

    fn handle(&mut self, el: &ActiveEventLoop, event: WindowEvent) -> Result<()> {
        match event {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::Resized(size) => self.resize(size)?,
            WindowEvent::Occluded(hidden) => {
                self.schedule.minimised = hidden;
                self.schedule.invalidate();
            }
            // Held keys repeat only where repeating makes sense (stepping);
            // keys found held when the window gains focus are not presses.
            WindowEvent::KeyboardInput { event, is_synthetic, .. }
                if event.state == ElementState::Pressed && !is_synthetic && (!event.repeat || Control::repeats(&event.logical_key)) =>
            {
                if let Some(control) = Control::of_key(&event.logical_key) {
                    self.control(el, control)?;
                }
            }
            WindowEvent::MouseInput { state, button: MouseButton::Left, .. } => {
                self.controls.drag = (state == ElementState::Pressed).then_some(self.controls.cursor);
                self.controls.last_input = Instant::now();
            }
            WindowEvent::CursorMoved { position, .. } => {
                let input = &mut self.controls;
                input.cursor = (position.x, position.y);
                if let (Some((x0, y0)), Some(gpu)) = (input.drag, &self.gpu) {
                    let h = f64::from(gpu.presenter.extent().1.max(1));
                    // A drag across the window's height turns by 180 degrees.
                    let orbit = &mut self.camera.orbit;
                    orbit.yaw -= (position.x - x0) / h * std::f64::consts::PI;
                    orbit.pitch = (orbit.pitch + (position.y - y0) / h * std::f64::consts::PI).clamp(-3.0, 3.0);
                    input.drag = Some(input.cursor);
                    input.last_input = Instant::now();
                    self.schedule.invalidate();
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => f64::from(y),
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                self.camera.orbit.zoom = (self.camera.orbit.zoom - 0.1 * lines).clamp(-5.0, 5.0);
                self.controls.last_input = Instant::now();
                self.schedule.invalidate();
            }
            _ => {}
        }
        Ok(())
    }

    fn fail(&mut self, el: &ActiveEventLoop, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        el.exit();
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.gpu.is_none()
            && self.error.is_none()
            && let Err(e) = self.open(el)
        {
            self.fail(el, e);
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        if let Err(e) = self.handle(el, event) {
            self.fail(el, e);
        }
    }

    fn about_to_wait(&mut self, el: &ActiveEventLoop) {
        if self.error.is_some() {
            return;
        }
        if let Err(e) = self.tick(el) {
            self.fail(el, e);
        }
    }

    fn exiting(&mut self, _el: &ActiveEventLoop) {
        if self.error.is_none()
            && let Some(path) = self.options.screenshot.clone()
            && let Err(e) = self.save_screenshot(Some(path))
        {
            self.error = Some(e);
        }
    }
}
