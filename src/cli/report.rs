//! The lines a command prints about what it did.

#[cfg(feature = "window")]
use crate::view::ViewSummary;
use isomarch::method::Method;
use isomarch::render::offscreen::{RenderJob, RenderStats};
use isomarch::scene::Scene;

/// Lines on stderr where the image will not be what the flags suggest:
/// the method chosen is known to be slow on the scene (so that a
/// surprising frame time comes with its reason), or shadows and ambient
/// occlusion were asked of a transparent scene, which they do not light.
pub fn method_note(scene: &Scene, method: Method) {
    if method == Method::Sphere && scene.has_gaussians() {
        eprintln!(
            "note: sphere tracing steps by one global Lipschitz bound, which Gaussian kernels (molecules) make small: expect many steps per ray; quadratic-taylor (the default) takes far fewer"
        );
    }
    if (scene.shadows || scene.ao.is_some()) && scene.transparency.is_some() {
        eprintln!(
            "note: {} is transparent, and transparent surfaces are drawn without shadows and ambient occlusion; --opaque renders it opaque, with them",
            scene.source
        );
    }
}

/// `n` and a noun, plural unless `n` is 1: "1 frame", "6 frames".
pub fn count(n: u64, noun: &str) -> String {
    if n == 1 { format!("1 {noun}") } else { format!("{n} {noun}s") }
}

/// This process's command line as a shell would take it back, the program
/// named `isomarch`.
pub fn command_line() -> String {
    let quote = |a: String| {
        if !a.is_empty() && a.chars().all(|c| c.is_ascii_alphanumeric() || "-_./,=:+@%".contains(c)) {
            a
        } else {
            format!("'{}'", a.replace('\'', "'\\''"))
        }
    };
    std::iter::once("isomarch".to_string()).chain(std::env::args().skip(1).map(quote)).collect::<Vec<_>>().join(" ")
}

/// `render`'s summary of one frame: its size, method and device, and the
/// march's statistics.
pub fn render(job: &RenderJob, s: &RenderStats) {
    eprintln!(
        "{}: {}x{}{} with {} on {}: {:.2} steps/ray, {:.1} evals/ray, {:.2} turns/ray, {:.1} visits/eval, hit rate {:.3}{}; pipelines built in {:.1} ms (outside GPU time)",
        job.output.display(),
        s.width,
        s.height,
        if s.samples > 1 { format!(", {} samples per pixel,", s.samples) } else { String::new() },
        s.method,
        s.device,
        s.march.steps_per_ray,
        s.march.evals_per_ray,
        s.march.turns_per_ray,
        s.march.visits_per_ray / s.march.evals_per_ray.max(1e-9),
        s.march.hit_rate,
        s.march.gpu_ms.map_or(String::new(), |ms| format!(
            ", GPU {ms:.1} ms ({}, {})",
            s.march.ns_per_eval.map_or("n/a".into(), |v| format!("{v:.1} ns/eval")),
            s.march.ns_per_turn.map_or("n/a".into(), |v| format!("{v:.1} ns/turn"))
        )),
        s.pipeline_ms
    );
    if let Some(a) = s.march.any_hit {
        eprintln!(
            "  and {} shadow rays ({:.2} steps/ray), {} occlusion rays ({:.2} steps/ray){}",
            a.shadow_rays,
            a.shadow_steps_per_ray,
            a.ao_rays,
            a.ao_steps_per_ray,
            a.gpu_ms.map_or(String::new(), |ms| format!(", GPU {ms:.1} ms"))
        );
    }
}

/// `view`'s summary at exit: frames presented, and a trajectory's playback.
#[cfg(feature = "window")]
pub fn view(s: &ViewSummary) {
    println!(
        "presented {} ({} at full resolution, {} made whole on the GPU, {} shown from the GPU's image, the last {}) in {:.1} s; last: {}, {:.2} steps/ray",
        count(s.presented, "frame"),
        s.full_frames,
        s.gpu_frames,
        s.gpu_presents,
        if s.last_from_gpu { "from the GPU" } else { "uploaded" },
        s.seconds,
        s.method,
        s.steps_per_ray
    );
    if let Some(p) = &s.playback {
        println!(
            "trajectory: {} frames shown ({:.2} per second), {} decoded in {:.1} ms each on the decoder thread, marching {:.1} ms per shown frame; peak RSS {}, RSS at the end {}",
            p.shown,
            p.shown as f64 / s.seconds.max(1e-9),
            p.decoded,
            p.decode_ms / p.decoded.max(1) as f64,
            p.march_ms / p.shown.max(1) as f64,
            isomarch::stats::peak_rss_mib().map_or("n/a".into(), |m| format!("{m:.1} MiB")),
            isomarch::stats::rss_mib().map_or("n/a".into(), |m| format!("{m:.1} MiB"))
        );
    }
}
