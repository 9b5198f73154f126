//! Marching settings that are plain values: shared by the scene (which
//! reads them), the methods (which pick them), the f64 field (which
//! mirrors the GPU with them) and the renderer (which uploads them). A leaf
//! module: it depends on nothing else in the crate.

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
