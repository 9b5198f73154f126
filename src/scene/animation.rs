//! Motion in scene time (seconds): primitives' centres and the camera's eye
//! follow parametric or keyframed paths; [`Scene::at_time`] poses a scene.

use glam::DVec3;

use super::{Aabb, Primitive, Scene};

/// A path of offsets added to a primitive's centre, in scene units.
#[derive(Clone, Debug, PartialEq)]
pub enum Motion {
    /// `axis · amplitude · sin(2π t / period + phase)`, `axis` unit.
    Sine { axis: DVec3, amplitude: f64, period: f64, phase: f64 },
    /// Piecewise linear through `(time, offset)` keys sorted by time; held
    /// constant before the first key and after the last.
    Keyframes(Vec<(f64, DVec3)>),
}

/// The camera's eye over time (the target stays).
#[derive(Clone, Debug, PartialEq)]
pub enum CameraPath {
    /// One turn about the vertical axis through the target every `period`
    /// seconds.
    Orbit { period: f64 },
    /// The eye, piecewise linear through `(time, eye)` keys.
    Keyframes(Vec<(f64, DVec3)>),
}

/// What moves in a scene. Primitives are addressed by (group, index).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Animation {
    pub primitives: Vec<((usize, usize), Motion)>,
    pub camera: Option<CameraPath>,
}

impl Animation {
    pub fn is_static(&self) -> bool {
        self.primitives.is_empty() && self.camera.is_none()
    }
}

/// Linear interpolation through sorted keys, held at both ends.
fn interpolate(keys: &[(f64, DVec3)], t: f64) -> DVec3 {
    let Some(&(t_first, first)) = keys.first() else { return DVec3::ZERO };
    if t <= t_first {
        return first;
    }
    for w in keys.windows(2) {
        let ((ta, a), (tb, b)) = (w[0], w[1]);
        if t <= tb {
            let s = if tb > ta { (t - ta) / (tb - ta) } else { 1.0 };
            return a.lerp(b, s);
        }
    }
    keys[keys.len() - 1].1
}

impl Motion {
    pub fn offset(&self, t: f64) -> DVec3 {
        match self {
            Motion::Sine { axis, amplitude, period, phase } => {
                *axis * (*amplitude * (std::f64::consts::TAU * t / period + phase).sin())
            }
            Motion::Keyframes(keys) => interpolate(keys, t),
        }
    }
}

impl CameraPath {
    fn eye(&self, rest: DVec3, target: DVec3, up: DVec3, t: f64) -> DVec3 {
        match self {
            CameraPath::Orbit { period } => {
                let turn = glam::DQuat::from_axis_angle(up, std::f64::consts::TAU * t / period);
                target + turn * (rest - target)
            }
            CameraPath::Keyframes(keys) => interpolate(keys, t),
        }
    }
}

impl Scene {
    /// The scene at time `t` (seconds): every moving primitive at its
    /// place, the camera on its path, and the bounds recomputed from the
    /// posed supports unless the file fixed them.
    pub fn at_time(&self, t: f64) -> Scene {
        let mut s = self.clone();
        for ((g, i), motion) in &self.animation.primitives {
            if let Primitive::Point { center, .. } = &mut s.groups[*g][*i] {
                *center += motion.offset(t);
            }
        }
        if let Some(path) = &self.animation.camera {
            s.camera.eye = path.eye(self.camera.eye, self.camera.target, self.camera.up, t);
        }
        if !self.bounds_explicit {
            s.bounds = s.support_bounds();
        }
        s
    }

    /// The union of the point primitives' supports (Gaussians: where they
    /// exceed `GAUSSIAN_BOUNDS_FRACTION · iso`).
    pub fn support_bounds(&self) -> Aabb {
        self.primitives().fold(Aabb::empty(), |b, p| match *p {
            Primitive::Point { center, kernel } => {
                let reach = DVec3::splat(kernel.cutoff(self.iso));
                b.union(Aabb { min: center - reach, max: center + reach })
            }
            Primitive::Plane { .. } => b,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keyframes_interpolate_and_hold() {
        let keys = vec![(1.0, DVec3::ZERO), (3.0, DVec3::new(2.0, 0.0, 0.0)), (4.0, DVec3::new(2.0, 4.0, 0.0))];
        let m = Motion::Keyframes(keys);
        assert_eq!(m.offset(0.0), DVec3::ZERO);
        assert_eq!(m.offset(2.0), DVec3::new(1.0, 0.0, 0.0));
        assert_eq!(m.offset(3.5), DVec3::new(2.0, 2.0, 0.0));
        assert_eq!(m.offset(9.0), DVec3::new(2.0, 4.0, 0.0));
    }

    #[test]
    fn sines_follow_the_benchmark_formula() {
        // BENCHMARKS.md fig16: y = 2.5 + 0.8 sin(2π t / 4 s + phase).
        let m = Motion::Sine { axis: DVec3::Y, amplitude: 0.8, period: 4.0, phase: 0.3 };
        for t in [0.0, 0.7, 1.0, 3.9] {
            let expected = 0.8 * (std::f64::consts::TAU * t / 4.0 + 0.3).sin();
            assert!((m.offset(t).y - expected).abs() < 1e-12 && m.offset(t).x == 0.0);
        }
        assert!((m.offset(4.0) - m.offset(0.0)).length() < 1e-12, "a 4-second loop");
    }

    #[test]
    fn an_orbit_keeps_the_distance_to_the_target() {
        let path = CameraPath::Orbit { period: 8.0 };
        let (rest, target) = (DVec3::new(0.0, 3.0, 10.0), DVec3::new(0.0, 1.0, 0.0));
        let quarter = path.eye(rest, target, DVec3::Y, 2.0);
        assert!(((quarter - target).length() - (rest - target).length()).abs() < 1e-12);
        assert!((quarter - DVec3::new(10.0, 3.0, 0.0)).length() < 1e-9, "{quarter}");
    }
}
