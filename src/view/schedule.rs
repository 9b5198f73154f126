//! When and what the viewer renders: its phase, a pure function from the
//! phase and what the user is doing to the next piece of work, and the
//! measured cost per ray that sizes each piece.
//!
//! The phases, and what moves between them:
//!
//! ```text
//!            any change (motion, a key, a new frame, a resize)
//!   every phase ─────────────────────────────────────────────> Stale
//!   Stale ──preview marched──> Preview       (at a reduced resolution)
//!                            > Accumulating  (whole at full resolution, samples > 1)
//!                            > Idle          (whole, one sample)
//!   Preview ──start the full frame──> Refining(centres)
//!   Accumulating(k) ──start pass k──> Refining(pass k)
//!   Refining(p) ──its last tile──> Accumulating(next pass) or Idle
//! ```
//!
//! While the view moves every turn is a preview (Stale); at rest the
//! window refines, then anti-aliases, then idles.

use std::time::{Duration, Instant};

/// Where the viewer stands with the frame it shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// The view changed, or nothing is shown yet: a preview comes first.
    Stale,
    /// A preview at a reduced resolution is shown: the full frame is due.
    Preview,
    /// A full-resolution pass is being marched, tile by tile: through the
    /// pixels' centres (`None`), or anti-aliasing pass `Some(k)`.
    Refining(Option<u32>),
    /// The whole frame is shown; anti-aliasing pass `k` is due.
    Accumulating(u32),
    /// The whole frame is shown, every pass of it.
    Idle,
}

/// The next piece of work.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Work {
    /// March a frame at the resolution that fits the budget, and show it.
    Preview,
    /// March the next tiles of the pass under way.
    Refine,
    /// Start a full-resolution pass (`None`: the centres; `Some(k)`:
    /// anti-aliasing pass k).
    StartPass(Option<u32>),
    /// Show the frame again (scripted runs keep presenting).
    Present,
    /// Nothing: wait for input.
    Wait,
}

/// The work for `phase` while the view `moving` (playing an animation,
/// dragging, zooming); `scripted` runs present even a finished frame.
pub fn next_work(phase: Phase, moving: bool, scripted: bool) -> Work {
    match phase {
        _ if moving => Work::Preview,
        Phase::Stale => Work::Preview,
        Phase::Refining(_) => Work::Refine,
        Phase::Preview => Work::StartPass(None),
        Phase::Accumulating(k) => Work::StartPass(Some(k)),
        Phase::Idle if scripted => Work::Present,
        Phase::Idle => Work::Wait,
    }
}

/// The phase after a preview at 1/`divisor` resolution with `samples`
/// anti-aliasing passes asked for.
pub fn after_preview(divisor: u32, samples: u32) -> Phase {
    if divisor > 1 { Phase::Preview } else { after_pass(None, samples) }
}

/// The phase after the last tile of pass `pass` (`None`: the centres).
pub fn after_pass(pass: Option<u32>, samples: u32) -> Phase {
    let next = pass.map_or(0, |k| k + 1);
    if samples > 1 && next < samples { Phase::Accumulating(next) } else { Phase::Idle }
}

/// The viewer's schedule: its phase, the measured cost per ray, and the
/// frame statistics of the title and the summary.
pub struct Schedule {
    pub phase: Phase,
    pub minimised: bool,
    /// Wall nanoseconds per ray, measured (exponential average).
    ns_per_ray: Option<f64>,
    /// The resolution divisor of the frame shown (1: full).
    pub preview_divisor: u32,
    pub presented: u64,
    pub full_frames: u64,
    pub steps_per_ray: f64,
    pub frame_ms: f64,
    pub fps_window: (Instant, u64),
    pub fps: f64,
    pub title_at: Instant,
    pub started: Instant,
}

impl Schedule {
    pub fn new(now: Instant) -> Schedule {
        Schedule {
            phase: Phase::Stale,
            minimised: false,
            ns_per_ray: None,
            preview_divisor: 1,
            presented: 0,
            full_frames: 0,
            steps_per_ray: 0.0,
            frame_ms: 0.0,
            fps_window: (now, 0),
            fps: 0.0,
            title_at: now,
            started: now,
        }
    }

    /// Something changed: render again, from a preview.
    pub fn invalidate(&mut self) {
        self.phase = Phase::Stale;
    }

    /// The cost per ray is another method's or scene's: measure it again,
    /// and render again.
    pub fn remeasure(&mut self) {
        self.ns_per_ray = None;
        self.invalidate();
    }

    /// Folds the wall time of a march into the measured cost per ray.
    pub fn measured(&mut self, elapsed: Duration, rays: usize) {
        let ns = elapsed.as_nanos() as f64 / rays.max(1) as f64;
        self.ns_per_ray = Some(self.ns_per_ray.map_or(ns, |old| 0.5 * (old + ns)));
    }

    /// Whether the window shows the whole frame: at full resolution, every
    /// tile and anti-aliasing pass marched, nothing pending.
    pub fn finished(&self) -> bool {
        self.phase == Phase::Idle
    }

    /// Rays that fit `budget` at the measured cost per ray (the first frame
    /// of a method has no cost yet: start small).
    pub fn affordable_rays(&self, budget: Duration) -> f64 {
        self.ns_per_ray.map_or(4096.0, |ns| budget.as_nanos() as f64 / ns.max(1.0))
    }
}

#[cfg(test)]
mod tests {
    use super::{Phase, Work, after_pass, after_preview, next_work};

    #[test]
    fn motion_always_previews() {
        for phase in [Phase::Stale, Phase::Preview, Phase::Refining(None), Phase::Refining(Some(2)), Phase::Accumulating(1), Phase::Idle] {
            for scripted in [false, true] {
                assert_eq!(next_work(phase, true, scripted), Work::Preview, "{phase:?}");
            }
        }
    }

    #[test]
    fn at_rest_each_phase_has_its_work() {
        assert_eq!(next_work(Phase::Stale, false, false), Work::Preview);
        assert_eq!(next_work(Phase::Preview, false, false), Work::StartPass(None));
        assert_eq!(next_work(Phase::Refining(None), false, false), Work::Refine);
        assert_eq!(next_work(Phase::Refining(Some(3)), false, false), Work::Refine);
        assert_eq!(next_work(Phase::Accumulating(0), false, false), Work::StartPass(Some(0)));
        assert_eq!(next_work(Phase::Accumulating(5), false, false), Work::StartPass(Some(5)));
        assert_eq!(next_work(Phase::Idle, false, false), Work::Wait);
        assert_eq!(next_work(Phase::Idle, false, true), Work::Present);
    }

    #[test]
    fn a_preview_leads_to_the_full_frame_or_its_passes() {
        assert_eq!(after_preview(4, 1), Phase::Preview);
        assert_eq!(after_preview(2, 8), Phase::Preview);
        assert_eq!(after_preview(1, 1), Phase::Idle);
        assert_eq!(after_preview(1, 4), Phase::Accumulating(0));
    }

    #[test]
    fn passes_run_in_order_then_idle() {
        // The centres, then every anti-aliasing pass 0..samples, then rest.
        assert_eq!(after_pass(None, 1), Phase::Idle);
        assert_eq!(after_pass(None, 3), Phase::Accumulating(0));
        assert_eq!(after_pass(Some(0), 3), Phase::Accumulating(1));
        assert_eq!(after_pass(Some(1), 3), Phase::Accumulating(2));
        assert_eq!(after_pass(Some(2), 3), Phase::Idle);
    }

    #[test]
    fn a_whole_walk_from_stale_to_idle() {
        // Preview at 1/2 resolution, 2 samples: the sequence of work at rest.
        let mut phase = Phase::Stale;
        let mut work = Vec::new();
        for _ in 0..8 {
            let w = next_work(phase, false, false);
            work.push(w);
            phase = match w {
                Work::Preview => after_preview(2, 2),
                Work::StartPass(p) => Phase::Refining(p),
                // One tile finishes each pass here.
                Work::Refine => match phase {
                    Phase::Refining(p) => after_pass(p, 2),
                    other => other,
                },
                Work::Present | Work::Wait => phase,
            };
        }
        use Work::*;
        assert_eq!(work, [Preview, StartPass(None), Refine, StartPass(Some(0)), Refine, StartPass(Some(1)), Refine, Wait]);
        assert_eq!(phase, Phase::Idle);
    }
}
