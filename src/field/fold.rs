//! The one loop over primitives, in f64: the mirror of
//! `shaders/include/fold.glsl` (its cursors in `cursor_*.glsl`). Every evaluation of the field is a
//! fold: a cursor yields the primitives, each adds its terms to its group's
//! sum, and the groups combine by max (Eq. 20).
//!
//! The cursor is the flat list, group by group, or for large fields the
//! grid of `grid.rs`. The contract is the GPU's: it yields every primitive
//! whose support meets the query, each once, and a group's primitives one
//! after another (groups in any order); the fold closes a group's sum when
//! the group changes.

use std::marker::PhantomData;

use glam::DVec3;

use super::bound::{Bound, max_bound};
use super::bounds::{Lin, Order, Taylor};
use super::kinds::PrimitiveKind;
use super::prim::PrimEval;
use super::quad::{QuadOptions, QuadSettings};
use super::raa::Affine;
use super::{Field, Query};
use crate::method::Method;

/// One evaluation as a fold: a group's sum starts at `zero`, each primitive
/// adds its terms (`add`), and a finished group's sum folds into the max
/// over groups (`close`, given the max so far, `None` for the first group).
pub trait Evaluation {
    type Sum: Copy;
    type Max;
    fn zero(&self) -> Self::Sum;
    fn add(&mut self, sum: Self::Sum, p: &dyn PrimitiveKind) -> Self::Sum;
    fn close(&mut self, max: Option<Self::Max>, sum: Self::Sum) -> Self::Max;
}

impl Field {
    /// The cursor: the primitives `q` may meet with their group index,
    /// group by group (all of them without a grid, or for `None`).
    pub fn cursor(&self, q: Option<Query>) -> Box<dyn Iterator<Item = (usize, &PrimEval)> + '_> {
        match (&self.grid, q) {
            (Some(grid), Some(q)) => Box::new(grid.candidates(q).into_iter().map(move |i| {
                let (g, k) = self.order[i as usize];
                (g as usize, &self.groups[g as usize][k as usize])
            })),
            _ => Box::new(self.groups.iter().enumerate().flat_map(|(g, prims)| prims.iter().map(move |p| (g, p)))),
        }
    }

    /// Folds `e` over the primitives the cursor yields for `q`: sums within
    /// groups, max across them. The first group is always folded in, so a
    /// query that meets no primitive gets the empty sum.
    pub fn fold<E: Evaluation>(&self, q: Option<Query>, e: &mut E) -> E::Max {
        let mut max = None;
        let mut group = 0;
        let mut sum = e.zero();
        for (g, p) in self.cursor(q) {
            if g != group {
                max = Some(e.close(max, sum));
                sum = e.zero();
                group = g;
            }
            sum = e.add(sum, p.kind());
        }
        e.close(max, sum)
    }
}

/// An evaluation from three closures, for those that need no state of
/// their own between primitives.
struct Closures<S, M, Z, A, C> {
    zero: Z,
    add: A,
    close: C,
    types: PhantomData<fn(S) -> M>,
}

impl<S: Copy, M, Z: Fn() -> S, A: FnMut(S, &dyn PrimitiveKind) -> S, C: FnMut(Option<M>, S) -> M> Evaluation for Closures<S, M, Z, A, C> {
    type Sum = S;
    type Max = M;
    fn zero(&self) -> S {
        (self.zero)()
    }
    fn add(&mut self, sum: S, p: &dyn PrimitiveKind) -> S {
        (self.add)(sum, p)
    }
    fn close(&mut self, max: Option<M>, sum: S) -> M {
        (self.close)(max, sum)
    }
}

fn fold_with<S: Copy, M>(
    field: &Field,
    q: Option<Query>,
    zero: impl Fn() -> S,
    add: impl FnMut(S, &dyn PrimitiveKind) -> S,
    close: impl FnMut(Option<M>, S) -> M,
) -> M {
    field.fold(q, &mut Closures { zero, add, close, types: PhantomData })
}

/// The max of plain numbers.
fn max_f64(max: Option<f64>, s: f64) -> f64 {
    max.map_or(s, |m| m.max(s))
}

impl Field {
    /// `f(p)`: positive inside.
    pub fn value(&self, p: DVec3) -> f64 {
        fold_with(self, Some(Query::Point(p)), || 0.0, |s, k| s + k.value(p), max_f64) - self.iso
    }

    /// `f(p)` and its gradient (of the group that attains the max).
    pub fn value_gradient(&self, p: DVec3) -> (f64, DVec3) {
        let (v, grad) = fold_with(
            self,
            Some(Query::Point(p)),
            || (0.0, DVec3::ZERO),
            |(v, g), k| {
                let (kv, kg) = k.value_gradient(p);
                (v + kv, g + kg)
            },
            |max: Option<(f64, DVec3)>, s| match max {
                Some(m) if m.0 >= s.0 => m,
                _ => s,
            },
        );
        (v - self.iso, grad)
    }

    /// Global Lipschitz constant of `f` (Eq. 10): for a max of sums, the
    /// largest group sum of per-kernel peaks.
    pub fn lipschitz(&self) -> f64 {
        fold_with(self, None, || 0.0, |s, k| s + k.lipschitz(), max_f64).max(0.0)
    }

    /// Segment tracing's Lipschitz bound on `[ta, tb]` along the ray.
    pub fn segment_lipschitz(&self, o: DVec3, u: DVec3, ta: f64, tb: f64) -> f64 {
        fold_with(self, Some(Query::Segment { o, u, t0: ta, t1: tb }), || 0.0, |s, k| s + k.segment_slope(o, u, ta, tb), max_f64).max(0.0)
    }
}

/// The Taylor bound of the whole field minus iso: per-primitive terms add
/// within a group, then the max of groups (the paper's mixed methods on a
/// max scene, Table 3).
pub fn field_taylor(field: &Field, o: DVec3, u: DVec3, t0: f64, t1: f64, order: Order, extension: bool) -> Bound {
    let quadratic = order == Order::Quadratic;
    let mut b = fold_with(
        field,
        Some(Query::Segment { o, u, t0, t1 }),
        Taylor::default,
        |s, k| {
            let k = k.taylor(o, u, t0, t1, order, extension);
            Taylor { value: s.value + k.value, slope: s.slope + k.slope, min: s.min + k.min, max: s.max + k.max }
        },
        |max, s| {
            let g = match order {
                // Eq. 13-15: asymmetric slopes from the range of f'.
                Order::Linear => Bound { v: s.value, a_lo: s.min, b_lo: 0.0, a_hi: s.max, b_hi: 0.0, e_hi: 0.0, t_valid: t1 },
                // Eq. 19: f(t0) + f'(t0) τ + ½ f''_{min/max} τ².
                Order::Quadratic => Bound { v: s.value, a_lo: s.slope, b_lo: 0.5 * s.min, a_hi: s.slope, b_hi: 0.5 * s.max, e_hi: 0.0, t_valid: t1 },
            };
            max_bounds(max, g, t1 - t0, quadratic)
        },
    );
    b.v -= field.iso;
    b
}

/// The bottom-up max of a group's bound with the max so far.
fn max_bounds(max: Option<Bound>, g: Bound, len: f64, quadratic: bool) -> Bound {
    match max {
        Some(m) => max_bound(&m, &g, len, quadratic),
        None => g,
    }
}

/// Bottom-up linear bound of the field minus iso: sums within groups, the
/// linear max across groups.
pub fn field_linear(field: &Field, o: DVec3, u: DVec3, t0: f64, t1: f64) -> Bound {
    let len = t1 - t0;
    let mut b = fold_with(
        field,
        Some(Query::Segment { o, u, t0, t1 }),
        || Lin { v: 0.0, lo: 0.0, hi: 0.0 },
        |s, k| {
            let k = k.linear(o, u, t0, len);
            Lin { v: s.v + k.v, lo: s.lo + k.lo, hi: s.hi + k.hi }
        },
        |max, s| max_bounds(max, Bound { v: s.v, a_lo: s.lo, b_lo: 0.0, a_hi: s.hi, b_hi: 0.0, e_hi: 0.0, t_valid: t1 }, len, false),
    );
    b.v -= field.iso;
    b
}

/// The bottom-up quadratic bounds as a fold: `len` shrinks with each
/// validity interval, and later primitives and groups use the shorter one
/// (earlier bounds stay valid on it).
struct Quadratic {
    o: DVec3,
    u: DVec3,
    t0: f64,
    len: f64,
    opts: QuadOptions,
}

impl Evaluation for Quadratic {
    type Sum = Bound;
    type Max = Bound;
    fn zero(&self) -> Bound {
        Bound::zero()
    }
    fn add(&mut self, sum: Bound, p: &dyn PrimitiveKind) -> Bound {
        sum.add(&p.quadratic(self.o, self.u, self.t0, &mut self.len, self.opts))
    }
    fn close(&mut self, max: Option<Bound>, sum: Bound) -> Bound {
        max_bounds(max, sum, self.len, true)
    }
}

/// Bottom-up quadratic bound of the field minus iso on `[t0, t1]` (or the
/// shorter interval `[t0, t_valid]` its validity intervals leave): sums
/// within groups, the quadratic maximum of Appendix C across them.
pub fn field_quadratic(field: &Field, o: DVec3, u: DVec3, t0: f64, t1: f64, opts: QuadOptions) -> Bound {
    let mut e = Quadratic { o, u, t0, len: t1 - t0, opts };
    let mut b = field.fold(Some(Query::Segment { o, u, t0, t1 }), &mut e);
    b.v -= field.iso;
    b.t_valid = t0 + e.len;
    b
}

/// The range of `f = max over groups (sums) - iso` over `[ta, tb]` in
/// revised affine arithmetic.
pub fn field_raa(field: &Field, o: DVec3, u: DVec3, ta: f64, tb: f64) -> (f64, f64) {
    let (lo, hi) = fold_with(
        field,
        Some(Query::Segment { o, u, t0: ta, t1: tb }),
        || Affine::ZERO,
        |s, k| s + k.raa(o, u, ta, tb),
        |max: Option<(f64, f64)>, s| {
            let (a, b) = s.range();
            max.map_or((a, b), |(lo, hi)| (lo.max(a), hi.max(b)))
        },
    );
    (lo - field.iso, hi - field.iso)
}

/// The forward bound of `method` for the field minus iso on `[t0, t1]`
/// (`t_valid` may be shorter); `None` for the methods without one (sphere,
/// segment, revised affine arithmetic). The one place that maps a method to
/// its bound. `quad`: see [`QuadSettings`].
pub fn field_bound(field: &Field, method: Method, quad: QuadSettings, o: DVec3, u: DVec3, t0: f64, t1: f64) -> Option<Bound> {
    Some(match method {
        Method::LinearTaylor => field_taylor(field, o, u, t0, t1, Order::Linear, quad.extension),
        Method::QuadraticTaylor => field_taylor(field, o, u, t0, t1, Order::Quadratic, quad.extension),
        Method::Linear | Method::LinearBisection => field_linear(field, o, u, t0, t1),
        Method::Quadratic | Method::QuadraticRelaxedT0 | Method::QuadraticRelaxedMax => {
            let exp_upper = method.exp_upper().expect("a bottom-up quadratic method");
            let validity_floor = quad.validity_floor(field.iso);
            field_quadratic(field, o, u, t0, t1, QuadOptions { exp_upper, extension: quad.extension, validity_floor })
        }
        Method::Sphere | Method::Segment | Method::Raa | Method::FieldInversion | Method::FieldInversionDynamol => return None,
    })
}
