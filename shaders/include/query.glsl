// A query of the field (a point, or the ray on [t0, t1]) and what a fold
// evaluates for it (fold.glsl).
#ifndef QUERY_GLSL
#define QUERY_GLSL

// What a fold evaluates.
const uint EVAL_VALUE = 0u;       // f at a point
const uint EVAL_GRADIENT = 1u;    // f and the gradient of the group attaining the max
const uint EVAL_LIPSCHITZ = 2u;   // f at t0 and segment tracing's bound on |f'| over [t0, t1]
const uint EVAL_TAYLOR = 3u;      // linear or quadratic Taylor bound (SC_METHOD says which)
const uint EVAL_LINEAR = 4u;      // bottom-up linear bound
const uint EVAL_QUAD = 5u;        // bottom-up quadratic bound (may shorten the interval)
const uint EVAL_RAA = 6u;         // revised affine arithmetic range

// A query: the ray o + t u on [t0, t1], or the point o.
struct Query {
    vec3 o;
    vec3 u;
    float t0;
    float t1;
    bool point;
};

Query point_query(vec3 p) {
    return Query(p, vec3(0.0), 0.0, 0.0, true);
}

Query ray_query(vec3 o, vec3 u, float t0, float t1) {
    return Query(o, u, t0, t1, false);
}

#endif
