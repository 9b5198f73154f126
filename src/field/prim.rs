//! A primitive, precomputed for evaluation: one variant per kind, each
//! behind [`PrimitiveKind`] (`kinds.rs` for points and planes, `hrbf.rs`
//! for HRBF terms and affine functions).

use super::KernelEval;
use super::hrbf::{AffinePrim, HrbfPrim, farthest};
use super::kinds::{PlanePrim, PointPrim, PrimitiveKind};
use crate::scene::{Aabb, Kernel, Primitive};

/// A primitive, precomputed: one variant per kind.
#[derive(Clone, Copy, Debug)]
pub enum PrimEval {
    Point(PointPrim),
    Plane(PlanePrim),
    Hrbf(HrbfPrim),
    Affine(AffinePrim),
}

impl PrimEval {
    /// `bounds`: the box where rays march (the global Lipschitz bound of
    /// kinds whose slope grows without bound needs it).
    pub fn new(p: &Primitive, bounds: &Aabb) -> PrimEval {
        match *p {
            Primitive::Point { center, kernel } => PrimEval::Point(PointPrim { center, kernel: KernelEval::new(kernel) }),
            Primitive::Plane { normal, offset, radius, weight } => {
                PrimEval::Plane(PlanePrim { normal, offset, kernel: KernelEval::new(Kernel::Compact { radius, weight }) })
            }
            Primitive::Hrbf { center, alpha, beta, .. } => PrimEval::Hrbf(HrbfPrim { center, alpha, beta, reach: farthest(bounds, center) }),
            Primitive::Affine { gradient, offset } => PrimEval::Affine(AffinePrim { gradient, offset, reach: farthest(bounds, glam::DVec3::ZERO) }),
        }
    }

    /// This primitive's evaluations.
    pub fn kind(&self) -> &dyn PrimitiveKind {
        match self {
            PrimEval::Point(p) => p,
            PrimEval::Plane(p) => p,
            PrimEval::Hrbf(p) => p,
            PrimEval::Affine(p) => p,
        }
    }

    /// The kernel of a point or plane primitive (HRBF terms and affine
    /// functions have none).
    pub fn kernel(&self) -> Option<&KernelEval> {
        match self {
            PrimEval::Point(p) => Some(&p.kernel),
            PrimEval::Plane(p) => Some(&p.kernel),
            PrimEval::Hrbf(_) | PrimEval::Affine(_) => None,
        }
    }

    /// The size of the values this primitive takes in the box where rays
    /// march: a kernel's weight, an HRBF term's or affine function's
    /// largest magnitude there. The scale for relative tolerances.
    pub fn magnitude(&self) -> f64 {
        match self {
            PrimEval::Point(p) => p.kernel.weight,
            PrimEval::Plane(p) => p.kernel.weight,
            PrimEval::Hrbf(p) => crate::scene::hrbf::term_size(p.alpha, p.beta, p.reach),
            PrimEval::Affine(p) => p.gradient.length() * p.reach + p.offset.abs(),
        }
    }
}
