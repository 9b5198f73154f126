//! The marchers isomarch implements, by name.

use std::fmt;
use std::str::FromStr;

use crate::layout;
use crate::settings::ExpUpper;

/// A ray-marching method. Each is a specialization of the one march shader.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Method {
    /// Sphere tracing with the global Lipschitz bound (Eq. 10).
    Sphere,
    /// Segment tracing (Galin et al. 2020), pinned in docs/benchmark-protocol.md.
    Segment,
    /// Linear Taylor forward bounds (Section 5.1, Eq. 13-15): slopes from
    /// the exact range of f' over the interval, per primitive.
    LinearTaylor,
    /// Quadratic Taylor forward bounds (Section 6.1, Eq. 19).
    QuadraticTaylor,
    /// Bottom-up linear forward bounds (Section 5.2) marched by Algorithm 1.
    Linear,
    /// The same bounds with bisection and interval pruning, the paper's
    /// baseline (Figure 10 f).
    LinearBisection,
    /// Revised affine arithmetic with bisection ([FPC10], the paper's
    /// baseline of Figure 10 e).
    Raa,
    /// Bottom-up quadratic forward bounds (Section 6.2) with validity
    /// intervals for the Gaussian's exp (Appendix B, Figure 21 a).
    Quadratic,
    /// Bottom-up quadratic, exp bounded on the whole interval by relaxing
    /// the bound's value at the query point (Figure 21 b).
    QuadraticRelaxedT0,
    /// Bottom-up quadratic, exp bounded on the whole interval by relaxing
    /// the bound at the kernel's maximum (Figure 21 c).
    QuadraticRelaxedMax,
    /// Field inversion (Bruckner 2019, the paper's molecule baseline):
    /// sphere tracing of the Gaussian density inverted into an approximate
    /// distance (src/field/inversion.rs). Not conservative: measured by its
    /// miss rate, not held to the no-missed-crossing tests.
    FieldInversion,
    /// Field inversion as dynamol runs it: at most 32 steps, a hit where the
    /// inverted distance g falls below 0.0125 reference radii (no
    /// refinement), and out of steps the point of smallest g taken as the
    /// hit. Not conservative.
    FieldInversionDynamol,
}

impl Method {
    /// Every method: the conservative ones, then those that may step over a
    /// crossing (field inversion), last.
    pub const ALL: &'static [Method] = &[
        Method::Sphere,
        Method::Segment,
        Method::LinearTaylor,
        Method::QuadraticTaylor,
        Method::Linear,
        Method::LinearBisection,
        Method::Raa,
        Method::Quadratic,
        Method::QuadraticRelaxedT0,
        Method::QuadraticRelaxedMax,
        Method::FieldInversion,
        Method::FieldInversionDynamol,
    ];

    /// The methods that never step over a crossing (up to the minimum step
    /// and f32): those the no-missed-crossing tests hold to it. Field
    /// inversion, either way, is not among them.
    pub const CONSERVATIVE: &'static [Method] = Method::ALL.split_at(Method::ALL.len() - 2).0;

    pub fn name(self) -> &'static str {
        match self {
            Method::Sphere => "sphere",
            Method::Segment => "segment",
            Method::LinearTaylor => "linear-taylor",
            Method::QuadraticTaylor => "quadratic-taylor",
            Method::Linear => "linear",
            Method::LinearBisection => "linear-bisection",
            Method::Raa => "raa",
            Method::Quadratic => "quadratic",
            Method::QuadraticRelaxedT0 => "quadratic-relaxed-t0",
            Method::QuadraticRelaxedMax => "quadratic-relaxed-max",
            Method::FieldInversion => "field-inversion",
            Method::FieldInversionDynamol => "field-inversion-dynamol",
        }
    }

    /// Algorithm 1's interval growth k: the next candidate interval is k
    /// times the last step. Segment tracing's 1.5 is pinned by
    /// docs/benchmark-protocol.md; linear Taylor takes 3, the best of the sweep in the
    /// docs/benchmarks.md (`scripts/growth-sweep.sh`); the others the paper's k = 2.
    pub fn default_growth(self) -> f64 {
        match self {
            Method::Sphere | Method::Segment => 1.5,
            Method::LinearTaylor => 3.0,
            _ => 2.0,
        }
    }

    /// The value of the `SC_METHOD` specialization constant.
    pub fn shader_id(self) -> u32 {
        match self {
            Method::Sphere => layout::METHOD_SPHERE,
            Method::Segment => layout::METHOD_SEGMENT,
            Method::LinearTaylor => layout::METHOD_LINEAR_TAYLOR,
            Method::QuadraticTaylor => layout::METHOD_QUADRATIC_TAYLOR,
            Method::Linear => layout::METHOD_LINEAR,
            Method::LinearBisection => layout::METHOD_LINEAR_BISECTION,
            Method::Raa => layout::METHOD_RAA,
            Method::Quadratic => layout::METHOD_QUADRATIC,
            Method::QuadraticRelaxedT0 => layout::METHOD_QUADRATIC_RELAXED_T0,
            Method::QuadraticRelaxedMax => layout::METHOD_QUADRATIC_RELAXED_MAX,
            Method::FieldInversion => layout::METHOD_FIELD_INVERSION,
            Method::FieldInversionDynamol => layout::METHOD_FIELD_INVERSION_DYNAMOL,
        }
    }

    /// Whether the method marches the inverted Gaussian density (field
    /// inversion, either hit rule): it needs one sum of like Gaussians.
    pub fn inverts(self) -> bool {
        matches!(self, Method::FieldInversion | Method::FieldInversionDynamol)
    }

    /// Whether the method bisects the whole ray with pruning (the paper's
    /// interval-arithmetic baselines) instead of stepping by Algorithm 1.
    pub fn bisects(self) -> bool {
        matches!(self, Method::LinearBisection | Method::Raa)
    }

    /// Whether the method has an inclusion bound (Taylor, bottom-up): the
    /// GPU's TWO_SIDED methods, which refine with it.
    pub fn has_bound(self) -> bool {
        !matches!(self, Method::Sphere | Method::Segment | Method::Raa | Method::LinearBisection) && !self.inverts()
    }

    /// Whether the method never steps over a crossing (see `CONSERVATIVE`).
    pub fn conservative(self) -> bool {
        Method::CONSERVATIVE.contains(&self)
    }

    /// The Gaussian's exp rule of a bottom-up quadratic method.
    pub fn exp_upper(self) -> Option<ExpUpper> {
        match self {
            Method::Quadratic => Some(ExpUpper::Validity),
            Method::QuadraticRelaxedT0 => Some(ExpUpper::RelaxedT0),
            Method::QuadraticRelaxedMax => Some(ExpUpper::RelaxedMax),
            _ => None,
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Method, String> {
        Method::ALL.iter().copied().find(|m| m.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
            format!("unknown method {s:?}; expected one of: {}", names.join(", "))
        })
    }
}

/// Command-line values: each method by its name, in `Method::ALL` order, so
/// that help lists the methods from that one list.
impl clap::ValueEnum for Method {
    fn value_variants<'a>() -> &'a [Method] {
        Method::ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(self.name()))
    }
}

/// Parses a comma-separated method list such as `sphere,segment`.
pub fn parse_list(s: &str) -> Result<Vec<Method>, String> {
    let methods: Vec<Method> = s.split(',').map(str::trim).filter(|p| !p.is_empty()).map(str::parse).collect::<Result<_, _>>()?;
    if methods.is_empty() {
        return Err("no method given".into());
    }
    Ok(methods)
}

#[cfg(test)]
mod tests {
    use super::Method;

    #[test]
    fn command_line_values_are_the_method_names() {
        for &m in Method::ALL {
            assert_eq!(<Method as clap::ValueEnum>::from_str(m.name(), false), Ok(m));
            assert_eq!(m.name().parse::<Method>(), Ok(m));
        }
        assert_eq!(super::parse_list(" sphere,,segment "), Ok(vec![Method::Sphere, Method::Segment]));
        assert_eq!(super::parse_list(", ,"), Err("no method given".to_string()));
    }

    #[test]
    fn every_method_but_field_inversion_is_conservative() {
        let others: Vec<Method> = Method::ALL.iter().copied().filter(|&m| !m.inverts()).collect();
        assert_eq!(others, Method::CONSERVATIVE);
        assert!(!Method::FieldInversion.conservative());
        assert!(!Method::FieldInversionDynamol.conservative());
    }
}
