//! Marching settings that are plain values: shared by the scene (which
//! reads them), the methods (which pick them), the f64 field (which
//! mirrors the GPU with them) and the renderer (which uploads them). It
//! depends on nothing else in the crate but the GPU layout's constants.

use crate::layout::{MAX_REFINE_TURNS, REFINE_BISECTION, REFINE_INCLUSION, REFINE_SECANT, REFINE_SIDE_SPLIT, SECANT_FREE_TURNS, SECANT_STRADDLE};

/// Fraction of the iso value below which a Gaussian kernel counts as zero
/// for bounding the scene (the kernel itself is never truncated).
pub const GAUSSIAN_BOUNDS_FRACTION: f64 = 1e-3;

/// The upper bound of the Gaussian's `e^{-y}` where the query interval
/// holds the ray's closest approach to the centre (so `y = α q` first falls
/// then rises and `y(t0)` is no end of its range): the three answers of
/// Figure 21.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ExpUpper {
    /// Shorten the interval to where `y(t0)` is still the largest value
    /// (Figure 20, Figure 21 a): exact at t0, valid on the shorter interval.
    Validity,
    /// The chord of `e^{-y}` over the whole range of `y` (Figure 21 b):
    /// valid on the whole interval but no longer exact at t0 (`e_hi > 0`).
    RelaxedT0,
    /// The chord from `y(t0)` to the far end, raised by a linear term that
    /// covers the deficit at the closest approach (Figure 21 c): exact at
    /// t0, looser at the field's maximum, valid on the whole interval.
    RelaxedMax,
}

/// Which Gaussians impose validity intervals (with [`ExpUpper::Validity`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ValidityScope {
    /// Those whose peak along the ray reaches `GAUSSIAN_BOUNDS_FRACTION ·
    /// iso`, the level that also bounds the scene. A fainter Gaussian
    /// (which the paper clips away, Figure 14) is bounded by the relaxed
    /// rule (c) instead: still exact at t0 and valid, but it no longer cuts
    /// the interval at its closest approach, which each of them otherwise
    /// does (Section 7.1: "a very small influence on the final field value
    /// but ... unnecessary interval subdivisions").
    #[default]
    Significant,
    /// Every Gaussian, as Appendix B alone reads.
    Every,
}

impl ValidityScope {
    pub fn name(self) -> &'static str {
        match self {
            ValidityScope::Significant => "significant",
            ValidityScope::Every => "every",
        }
    }
}

/// The settings of the bottom-up quadratic bounds that are not the method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct QuadSettings {
    /// Compact kernels: the bound of the part of the interval inside the
    /// support, extended to the whole interval by moving its control points
    /// (Section 6.2.1, Figure 9). Off: `max(Q, 0)³` built on the whole
    /// interval with the bottom-up maximum (Appendix C). The Taylor methods
    /// use the same switch for a support entered after t0
    /// (`bounds::entering_taylor`).
    pub extension: bool,
    pub validity: ValidityScope,
}

impl QuadSettings {
    /// The peak along a ray below which a Gaussian imposes no validity
    /// interval, for a scene of iso value `iso` (0: every Gaussian does).
    pub fn validity_floor(&self, iso: f64) -> f64 {
        match self.validity {
            ValidityScope::Significant => GAUSSIAN_BOUNDS_FRACTION * iso,
            ValidityScope::Every => 0.0,
        }
    }
}

impl Default for QuadSettings {
    fn default() -> Self {
        QuadSettings { extension: true, validity: ValidityScope::Significant }
    }
}

/// How a crossing that the marcher has bracketed, between its last point
/// outside and the first inside, is narrowed to the refinement tolerance.
/// Every way the bracket always holds the sign change, the crossing is
/// reported at the bracket's end past it (never early), and the result is
/// within the tolerance; they differ in how many field evaluations that
/// takes (docs/refinement.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Refinement {
    /// The inclusion methods (Taylor, bottom-up) fold their bound over the
    /// bracket: f < 0 up to the upper bound's root and f >= 0 at the lower
    /// one's, so both ends move at once, and the quadratic forms close a
    /// bracket of a step in one or two turns. The methods without a bound
    /// (sphere, segment, field inversion, the bisection baselines) refine
    /// by secant.
    #[default]
    Inclusion,
    /// Illinois regula falsi from the field values the marcher already has
    /// at both ends, each point placed a quarter tolerance past the
    /// estimate so that consecutive points straddle the crossing and the
    /// bracket closes from both sides; every other turn a bisection after
    /// four turns, so it never takes more than twice bisection's turns
    /// plus four. About 3 evaluations per crossing on the protocol scenes.
    Secant,
    /// Halving the bracket (the protocol's figures before secant refinement).
    Bisection,
}

impl Refinement {
    pub fn name(self) -> &'static str {
        match self {
            Refinement::Inclusion => "inclusion",
            Refinement::Secant => "secant",
            Refinement::Bisection => "bisection",
        }
    }

    /// The inverse of [`Refinement::name`].
    pub fn from_name(name: &str) -> Option<Refinement> {
        [Refinement::Inclusion, Refinement::Secant, Refinement::Bisection].into_iter().find(|r| r.name() == name)
    }

    /// Its value in the shaders (`SC_REFINE`).
    pub fn shader_id(self) -> u32 {
        match self {
            Refinement::Inclusion => REFINE_INCLUSION,
            Refinement::Secant => REFINE_SECANT,
            Refinement::Bisection => REFINE_BISECTION,
        }
    }
}

/// The bracketed refinement of a crossing, one field evaluation per turn:
/// the same arithmetic as the GPU's `refine_turn` (shaders/include/
/// refine.glsl), in f64. `g` is the field signed so that it is negative
/// on the side the march comes from (`-f` for a crossing that leaves).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bracket {
    /// The crossing lies in `(a, b]`: `g(a) < 0 <= g(b)`.
    pub a: f64,
    pub b: f64,
    /// `g` at the ends as the interpolation uses them (Illinois halves the
    /// one kept twice); `ga` is 0 where unknown (the first turn bisects).
    pub ga: f64,
    pub gb: f64,
    /// Which end the last turn moved: 0 none, 1 a, 2 b.
    pub side: u32,
    pub turns: u32,
}

impl Bracket {
    pub fn new(a: f64, ga: f64, b: f64, gb: f64) -> Bracket {
        Bracket { a, b, ga: if ga < 0.0 { ga } else { 0.0 }, gb, side: 0, turns: 0 }
    }

    /// The next point to evaluate, or `None` when the bracket is within
    /// `tolerance` (or no float lies strictly inside it).
    pub fn next(&self, mode: Refinement, tolerance: f64) -> Option<f64> {
        let mid = self.open(tolerance)?;
        let w = self.b - self.a;
        let interpolate = mode != Refinement::Bisection && self.ga < 0.0 && (self.turns < SECANT_FREE_TURNS || self.turns.is_multiple_of(2));
        if !interpolate {
            return Some(mid);
        }
        let margin = f64::from(SECANT_STRADDLE) * tolerance;
        let mut x = self.a + w * (self.ga / (self.ga - self.gb));
        x += match self.side {
            1 => margin,
            2 => -margin,
            _ => 0.0,
        };
        x = x.clamp(self.a + margin, self.b - margin);
        Some(if x > self.a && x < self.b { x } else { mid })
    }

    /// Inclusion refinement: where the next turn folds the bound from
    /// (over `[x, b]`), or `None` when the bracket is within `tolerance`.
    /// The GPU's `inclusion_next`.
    pub fn next_inclusion(&self, tolerance: f64) -> Option<f64> {
        let mid = self.open(tolerance)?;
        Some(if self.side == REFINE_SIDE_SPLIT { mid } else { self.a })
    }

    /// The bracket's middle while a turn may narrow it: within the turn
    /// budget, wider than `tolerance`, with a float strictly inside. The
    /// GPU's `bracket_open`.
    fn open(&self, tolerance: f64) -> Option<f64> {
        let w = self.b - self.a;
        let mid = self.a + 0.5 * w;
        (self.turns < MAX_REFINE_TURNS && w > tolerance && mid > self.a && mid < self.b).then_some(mid)
    }

    /// Takes the fold from `x` (see [`Bracket::next_inclusion`]): `g` at
    /// `x`, the upper bound's first root `up` and the lower bound's
    /// `cross` (infinite where it stays negative), both from `x`.
    pub fn update_inclusion(&mut self, x: f64, g: f64, up: f64, cross: f64) {
        let w = self.b - self.a;
        if g >= 0.0 {
            self.b = x;
            self.side = 2;
        } else {
            self.a = (x + up).min(self.b);
            self.b = self.b.min(x + cross);
            self.side = if self.b - self.a > 0.5 * w { REFINE_SIDE_SPLIT } else { 1 };
        }
        self.ga = 0.0;
        self.turns += 1;
    }

    /// Takes `g(x)` at the point [`Bracket::next`] gave.
    pub fn update(&mut self, x: f64, g: f64) {
        if g < 0.0 {
            if self.side == 1 {
                self.gb *= 0.5;
            }
            self.a = x;
            self.ga = g;
            self.side = 1;
        } else {
            if self.side == 2 {
                self.ga *= 0.5;
            }
            self.b = x;
            self.gb = g;
            self.side = 2;
        }
        self.turns += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Refines `g` on (a, b] and returns the reported end and the turns.
    fn refine(g: &dyn Fn(f64) -> f64, a: f64, b: f64, mode: Refinement, tol: f64) -> (f64, u32) {
        let mut k = Bracket::new(a, g(a), b, g(b));
        while let Some(x) = k.next(mode, tol) {
            assert!(x > k.a && x < k.b, "{x} outside ({}, {})", k.a, k.b);
            k.update(x, g(x));
            assert!(g(k.a) < 0.0 && g(k.b) >= 0.0, "the bracket lost the sign change");
        }
        (k.b, k.turns)
    }

    /// Both refinements end within the tolerance past the crossing, never
    /// before it; secant takes no more than twice bisection's turns plus
    /// four, and on smooth fields (the blobs' kernels) far fewer.
    #[test]
    fn refinement_brackets_the_crossing_within_the_tolerance() {
        let tol = 1e-4;
        let r = 0.637_123;
        type Case = (&'static str, Box<dyn Fn(f64) -> f64>);
        let smooth: Vec<Case> = vec![
            ("line", Box::new(move |x| x - r)),
            ("kernel", Box::new(move |x: f64| (1.0 - (2.0 - x) * (2.0 - x) / 4.0).max(0.0).powi(3) - (1.0 - (2.0 - r) * (2.0 - r) / 4.0).powi(3))),
            ("steep", Box::new(move |x: f64| ((x - r) * 40.0).tanh())),
            ("curved", Box::new(move |x: f64| (x - r) * (1.0 + 30.0 * (x - r)) + 3.0 * (x - r).powi(3))),
        ];
        let hard: Vec<Case> = vec![
            ("step", Box::new(move |x| if x < r { -1.0 } else { 1.0 })),
            ("flat", Box::new(move |x: f64| (x - r).powi(9))),
            ("cliff", Box::new(move |x: f64| if x < r { -1e-6 } else { 1e6 * (x - r + 1e-9) })),
        ];
        let mut secant_smooth = Vec::new();
        for (name, g) in smooth.iter().chain(&hard) {
            for (a, b) in [(0.6, 0.7), (0.1, 0.9), (0.637, 0.638), (r - 3e-5, r + 9e-5), (0.5, r)] {
                if !(g(a) < 0.0 && g(b) >= 0.0) {
                    continue;
                }
                let (tb, nb) = refine(g.as_ref(), a, b, Refinement::Bisection, tol);
                let (ts, ns) = refine(g.as_ref(), a, b, Refinement::Secant, tol);
                for (t, mode) in [(tb, "bisection"), (ts, "secant")] {
                    assert!(t >= r - 1e-12 && t <= r + tol, "{name} on ({a}, {b}), {mode}: reported {t}, crossing {r}");
                }
                assert!(ns <= 2 * nb + SECANT_FREE_TURNS, "{name} on ({a}, {b}): secant {ns} turns, bisection {nb}");
                if smooth.iter().any(|(n, _)| n == name) {
                    secant_smooth.push((ns, nb));
                }
            }
        }
        let (s, b): (u32, u32) = secant_smooth.iter().fold((0, 0), |(s, b), &(ns, nb)| (s + ns, b + nb));
        assert!(secant_smooth.len() >= 15 && 2 * s <= b, "smooth fields: secant {s} turns in all, bisection {b}: {secant_smooth:?}");
    }

    /// A bracket already within the tolerance, and one no float lies
    /// inside, take no turn.
    #[test]
    fn a_closed_bracket_takes_no_turn() {
        let k = Bracket::new(1.0, -1.0, 1.0 + 1e-5, 1.0);
        assert_eq!(k.next(Refinement::Secant, 1e-4), None);
        let k = Bracket::new(1.0, -1.0, f64::from_bits(1.0f64.to_bits() + 1), 1.0);
        assert_eq!(k.next(Refinement::Secant, 0.0), None);
    }
}
