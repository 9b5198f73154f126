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
use crate::molecule::playback::{Order, Prefetch, Stager};
use crate::output::{self, LEGEND_HEIGHT};
use crate::render::offscreen::SAMPLE_SEED;
use crate::render::offscreen::{march_camera_frame, pixel_stats};
use crate::render::rays::{PIXEL_TILE, camera_rays, camera_rays_through, subpixel};
use crate::render::{MarchOptions, Renderer};
use crate::scene::Scene;

/// How to open the viewer.
#[derive(Debug)]
pub struct ViewOptions {
    /// The scene as loaded (with its animation); of a trajectory, its
    /// first frame's.
    pub scene: Scene,
    /// A trajectory to play: frame n at scene time n / fps, looping.
    pub frames: Option<Playback>,
    pub method: Method,
    /// Initial window size in pixels.
    pub size: (u32, u32),
    /// Scene time at start, seconds.
    pub time: f64,
    /// Start paused.
    pub paused: bool,
    /// Left/Right step by 1/fps seconds of scene time (one frame of a
    /// trajectory).
    pub fps: f64,
    /// Wall time one piece of rendering may take before the window handles
    /// its events again (sets the preview resolution and the tiles).
    pub preview: Duration,
    /// Anti-aliasing: at rest, the frame is marched again at this many
    /// sub-pixel positions and the passes averaged (1: none).
    pub samples: u32,
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

/// A trajectory for the viewer.
#[derive(Debug)]
pub struct Playback {
    pub stager: Stager,
    /// The frame shown first.
    pub start: usize,
    /// Show every frame in turn, one per presented image (scene time
    /// moves one frame per image) instead of the frame of the wall clock.
    pub every_frame: bool,
    /// Close after playing the trajectory through this many times.
    pub loops: Option<u64>,
}

/// What playing a trajectory did.
#[derive(Clone, Copy, Debug, Default)]
pub struct PlaybackStats {
    /// Frames shown (each marched at least once), the start frame included.
    pub shown: u64,
    /// Frames the decoder thread delivered, and its wall time on them
    /// (reading the frame and building its scene).
    pub decoded: u64,
    pub decode_ms: f64,
    /// Wall time of marching, all frames together.
    pub march_ms: f64,
}

/// How many decoded frames wait ready for the viewer.
const PREFETCH_DEPTH: usize = 3;

/// A trajectory being played.
struct Player {
    prefetch: Prefetch,
    len: usize,
    every_frame: bool,
    loops: Option<u64>,
    /// The frame shown, its simulation time and its scene.
    frame: usize,
    time_ps: Option<f64>,
    scene: Scene,
    /// The frame the decoder delivers next.
    expected: usize,
    stats: PlaybackStats,
    /// Images presented when the frame shown was taken: with
    /// `every_frame`, the next is taken once this one has been presented.
    taken_at: u64,
}

impl Player {
    /// The frame of scene time `time` at `fps` frames per second.
    fn frame_at(&self, time: f64, fps: f64) -> usize {
        ((time * fps + 1e-9).floor() as i64).rem_euclid(self.len as i64) as usize
    }

    /// Takes `wanted` from the decoder if it is ready (seeking there when
    /// the decoder is not on its way), waiting for it when `wait`. Returns
    /// whether the frame shown changed.
    fn fetch(&mut self, wanted: usize, wait: bool) -> Result<bool> {
        if wanted == self.frame {
            return Ok(false);
        }
        let ahead = (wanted + self.len - self.expected) % self.len;
        if ahead > PREFETCH_DEPTH + 1 {
            self.prefetch.seek(Order::Loop(wanted));
            self.expected = wanted;
        }
        loop {
            let staged = if wait { self.prefetch.wait() } else { self.prefetch.try_next() };
            let Some(staged) = staged else { return Ok(false) };
            let staged = staged?;
            self.stats.decoded += 1;
            self.stats.decode_ms += staged.decode.as_secs_f64() * 1e3;
            self.expected = (staged.frame + 1) % self.len;
            if staged.frame == wanted {
                (self.frame, self.time_ps, self.scene) = (staged.frame, staged.time_ps, staged.scene);
                self.stats.shown += 1;
                return Ok(true);
            }
        }
    }

    /// Whether the trajectory has been played through `loops` times.
    fn done(&self) -> bool {
        self.loops.is_some_and(|n| self.stats.shown >= n * self.len as u64)
    }
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
    /// Of a trajectory.
    pub playback: Option<PlaybackStats>,
}

/// winit's error without the source location it prefixes (`os error at
/// /root/.cargo/registry/.../mod.rs:765: neither WAYLAND_DISPLAY nor ...`),
/// which is winit's, not the user's, business.
fn without_location(message: &str) -> String {
    match message.split_once(".rs:").and_then(|(_, rest)| rest.split_once(": ")) {
        Some((line, text)) if line.chars().all(|c| c.is_ascii_digit()) => text.to_string(),
        _ => message.to_string(),
    }
}

/// Runs the viewer until the window closes (Esc, the close button, or
/// `exit_after` frames).
pub fn run(options: ViewOptions) -> Result<ViewSummary> {
    let event_loop = EventLoop::new()
        .map_err(|e| anyhow!("opening the window system: {} (no display? under CI, run inside Xvfb)", without_location(&e.to_string())))?;
    let mut app = App::new(options)?;
    event_loop.run_app(&mut app).context("running the window's event loop")?;
    if let Some(e) = app.error.take() {
        // The GPU objects go first, while the window still exists.
        app.gpu = None;
        return Err(e);
    }
    app.gpu = None;
    Ok(ViewSummary {
        presented: app.schedule.presented,
        full_frames: app.schedule.full_frames,
        seconds: app.schedule.started.elapsed().as_secs_f64(),
        method: app.input.method,
        steps_per_ray: app.schedule.steps_per_ray,
        ctx: app.ctx.take(),
        playback: app.player.as_ref().map(|p| p.stats),
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

/// What the user has chosen and is doing: the marcher and the display the
/// keys select, and the mouse.
struct Input {
    method: Method,
    /// The scene's transparency shown (T toggles it off and on).
    transparency: bool,
    /// Field inversion can march the scene (one sum of like Gaussians).
    invertible: bool,
    /// The steps heatmap shown instead of the shaded frame (H).
    heatmap: bool,
    /// Where the left button drags from; `None` while it is up.
    drag: Option<(f64, f64)>,
    cursor: (f64, f64),
    /// When the mouse last turned or zoomed the view (or pressed to).
    last_input: Instant,
    /// Screenshots saved with S, to number their files.
    screenshots: u32,
}

impl Input {
    fn new(options: &ViewOptions, now: Instant) -> Input {
        Input {
            method: options.method,
            transparency: options.scene.transparency.is_some(),
            invertible: crate::field::inversion::Inversion::of_field(&crate::field::Field::new(&options.scene)).is_ok(),
            heatmap: false,
            drag: None,
            cursor: (0.0, 0.0),
            last_input: now - Duration::from_secs(1),
            screenshots: 0,
        }
    }

    /// Methods the scene can be marched with as shown (the bisection
    /// baselines find only a first entering crossing: opaque only; field
    /// inversion needs a molecule-like scene).
    fn usable(&self, m: Method) -> bool {
        !(self.transparency && matches!(m, Method::LinearBisection | Method::Raa)) && (!m.inverts() || self.invertible)
    }

    /// The next usable method after the current one, in `Method::ALL` order.
    fn next_method(&mut self) {
        let all = Method::ALL;
        let at = all.iter().position(|&m| m == self.method).unwrap_or(0);
        self.method = (1..=all.len()).map(|i| all[(at + i) % all.len()]).find(|&m| self.usable(m)).unwrap_or(self.method);
    }

    /// The mouse is moving the view: dragging, or it did so just now.
    fn moving(&self) -> bool {
        self.drag.is_some() || self.last_input.elapsed() < Duration::from_millis(250)
    }
}

/// Where the camera is: the scene time it shows, advancing with the wall
/// clock while playing, and the user's orbit about the scene's camera.
struct Camera {
    /// Scene time shown, and the wall clock it advances with.
    time: f64,
    playing: bool,
    clock: Instant,
    orbit: Orbit,
    /// Scene seconds per wall second (+ and - double and halve it).
    speed: f64,
}

impl Camera {
    fn new(options: &ViewOptions, now: Instant) -> Camera {
        let start = options.frames.as_ref().map_or(0.0, |p| p.start as f64 / options.fps);
        Camera { time: options.time + start, playing: !options.paused, clock: now, orbit: Orbit::default(), speed: 1.0 }
    }

    /// Moves scene time on by the wall time since the last call, while
    /// playing.
    fn advance(&mut self) {
        if self.playing {
            let now = Instant::now();
            self.time += now.duration_since(self.clock).as_secs_f64() * self.speed;
            self.clock = now;
        }
    }

    fn toggle_playing(&mut self) {
        self.playing = !self.playing;
        self.clock = Instant::now();
    }

    /// Pauses, and moves `frames` frames of 1/fps s from the frame nearest
    /// the current time.
    fn step(&mut self, frames: f64, fps: f64) {
        self.playing = false;
        self.time = ((self.time * fps).round() + frames) / fps;
    }
}

/// When and what to render: what the window shows, the full-resolution
/// frame being refined, the measured cost per ray that sizes each piece of
/// work, and the frame statistics of the title and the summary.
struct Schedule {
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
    preview_divisor: u32,
    presented: u64,
    full_frames: u64,
    steps_per_ray: f64,
    frame_ms: f64,
    fps_window: (Instant, u64),
    fps: f64,
    title_at: Instant,
    /// Anti-aliasing: the running mean of the passes (linear light), and
    /// the next pass to march (at or past `samples`: none).
    linear: Vec<[f32; 3]>,
    next_sample: u32,
    started: Instant,
}

impl Schedule {
    fn new(now: Instant) -> Schedule {
        Schedule {
            dirty: true,
            minimised: false,
            ns_per_ray: None,
            shown_rgb: Vec::new(),
            shown_steps: Vec::new(),
            progressive: None,
            wants_full: false,
            preview_divisor: 1,
            presented: 0,
            full_frames: 0,
            steps_per_ray: 0.0,
            frame_ms: 0.0,
            fps_window: (now, 0),
            fps: 0.0,
            title_at: now,
            linear: Vec::new(),
            next_sample: u32::MAX,
            started: now,
        }
    }

    /// The cost per ray is another method's or scene's: measure it again,
    /// and render again.
    fn remeasure(&mut self) {
        self.ns_per_ray = None;
        self.dirty = true;
    }

    /// Folds the wall time of a march into the measured cost per ray.
    fn measured(&mut self, elapsed: Duration, rays: usize) {
        let ns = elapsed.as_nanos() as f64 / rays.max(1) as f64;
        self.ns_per_ray = Some(self.ns_per_ray.map_or(ns, |old| 0.5 * (old + ns)));
    }

    /// Whether the window shows the whole frame: at full resolution, every
    /// tile and anti-aliasing pass of `samples` marched, nothing pending.
    fn finished(&self, samples: u32) -> bool {
        !self.dirty
            && !self.shown_rgb.is_empty()
            && self.progressive.is_none()
            && !self.wants_full
            && self.preview_divisor == 1
            && (self.next_sample >= samples || samples <= 1)
    }

    /// Rays that fit `budget` at the measured cost per ray (the first frame
    /// of a method has no cost yet: start small).
    fn affordable_rays(&self, budget: Duration) -> f64 {
        self.ns_per_ray.map_or(4096.0, |ns| budget.as_nanos() as f64 / ns.max(1.0))
    }
}

struct App {
    options: ViewOptions,
    player: Option<Player>,
    gpu: Option<Gpu>,
    ctx: Option<Arc<Context>>,
    error: Option<anyhow::Error>,
    input: Input,
    camera: Camera,
    schedule: Schedule,
}

impl App {
    fn new(mut options: ViewOptions) -> Result<App> {
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
            input: Input::new(&options, now),
            camera: Camera::new(&options, now),
            schedule: Schedule::new(now),
            player,
            options,
            gpu: None,
            ctx: None,
            error: None,
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
        let base = self.player.as_ref().map_or(&self.options.scene, |p| &p.scene);
        let mut s = base.at_time(self.camera.time);
        if !self.input.transparency {
            s.transparency = None;
        }
        self.camera.orbit.apply(&mut s);
        (s.camera.width, s.camera.height) = size;
        s.recentred_on_camera()
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
        let mut renderer = Renderer::for_camera(&ctx, &self.posed(presenter.extent()))?;
        renderer.timeout = self.options.timeout;
        self.ctx = Some(ctx);
        self.gpu = Some(Gpu { presenter, renderer, window });
        self.camera.clock = Instant::now();
        Ok(())
    }

    fn key(&mut self, el: &ActiveEventLoop, key: &Key) -> Result<()> {
        match key {
            Key::Named(NamedKey::Escape) => el.exit(),
            Key::Named(NamedKey::Space) => {
                self.camera.toggle_playing();
                // Paused on a preview: draw the frame again, then in full.
                self.schedule.dirty = true;
            }
            Key::Named(NamedKey::ArrowRight) | Key::Named(NamedKey::ArrowLeft) => {
                let frames = if matches!(key, Key::Named(NamedKey::ArrowRight)) { 1.0 } else { -1.0 };
                self.camera.step(frames, self.options.fps);
                self.schedule.dirty = true;
            }
            Key::Character(c) => match c.to_lowercase().as_str() {
                "m" => {
                    self.input.next_method();
                    self.schedule.remeasure();
                }
                "h" => {
                    self.input.heatmap = !self.input.heatmap;
                    self.show()?;
                }
                "t" if self.options.scene.transparency.is_some() => {
                    self.input.transparency = !self.input.transparency;
                    if !self.input.usable(self.input.method) {
                        self.input.method = Method::QuadraticTaylor;
                    }
                    self.schedule.remeasure();
                }
                "s" => self.save_screenshot(None)?,
                "+" | "=" => self.camera.speed = (self.camera.speed * 2.0).min(64.0),
                "-" => self.camera.speed = (self.camera.speed / 2.0).max(1.0 / 64.0),
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
        if self.schedule.shown_rgb.len() != (w * h * 3) as usize {
            // Nothing whole to save (the window changed size just now).
            return match path {
                Some(p) => Err(anyhow!("no complete frame to save to {} (the window was resized or never drawn)", p.display())),
                None => Ok(()),
            };
        }
        let path = path.unwrap_or_else(|| {
            self.input.screenshots += 1;
            let name = format!("{}-{}-{:.3}s-{}.png", self.scene_name(), self.input.method, self.camera.time, self.input.screenshots);
            self.options.screenshot_dir.join(name)
        });
        let img = image::RgbImage::from_raw(w, h, self.displayed()).ok_or_else(|| anyhow!("screenshot size"))?;
        output::write_atomic(&path, &output::png_bytes(&img)?)?;
        if self.schedule.finished(self.options.samples) {
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
        let shown = &self.schedule;
        if !self.input.heatmap || h <= LEGEND_HEIGHT + 8 || shown.shown_steps.len() != (w * h) as usize {
            return shown.shown_rgb.clone();
        }
        let rows = h - LEGEND_HEIGHT;
        output::heatmap_image(w, rows, &shown.shown_steps[..(w * rows) as usize], None).into_raw()
    }

    fn show(&mut self) -> Result<()> {
        let pixels = self.displayed();
        let Some(gpu) = &mut self.gpu else { return Ok(()) };
        if pixels.is_empty() {
            return Ok(());
        }
        let shown = gpu.presenter.present(&pixels)?;
        if shown != Presented::OutOfDate {
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
        if gpu.presenter.extent() == before && !schedule.shown_rgb.is_empty() {
            return Ok(());
        }
        schedule.shown_rgb.clear();
        schedule.shown_steps.clear();
        schedule.progressive = None;
        schedule.dirty = true;
        Ok(())
    }

    /// Marches `rays` of `scene`, the camera rays of its `size` frame from
    /// ray `first` on (whole tiles), updating the measured wall cost per
    /// ray. Camera rays take their candidates as `render`'s do (the tile
    /// lists where they apply).
    fn march(&mut self, scene: &Scene, size: (u32, u32), rays: &[GpuRay], first: usize) -> Result<crate::render::MarchOutput> {
        let gpu = self.gpu.as_mut().ok_or_else(|| anyhow!("no window"))?;
        gpu.renderer.set_scene(scene)?;
        let t = Instant::now();
        // Transparent as shown: T takes the posed scene's transparency away.
        let options = MarchOptions::for_scene(scene);
        gpu.renderer.prepare_camera(self.input.method, &options, &scene.camera, size.0, size.1)?;
        let out = march_camera_frame(&mut gpu.renderer, self.input.method, options, rays, first)?;
        self.schedule.measured(t.elapsed(), rays.len());
        if let Some(p) = &mut self.player {
            p.stats.march_ms += t.elapsed().as_secs_f64() * 1e3;
        }
        Ok(out)
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
        let (rays, pixels) = camera_rays(&scene.camera, small.0, small.1, &scene.bounds);
        let started = Instant::now();
        let out = self.march(&scene, small, &rays, 0)?;
        let frame = output::Frame::from_results(small.0, small.1, &out.results, &pixels);
        let schedule = &mut self.schedule;
        schedule.frame_ms = started.elapsed().as_secs_f64() * 1e3;
        schedule.steps_per_ray = pixel_stats(&out, &pixels).steps_per_ray;
        // Nearest-neighbour scale-up to the window.
        let (w, h) = size;
        let shaded = frame.shaded();
        let steps = frame.steps();
        schedule.shown_rgb = vec![0; (w * h * 3) as usize];
        schedule.shown_steps = vec![0; (w * h) as usize];
        for y in 0..h {
            let sy = (y * small.1 / h).min(small.1 - 1);
            for x in 0..w {
                let sx = (x * small.0 / w).min(small.0 - 1);
                let i = (y * w + x) as usize;
                schedule.shown_rgb[3 * i..3 * i + 3].copy_from_slice(&shaded.get_pixel(sx, sy).0);
                schedule.shown_steps[i] = steps[(sy * small.0 + sx) as usize];
            }
        }
        if divisor == 1 {
            schedule.full_frames += 1;
        }
        self.show()
    }

    /// Starts marching the full-resolution frame, tile by tile: through the
    /// pixels' centres, or anti-aliasing pass `sample` of `samples`.
    fn start_pass(&mut self, size: (u32, u32), sample: Option<u32>) -> Result<()> {
        let scene = self.posed(size);
        let n = self.options.samples;
        let (rays, pixels) = match sample {
            None => camera_rays(&scene.camera, size.0, size.1, &scene.bounds),
            Some(s) => camera_rays_through(&scene.camera, size.0, size.1, &scene.bounds, |p| subpixel(p, s, n, SAMPLE_SEED)),
        };
        if sample == Some(0) {
            self.schedule.linear = vec![[0.0; 3]; (size.0 * size.1) as usize];
        }
        self.schedule.next_sample = sample.map_or(self.schedule.next_sample, |s| s + 1);
        self.schedule.progressive = Some(Progressive { sample, scene, size, rays, pixels, next: 0, steps: 0, rays_done: 0, started: Instant::now() });
        self.progressive_step()
    }

    /// Marches the next tiles of the full-resolution frame (as many as fit
    /// the budget) and shows them over the preview.
    fn progressive_step(&mut self) -> Result<()> {
        let Some(mut job) = self.schedule.progressive.take() else { return Ok(()) };
        let tile = (PIXEL_TILE * PIXEL_TILE) as usize;
        let count = (self.schedule.affordable_rays(self.options.preview) as usize / tile).max(1) * tile;
        let end = (job.next + count).min(job.rays.len());
        let results = self.march(&job.scene, job.size, &job.rays[job.next..end], job.next)?.results;
        let schedule = &mut self.schedule;
        for (r, p) in results.iter().zip(&job.pixels[job.next..end]) {
            let Some(p) = *p else { continue };
            let i = p as usize;
            let mut c = r.color;
            if let Some(s) = job.sample {
                // The running mean of the passes so far, in linear light.
                let mean = &mut schedule.linear[i];
                for (m, v) in mean.iter_mut().zip(&mut c) {
                    *m += (*v - *m) / (s + 1) as f32;
                    *v = *m;
                }
            }
            schedule.shown_rgb[3 * i..3 * i + 3].copy_from_slice(&[output::srgb(c[0]), output::srgb(c[1]), output::srgb(c[2])]);
            schedule.shown_steps[i] = r.counts[0];
            job.steps += u64::from(r.counts[0]);
            job.rays_done += 1;
        }
        job.next = end;
        if job.next < job.rays.len() {
            schedule.progressive = Some(job);
        } else {
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
            let moving = (self.camera.playing && self.animated()) || self.input.moving();
            if self.options.screenshot.is_none() || moving || self.schedule.finished(self.options.samples) {
                el.exit();
                return Ok(());
            }
        }
        if self.player.as_ref().is_some_and(|p| p.done()) && !self.schedule.dirty {
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
                    self.schedule.dirty = true;
                }
            } else {
                let wanted = p.frame_at(self.camera.time, self.options.fps);
                if p.fetch(wanted, false)? {
                    self.schedule.dirty = true;
                }
            }
        }
        let size = self.gpu.as_ref().map(|g| g.presenter.extent()).unwrap_or((1, 1));
        let moving = (self.camera.playing && self.animated()) || self.input.moving();
        // Scripted runs keep presenting, even a still view.
        let scripted = self.options.exit_after.is_some();
        if moving || self.schedule.dirty || self.schedule.shown_rgb.is_empty() {
            self.schedule.dirty = false;
            self.schedule.progressive = None;
            self.preview_frame(size)?;
            self.schedule.wants_full = self.schedule.preview_divisor > 1;
            // Anti-aliasing starts again from its first pass.
            self.schedule.next_sample = if self.options.samples > 1 { 0 } else { u32::MAX };
        } else if self.schedule.progressive.is_some() {
            self.progressive_step()?;
        } else if self.schedule.wants_full {
            // At rest on a preview: march the full frame, tile by tile.
            self.schedule.wants_full = false;
            self.start_pass(size, None)?;
        } else if self.schedule.next_sample < self.options.samples {
            // At rest on a whole frame: the next anti-aliasing pass.
            let s = self.schedule.next_sample;
            self.start_pass(size, Some(s))?;
        } else if scripted {
            self.show()?;
        }
        let schedule = &self.schedule;
        let waiting = self.player.as_ref().is_some_and(|p| p.frame != p.frame_at(self.camera.time, self.options.fps) && !p.every_frame);
        let accumulating = schedule.next_sample < self.options.samples;
        let busy = moving || schedule.dirty || schedule.wants_full || schedule.progressive.is_some() || scripted || waiting || accumulating;
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
        let (schedule, input, camera) = (&self.schedule, &self.input, &self.camera);
        let mut title = format!(
            "isomarch: {name} | {} | {:.1} ms/frame | {:.1} FPS | {:.2} steps/ray | t = {:.2} s",
            input.method, schedule.frame_ms, schedule.fps, schedule.steps_per_ray, camera.time
        );
        if let Some(job) = &schedule.progressive {
            title.push_str(&format!(" | refining {:.0}%", 100.0 * job.next as f64 / job.rays.len().max(1) as f64));
        } else if schedule.preview_divisor > 1 {
            title.push_str(&format!(" | preview 1/{}", schedule.preview_divisor));
        }
        if let Some(p) = &self.player {
            title.push_str(&format!(" | frame {}/{}", p.frame, p.len));
            if let Some(t) = p.time_ps {
                title.push_str(&format!(" ({} ps)", crate::molecule::trajectory::ps(t)));
            }
        }
        if camera.speed != 1.0 {
            title.push_str(&format!(" | speed x{}", camera.speed));
        }
        if !camera.playing {
            title.push_str(" | paused");
        }
        if input.heatmap {
            title.push_str(" | steps");
        }
        if let Some(s) = schedule.progressive.as_ref().and_then(|j| j.sample) {
            title.push_str(&format!(" | anti-aliasing {}/{}", s + 1, self.options.samples));
        }
        if self.options.scene.transparency.is_some() && !input.transparency {
            title.push_str(" | opaque");
        }
        gpu.window.set_title(&title);
    }

    fn handle(&mut self, el: &ActiveEventLoop, event: WindowEvent) -> Result<()> {
        match event {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::Resized(size) => self.resize(size)?,
            WindowEvent::Occluded(hidden) => {
                self.schedule.minimised = hidden;
                self.schedule.dirty = true;
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
                self.input.drag = (state == ElementState::Pressed).then_some(self.input.cursor);
                self.input.last_input = Instant::now();
            }
            WindowEvent::CursorMoved { position, .. } => {
                let input = &mut self.input;
                input.cursor = (position.x, position.y);
                if let (Some((x0, y0)), Some(gpu)) = (input.drag, &self.gpu) {
                    let h = f64::from(gpu.presenter.extent().1.max(1));
                    // A drag across the window's height turns by 180 degrees.
                    let orbit = &mut self.camera.orbit;
                    orbit.yaw -= (position.x - x0) / h * std::f64::consts::PI;
                    orbit.pitch = (orbit.pitch + (position.y - y0) / h * std::f64::consts::PI).clamp(-3.0, 3.0);
                    input.drag = Some(input.cursor);
                    input.last_input = Instant::now();
                    self.schedule.dirty = true;
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => f64::from(y),
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                self.camera.orbit.zoom = (self.camera.orbit.zoom - 0.1 * lines).clamp(-5.0, 5.0);
                self.input.last_input = Instant::now();
                self.schedule.dirty = true;
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
