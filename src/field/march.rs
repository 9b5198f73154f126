//! The marchers in f64: the mirror of `shaders/include/marchers.glsl` (with
//! `march_state.glsl`, `step.glsl`, `refine.glsl` and `crossings.glsl`), so
//! that the no-missed-crossing tests run on the GPU and on the mirror with
//! the same cases.

use glam::DVec3;

use super::Field;
use super::bound::{PROVEN_MARGIN, next_root, proven_crossing};
use super::fold::{field_bound, field_linear, field_raa};
use super::inversion::{Inversion, OVER_RELAXATION};
use super::quad::QuadSettings;
use crate::layout::{DYNAMOL_EPSILON, DYNAMOL_STEPS};
use crate::method::Method;
use crate::settings::{Bracket, Refinement};

/// Marching settings shared with the GPU.
#[derive(Clone, Copy, Debug)]
pub struct MarchSettings {
    pub min_step: f64,
    pub max_steps: u32,
    pub growth: f64,
    pub tolerance: f64,
    pub quad: QuadSettings,
    /// How a bracketed crossing is narrowed to `tolerance`.
    pub refine: Refinement,
    /// Every crossing to the end of the interval (transparent rendering),
    /// not only the first.
    pub transparent: bool,
}

impl MarchSettings {
    /// What `scene` marches `method` with: its file's marching settings,
    /// and the method's default interval growth unless the file sets one.
    pub fn for_scene(scene: &crate::scene::Scene, method: Method) -> MarchSettings {
        MarchSettings {
            min_step: scene.marching.min_step,
            max_steps: scene.marching.max_steps,
            growth: scene.marching.growth.unwrap_or_else(|| method.default_growth()),
            tolerance: scene.refine_tolerance(),
            quad: scene.marching.quad,
            refine: scene.marching.refine,
            transparent: scene.transparency.is_some(),
        }
    }
}

/// What an f64 march found: the hit distance (the inside end of the
/// refined bracket) and the steps taken; `None` hit on a miss.
#[derive(Clone, Debug, PartialEq)]
pub struct MarchResult {
    /// The first crossing.
    pub hit: Option<f64>,
    /// Every crossing found, in order (transparent marching; else the first).
    pub crossings: Vec<f64>,
    pub steps: u32,
    pub out_of_steps: bool,
    /// Sum over the steps with a bound of the fraction of the requested
    /// interval where the bound is valid (validity intervals, Section 4.2).
    pub kept: f64,
}

/// The first crossing of `o + t u` on `[t0, t1]` found by `method`.
pub fn march(field: &Field, method: Method, o: DVec3, u: DVec3, t0: f64, t1: f64, s: MarchSettings) -> MarchResult {
    let at = |t: f64| field.value(o + t * u);
    let mut r = MarchResult { hit: None, crossings: Vec::new(), steps: 0, out_of_steps: false, kept: 0.0 };
    if !(t1 >= t0) {
        return r;
    }
    if matches!(method, Method::LinearBisection | Method::Raa) {
        return bisection(field, method, o, u, t0, t1, s);
    }
    // A field that field inversion cannot march (not one sum of like Gaussians)
    // takes no step; the GPU refuses it (Renderer::march).
    let inversion = if method.inverts() {
        match Inversion::of_field(field) {
            Ok(inv) => Some(inv),
            Err(_) => return r,
        }
    } else {
        None
    };
    let (mut t, mut t_prev, mut window) = (t0, t0, t1 - t0);
    let mut f_prev = 0.0;
    let mut inside = false;
    // An inclusion method's march takes the bound on the far side of the
    // field's sign too (the GPU's TWO_SIDED): where it crosses 0, so has f.
    let two_sided = method.has_bound();
    let margin = if s.transparent { PROVEN_MARGIN * field.iso } else { 0.0 };
    // dynamol's field inversion: its budget, its hit rule, and the point of
    // smallest inverted distance g so far (the GPU's step_apply).
    let dynamol = method == Method::FieldInversionDynamol;
    let max_steps = if dynamol { s.max_steps.min(DYNAMOL_STEPS) } else { s.max_steps };
    let mut closest = (t0, f64::INFINITY);
    let bounded = |a: f64, b: f64, entering: bool| refine_inclusion(field, method, o, u, a, b, entering, margin, s);
    loop {
        if r.steps >= max_steps {
            r.out_of_steps = true;
            if dynamol && r.steps > 0 {
                r.hit = Some(closest.0);
                r.crossings.push(closest.0);
            }
            return r;
        }
        r.steps += 1;
        let t_end = (t + window).min(t1);
        let len = t_end - t;
        let mut cross = f64::INFINITY;
        let (f, step) = match method {
            Method::Sphere => {
                let f = at(t);
                (f, f.abs() / field.lipschitz())
            }
            Method::Segment => {
                let f = at(t);
                let lambda = field.segment_lipschitz(o, u, t, t_end);
                (f, if lambda > 0.0 { (f.abs() / lambda).min(len) } else { len })
            }
            Method::FieldInversion | Method::FieldInversionDynamol => {
                let f = at(t);
                (f, inversion.map_or(0.0, |inv| inv.step(f, field.iso)))
            }
            _ => {
                let b = field_bound(field, method, s.quad, o, u, t, t_end).expect("an inclusion method");
                if len > 0.0 {
                    r.kept += (b.t_valid - t) / len;
                }
                // Opaque marches bracket at the proven root (below); a
                // transparent one's refinement alone takes it.
                if two_sided && !s.transparent {
                    cross = proven_crossing(&b, t, margin);
                }
                // Up to where the bound is valid (Section 4.2).
                (b.v, next_root(&b).min(b.t_valid - t))
            }
        };
        if let (true, Some(inv)) = (dynamol, inversion) {
            let g = if f >= 0.0 { -1.0 } else { step / OVER_RELAXATION };
            if g < f64::from(DYNAMOL_EPSILON) * inv.r_ref {
                r.hit = Some(t);
                r.crossings.push(t);
                return r;
            }
            if g < closest.1 {
                closest = (t, g);
            }
        }
        // A crossing: f >= 0 entering, f <= 0 again leaving.
        if if inside { f <= 0.0 } else { f >= 0.0 } {
            let tc = if r.steps == 1 {
                t
            } else if two_sided && s.refine == Refinement::Inclusion {
                bounded(t_prev, t, !inside)
            } else {
                refine_past(&at, t_prev, f_prev, t, f, !inside, s)
            };
            r.hit = r.hit.or(Some(tc));
            r.crossings.push(tc);
            if !s.transparent {
                return r;
            }
            inside = !inside;
        }
        if cross < f64::INFINITY {
            // f < 0 up to the upper bound's root, f >= 0 at the lower one's.
            // (Opaque only: a transparent march steps on, since the stretch
            // to the proven point may hold more crossings.)
            let (a, b) = ((t + step).min(t + cross), t + cross);
            let tc = if s.refine == Refinement::Inclusion { bounded(a, b, true) } else { refine_past(&at, a, 0.0, b, 0.0, true, s) };
            r.hit = Some(tc);
            r.crossings.push(tc);
            return r;
        }
        if t >= t1 {
            return r;
        }
        let safe = step;
        let step = step.max(s.min_step);
        t_prev = t;
        f_prev = f;
        t = (t + step).min(t1);
        if t >= t1 && safe >= t1 - t_prev {
            return r;
        }
        window = s.growth * step;
    }
}

/// Refinement of a crossing in `(a, b]` (`fa`, `fb` the field there, `fa`
/// 0 where unknown; `entering`: f < 0 at a) to the tolerance, reported at
/// the bracket's end past the crossing like the GPU's `refine_turn`.
#[allow(clippy::too_many_arguments)]
fn refine_past(at: &impl Fn(f64) -> f64, a: f64, fa: f64, b: f64, fb: f64, entering: bool, s: MarchSettings) -> f64 {
    let sign = if entering { 1.0 } else { -1.0 };
    let mut bracket = Bracket::new(a, sign * fa, b, sign * fb);
    while let Some(x) = bracket.next(s.refine, s.tolerance) {
        bracket.update(x, sign * at(x));
    }
    bracket.b
}

/// Inclusion refinement of a crossing in `(a, b]` (`entering`: f < 0 at
/// a; leaving, f > 0 there): the GPU's `inclusion_next` and
/// `inclusion_update` turns. From either side the step and the proven
/// root are those of the field's sign at x, so only the test of x swaps.
#[allow(clippy::too_many_arguments)]
fn refine_inclusion(field: &Field, method: Method, o: DVec3, u: DVec3, a: f64, b: f64, entering: bool, margin: f64, s: MarchSettings) -> f64 {
    let sign = if entering { 1.0 } else { -1.0 };
    let mut bracket = Bracket::new(a, 0.0, b, 0.0);
    while let Some(x) = bracket.next_inclusion(s.tolerance) {
        let bd = field_bound(field, method, s.quad, o, u, x, bracket.b).expect("an inclusion method");
        bracket.update_inclusion(x, sign * bd.v, next_root(&bd).min(bd.t_valid - x), proven_crossing(&bd, x, margin));
    }
    bracket.b
}

/// Front-to-back bisection with pruning (the GPU's stackless traversal in
/// recursive form).
fn bisection(field: &Field, method: Method, o: DVec3, u: DVec3, t0: f64, t1: f64, s: MarchSettings) -> MarchResult {
    let at = |t: f64| field.value(o + t * u);
    let mut r = MarchResult { hit: None, crossings: Vec::new(), steps: 0, out_of_steps: false, kept: 0.0 };
    r.steps = 1;
    if at(t0) >= 0.0 {
        r.hit = Some(t0);
        r.crossings.push(t0);
        return r;
    }
    r.steps = 0;
    let mut stack = vec![(t0, t1, 0u32)];
    while let Some((a, b, depth)) = stack.pop() {
        if r.steps >= s.max_steps {
            r.out_of_steps = true;
            return r;
        }
        r.steps += 1;
        let len = b - a;
        let hi = match method {
            Method::Raa => field_raa(field, o, u, a, b).1,
            _ => {
                let bd = field_linear(field, o, u, a, b);
                bd.v + (bd.a_hi * len).max(0.0)
            }
        };
        if hi < 0.0 {
            continue;
        }
        if len <= s.min_step || depth >= 30 {
            let fb = at(b);
            if fb >= 0.0 {
                let tc = refine_past(&at, a, 0.0, b, fb, true, s);
                r.hit = Some(tc);
                r.crossings.push(tc);
                return r;
            }
            continue;
        }
        let m = a + 0.5 * len;
        stack.push((m, b, depth + 1));
        stack.push((a, m, depth + 1));
    }
    r
}
