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
//!
//! The house: app.rs is the window shell (winit's handler, the swapchain,
//! each turn's work); schedule.rs decides that work from an explicit phase
//! (a pure function, unit-tested); canvas.rs holds what the window shows;
//! controls.rs the keys as values, the mouse and the camera; player.rs a
//! trajectory's frames; title.rs the title.

mod app;
mod canvas;
mod controls;
mod player;
mod schedule;
mod title;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context as _, Result, anyhow};
use winit::event_loop::EventLoop;

use isomarch::gpu::Context;
use isomarch::method::Method;
use isomarch::molecule::playback::Stager;
use isomarch::scene::Scene;

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

/// What a viewer session did, for the caller to report.
pub struct ViewSummary {
    pub presented: u64,
    pub full_frames: u64,
    /// Frames (previews and resting frames) made whole on the GPU
    /// (render::frame) and left there; the rest were marched ray by ray.
    pub gpu_frames: u64,
    /// Presents that took an image on the GPU (nothing uploaded); the rest
    /// uploaded the host's pixels.
    pub gpu_presents: u64,
    /// Whether the last present took an image on the GPU.
    pub last_from_gpu: bool,
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
    let mut app = app::App::new(options)?;
    event_loop.run_app(&mut app).context("running the window's event loop")?;
    app.finish()
}
