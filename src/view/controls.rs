//! What the user controls: the keys as values, the marcher and display
//! they select, the mouse, and the camera (scene time and the orbit about
//! the scene's own camera).

use std::time::{Duration, Instant};

use glam::{DQuat, DVec3};
use winit::keyboard::{Key, NamedKey};

use super::ViewOptions;
use isomarch::method::Method;
use isomarch::scene::{Projection, Scene};

/// What a key asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Control {
    Quit,
    /// Pause or play.
    TogglePlaying,
    /// Pause, and step this many frames (Left/Right).
    Step(f64),
    NextMethod,
    ToggleHeatmap,
    ToggleTransparency,
    Screenshot,
    /// Write the camera as shown (a RON camera block for `render --camera`).
    SaveCamera,
    Faster,
    Slower,
}

impl Control {
    /// The control of a pressed key, if any (the list in `view --help`).
    pub fn of_key(key: &Key) -> Option<Control> {
        Some(match key {
            Key::Named(NamedKey::Escape) => Control::Quit,
            Key::Named(NamedKey::Space) => Control::TogglePlaying,
            Key::Named(NamedKey::ArrowRight) => Control::Step(1.0),
            Key::Named(NamedKey::ArrowLeft) => Control::Step(-1.0),
            Key::Character(c) => match c.to_lowercase().as_str() {
                "m" => Control::NextMethod,
                "h" => Control::ToggleHeatmap,
                "t" => Control::ToggleTransparency,
                "s" => Control::Screenshot,
                "c" => Control::SaveCamera,
                "+" | "=" => Control::Faster,
                "-" => Control::Slower,
                _ => return None,
            },
            _ => return None,
        })
    }

    /// Held keys repeat only where repeating makes sense (stepping).
    pub fn repeats(key: &Key) -> bool {
        matches!(key, Key::Named(NamedKey::ArrowLeft | NamedKey::ArrowRight))
    }
}

/// The user's changes to the scene's camera: turns about the target and a
/// distance factor, applied on top of the camera's own path.
#[derive(Clone, Copy, Debug, Default)]
pub struct Orbit {
    pub yaw: f64,
    pub pitch: f64,
    /// log of the distance factor.
    pub zoom: f64,
}

impl Orbit {
    pub fn apply(&self, scene: &mut Scene) {
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
        match &mut cam.projection {
            // An orthographic view zooms by its height (moving the eye
            // would only cut the front away).
            Projection::Orthographic { height } => {
                cam.eye = cam.target + pitched;
                *height *= self.zoom.exp();
            }
            Projection::Perspective => cam.eye = cam.target + pitched * self.zoom.exp(),
        }
    }
}

/// What the user has chosen and is doing: the marcher and the display the
/// keys select, and the mouse.
pub struct Controls {
    pub method: Method,
    /// The scene's transparency shown (T toggles it off and on).
    pub transparency: bool,
    /// Field inversion can march the scene (one sum of like Gaussians).
    pub invertible: bool,
    /// The steps heatmap shown instead of the shaded frame (H).
    pub heatmap: bool,
    /// Where the left button drags from; `None` while it is up.
    pub drag: Option<(f64, f64)>,
    pub cursor: (f64, f64),
    /// When the mouse last turned or zoomed the view (or pressed to).
    pub last_input: Instant,
    /// Cameras saved with C, to number their files.
    pub cameras: u32,
    /// Screenshots saved with S, to number their files.
    pub screenshots: u32,
}

impl Controls {
    pub fn new(options: &ViewOptions, now: Instant) -> Controls {
        Controls {
            method: options.method,
            transparency: options.scene.transparency.is_some(),
            invertible: isomarch::field::inversion::Inversion::of_field(&isomarch::field::Field::new(&options.scene)).is_ok(),
            heatmap: false,
            drag: None,
            cursor: (0.0, 0.0),
            last_input: now - Duration::from_secs(1),
            screenshots: 0,
            cameras: 0,
        }
    }

    /// Methods the scene can be marched with as shown (the bisection
    /// baselines find only a first entering crossing: opaque only; field
    /// inversion needs a molecule-like scene).
    pub fn usable(&self, m: Method) -> bool {
        !(self.transparency && matches!(m, Method::LinearBisection | Method::Raa)) && (!m.inverts() || self.invertible)
    }

    /// The next usable method after the current one, in `Method::ALL` order.
    pub fn next_method(&mut self) {
        let all = Method::ALL;
        let at = all.iter().position(|&m| m == self.method).unwrap_or(0);
        self.method = (1..=all.len()).map(|i| all[(at + i) % all.len()]).find(|&m| self.usable(m)).unwrap_or(self.method);
    }

    /// The mouse is moving the view: dragging, or it did so just now.
    pub fn moving(&self) -> bool {
        self.drag.is_some() || self.last_input.elapsed() < Duration::from_millis(250)
    }
}

/// Where the camera is: the scene time it shows, advancing with the wall
/// clock while playing, and the user's orbit about the scene's camera.
pub struct Camera {
    /// Scene time shown, and the wall clock it advances with.
    pub time: f64,
    pub playing: bool,
    pub clock: Instant,
    pub orbit: Orbit,
    /// Scene seconds per wall second (+ and - double and halve it).
    pub speed: f64,
}

impl Camera {
    pub fn new(options: &ViewOptions, now: Instant) -> Camera {
        let start = options.frames.as_ref().map_or(0.0, |p| p.start as f64 / options.fps);
        Camera { time: options.time + start, playing: !options.paused, clock: now, orbit: Orbit::default(), speed: 1.0 }
    }

    /// Moves scene time on by the wall time since the last call, while
    /// playing.
    pub fn advance(&mut self) {
        if self.playing {
            let now = Instant::now();
            self.time += now.duration_since(self.clock).as_secs_f64() * self.speed;
            self.clock = now;
        }
    }

    pub fn toggle_playing(&mut self) {
        self.playing = !self.playing;
        self.clock = Instant::now();
    }

    /// Pauses, and moves `frames` frames of 1/fps s from the frame nearest
    /// the current time.
    pub fn step(&mut self, frames: f64, fps: f64) {
        self.playing = false;
        self.time = ((self.time * fps).round() + frames) / fps;
    }
}

#[cfg(test)]
mod tests {
    use winit::keyboard::{Key, NamedKey, SmolStr};

    use super::{Control, Orbit};
    use isomarch::scene::Projection;

    #[test]
    fn the_wheel_zooms_an_orthographic_view_by_its_height() {
        let mut scene = isomarch::scene::Scene::parse(
            "Scene(camera: (eye: (0.0, 0.0, 10.0), target: (0.0, 0.0, 0.0), projection: Orthographic(height: 4.0)), iso: 0.5, \
             groups: [(primitives: [Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 1.0))])])",
            "t",
        )
        .unwrap();
        Orbit { zoom: -0.5, ..Orbit::default() }.apply(&mut scene);
        assert!((scene.camera.eye.z - 10.0).abs() < 1e-12, "the eye moved: {}", scene.camera.eye);
        let Projection::Orthographic { height } = scene.camera.projection else { panic!("not orthographic") };
        assert!((height - 4.0 * (-0.5f64).exp()).abs() < 1e-12, "height {height}");
    }

    #[test]
    fn keys_map_to_their_controls() {
        let ch = |c: &str| Key::Character(SmolStr::new(c));
        assert_eq!(Control::of_key(&Key::Named(NamedKey::Escape)), Some(Control::Quit));
        assert_eq!(Control::of_key(&Key::Named(NamedKey::Space)), Some(Control::TogglePlaying));
        assert_eq!(Control::of_key(&Key::Named(NamedKey::ArrowRight)), Some(Control::Step(1.0)));
        assert_eq!(Control::of_key(&Key::Named(NamedKey::ArrowLeft)), Some(Control::Step(-1.0)));
        assert_eq!(Control::of_key(&ch("M")), Some(Control::NextMethod));
        assert_eq!(Control::of_key(&ch("h")), Some(Control::ToggleHeatmap));
        assert_eq!(Control::of_key(&ch("t")), Some(Control::ToggleTransparency));
        assert_eq!(Control::of_key(&ch("s")), Some(Control::Screenshot));
        assert_eq!(Control::of_key(&ch("c")), Some(Control::SaveCamera));
        assert_eq!(Control::of_key(&ch("=")), Some(Control::Faster));
        assert_eq!(Control::of_key(&ch("-")), Some(Control::Slower));
        assert_eq!(Control::of_key(&ch("x")), None);
        assert!(Control::repeats(&Key::Named(NamedKey::ArrowLeft)) && !Control::repeats(&ch("m")));
    }
}
