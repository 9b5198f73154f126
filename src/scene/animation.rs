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

/// A factor on a point primitive's size over time: the compact support
/// radius R or the Gaussian scale r is multiplied by it (the weight stays).
#[derive(Clone, Debug, PartialEq)]
pub enum Scale {
    /// `1 + amplitude · sin(2π t / period + phase)`, `0 <= amplitude < 1`.
    Sine { amplitude: f64, period: f64, phase: f64 },
    /// Piecewise linear through `(time, factor)` keys (factors positive),
    /// held at both ends.
    Keyframes(Vec<(f64, f64)>),
}

impl Scale {
    pub fn factor(&self, t: f64) -> f64 {
        match self {
            Scale::Sine { amplitude, period, phase } => 1.0 + amplitude * (std::f64::consts::TAU * t / period + phase).sin(),
            Scale::Keyframes(keys) => {
                let as_vec: Vec<(f64, DVec3)> = keys.iter().map(|&(t, f)| (t, DVec3::splat(f))).collect();
                interpolate(&as_vec, t).x
            }
        }
    }

    /// The smallest factor the scale ever takes.
    pub fn min_factor(&self) -> f64 {
        match self {
            Scale::Sine { amplitude, .. } => 1.0 - amplitude,
            Scale::Keyframes(keys) => keys.iter().map(|k| k.1).fold(f64::INFINITY, f64::min),
        }
    }
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
    /// Points whose size changes.
    pub radii: Vec<((usize, usize), Scale)>,
    pub camera: Option<CameraPath>,
}

impl Animation {
    pub fn is_static(&self) -> bool {
        self.primitives.is_empty() && self.radii.is_empty() && self.camera.is_none()
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
            Motion::Sine { axis, amplitude, period, phase } => *axis * (*amplitude * (std::f64::consts::TAU * t / period + phase).sin()),
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
        for ((g, i), scale) in &self.animation.radii {
            if let Primitive::Point { kernel, .. } = &mut s.groups[*g][*i] {
                let f = scale.factor(t);
                match kernel {
                    super::Kernel::Compact { radius, .. } => *radius *= f,
                    super::Kernel::Gaussian { r, .. } => *r *= f,
                }
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

    /// The same scene in coordinates whose origin is the world point
    /// `origin`, computed in f64. The GPU computes in f32, whose spacing at
    /// 1e5 is 0.008: a scene far from the world's origin keeps its detail
    /// only once moved next to the viewer. Distances along rays, normals
    /// and so images are unchanged (lights are directions).
    pub fn recentred(&self, origin: DVec3) -> Scene {
        let mut s = self.clone();
        for p in s.groups.iter_mut().flatten() {
            match p {
                Primitive::Point { center, .. } => *center -= origin,
                Primitive::Plane { normal, offset, .. } => *offset -= normal.dot(origin),
                Primitive::Hrbf { center, domain, .. } => {
                    *center -= origin;
                    *domain = Aabb { min: domain.min - origin, max: domain.max - origin };
                }
                Primitive::Affine { gradient, offset } => *offset += gradient.dot(origin),
            }
        }
        s.camera.eye -= origin;
        s.camera.target -= origin;
        for p in &mut s.camera.clip.planes {
            p.point -= origin;
        }
        s.bounds = Aabb { min: s.bounds.min - origin, max: s.bounds.max - origin };
        // Primitive motions are offsets; keyframed eyes are positions.
        if let Some(CameraPath::Keyframes(keys)) = &mut s.animation.camera {
            for (_, eye) in keys {
                *eye -= origin;
            }
        }
        s
    }

    /// [`Scene::recentred`] on the camera's eye: rays start at the origin.
    pub fn recentred_on_camera(&self) -> Scene {
        self.recentred(self.camera.eye)
    }

    /// The union of the point primitives' supports (Gaussians: where they
    /// exceed `GAUSSIAN_BOUNDS_FRACTION · iso`) and the HRBFs' boxes.
    pub fn support_bounds(&self) -> Aabb {
        self.primitives().fold(Aabb::empty(), |b, p| match *p {
            Primitive::Point { center, kernel } => {
                let reach = DVec3::splat(kernel.cutoff(self.iso));
                b.union(Aabb { min: center - reach, max: center + reach })
            }
            Primitive::Hrbf { domain, .. } => b.union(domain),
            Primitive::Plane { .. } | Primitive::Affine { .. } => b,
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
        // fig16 (docs/benchmark-protocol.md, "Scenes"): y = 2.5 + 0.8 sin(2π t / 4 s + phase).
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

    const PULSING: &str = r#"(
        camera: (eye: (0.0, 0.0, 10.0), target: (0.0, 0.0, 0.0)),
        iso: 0.5,
        groups: [(primitives: [
            Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 2.0), radius_scale: Some(Sine(amplitude: 0.25, period: 2.0))),
            Point(center: (3.0, 0.0, 0.0), kernel: Gaussian(r: 1.0, s: 2.0), radius_scale: Some(Keyframes([(0.0, 1.0), (1.0, 2.0)]))),
        ])],
    )"#;

    #[test]
    fn radii_scale_over_time_and_the_bounds_follow() {
        let s = Scene::parse(PULSING, "pulsing.ron").unwrap();
        assert!(!s.animation.is_static());
        let radius = |s: &Scene, i: usize| match s.groups[0][i] {
            Primitive::Point { kernel: super::super::Kernel::Compact { radius, .. }, .. } => radius,
            Primitive::Point { kernel: super::super::Kernel::Gaussian { r, .. }, .. } => r,
            _ => unreachable!(),
        };
        // A quarter period in: 2 · (1 + 0.25); the keyframes halfway: 1.5.
        let later = s.at_time(0.5);
        assert!((radius(&later, 0) - 2.5).abs() < 1e-12, "{}", radius(&later, 0));
        assert!((radius(&later, 1) - 1.5).abs() < 1e-12);
        assert!(later.bounds.max.y > s.at_time(0.0).bounds.max.y, "the bounds grow with the radii");
        // The size must stay positive.
        let bad = PULSING.replace("amplitude: 0.25", "amplitude: 1.0");
        let err = Scene::parse(&bad, "bad.ron").unwrap_err().to_string();
        assert!(err.contains("radius_scale.amplitude"), "{err}");
        let bad = PULSING.replace("(1.0, 2.0)", "(1.0, 0.0)");
        let err = Scene::parse(&bad, "bad.ron").unwrap_err().to_string();
        assert!(err.contains("radius_scale[1].1"), "{err}");
    }

    #[test]
    fn recentring_moves_everything_but_changes_no_distance() {
        let s = Scene::parse(PULSING, "pulsing.ron").unwrap();
        let origin = DVec3::new(1e5, -2.0, 3.0);
        let r = s.recentred(origin);
        assert_eq!(r.camera.eye, s.camera.eye - origin);
        assert_eq!(r.bounds.min, s.bounds.min - origin);
        let f = crate::field::Field::new(&s);
        let g = crate::field::Field::new(&r);
        for p in [DVec3::ZERO, DVec3::new(1.0, 0.5, 0.0), DVec3::new(3.2, 0.1, -0.4)] {
            assert!((f.value(p) - g.value(p - origin)).abs() < 1e-9);
        }
    }
}
