//! Trajectories as scenes, decoded ahead of the renderer (docs/trajectories.md).
//!
//! [`Stager`] turns frame k of a [`Trajectory`] into the scene text that
//! `isomarch scene TOPOLOGY TRAJECTORY --frame k` writes, and that text
//! into the [`Scene`] every command renders, so a batch frame and the
//! scene file of the same frame are the same scene by construction. The
//! camera is framed once, on the first frame or on every frame's atoms
//! ([`FramingRule`]), and stays put.
//!
//! [`Prefetch`] runs a stager on its own thread, decoding and building the
//! frames a player asks for into a bounded queue: memory holds `depth`
//! scenes whatever the trajectory's length, and the renderer takes a
//! ready scene instead of waiting on the decoder. A seek (the viewer
//! stepping back, or looping) starts a new order; frames of the old one
//! still queued are dropped on arrival.

use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use glam::DVec3;

use super::MoleculeOptions;
use super::build::{Framing, Notes, Picks, Stage, balls_of, staged_text};
use super::trajectory::Trajectory;
use crate::scene::Scene;

/// Where the camera of a trajectory looks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum FramingRule {
    /// The first frame's atoms, as a single structure would be framed.
    #[default]
    First,
    /// Every frame's atoms (one pass over the trajectory on opening).
    All,
}

/// Changes applied to every frame's scene after it is built (the command
/// line's marching overrides).
pub type Adjust = Box<dyn Fn(&mut Scene) -> Result<()> + Send>;

/// Turns frames of a trajectory into scenes.
pub struct Stager {
    pub trajectory: Trajectory,
    pub options: MoleculeOptions,
    pub framing: Framing,
    /// What the selections pick of the topology's atoms, made once, on
    /// the first frame, so every frame draws the same atoms in the same
    /// surfaces (a selection by distance would otherwise change with them).
    picks: Picks,
    adjust: Option<Adjust>,
    /// Frame 0's scene as parsed, and the site of each of its primitives:
    /// later frames move the primitives of a copy (see [`Stager::scene`]).
    template: Option<(Scene, Vec<usize>)>,
}

impl std::fmt::Debug for Stager {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Stager").field("trajectory", &self.trajectory).field("framing", &self.framing).finish()
    }
}

impl Stager {
    /// A stager with the camera framed by `rule`.
    pub fn new(trajectory: Trajectory, options: MoleculeOptions, rule: FramingRule) -> Result<Stager> {
        options.check()?;
        let mut t = trajectory;
        let picks = Picks::of(&t.topology, &options);
        if t.unwrap.as_ref().is_some_and(|u| u.center.is_some()) {
            // `--pbc center`: on the atoms drawn.
            let sites = super::build::kept_sites(&t.topology, &options, Some(&picks))?;
            t.center_on(sites)?;
        }
        let first = balls_of(&t.topology, &options, Some(&picks))?;
        let mut framing = Framing::of(&first);
        if rule == FramingRule::All {
            let (mut lo, mut hi, mut widest) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY), 0f64);
            for k in 0..t.len() {
                let frame = t.read(k)?;
                let m = t.molecule_at(&frame)?;
                for b in balls_of(&m, &options, Some(&picks))? {
                    lo = lo.min(b.center);
                    hi = hi.max(b.center);
                    widest = widest.max(b.radius);
                }
            }
            // The box's half diagonal holds every centre of every frame.
            framing = Framing { center: 0.5 * (lo + hi), reach: 0.5 * (hi - lo).length() + widest };
        }
        Ok(Stager { trajectory: t, options, framing, picks, adjust: None, template: None })
    }

    /// Applies `adjust` to every scene built from now on.
    pub fn with_adjust(mut self, adjust: Adjust) -> Stager {
        self.adjust = Some(adjust);
        self
    }

    pub fn len(&self) -> usize {
        self.trajectory.len()
    }

    pub fn is_empty(&self) -> bool {
        self.trajectory.is_empty()
    }

    /// Checks that `frame` exists.
    pub fn check_frame(&self, frame: usize) -> Result<()> {
        if frame >= self.len() {
            bail!("{}: no frame {frame}: the trajectory has {} (0 to {})", self.trajectory.source, self.len(), self.len() - 1);
        }
        Ok(())
    }

    /// The scene text of frame `k`, its simulation time, and the notes
    /// of building it.
    pub fn text(&mut self, k: usize) -> Result<(String, Option<f64>, Notes)> {
        self.check_frame(k)?;
        let frame = self.trajectory.read(k)?;
        let m = self.trajectory.molecule_at(&frame)?;
        let time = frame.time_ps.map_or(String::new(), |t| format!(", t = {} ps", super::trajectory::ps(t)));
        let between = match self.trajectory.between(k) {
            _ if self.trajectory.interpolate == 0 => String::new(),
            (i, j, _) if i == j => format!(", saved frame {i} of {}", self.trajectory.saved_len()),
            (i, j, t) => format!(", {t:.4} of the way from saved frame {i} to {j} of {}", self.trajectory.saved_len()),
        };
        let note = format!("Frame {k} of {} ({} frames{between}{time}), camera on {}.", self.trajectory.source, self.len(), describe(&self.framing));
        let stage = Stage { framing: Some(self.framing), note: &note, frame: k, picks: Some(&self.picks) };
        let (text, notes) = staged_text(&m, &self.options, stage)?;
        Ok((text, frame.time_ps, notes))
    }

    /// The scene of frame `k`: the scene [`Stager::text`] writes, as
    /// parsed. Only the first is parsed: the others are its copy with each
    /// atom moved to where the text puts it (its coordinates rounded to the
    /// six decimals written) and the bounds taken again, which is the same
    /// scene (tested against the parsed text) in a tenth of the time.
    pub fn scene(&mut self, k: usize) -> Result<(Scene, Option<f64>)> {
        let (mut scene, time) = match &self.template {
            Some((template, sites)) => {
                self.check_frame(k)?;
                let frame = self.trajectory.read(k)?;
                self.trajectory.check(&frame)?;
                let mut scene = template.clone();
                for (p, &site) in scene.groups.iter_mut().flatten().zip(sites) {
                    if let crate::scene::Primitive::Point { center, .. } = p {
                        *center = frame.positions[site].map(written);
                    }
                }
                if !scene.bounds_explicit {
                    scene.bounds = scene.support_bounds();
                }
                (scene, frame.time_ps)
            }
            None => {
                let (scene, time) = self.parsed(k)?;
                let sites = super::build::kept_sites(&self.trajectory.topology, &self.options, Some(&self.picks))?;
                // Values per frame change the colours too: each frame is
                // then built from its text.
                let moving_colors = self.options.values.as_ref().is_some_and(|v| v.frames() > 1);
                if scene.primitive_count() == sites.len() && !moving_colors {
                    self.template = Some((scene.clone(), sites));
                }
                (scene, time)
            }
        };
        if let Some(adjust) = &self.adjust {
            adjust(&mut scene)?;
        }
        Ok((scene, time))
    }

    /// The scene of frame `k` parsed from its text.
    pub fn parsed(&mut self, k: usize) -> Result<(Scene, Option<f64>)> {
        let (text, time, _) = self.text(k)?;
        Ok((Scene::parse(&text, &self.trajectory.topology.source)?, time))
    }
}

/// A coordinate as the scene text writes it and its parser reads it back.
fn written(x: f64) -> f64 {
    super::build::num(x).parse().unwrap_or(x)
}

fn describe(f: &Framing) -> String {
    format!("a sphere of radius {:.3} Å about ({:.3}, {:.3}, {:.3})", f.reach, f.center.x, f.center.y, f.center.z)
}

/// Which frames to decode, in order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Order {
    /// These frames, then nothing.
    List(Vec<usize>),
    /// From this frame on, forever, wrapping after the last.
    Loop(usize),
}

/// A decoded frame.
#[derive(Debug)]
pub struct Staged {
    pub frame: usize,
    pub time_ps: Option<f64>,
    pub scene: Scene,
    /// Wall time spent reading the frame and building its scene.
    pub decode: Duration,
    /// The saved frames it lies between and how far from the first
    /// ([`Trajectory::between`]; (k, k, 0) for saved frame k).
    pub between: (usize, usize, f64),
}

struct Request {
    generation: u64,
    order: Order,
}

/// A stager on its own thread, decoding ahead into a bounded queue.
pub struct Prefetch {
    requests: mpsc::Sender<Request>,
    staged: mpsc::Receiver<(u64, Result<Staged, String>)>,
    generation: u64,
    len: usize,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Prefetch {
    /// Starts decoding `order`, holding at most `depth` frames ready.
    pub fn spawn(stager: Stager, order: Order, depth: usize) -> Result<Prefetch> {
        let (requests, incoming) = mpsc::channel::<Request>();
        let (outgoing, staged) = mpsc::sync_channel(depth.max(1));
        let len = stager.len();
        requests.send(Request { generation: 0, order }).ok();
        let thread = std::thread::Builder::new().name("trajectory-decoder".into()).spawn(move || decode_loop(stager, &incoming, &outgoing))?;
        Ok(Prefetch { requests, staged, generation: 0, len, thread: Some(thread) })
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Decodes `order` from now on; frames of earlier orders are dropped.
    pub fn seek(&mut self, order: Order) {
        self.generation += 1;
        self.requests.send(Request { generation: self.generation, order }).ok();
    }

    /// The next frame of the current order, waiting for it; `None` once a
    /// list is done.
    pub fn wait(&mut self) -> Option<Result<Staged>> {
        loop {
            let (generation, staged) = self.staged.recv().ok()?;
            if generation == self.generation {
                return Some(staged.map_err(anyhow::Error::msg));
            }
        }
    }

    /// The next frame of the current order if one is ready.
    pub fn try_next(&mut self) -> Option<Result<Staged>> {
        loop {
            let (generation, staged) = self.staged.try_recv().ok()?;
            if generation == self.generation {
                return Some(staged.map_err(anyhow::Error::msg));
            }
        }
    }
}

impl Drop for Prefetch {
    fn drop(&mut self) {
        // Closing both channels ends the thread at its next send or wait.
        let (tx, _) = mpsc::channel();
        self.requests = tx;
        let (_, rx) = mpsc::sync_channel(1);
        self.staged = rx;
        if let Some(t) = self.thread.take() {
            t.join().ok();
        }
    }
}

fn decode_loop(mut stager: Stager, requests: &mpsc::Receiver<Request>, out: &mpsc::SyncSender<(u64, Result<Staged, String>)>) {
    let Ok(mut current) = requests.recv() else { return };
    let mut at = 0usize;
    loop {
        // The newest request wins.
        while let Ok(r) = requests.try_recv() {
            (current, at) = (r, 0);
        }
        let frame = match &current.order {
            Order::List(frames) => frames.get(at).copied(),
            Order::Loop(start) => Some((start + at) % stager.len().max(1)),
        };
        let Some(frame) = frame else {
            // The list is done: wait for the next order.
            match requests.recv() {
                Ok(r) => (current, at) = (r, 0),
                Err(_) => return,
            }
            continue;
        };
        at += 1;
        let started = Instant::now();
        let between = stager.trajectory.between(frame);
        let staged = stager
            .scene(frame)
            .map(|(scene, time_ps)| Staged { frame, time_ps, scene, decode: started.elapsed(), between })
            .map_err(|e| format!("{e:#}"));
        let failed = staged.is_err();
        if out.send((current.generation, staged)).is_err() {
            return;
        }
        if failed {
            // Nothing after a bad frame: wait for a new order.
            match requests.recv() {
                Ok(r) => (current, at) = (r, 0),
                Err(_) => return,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::molecule::trajectory::{Frame, Frames};
    use crate::molecule::{Atom, Molecule};

    /// Frames of three atoms (a hydrogen among them) moving by 0.1234567 Å
    /// a frame, with a negative zero.
    struct Moving;

    impl Frames for Moving {
        fn len(&self) -> usize {
            4
        }
        fn read(&mut self, index: usize) -> Result<Frame, crate::molecule::MoleculeError> {
            let d = index as f64 * 0.123_456_7;
            let positions = vec![DVec3::new(d, -0.0, 1.0), DVec3::new(1.0 + d, 2.0, -3.000_000_4), DVec3::new(2.5, d, 0.0)];
            Ok(Frame { index, time_ps: Some(index as f64), positions, cell: None })
        }
    }

    fn trajectory() -> Trajectory {
        let atom = |element: &str, site: usize| Atom { element: element.into(), chain: "A".into(), line: site + 1, site, ..Default::default() };
        let mut topology = Molecule {
            source: "t.gro".into(),
            atoms: vec![atom("C", 0), atom("H", 1), atom("O", 2)],
            skipped_sites: None,
            extra_models: 0,
            sites: 3,
            cell: None,
            bonds: Vec::new(),
        };
        let first = Moving.read(0).unwrap();
        for a in &mut topology.atoms {
            a.position = first.positions[a.site];
        }
        Trajectory { topology, source: "t.xtc".into(), frames: Box::new(Moving), unwrap: None, interpolate: 0, saved: Vec::new() }
    }

    #[test]
    fn a_moved_copy_of_the_first_frame_is_the_parsed_scene_of_each_frame() {
        for hydrogens in [false, true] {
            let options = MoleculeOptions { hydrogens, turntable: Some(8.0), ..Default::default() };
            for rule in [FramingRule::First, FramingRule::All] {
                let mut stager = Stager::new(trajectory(), options.clone(), rule).unwrap();
                let (first, _) = stager.scene(0).unwrap();
                assert!(stager.template.is_some(), "the first scene is kept");
                assert_eq!(first, stager.parsed(0).unwrap().0);
                for k in [3, 1, 2] {
                    let (moved, time) = stager.scene(k).unwrap();
                    assert_eq!(time, Some(k as f64));
                    assert_eq!(moved, stager.parsed(k).unwrap().0, "frame {k}, hydrogens {hydrogens}, {rule:?}");
                }
            }
        }
    }
}
