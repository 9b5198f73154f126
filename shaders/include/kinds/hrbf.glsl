// Hermite RBF terms (Eq. 9, φ(r) = r³, PRIM_HRBF): every evaluation of the
// kind, in f32; kinds/affine.glsl has the affine functions that go with
// them. Mirrors src/field/hrbf.rs, whose module documentation (and
// docs/hrbf.md) carries the derivations.
//
// A term about its control point c: g = α r³ + 3 r β·(p - c). Along a ray,
// x = t - tc, h the distance of c from the line, w the vector from c to
// the closest point: g = ρ P with ρ = √(x² + h²) and the exact quadratic
// P(x) = α x² + 3 c1 x + α h² + 3 c0, c0 = β·w, c1 = β·u.
#ifndef KIND_HRBF_GLSL
#define KIND_HRBF_GLSL

#include "bindings.glsl"
#include "counters.glsl"
#include "bound.glsl"
#include "quad.glsl"
#include "raa.glsl"

struct HrbfRay {
    float alpha;
    float h, h2;
    float x0;
    float c0, c0_hat, c1;   // β·w, β·w/h (0 when h = 0), β·u
};

HrbfRay hrbf_on_ray(GpuPrimitive pr, vec3 o, vec3 u, float t0) {
    vec3 co = pr.a.xyz - o;
    float tc = dot(co, u);
    vec3 w = tc * u - co;
    float h2 = dot(w, w);
    float h = sqrt(h2);
    float c0 = dot(pr.b.xyz, w);
    return HrbfRay(pr.a.w, h, h2, t0 - tc, c0, h > 0.0 ? c0 / h : 0.0, dot(pr.b.xyz, u));
}

float hrbf_p(HrbfRay g, float x) {
    return g.alpha * x * x + 3.0 * g.c1 * x + g.alpha * g.h2 + 3.0 * g.c0;
}

float hrbf_dp(HrbfRay g, float x) {
    return 2.0 * g.alpha * x + 3.0 * g.c1;
}

float hrbf_rho(HrbfRay g, float x) {
    return sqrt(x * x + g.h2);
}

// (ρ, x/ρ, h/ρ); at the control point (ρ = 0) the one-sided limit of x/ρ
// from the side `right`.
vec3 hrbf_angles(HrbfRay g, float x, bool right) {
    float r = hrbf_rho(g, x);
    return r > 0.0 ? vec3(r, x / r, g.h / r) : vec3(0.0, right ? 1.0 : -1.0, 0.0);
}

float hrbf_d1(HrbfRay g, float x) {
    vec3 a = hrbf_angles(g, x, true);
    return a.y * hrbf_p(g, x) + a.x * hrbf_dp(g, x);
}

// g'' with the bounded ratios x/ρ and h/ρ.
float hrbf_d2(HrbfRay g, float x, bool right) {
    vec3 a = hrbf_angles(g, x, right);
    return a.z * a.z * (g.alpha * a.x + 3.0 * g.c1 * a.y + 3.0 * g.c0_hat * a.z) + 2.0 * a.y * hrbf_dp(g, x) + 2.0 * g.alpha * a.x;
}

// M(s) and M'(s): ρ⁵ g'''/3 = h⁴ M(x/h).
vec2 hrbf_m(HrbfRay g, float s) {
    float ah = g.alpha * g.h;
    float s2 = s * s;
    return vec2(ah * s * (2.0 * s2 + 3.0) * (s2 + 1.0) - 3.0 * g.c0_hat * s + 3.0 * g.c1,
                ah * (10.0 * s2 * s2 + 15.0 * s2 + 3.0) - 3.0 * g.c0_hat);
}

// One safeguarded Newton step on the bracket [a, b] of a root of M, with
// M's values ma and mb at its ends.
void hrbf_newton(HrbfRay g, bool a_positive, inout float a, inout float b, inout float ma, inout float mb, inout float s) {
    vec2 m = hrbf_m(g, s);
    if ((m.x > 0.0) == a_positive) {
        a = s;
        ma = m.x;
    } else {
        b = s;
        mb = m.x;
    }
    float newton = s - m.x / m.y;
    s = m.y != 0.0 && newton > a && newton < b ? newton : 0.5 * (a + b);
}

// The root of M on [a, b], where it is monotone, taken into the range of
// g'' when M changes sign there. Straight-line steps: lavapipe counts loop
// turns against its per-invocation cap, and runs straight code faster.
//
// g'' at the estimate s differs from its extremum at the root s* by at most
// sup|g'''| · h |s - s*|, and with ρ⁵ g''' = 3 h⁴ M, ρ >= h and M monotone
// on the bracket, that is at most 3 (b - a) max(|M(a)|, |M(b)|): the value
// taken is widened by it, so the range stays a valid one however far the
// steps got (once they converge the pad vanishes).
void hrbf_piece(HrbfRay g, float a, float b, inout vec2 range) {
    if (!(a < b)) return;
    float ma = hrbf_m(g, a).x;
    float mb = hrbf_m(g, b).x;
    if ((ma > 0.0) == (mb > 0.0) && ma != 0.0 && mb != 0.0) return;
    bool a_positive = ma > 0.0;
    float s = 0.5 * (a + b);
    hrbf_newton(g, a_positive, a, b, ma, mb, s);
    hrbf_newton(g, a_positive, a, b, ma, mb, s);
    hrbf_newton(g, a_positive, a, b, ma, mb, s);
    hrbf_newton(g, a_positive, a, b, ma, mb, s);
    hrbf_newton(g, a_positive, a, b, ma, mb, s);
    hrbf_newton(g, a_positive, a, b, ma, mb, s);
    hrbf_newton(g, a_positive, a, b, ma, mb, s);
    hrbf_newton(g, a_positive, a, b, ma, mb, s);
    hrbf_newton(g, a_positive, a, b, ma, mb, s);
    hrbf_newton(g, a_positive, a, b, ma, mb, s);
    float d = hrbf_d2(g, g.h * s, true);
    float pad = 3.0 * (b - a) * max(abs(ma), abs(mb));
    range = vec2(min(range.x, d - pad), max(range.y, d + pad));
}

// The exact range of g'' over [xa, xb]: the ends and the roots of g'''.
vec2 hrbf_d2_range(HrbfRay g, float xa, float xb) {
    float da = hrbf_d2(g, xa, true);
    float db = hrbf_d2(g, xb, xb <= xa);
    vec2 range = vec2(min(da, db), max(da, db));
    if (g.h == 0.0) {
        // Through the control point: g'' jumps there, by ±6 c1.
        if (xa < 0.0 && xb > 0.0) range = vec2(min(range.x, -6.0 * abs(g.c1)), max(range.y, 6.0 * abs(g.c1)));
        return range;
    }
    float ah = g.alpha * g.h;
    float c = abs(g.c0_hat) + abs(g.c1);
    if (abs(ah) <= 1e-30 * c) {
        // M is linear at f32's precision.
        if (g.c0_hat != 0.0) {
            float x = g.h * g.c1 / g.c0_hat;
            if (x > xa && x < xb) {
                float d = hrbf_d2(g, x, true);
                range = vec2(min(range.x, d), max(range.y, d));
            }
        }
        return range;
    }
    // Real roots of M lie in |s| <= S; M' has its real roots at ±s*.
    float bound = max(1.0, sqrt(sqrt(1.5 * c / abs(ah))));
    float sa = max(xa / g.h, -bound);
    float sb = min(xb / g.h, bound);
    float k = 3.0 * g.c0_hat / ah;
    float s_star = 3.0e38;
    if (k > 3.0) {
        float y = k > 1e30 ? sqrt(0.1 * k) : (2.0 * k - 6.0) / (15.0 + 6.3245553 * sqrt(k + 2.625));
        s_star = sqrt(y);
    }
    float m1 = clamp(-s_star, sa, sb);
    float m2 = clamp(s_star, sa, sb);
    hrbf_piece(g, sa, m1, range);
    hrbf_piece(g, m1, m2, range);
    hrbf_piece(g, m2, sb, range);
    return range;
}

// A range of g' from its ends and the range [m, M] of g'' (not exact):
// g' stays below ga + M τ and gb - m (len - τ), above the mirror images.
vec2 hrbf_d1_range(HrbfRay g, float xa, float xb) {
    float ga = hrbf_d1(g, xa);
    float gb = hrbf_d1(g, xb);
    float len = xb - xa;
    vec2 m = hrbf_d2_range(g, xa, xb);
    vec2 ends = vec2(min(ga, gb), max(ga, gb));
    if (len <= 0.0 || m.y - m.x <= 0.0) return ends;
    float tau_hi = clamp((gb - ga - m.x * len) / (m.y - m.x), 0.0, len);
    float hi = m.y < 0.0 ? ga : m.x > 0.0 ? gb : ga + m.y * tau_hi;
    float tau_lo = clamp((m.y * len - (gb - ga)) / (m.y - m.x), 0.0, len);
    float lo = m.x > 0.0 ? ga : m.y < 0.0 ? gb : ga + m.x * tau_lo;
    return vec2(min(lo, ends.x), max(hi, ends.y));
}

// Largest |g''| over [xa, xb], term by term ((h/ρ)² |x/ρ| <= 2/(3√3)).
float hrbf_d2_magnitude(HrbfRay g, float xa, float xb) {
    float a = abs(g.alpha);
    float rho_max = max(hrbf_rho(g, xa), hrbf_rho(g, xb));
    return a * g.h + 1.1547005 * abs(g.c1) + 3.0 * abs(g.c0_hat) + 2.0 * max(abs(hrbf_dp(g, xa)), abs(hrbf_dp(g, xb))) + 2.0 * a * rho_max;
}

// --- The kind's interface (kinds.glsl).

float hrbf_value(GpuPrimitive pr, vec3 p, bool want_grad, inout vec3 grad) {
    g_evals += 1u;
    vec3 d = p - pr.a.xyz;
    float r = length(d);
    float bd = dot(pr.b.xyz, d);
    if (want_grad && r > 0.0) grad += 3.0 * pr.a.w * r * d + 3.0 * bd * d / r + 3.0 * r * pr.b.xyz;
    return pr.a.w * r * r * r + 3.0 * r * bd;
}

// |g'| <= max|x/ρ| max|P| + max ρ max|P'| over the segment.
float hrbf_lipschitz(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    g_evals += 1u;
    HrbfRay g = hrbf_on_ray(pr, o, u, ta);
    float xa = g.x0;
    float xb = g.x0 + (tb - ta);
    vec3 a = hrbf_angles(g, xa, true);
    vec3 b = hrbf_angles(g, xb, false);
    float p_max = max(abs(hrbf_p(g, xa)), abs(hrbf_p(g, xb)));
    float vertex = g.alpha != 0.0 ? -1.5 * g.c1 / g.alpha : xa;
    if (vertex > xa && vertex < xb) p_max = max(p_max, abs(hrbf_p(g, vertex)));
    return max(abs(a.y), abs(b.y)) * p_max + max(a.x, b.x) * max(abs(hrbf_dp(g, xa)), abs(hrbf_dp(g, xb)));
}

Taylor hrbf_taylor(GpuPrimitive pr, vec3 o, vec3 u, float t0, float t1, bool QUADRATIC) {
    g_evals += 1u;
    HrbfRay g = hrbf_on_ray(pr, o, u, t0);
    float xa = g.x0;
    float xb = g.x0 + (t1 - t0);
    vec2 range = QUADRATIC ? hrbf_d2_range(g, xa, xb) : hrbf_d1_range(g, xa, xb);
    return Taylor(hrbf_rho(g, xa) * hrbf_p(g, xa), hrbf_d1(g, xa), range.x, range.y);
}

// ρ convex (tangent below, chord above) times P (a quadratic), Eq. 17.
Lin hrbf_linear(GpuPrimitive pr, vec3 o, vec3 u, float t0, float len) {
    g_evals += 1u;
    HrbfRay g = hrbf_on_ray(pr, o, u, t0);
    float x0 = g.x0;
    float r0 = hrbf_rho(g, x0);
    float r1 = hrbf_rho(g, x0 + len);
    float tangent = r0 > 0.0 ? x0 / r0 : 1.0;
    Lin rho = Lin(r0, tangent, len > 0.0 ? (r1 - r0) / len : tangent);
    float p_tangent = hrbf_dp(g, x0);
    float p_chord = p_tangent + g.alpha * len;
    return lin_mul(rho, Lin(hrbf_p(g, x0), min(p_tangent, p_chord), max(p_tangent, p_chord)), len);
}

// ρ between quadratics from its curvature h²/ρ³ (capped by 1/ρ0 above),
// times the exact P (Figure 8); each side's curvature capped by |g''|.
Bound hrbf_quad(GpuPrimitive pr, vec3 o, vec3 u, float t0, inout float len) {
    g_evals += 1u;
    HrbfRay g = hrbf_on_ray(pr, o, u, t0);
    float x0 = g.x0;
    float x1 = g.x0 + len;
    float r0 = hrbf_rho(g, x0);
    float r1 = hrbf_rho(g, x1);
    float rho_max = max(r0, r1);
    float rho_min = x0 <= 0.0 && x1 >= 0.0 ? g.h : min(r0, r1);
    float slope = r0 > 0.0 ? x0 / r0 : 1.0;
    float curv_lo = rho_max > 0.0 ? g.h2 / (rho_max * rho_max * rho_max) : 0.0;
    // f32: curvatures past 1e30 only arise within 1e-10 of a control
    // point, where the cap below takes over.
    float inv_r0 = r0 > 1e-30 ? 1.0 / r0 : 1e30;
    float curv_hi = r0 == 0.0 ? 0.0 : rho_min > 1e-10 ? min(g.h2 / (rho_min * rho_min * rho_min), inv_r0) : inv_r0;
    Bound rho = Bound(r0, slope, 0.5 * curv_lo, slope, 0.5 * curv_hi, 0.0);
    Bound b = quad_mul(rho, quad_exact(hrbf_p(g, x0), hrbf_dp(g, x0), g.alpha), len, false, true);
    float cap = 0.5 * hrbf_d2_magnitude(g, x0, x1);
    b.b_hi = min(b.b_hi, cap);
    b.b_lo = max(b.b_lo, -cap);
    return b;
}

vec3 hrbf_raa(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    g_evals += 1u;
    HrbfRay g = hrbf_on_ray(pr, o, u, ta);
    float xa = g.x0;
    float xb = g.x0 + (tb - ta);
    vec3 x = vec3(0.5 * (xa + xb), 0.5 * (xb - xa), 0.0);
    vec3 y = aa_mul(x, x) + vec3(g.h2, 0.0, 0.0);
    vec3 p = aa_scale(y, g.alpha) + aa_scale(x, 3.0 * g.c1) + vec3(3.0 * g.c0, 0.0, 0.0);
    return aa_mul(aa_sqrt(y, g.h2), p);
}

#endif
