//! `isomarch view`: a window playing the scene's animation in scene time.
//!
//! Each frame is marched with compute like an offscreen one, read back, and
//! copied into the window's swapchain ([`Presenter`]). Rendering never
//! holds the window for long: the measured cost per ray sizes every piece
//! of work to `preview` wall time. While the view moves (playing an
//! animation, dragging, zooming) frames are marched at a lower resolution
//! that fits that budget and scaled up; once it rests, the full-resolution
//! frame is marched progressively in tiles that fit the same budget, each
//! presented over the preview as it lands, with window events handled
//! between them.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, anyhow};
use glam::{DQuat, DVec3};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::window::{Window, WindowId};

use crate::gpu::{Context, ContextOptions, Presented, Presenter};
use crate::layout::GpuRay;
use crate::method::Method;
use crate::output::{self, LEGEND_HEIGHT};
use crate::render::{MarchOptions, Renderer};
use crate::render::offscreen::{march_frame, pixel_stats};
use crate::render::rays::{PIXEL_TILE, camera_rays};
use crate::scene::Scene;

/// How to open the viewer.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    /// The scene as loaded (with its animation).
    pub scene: Scene,
    pub method: Method,
    /// Initial window size in pixels.
    pub size: (u32, u32),
    /// Scene time at start, seconds.
    pub time: f64,
    /// Start paused.
    pub paused: bool,
    /// Left/Right step by 1/fps seconds of scene time.
    pub fps: f64,
    /// Wall time one piece of rendering may take before the window handles
    /// its events again (sets the preview resolution and the tiles).
    pub preview: Duration,
    /// Close after this many presented frames (tests, scripted captures).
    pub exit_after: Option<u64>,
    /// At exit, save the last presented image here.
    pub screenshot: Option<PathBuf>,
    /// Where S saves screenshots.
    pub screenshot_dir: PathBuf,
    pub device: Option<String>,
    pub validation: bool,
    pub timeout: Duration,
}

/// What a viewer session did, for the caller to report.
pub struct ViewSummary {
    pub presented: u64,
    pub full_frames: u64,
    pub seconds: f64,
    pub method: Method,
    pub steps_per_ray: f64,
    /// The device's context, for its validation messages.
    pub ctx: Option<Arc<Context>>,
}

/// Runs the viewer until the window closes (Esc, the close button, or
/// `exit_after` frames).
pub fn run(options: ViewOptions) -> Result<ViewSummary> {
    let event_loop = EventLoop::new().context("opening the window system (no display? under CI, run inside Xvfb)")?;
    let mut app = App::new(options);
    event_loop.run_app(&mut app).context("running the window's event loop")?;
    if let Some(e) = app.error.take() {
        // The GPU objects go first, while the window still exists.
        app.gpu = None;
        return Err(e);
    }
    app.gpu = None;
    Ok(ViewSummary {
        presented: app.presented,
        full_frames: app.full_frames,
        seconds: app.started.elapsed().as_secs_f64(),
        method: app.method,
        steps_per_ray: app.steps_per_ray,
        ctx: app.ctx.take(),
    })
}

/// The user's changes to the scene's camera: turns about the target and a
/// distance factor, applied on top of the camera's own path.
#[derive(Clone, Copy, Debug, Default)]
struct Orbit {
    yaw: f64,
    pitch: f64,
    /// log of the distance factor.
    zoom: f64,
}

impl Orbit {
    fn apply(&self, scene: &mut Scene) {
        let cam = &mut scene.camera;
        let up = cam.up.normalize();
        let offset = cam.eye - cam.target;
        let turned = DQuat::from_axis_angle(up, self.yaw) * offset;
        // Pitch about the camera's right axis, kept clear of the poles.
        let elevation = (turned.normalize().dot(up)).clamp(-1.0, 1.0).asin();
        // The scene's own camera may be steeper: it is never moved unasked.
        let limit = 85f64.to_radians().max(elevation.abs());
        let pitch = (elevation + self.pitch).clamp(-limit, limit) - elevation;
        let right = turned.cross(up).normalize_or_zero();
        let pitched = if right == DVec3::ZERO { turned } else { DQuat::from_axis_angle(right, pitch) * turned };
        cam.eye = cam.target + pitched * self.zoom.exp();
    }
}

/// The full-resolution frame being marched tile by tile.
struct Progressive {
    scene: Scene,
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

struct App {
    options: ViewOptions,
    gpu: Option<Gpu>,
    ctx: Option<Arc<Context>>,
    error: Option<anyhow::Error>,
    method: Method,
    /// Scene time shown, and the wall clock it advances with.
    time: f64,
    playing: bool,
    clock: Instant,
    orbit: Orbit,
    transparency: bool,
    heatmap: bool,
    drag: Option<(f64, f64)>,
    cursor: (f64, f64),
    last_input: Instant,
    /// Something changed since the last frame: render again.
    dirty: bool,
    minimised: bool,
    /// Wall nanoseconds per ray, measured (exponential average).
    ns_per_ray: Option<f64>,
    /// What the window shows: the frame's steps and shaded colours.
    shown_rgb: Vec<u8>,
    shown_steps: Vec<u32>,
    progressive: Option<Progressive>,
    /// The window shows a preview: march the full frame once at rest.
    wants_full: bool,
    presented: u64,
    full_frames: u64,
    steps_per_ray: f64,
    frame_ms: f64,
    preview_divisor: u32,
    fps_window: (Instant, u64),
    fps: f64,
    title_at: Instant,
    screenshots: u32,
    started: Instant,
}

impl App {
    fn new(options: ViewOptions) -> App {
        let now = Instant::now();
        App {
            method: options.method,
            time: options.time,
            playing: !options.paused,
            transparency: options.scene.transparency.is_some(),
            options,
            gpu: None,
            ctx: None,
            error: None,
            clock: now,
            orbit: Orbit::default(),
            heatmap: false,
            drag: None,
            cursor: (0.0, 0.0),
            last_input: now - Duration::from_secs(1),
            dirty: true,
            minimised: false,
            ns_per_ray: None,
            shown_rgb: Vec::new(),
            shown_steps: Vec::new(),
            progressive: None,
            wants_full: false,
            presented: 0,
            full_frames: 0,
            steps_per_ray: 0.0,
            frame_ms: 0.0,
            preview_divisor: 1,
            fps_window: (now, 0),
            fps: 0.0,
            title_at: now,
            screenshots: 0,
            started: now,
        }
    }

    /// The scene file's name without folder and extension.
    fn scene_name(&self) -> String {
        std::path::Path::new(&self.options.scene.source).file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned())
    }

    fn animated(&self) -> bool {
        !self.options.scene.animation.is_static()
    }

    /// The scene as it should look now, for an image of `size`.
    fn posed(&self, size: (u32, u32)) -> Scene {
        let mut s = self.options.scene.at_time(self.time);
        if !self.transparency {
            s.transparency = None;
        }
        self.orbit.apply(&mut s);
        (s.camera.width, s.camera.height) = size;
        s.recentred_on_camera()
    }

    fn open(&mut self, el: &ActiveEventLoop) -> Result<()> {
        let (w, h) = self.options.size;
        let attributes = Window::default_attributes()
            .with_title(format!("isomarch: {}", self.options.scene.source))
            .with_inner_size(PhysicalSize::new(w, h));
        let window = el.create_window(attributes).context("creating the window")?;
        let display = el.display_handle().map_err(|e| anyhow!("the display's handle: {e}"))?.as_raw();
        let ctx = Context::new(&ContextOptions {
            validation: self.options.validation,
            device: self.options.device.clone(),
            present: Some(display),
        })?;
        let size = window.inner_size();
        let window_handle = window.window_handle().map_err(|e| anyhow!("the window's handle: {e}"))?.as_raw();
        let presenter = Presenter::new(&ctx, display, window_handle, (size.width.max(1), size.height.max(1)), self.options.timeout)?;
        let mut renderer = Renderer::new(&ctx, &self.posed(presenter.extent()))?;
        renderer.timeout = self.options.timeout;
        self.ctx = Some(ctx);
        self.gpu = Some(Gpu { presenter, renderer, window });
        self.clock = Instant::now();
        Ok(())
    }

    /// Methods the scene can be marched with as shown (the bisection
    /// baselines find only a first entering crossing: opaque only).
    fn usable(&self, m: Method) -> bool {
        !(self.transparency && matches!(m, Method::LinearBisection | Method::Raa))
    }

    fn key(&mut self, el: &ActiveEventLoop, key: &Key) -> Result<()> {
        let fps = self.options.fps;
        match key {
            Key::Named(NamedKey::Escape) => el.exit(),
            Key::Named(NamedKey::Space) => {
                self.playing = !self.playing;
                self.clock = Instant::now();
                // Paused on a preview: draw the frame again, then in full.
                self.dirty = true;
            }
            Key::Named(NamedKey::ArrowRight) | Key::Named(NamedKey::ArrowLeft) => {
                self.playing = false;
                let step = if matches!(key, Key::Named(NamedKey::ArrowRight)) { 1.0 } else { -1.0 };
                // Onto the frame grid, then one frame on.
                self.time = ((self.time * fps).round() + step) / fps;
                self.dirty = true;
            }
            Key::Character(c) => match c.to_lowercase().as_str() {
                "m" => {
                    let all = Method::ALL;
                    let at = all.iter().position(|&m| m == self.method).unwrap_or(0);
                    self.method = (1..=all.len()).map(|i| all[(at + i) % all.len()]).find(|&m| self.usable(m)).unwrap_or(self.method);
                    self.ns_per_ray = None;
                    self.dirty = true;
                }
                "h" => {
                    self.heatmap = !self.heatmap;
                    self.show()?;
                }
                "t" => {
                    if self.options.scene.transparency.is_some() {
                        self.transparency = !self.transparency;
                        if !self.usable(self.method) {
                            self.method = Method::QuadraticTaylor;
                        }
                        self.ns_per_ray = None;
                        self.dirty = true;
                    }
                }
                "s" => self.save_screenshot(None)?,
                _ => {}
            },
            _ => {}
        }
        self.update_title(true);
        Ok(())
    }

    fn save_screenshot(&mut self, path: Option<PathBuf>) -> Result<()> {
        let Some(gpu) = &self.gpu else { return Ok(()) };
        let (w, h) = gpu.presenter.extent();
        if self.shown_rgb.len() != (w * h * 3) as usize {
            // Nothing whole to save (the window changed size just now).
            return match path {
                Some(p) => Err(anyhow!("no complete frame to save to {} (the window was resized or never drawn)", p.display())),
                None => Ok(()),
            };
        }
        let path = path.unwrap_or_else(|| {
            self.screenshots += 1;
            self.options.screenshot_dir.join(format!("{}-{}-{:.3}s-{}.png", self.scene_name(), self.method, self.time, self.screenshots))
        });
        let img = image::RgbImage::from_raw(w, h, self.displayed()).ok_or_else(|| anyhow!("screenshot size"))?;
        output::write_atomic(&path, &output::png_bytes(&img)?)?;
        eprintln!("saved {}", path.display());
        Ok(())
    }

    /// The pixels the window shows: the shaded frame, or its steps through
    /// the heatmap's colour map with its legend along the bottom.
    fn displayed(&self) -> Vec<u8> {
        let Some(gpu) = &self.gpu else { return Vec::new() };
        let (w, h) = gpu.presenter.extent();
        if !self.heatmap || h <= LEGEND_HEIGHT + 8 || self.shown_steps.len() != (w * h) as usize {
            return self.shown_rgb.clone();
        }
        let rows = h - LEGEND_HEIGHT;
        output::heatmap_image(w, rows, &self.shown_steps[..(w * rows) as usize], None).into_raw()
    }

    fn show(&mut self) -> Result<()> {
        let pixels = self.displayed();
        let Some(gpu) = &mut self.gpu else { return Ok(()) };
        if pixels.is_empty() {
            return Ok(());
        }
        let shown = gpu.presenter.present(&pixels)?;
        if shown != Presented::OutOfDate {
            self.presented += 1;
            self.fps_window.1 += 1;
        }
        if shown != Presented::Yes {
            // Rebuild the swapchain for the window as it is now.
            let size = gpu.window.inner_size();
            self.resize(size)?;
        }
        Ok(())
    }

    fn resize(&mut self, size: PhysicalSize<u32>) -> Result<()> {
        self.minimised = size.width == 0 || size.height == 0;
        if self.minimised {
            return Ok(());
        }
        let Some(gpu) = &mut self.gpu else { return Ok(()) };
        let before = gpu.presenter.extent();
        if !gpu.presenter.resize((size.width, size.height))? {
            self.minimised = true;
            return Ok(());
        }
        if gpu.presenter.extent() == before && !self.shown_rgb.is_empty() {
            return Ok(());
        }
        self.shown_rgb.clear();
        self.shown_steps.clear();
        self.progressive = None;
        self.dirty = true;
        Ok(())
    }

    /// Marches `rays` of `scene`, updating the measured wall cost per ray.
    fn march(&mut self, scene: &Scene, rays: &[GpuRay]) -> Result<crate::render::MarchOutput> {
        let gpu = self.gpu.as_mut().ok_or_else(|| anyhow!("no window"))?;
        gpu.renderer.set_scene(scene)?;
        let t = Instant::now();
        // Transparent as shown: T takes the posed scene's transparency away.
        let out = march_frame(&mut gpu.renderer, self.method, MarchOptions::for_scene(scene), rays)?;
        let ns = t.elapsed().as_nanos() as f64 / rays.len().max(1) as f64;
        self.ns_per_ray = Some(self.ns_per_ray.map_or(ns, |old| 0.5 * (old + ns)));
        Ok(out)
    }

    /// Rays that fit the preview budget at the measured cost per ray (the
    /// first frame of a method has no cost yet: start small).
    fn affordable_rays(&self) -> f64 {
        let budget = self.options.preview.as_nanos() as f64;
        self.ns_per_ray.map_or(4096.0, |ns| budget / ns.max(1.0))
    }

    /// Renders at a resolution that fits the preview budget and shows it
    /// scaled up to the window; full resolution when that fits.
    fn preview_frame(&mut self, size: (u32, u32)) -> Result<()> {
        let full_rays = f64::from(size.0) * f64::from(size.1);
        let divisor = (full_rays / self.affordable_rays().max(64.0)).sqrt().ceil().clamp(1.0, 64.0) as u32;
        self.preview_divisor = divisor;
        let small = (size.0.div_ceil(divisor).max(1), size.1.div_ceil(divisor).max(1));
        let scene = self.posed(small);
        let (rays, pixels) = camera_rays(&scene.camera, small.0, small.1, &scene.bounds);
        let started = Instant::now();
        let out = self.march(&scene, &rays)?;
        let frame = output::Frame::from_results(small.0, small.1, &out.results, &pixels);
        self.frame_ms = started.elapsed().as_secs_f64() * 1e3;
        self.steps_per_ray = pixel_stats(&out, &pixels).steps_per_ray;
        // Nearest-neighbour scale-up to the window.
        let (w, h) = size;
        let shaded = frame.shaded();
        let steps = frame.steps();
        self.shown_rgb = vec![0; (w * h * 3) as usize];
        self.shown_steps = vec![0; (w * h) as usize];
        for y in 0..h {
            let sy = (y * small.1 / h).min(small.1 - 1);
            for x in 0..w {
                let sx = (x * small.0 / w).min(small.0 - 1);
                let i = (y * w + x) as usize;
                self.shown_rgb[3 * i..3 * i + 3].copy_from_slice(&shaded.get_pixel(sx, sy).0);
                self.shown_steps[i] = steps[(sy * small.0 + sx) as usize];
            }
        }
        if divisor == 1 {
            self.full_frames += 1;
        }
        self.show()
    }

    /// Marches the next tiles of the full-resolution frame (as many as fit
    /// the budget) and shows them over the preview.
    fn progressive_step(&mut self) -> Result<()> {
        let Some(mut job) = self.progressive.take() else { return Ok(()) };
        let tile = (PIXEL_TILE * PIXEL_TILE) as usize;
        let count = (self.affordable_rays() as usize / tile).max(1) * tile;
        let end = (job.next + count).min(job.rays.len());
        let results = self.march(&job.scene, &job.rays[job.next..end])?.results;
        for (r, p) in results.iter().zip(&job.pixels[job.next..end]) {
            let Some(p) = *p else { continue };
            let i = p as usize;
            let c = r.color;
            self.shown_rgb[3 * i..3 * i + 3].copy_from_slice(&[output::srgb(c[0]), output::srgb(c[1]), output::srgb(c[2])]);
            self.shown_steps[i] = r.counts[0];
            job.steps += u64::from(r.counts[0]);
            job.rays_done += 1;
        }
        job.next = end;
        if job.next < job.rays.len() {
            self.progressive = Some(job);
        } else {
            self.full_frames += 1;
            self.preview_divisor = 1;
            self.frame_ms = job.started.elapsed().as_secs_f64() * 1e3;
            self.steps_per_ray = job.steps as f64 / job.rays_done.max(1) as f64;
        }
        self.show()
    }

    /// One turn of the render loop: what to draw now, if anything.
    fn tick(&mut self, el: &ActiveEventLoop) -> Result<()> {
        if self.gpu.is_none() || self.minimised {
            el.set_control_flow(ControlFlow::Wait);
            return Ok(());
        }
        if let Some(n) = self.options.exit_after {
            if self.presented >= n {
                el.exit();
                return Ok(());
            }
        }
        if self.playing {
            let now = Instant::now();
            self.time += now.duration_since(self.clock).as_secs_f64();
            self.clock = now;
        }
        let size = self.gpu.as_ref().map(|g| g.presenter.extent()).unwrap_or((1, 1));
        let moving = (self.playing && self.animated()) || self.drag.is_some() || self.last_input.elapsed() < Duration::from_millis(250);
        // Scripted runs keep presenting, even a still view.
        let scripted = self.options.exit_after.is_some();
        if moving || self.dirty || self.shown_rgb.is_empty() {
            self.dirty = false;
            self.progressive = None;
            self.preview_frame(size)?;
            self.wants_full = self.preview_divisor > 1;
        } else if self.progressive.is_some() {
            self.progressive_step()?;
        } else if self.wants_full {
            // At rest on a preview: march the full frame, tile by tile.
            self.wants_full = false;
            let scene = self.posed(size);
            let (rays, pixels) = camera_rays(&scene.camera, size.0, size.1, &scene.bounds);
            self.progressive = Some(Progressive { scene, rays, pixels, next: 0, steps: 0, rays_done: 0, started: Instant::now() });
            self.progressive_step()?;
        } else if scripted {
            self.show()?;
        }
        let busy = moving || self.dirty || self.wants_full || self.progressive.is_some() || scripted;
        // Going idle: the title must show the final state.
        self.update_title(!busy);
        el.set_control_flow(if busy { ControlFlow::Poll } else { ControlFlow::Wait });
        Ok(())
    }

    fn update_title(&mut self, now: bool) {
        let Some(gpu) = &self.gpu else { return };
        let since = self.fps_window.0.elapsed().as_secs_f64();
        if since >= 1.0 {
            self.fps = self.fps_window.1 as f64 / since;
            self.fps_window = (Instant::now(), 0);
        }
        if !now && self.title_at.elapsed() < Duration::from_millis(250) {
            return;
        }
        self.title_at = Instant::now();
        let name = self.scene_name();
        let mut title = format!(
            "isomarch: {name} | {} | {:.1} ms/frame | {:.1} FPS | {:.2} steps/ray | t = {:.2} s",
            self.method, self.frame_ms, self.fps, self.steps_per_ray, self.time
        );
        if let Some(job) = &self.progressive {
            title.push_str(&format!(" | refining {:.0}%", 100.0 * job.next as f64 / job.rays.len().max(1) as f64));
        } else if self.preview_divisor > 1 {
            title.push_str(&format!(" | preview 1/{}", self.preview_divisor));
        }
        if !self.playing {
            title.push_str(" | paused");
        }
        if self.heatmap {
            title.push_str(" | steps");
        }
        if self.options.scene.transparency.is_some() && !self.transparency {
            title.push_str(" | opaque");
        }
        gpu.window.set_title(&title);
    }

    fn handle(&mut self, el: &ActiveEventLoop, event: WindowEvent) -> Result<()> {
        match event {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::Resized(size) => self.resize(size)?,
            WindowEvent::Occluded(hidden) => {
                self.minimised = hidden;
                self.dirty = true;
            }
            // Held keys repeat only where repeating makes sense (stepping);
            // keys found held when the window gains focus are not presses.
            WindowEvent::KeyboardInput { event, is_synthetic, .. }
                if event.state == ElementState::Pressed
                    && !is_synthetic
                    && (!event.repeat || matches!(event.logical_key, Key::Named(NamedKey::ArrowLeft | NamedKey::ArrowRight))) =>
            {
                self.key(el, &event.logical_key)?;
            }
            WindowEvent::MouseInput { state, button: MouseButton::Left, .. } => {
                self.drag = (state == ElementState::Pressed).then_some(self.cursor);
                self.last_input = Instant::now();
            }
            WindowEvent::CursorMoved { position, .. } => {
                self.cursor = (position.x, position.y);
                if let (Some((x0, y0)), Some(gpu)) = (self.drag, &self.gpu) {
                    let h = f64::from(gpu.presenter.extent().1.max(1));
                    // A drag across the window's height turns by 180 degrees.
                    self.orbit.yaw -= (position.x - x0) / h * std::f64::consts::PI;
                    self.orbit.pitch = (self.orbit.pitch + (position.y - y0) / h * std::f64::consts::PI).clamp(-3.0, 3.0);
                    self.drag = Some(self.cursor);
                    self.last_input = Instant::now();
                    self.dirty = true;
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => f64::from(y),
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                self.orbit.zoom = (self.orbit.zoom - 0.1 * lines).clamp(-5.0, 5.0);
                self.last_input = Instant::now();
                self.dirty = true;
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
        if self.gpu.is_none() && self.error.is_none() {
            if let Err(e) = self.open(el) {
                self.fail(el, e);
            }
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
        if self.error.is_none() {
            if let Some(path) = self.options.screenshot.clone() {
                if let Err(e) = self.save_screenshot(Some(path)) {
                    self.error = Some(e);
                }
            }
        }
    }
}
