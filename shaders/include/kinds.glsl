// The kinds of primitive, one file each in kinds/, mirroring
// src/field/kinds.rs and hrbf.rs. A kind's file holds its six functions,
// each of one primitive pr along o + t u:
//   KIND_value(pr, p, want_grad, grad)  the value at p, the gradient added
//       to `grad` when want_grad;
//   KIND_lipschitz(pr, o, u, ta, tb)  segment tracing's bound on |df/dt|
//       over t in [ta, tb] (docs/benchmark-protocol.md): for a kernel, the
//       largest |dk/dd| over the segment's distance range (|dk/dd| is
//       unimodal, peaking at b.w), times the largest |dd/dt| at its ends;
//       0 when the support misses the segment;
//   KIND_taylor(pr, o, u, t0, t1, QUADRATIC)  the Taylor data on [t0, t1];
//   KIND_linear(pr, o, u, t0, len)  the bottom-up linear bound on
//       [t0, t0 + len];
//   KIND_quad(pr, o, u, t0, len)  the bottom-up quadratic bound on
//       [t0, t0 + len]; a Gaussian may shorten len (the compact kinds
//       leave it);
//   KIND_raa(pr, o, u, ta, tb)  revised affine arithmetic on [ta, tb].
// A new kind is its file, its KIND_TERMS line and its case below (and its
// PRIM_* constant in src/layout.rs; src/field/kinds.rs tests that each
// constant has all three).
#ifndef KINDS_GLSL
#define KINDS_GLSL

#include "bindings.glsl"
#include "terms.glsl"
#include "kinds/compact_point.glsl"
#include "kinds/gaussian_point.glsl"
#include "kinds/compact_plane.glsl"
#include "kinds/hrbf.glsl"
#include "kinds/affine.glsl"

KIND_TERMS(compact_point)
KIND_TERMS(gaussian_point)
KIND_TERMS(compact_plane)
KIND_TERMS(hrbf)
KIND_TERMS(affine)

// The one dispatch on the primitive's kind: exhaustive, a kind the shader
// does not know poisons the result. A kind the scene does not use is
// compiled out (SC_HAS_*) and adds nothing.
Terms prim_terms(uint what, GpuPrimitive pr, Query q, inout float len) {
    switch (pr.ids.x) {
    case PRIM_COMPACT_POINT: return SC_HAS_COMPACT_POINT != 0u ? compact_point_terms(what, pr, q, len) : no_terms();
    case PRIM_GAUSSIAN_POINT: return SC_HAS_GAUSSIAN_POINT != 0u ? gaussian_point_terms(what, pr, q, len) : no_terms();
    // The bracket's kernel (SC_BRACKET) marches point kernels alone.
    case PRIM_COMPACT_PLANE: return SC_BRACKET == 0u && SC_HAS_COMPACT_PLANE != 0u ? compact_plane_terms(what, pr, q, len) : no_terms();
    case PRIM_HRBF: return SC_BRACKET == 0u && SC_HAS_HRBF != 0u ? hrbf_terms(what, pr, q, len) : no_terms();
    case PRIM_AFFINE: return SC_BRACKET == 0u && SC_HAS_AFFINE != 0u ? affine_terms(what, pr, q, len) : no_terms();
    default: return poison_terms();
    }
}

#endif
