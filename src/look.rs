//! The view and look given to a scene from outside its file: the command
//! line's `--camera`, `--turn`, `--zoom`, `--fov`, `--ortho`, `--clip` and
//! `--background`, and Python's `Scene.viewed` (docs/figures.md). Each value
//! is checked as it is applied; a problem is one line naming the flag.

use std::path::PathBuf;

use anyhow::Result;

use crate::checks;
use crate::scene::turn::Turn;
use crate::scene::{Camera, Projection, Scene};

/// Changes to a scene's camera and background, applied in this order: the
/// camera whole, the turns in the order given, the zoom, the field of
/// view, the projection, the clipping and the background.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct View {
    /// A file holding a RON camera block (what the viewer's C key writes).
    pub camera: Option<PathBuf>,
    pub turns: Vec<Turn>,
    pub zoom: Option<f64>,
    pub fov: Option<f64>,
    /// Orthographic: `Some(None)` takes the height the perspective view has
    /// at the target.
    pub ortho: Option<Option<f64>>,
    /// `near:D`, `far:D` or both.
    pub clip: Option<String>,
    /// A colour name, `#rrggbb` or linear `r,g,b`.
    pub background: Option<String>,
}

impl View {
    pub fn is_empty(&self) -> bool {
        *self == View::default()
    }

    /// Checks the values and applies them to `scene`.
    pub fn apply(&self, scene: &mut Scene) -> Result<()> {
        if let Some(path) = &self.camera {
            scene.camera = Camera::load(path)?;
            // The view stays: a path would move it again.
            scene.animation.camera = None;
        }
        for &turn in &self.turns {
            scene.camera = scene.camera.turned(turn);
        }
        if let Some(f) = self.zoom {
            scene.camera = scene.camera.zoomed(checks::zoom(f)?);
        }
        if let Some(deg) = self.fov {
            scene.camera.fov_y_deg = checks::fov(deg)?;
        }
        if let Some(height) = self.ortho {
            let c = &scene.camera;
            let height = match height {
                Some(h) => checks::ortho(h)?,
                None => 2.0 * (c.target - c.eye).length() * (0.5 * c.fov_y_deg.to_radians()).tan(),
            };
            scene.camera.projection = Projection::Orthographic { height };
        }
        if let Some(text) = &self.clip {
            let (near, far) = checks::clip(text)?;
            scene.camera.clip.near = near.or(scene.camera.clip.near);
            scene.camera.clip.far = far.or(scene.camera.clip.far);
            if let (Some(n), Some(f)) = (scene.camera.clip.near, scene.camera.clip.far)
                && n >= f
            {
                anyhow::bail!("--clip: near ({n}) must be closer than far ({f}), the scene's camera.clip included");
            }
        }
        if let Some(text) = &self.background {
            scene.background = checks::background(text)?.into();
        }
        Ok(())
    }
}
