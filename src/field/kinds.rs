//! The kinds of primitive, each behind one interface: every evaluation the
//! marchers make of one primitive (value and gradient at a point, segment
//! tracing's slope bound, the Taylor, linear, quadratic and RAA bounds along
//! a ray). The mirror of `shaders/include/kinds/`, one file per kind with
//! its six functions (`compact_point.glsl`, `gaussian_point.glsl`,
//! `compact_plane.glsl`; HRBF terms and affine functions below), built on the
//! kernels of `kernel_compact.glsl` and `kernel_gaussian.glsl`.
//!
//! A kind maps the ray onto its kernel's argument (a point: the distance to
//! its centre, `x² + h²` along the ray; a plane: the signed distance
//! `s0 + σ t`) and hands the kernel algebra of `bounds.rs`, `quad.rs` and
//! `raa.rs` what it needs. HRBF terms and affine functions, which are not
//! kernels, are two more implementations of [`PrimitiveKind`] in `hrbf.rs`;
//! the fold over primitives (`fold.rs`) does not change.

use glam::DVec3;

use super::bound::Bound;
use super::bounds::{Lin, Order, Taylor, compact_derivs, compact_lin, kernel_taylor};
use super::quad::{QuadOptions, compact_quad, gaussian_quad};
use super::raa::{Affine, compact_raa, exp_neg};
use super::{KernelEval, point_on_ray};

/// Every evaluation of one primitive along a ray `o + t u`, `|u| = 1`.
pub trait PrimitiveKind {
    /// Value and gradient at `p`.
    fn value_gradient(&self, p: DVec3) -> (f64, DVec3);

    /// Value at `p`.
    fn value(&self, p: DVec3) -> f64;

    /// The global Lipschitz constant (Eq. 10): the peak of `|dk/dd|` for a
    /// kernel; for kinds whose slope grows without bound (HRBF terms), the
    /// largest `|∇f|` in the box where rays march.
    fn lipschitz(&self) -> f64;

    /// Segment tracing's bound on `|df/dt|` over `t ∈ [ta, tb]`
    /// (docs/benchmark-protocol.md): the largest `|dk/dd|` over the
    /// segment's distance range, times the largest `|∂d/∂t|` at its ends.
    /// Zero when the support misses the segment.
    fn segment_slope(&self, o: DVec3, u: DVec3, ta: f64, tb: f64) -> f64;

    /// Taylor data on `[t0, t1]` (value and slope at `t0`, range of the
    /// order's derivative); with `extension`, a compact support entered
    /// late gets the per-primitive bound of Section 6.2.1.
    fn taylor(&self, o: DVec3, u: DVec3, t0: f64, t1: f64, order: Order, extension: bool) -> Taylor;

    /// Bottom-up linear bound on `[t0, t0 + len]`.
    fn linear(&self, o: DVec3, u: DVec3, t0: f64, len: f64) -> Lin;

    /// Bottom-up quadratic bound on `[t0, t0 + len]`; may shorten `len`
    /// (a validity interval).
    fn quadratic(&self, o: DVec3, u: DVec3, t0: f64, len: &mut f64, opts: QuadOptions) -> Bound;

    /// Revised affine arithmetic on `[ta, tb]` (`ta == tb` is allowed).
    fn raa(&self, o: DVec3, u: DVec3, ta: f64, tb: f64) -> Affine;
}

/// A point primitive: a radial kernel of the distance to its centre.
#[derive(Clone, Copy, Debug)]
pub struct PointPrim {
    pub center: DVec3,
    pub kernel: KernelEval,
}

/// A plane primitive: the compact kernel of the signed distance
/// `normal · p - offset`.
#[derive(Clone, Copy, Debug)]
pub struct PlanePrim {
    pub normal: DVec3,
    pub offset: f64,
    pub kernel: KernelEval,
}

impl PrimitiveKind for PointPrim {
    fn value_gradient(&self, p: DVec3) -> (f64, DVec3) {
        let d = p - self.center;
        let q = d.length_squared();
        (self.kernel.value(q), 2.0 * self.kernel.dq(q) * d)
    }

    fn value(&self, p: DVec3) -> f64 {
        self.kernel.value((p - self.center).length_squared())
    }

    fn lipschitz(&self) -> f64 {
        self.kernel.peak_slope
    }

    fn segment_slope(&self, o: DVec3, u: DVec3, ta: f64, tb: f64) -> f64 {
        let (center, kernel) = (self.center, self.kernel);
        let ca = o + ta * u - center;
        let cb = o + tb * u - center;
        let tc = (center - o).dot(u).clamp(ta, tb);
        let lo = (o + tc * u - center).length();
        if lo >= kernel.support() {
            return 0.0;
        }
        let (la, lb) = (ca.length(), cb.length());
        let cos = |v: DVec3, l: f64| if l > 0.0 { (v.dot(u) / l).abs() } else { 1.0 };
        kernel.max_slope(lo, la.max(lb)) * cos(ca, la).max(cos(cb, lb))
    }

    fn taylor(&self, o: DVec3, u: DVec3, t0: f64, t1: f64, order: Order, extension: bool) -> Taylor {
        let (h2, x0) = point_on_ray(self.center, o, u, t0);
        kernel_taylor(&self.kernel, h2, x0, x0 + (t1 - t0), order, extension)
    }

    fn linear(&self, o: DVec3, u: DVec3, t0: f64, len: f64) -> Lin {
        let kernel = self.kernel;
        let (h2, x0) = point_on_ray(self.center, o, u, t0);
        if !kernel.gaussian {
            return compact_lin(kernel.weight, kernel.inv, 1.0 - h2 * kernel.inv, x0, len);
        }
        // y = α(x² + h²) is convex: tangent below, chord above.
        let y = Lin { v: kernel.inv * (x0 * x0 + h2), lo: 2.0 * kernel.inv * x0, hi: kernel.inv * (2.0 * x0 + len) };
        // Far from t0 the chord of e^{-y} over the lower line's range can
        // exceed any float; but |f'| never exceeds the kernel's Lipschitz
        // constant, so by the mean value theorem slopes can be clamped to
        // it (also tighter).
        // A negative weight mirrors the kernel of |w|: its bounds swap.
        let k = y.exp_neg(kernel.weight.abs(), len);
        let k = Lin { v: k.v, lo: k.lo.max(-kernel.peak_slope), hi: k.hi.min(kernel.peak_slope) };
        if kernel.weight < 0.0 { -k } else { k }
    }

    fn quadratic(&self, o: DVec3, u: DVec3, t0: f64, len: &mut f64, opts: QuadOptions) -> Bound {
        let kernel = self.kernel;
        let (h2, x0) = point_on_ray(self.center, o, u, t0);
        if kernel.gaussian {
            gaussian_quad(kernel.weight, kernel.inv, h2, x0, len, opts.exp_upper, opts.validity_floor)
        } else {
            compact_quad(kernel.weight, kernel.inv, 1.0 - h2 * kernel.inv, x0, *len, opts.extension)
        }
    }

    fn raa(&self, o: DVec3, u: DVec3, ta: f64, tb: f64) -> Affine {
        let kernel = self.kernel;
        let (h2, xa) = point_on_ray(self.center, o, u, ta);
        let xb = xa + (tb - ta);
        if !kernel.gaussian {
            return compact_raa(&kernel, kernel.inv, h2, xa, xb);
        }
        let x = Affine { x0: 0.5 * (xa + xb), x1: 0.5 * (xb - xa), e: 0.0 };
        let y = (x * x + Affine { x0: h2, x1: 0.0, e: 0.0 }).scale(kernel.inv);
        exp_neg(y, kernel.inv * h2).scale(kernel.weight)
    }
}

impl PlanePrim {
    /// Signed distance at `p`.
    fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.offset
    }
}

/// Along a ray, a plane's kernel is the compact kernel in `x = s/σ` with
/// `1/R'² = σ²/R²` and `h = 0`, `s = s0 + σ t` the signed distance; `None`
/// for a ray parallel to the plane, where the kernel is constant.
fn plane_as_point(kernel: &KernelEval, s0: f64, sigma: f64) -> Option<(f64, f64)> {
    (sigma.abs() >= 1e-9).then(|| (kernel.inv * sigma * sigma, s0 / sigma))
}

impl PrimitiveKind for PlanePrim {
    fn value_gradient(&self, p: DVec3) -> (f64, DVec3) {
        let s = self.distance(p);
        let q = s * s;
        (self.kernel.value(q), 2.0 * self.kernel.dq(q) * s * self.normal)
    }

    fn value(&self, p: DVec3) -> f64 {
        let s = self.distance(p);
        self.kernel.value(s * s)
    }

    /// The signed distance has a unit gradient.
    fn lipschitz(&self) -> f64 {
        self.kernel.peak_slope
    }

    fn segment_slope(&self, o: DVec3, u: DVec3, ta: f64, tb: f64) -> f64 {
        let (sa, sb) = (self.distance(o + ta * u), self.distance(o + tb * u));
        let lo = if sa * sb <= 0.0 { 0.0 } else { sa.abs().min(sb.abs()) };
        if lo >= self.kernel.support() {
            return 0.0;
        }
        self.kernel.max_slope(lo, sa.abs().max(sb.abs())) * self.normal.dot(u).abs()
    }

    fn taylor(&self, o: DVec3, u: DVec3, t0: f64, t1: f64, order: Order, _extension: bool) -> Taylor {
        // Signed distance s = s0 + σ t: the kernel of s with h = 0,
        // derivatives in t scaled by σ and σ².
        let kernel = self.kernel;
        let sigma = self.normal.dot(u);
        let s0 = self.distance(o + t0 * u);
        let s1 = self.distance(o + t1 * u);
        let (lo, hi) = (s0.min(s1), s0.max(s1));
        let mut k = kernel_taylor(&kernel, 0.0, lo, hi, order, false);
        // kernel_taylor evaluated value/slope at `lo`; redo them at s0.
        let (value, slope, _) = compact_derivs(kernel.weight, kernel.inv, 1.0, s0);
        k.value = value;
        k.slope = slope * sigma;
        let scale = if order == Order::Linear { sigma } else { sigma * sigma };
        let (a, b) = (k.min * scale, k.max * scale);
        k.min = a.min(b);
        k.max = a.max(b);
        k
    }

    fn linear(&self, o: DVec3, u: DVec3, t0: f64, len: f64) -> Lin {
        let s0 = self.distance(o + t0 * u);
        match plane_as_point(&self.kernel, s0, self.normal.dot(u)) {
            Some((inv_r2, x0)) => compact_lin(self.kernel.weight, inv_r2, 1.0, x0, len),
            None => Lin { v: self.kernel.value(s0 * s0), lo: 0.0, hi: 0.0 },
        }
    }

    fn quadratic(&self, o: DVec3, u: DVec3, t0: f64, len: &mut f64, opts: QuadOptions) -> Bound {
        let s0 = self.distance(o + t0 * u);
        match plane_as_point(&self.kernel, s0, self.normal.dot(u)) {
            Some((inv_r2, x0)) => compact_quad(self.kernel.weight, inv_r2, 1.0, x0, *len, opts.extension),
            None => Bound::exact(self.kernel.value(s0 * s0), 0.0, 0.0),
        }
    }

    fn raa(&self, o: DVec3, u: DVec3, ta: f64, tb: f64) -> Affine {
        let sigma = self.normal.dot(u);
        let sa = self.distance(o + ta * u);
        let Some((inv_r2, xa)) = plane_as_point(&self.kernel, sa, sigma) else {
            return Affine { x0: self.kernel.value(sa * sa), x1: 0.0, e: 0.0 };
        };
        // x = s / σ = xa + (t - ta) runs with t whatever σ's sign, so the
        // affine form is in the ray's own ε.
        let xb = self.distance(o + tb * u) / sigma;
        compact_raa(&self.kernel, inv_r2, 0.0, xa, xb)
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    /// Every kind the GPU knows (a `PRIM_*` constant shared with GLSL) has
    /// its own file, `shaders/include/kinds/<kind>.glsl`, defining its six
    /// functions, and `shaders/include/kinds.glsl` includes that file and
    /// names the kind in its switch (its `KIND_TERMS` line and its case in
    /// `prim_terms`): a kind whose file goes missing, or which the switch
    /// forgets and would poison, fails here before any GPU runs.
    #[test]
    fn every_kind_has_its_shader_file_and_its_line_in_the_kind_switch() {
        let include = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders/include");
        // The code alone: a line commented out is not in the switch.
        let code = |text: &str| text.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n");
        let switch = code(&std::fs::read_to_string(include.join("kinds.glsl")).expect("reading shaders/include/kinds.glsl"));
        let kinds: Vec<&str> = crate::layout::GLSL_CONSTANTS.iter().filter_map(|(name, _)| name.strip_prefix("PRIM_")).collect();
        assert!(!kinds.is_empty(), "no PRIM_* constant in layout::GLSL_CONSTANTS");
        for upper in kinds {
            let kind = upper.to_lowercase();
            let file = include.join("kinds").join(format!("{kind}.glsl"));
            let source = code(&std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("PRIM_{upper} has no {}: {e}", file.display())));
            for function in ["value", "lipschitz", "taylor", "linear", "quad", "raa"] {
                let definition = format!("{kind}_{function}(GpuPrimitive pr");
                assert!(source.contains(&definition), "{} does not define {kind}_{function}", file.display());
            }
            for line in [format!("#include \"kinds/{kind}.glsl\""), format!("KIND_TERMS({kind})"), format!("case PRIM_{upper}:")] {
                assert!(switch.contains(&line), "shaders/include/kinds.glsl lacks `{line}` for PRIM_{upper}");
            }
        }
    }
}
