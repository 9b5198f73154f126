//! A trajectory being played: frames taken from the decoder thread as the
//! clock (or every presented image) asks for them.

use anyhow::Result;

use super::PlaybackStats;
use isomarch::molecule::playback::{Order, Prefetch};
use isomarch::scene::Scene;

/// How many decoded frames wait ready for the viewer.
pub const PREFETCH_DEPTH: usize = 3;

/// A trajectory being played.
pub struct Player {
    pub prefetch: Prefetch,
    pub len: usize,
    pub every_frame: bool,
    pub loops: Option<u64>,
    /// The frame shown, its simulation time and its scene.
    pub frame: usize,
    pub time_ps: Option<f64>,
    pub scene: Scene,
    /// The frame the decoder delivers next.
    pub expected: usize,
    pub stats: PlaybackStats,
    /// Images presented when the frame shown was taken: with
    /// `every_frame`, the next is taken once this one has been presented.
    pub taken_at: u64,
}

impl Player {
    /// The frame of scene time `time` at `fps` frames per second.
    pub fn frame_at(&self, time: f64, fps: f64) -> usize {
        ((time * fps + 1e-9).floor() as i64).rem_euclid(self.len as i64) as usize
    }

    /// Takes `wanted` from the decoder if it is ready (seeking there when
    /// the decoder is not on its way), waiting for it when `wait`. Returns
    /// whether the frame shown changed.
    pub fn fetch(&mut self, wanted: usize, wait: bool) -> Result<bool> {
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
    pub fn done(&self) -> bool {
        self.loops.is_some_and(|n| self.stats.shown >= n * self.len as u64)
    }
}
