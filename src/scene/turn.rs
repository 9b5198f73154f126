//! The view from the command line: turns of the camera about its target,
//! a zoom and a field of view (`--turn y:90 --zoom 1.5 --fov 25`).
//!
//! A turn follows VTK's and ParaView's camera (`Azimuth`, `Elevation`,
//! `Roll`): the camera moves, the scene stays. `y:D` turns the camera D
//! degrees about the view's vertical through the target (the world seems
//! to turn -D about it), `x:D` about the view's horizontal (positive
//! raises the eye), `z:D` rolls the view about its direction. Turns apply
//! in the order given, each about the axes of the view it leaves. `--zoom
//! F` moves the eye F times closer to the target (F < 1 backs away).

use std::fmt;
use std::str::FromStr;

use glam::{DQuat, DVec3};

use super::{Camera, Projection};

/// An axis of the view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewAxis {
    /// Horizontal, to the right on the image.
    X,
    /// Vertical, up on the image.
    Y,
    /// Out of the image, towards the eye.
    Z,
}

/// One turn of the camera: `AXIS:DEGREES`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Turn {
    pub axis: ViewAxis,
    pub degrees: f64,
}

impl FromStr for Turn {
    type Err = String;

    fn from_str(s: &str) -> Result<Turn, String> {
        let (axis, degrees) = s.split_once(':').ok_or_else(|| format!("expected AXIS:DEGREES such as y:90, got {s:?}"))?;
        let axis = match axis.trim() {
            "x" | "X" => ViewAxis::X,
            "y" | "Y" => ViewAxis::Y,
            "z" | "Z" => ViewAxis::Z,
            other => return Err(format!("the axis is x, y or z (the view's), got {other:?}")),
        };
        let degrees: f64 = degrees.trim().parse().map_err(|_| format!("expected degrees after the axis, got {degrees:?}"))?;
        if !degrees.is_finite() {
            return Err(format!("expected finite degrees, got {degrees}"));
        }
        Ok(Turn { axis, degrees })
    }
}

impl fmt::Display for Turn {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let axis = match self.axis {
            ViewAxis::X => 'x',
            ViewAxis::Y => 'y',
            ViewAxis::Z => 'z',
        };
        write!(f, "{axis}:{}", self.degrees)
    }
}

impl Camera {
    /// The view's right, up and backward unit axes (up made orthogonal to
    /// the view direction).
    pub fn view_axes(&self) -> (DVec3, DVec3, DVec3) {
        let back = (self.eye - self.target).normalize();
        let right = self.up.cross(back).normalize();
        (right, back.cross(right), back)
    }

    /// The camera turned about its target by `turn`.
    pub fn turned(&self, turn: Turn) -> Camera {
        let (right, up, back) = self.view_axes();
        let angle = turn.degrees.to_radians();
        let q = match turn.axis {
            ViewAxis::X => DQuat::from_axis_angle(right, -angle),
            ViewAxis::Y => DQuat::from_axis_angle(up, angle),
            ViewAxis::Z => DQuat::from_axis_angle(back, -angle),
        };
        Camera { eye: self.target + q * (self.eye - self.target), up: q * up, ..self.clone() }
    }

    /// The eye `factor` times closer to the target.
    pub fn zoomed(&self, factor: f64) -> Camera {
        // An orthographic view shows the same at any distance: its height
        // shrinks instead, and the eye stays (moving it would only cut the
        // front away, its rays starting at the eye's plane).
        match self.projection {
            Projection::Orthographic { height } => Camera { projection: Projection::Orthographic { height: height / factor }, ..self.clone() },
            Projection::Perspective => Camera { eye: self.target + (self.eye - self.target) / factor, ..self.clone() },
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::{Turn, ViewAxis};
    use crate::scene::{Camera, Projection};

    fn camera() -> Camera {
        Camera {
            eye: DVec3::new(0.0, 0.0, 10.0),
            target: DVec3::ZERO,
            up: DVec3::Y,
            fov_y_deg: 30.0,
            projection: Projection::Perspective,
            clip: Default::default(),
            width: 8,
            height: 8,
            samples: 1,
        }
    }

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-12
    }

    #[test]
    fn turns_move_the_camera_as_vtk_does() {
        // Azimuth 90: from +z the eye goes to +x (the camera moves right,
        // the world seems to turn left).
        let c = camera().turned(Turn { axis: ViewAxis::Y, degrees: 90.0 });
        assert!(close(c.eye, DVec3::new(10.0, 0.0, 0.0)) && close(c.up, DVec3::Y), "{c:?}");
        // Elevation 90: the eye rises above the target, up turns to -z.
        let c = camera().turned(Turn { axis: ViewAxis::X, degrees: 90.0 });
        assert!(close(c.eye, DVec3::new(0.0, 10.0, 0.0)) && close(c.up, DVec3::new(0.0, 0.0, -1.0)), "{c:?}");
        // Roll 90: the eye stays and the view's up goes to its right (+x):
        // the image turns counterclockwise.
        let c = camera().turned(Turn { axis: ViewAxis::Z, degrees: 90.0 });
        assert!(close(c.eye, DVec3::new(0.0, 0.0, 10.0)) && close(c.up, DVec3::X), "{c:?}");
        // A full turn about any axis returns.
        for axis in [ViewAxis::X, ViewAxis::Y, ViewAxis::Z] {
            let c = (0..4).fold(camera(), |c, _| c.turned(Turn { axis, degrees: 90.0 }));
            assert!(close(c.eye, camera().eye) && (c.up - DVec3::Y).length() < 1e-12, "{axis:?}: {c:?}");
        }
        assert!(close(camera().zoomed(2.0).eye, DVec3::new(0.0, 0.0, 5.0)));
    }

    #[test]
    fn turns_parse_as_axis_and_degrees() {
        assert_eq!("y:90".parse::<Turn>(), Ok(Turn { axis: ViewAxis::Y, degrees: 90.0 }));
        assert_eq!("X:-12.5".parse::<Turn>(), Ok(Turn { axis: ViewAxis::X, degrees: -12.5 }));
        for bad in ["y90", "w:90", "y:ninety", "y:inf", ""] {
            assert!(bad.parse::<Turn>().is_err(), "{bad}");
        }
        assert_eq!(Turn { axis: ViewAxis::Z, degrees: 45.0 }.to_string(), "z:45");
    }
}
