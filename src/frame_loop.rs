//! The frame loop (`isomarch bench --frames N`): N frames rendered
//! offscreen along the path a window or a batch takes, a turn of the
//! camera about its target for a still scene (360 degrees over the N
//! frames) or a trajectory's frames in order, through one renderer that
//! keeps its pipelines and buffers, every image made (rays, march, light,
//! samples, look) and none written. Each frame is timed on the wall and on
//! the GPU and counts the bytes that crossed and the fences waited: the
//! frame's cost around its march, which a window pays every frame.

use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;
use serde::Serialize;

use crate::gpu::{Context, TransferStats};
use crate::molecule::playback::{Order, Prefetch, Stager};
use crate::render::offscreen::{RenderJob, march_image};
use crate::render::{MarchOptions, Renderer};
use crate::scene::turn::{Turn, ViewAxis};

/// One frame of the loop.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct LoopFrame {
    /// Wall time from posing the scene to the image in host memory.
    pub wall_ms: f64,
    /// GPU time of its marches (camera rays, shadow and occlusion rays);
    /// `None` without timestamps.
    pub gpu_ms: Option<f64>,
    #[serde(flatten)]
    pub transfers: TransferStats,
}

/// What the loop measured: each frame, and their medians.
#[derive(Clone, Debug, Serialize)]
pub struct LoopReport {
    pub scene: String,
    pub method: String,
    pub device: String,
    pub width: u32,
    pub height: u32,
    pub samples: u32,
    /// `orbit` (a still scene turned) or `trajectory`.
    pub path: &'static str,
    /// Pipeline creation before the first frame (outside every frame).
    pub pipeline_ms: f64,
    pub frames: Vec<LoopFrame>,
}

impl LoopReport {
    /// The median of `f` over the frames (NaN without any).
    fn median(&self, f: impl Fn(&LoopFrame) -> Option<f64>) -> f64 {
        crate::stats::median(&self.frames.iter().filter_map(f).collect::<Vec<f64>>())
    }

    /// Median wall milliseconds per frame.
    pub fn wall_ms(&self) -> f64 {
        self.median(|f| Some(f.wall_ms))
    }

    /// Median GPU milliseconds per frame (NaN without timestamps).
    pub fn gpu_ms(&self) -> f64 {
        self.median(|f| f.gpu_ms)
    }

    /// The summary line: wall and GPU time per frame, frames per second,
    /// their ratio, and what crossed per frame.
    pub fn summary(&self) -> String {
        let (wall, gpu) = (self.wall_ms(), self.gpu_ms());
        let per = |f: fn(&LoopFrame) -> u64| self.median(|x| Some(f(x) as f64));
        format!(
            "{}: {} {} frames at {}x{} ({} sample{}) with {} on {}: wall {wall:.2} ms/frame, GPU {gpu:.2} ms/frame, {:.1} frames/s, wall/GPU {:.2}x; per frame {:.0} bytes read back, {:.0} uploaded, {:.0} fence waits (medians; pipelines {:.0} ms before the first)",
            self.scene,
            self.frames.len(),
            self.path,
            self.width,
            self.height,
            self.samples,
            if self.samples == 1 { "" } else { "s" },
            self.method,
            self.device,
            1e3 / wall,
            wall / gpu,
            per(|x| x.transfers.readback_bytes),
            per(|x| x.transfers.upload_bytes),
            per(|x| x.transfers.submits),
            self.pipeline_ms,
        )
    }
}

/// Renders `count` frames of `job` (its scene, method, size, samples and
/// look) along the loop's path: `trajectory`'s frames from its first
/// (wrapping after its last), else the scene turned about the view's
/// vertical axis by 360/count degrees a frame. `progress` hears of each
/// frame done.
pub fn run(ctx: &Arc<Context>, job: &RenderJob, trajectory: Option<Stager>, count: usize, mut progress: impl FnMut(usize)) -> Result<LoopReport> {
    anyhow::ensure!(count > 0, "--frames takes at least one frame");
    let path = if trajectory.is_some() { "trajectory" } else { "orbit" };
    let mut prefetch = match trajectory {
        Some(stager) => {
            let len = stager.len();
            Some(Prefetch::spawn(stager, Order::List((0..count).map(|k| k % len).collect()), 2)?)
        }
        None => None,
    };
    let still = job.scene.recentred_on_camera();
    let mut renderer = Renderer::for_camera(ctx, &still, job.timeout)?;
    let options = MarchOptions::for_scene(&still);
    let mut frames = Vec::with_capacity(count);
    let mut before = renderer.transfer_stats();
    let mut pipeline_ms = 0.0;
    for k in 0..count {
        let started = Instant::now();
        let shown = match prefetch.as_mut() {
            Some(p) => p.wait().ok_or_else(|| anyhow::anyhow!("the trajectory's decoder stopped before frame {k}"))??.scene.recentred_on_camera(),
            None => {
                let mut s = job.scene.clone();
                s.camera = s.camera.turned(Turn { axis: ViewAxis::Y, degrees: 360.0 * k as f64 / count as f64 });
                s.recentred_on_camera()
            }
        };
        renderer.set_scene(&shown)?;
        // The image is not kept: made on the GPU wherever it can be.
        let (_, stats) = march_image(&mut renderer, job.method, options, &shown, (job.width, job.height), job.samples, job.effects, true)?;
        let gpu_ms = stats.gpu_ms.map(|g| g + stats.any_hit.as_ref().and_then(|a| a.gpu_ms).unwrap_or(0.0));
        // Pipelines are made once, in the first frame: not the loop's cost.
        let made = renderer.pipeline_ms() - pipeline_ms;
        pipeline_ms = renderer.pipeline_ms();
        let now = renderer.transfer_stats();
        let transfers = now - before;
        before = now;
        frames.push(LoopFrame { wall_ms: started.elapsed().as_secs_f64() * 1e3 - made, gpu_ms, transfers });
        progress(k + 1);
    }
    Ok(LoopReport {
        scene: job.scene.source.clone(),
        method: job.method.to_string(),
        device: ctx.info.name.clone(),
        width: job.width,
        height: job.height,
        samples: job.samples,
        path,
        pipeline_ms,
        frames,
    })
}
