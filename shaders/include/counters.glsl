// What an invocation counts for the statistics (GpuResult::counts and
// ::crossings): the kernel evaluations of the kinds and kernels, and the
// positions the cursors visited.
#ifndef COUNTERS_GLSL
#define COUNTERS_GLSL

// Per-primitive kernel evaluations made by this invocation (values, bounds).
uint g_evals = 0u;
// Positions the folds' cursors visited (list entries, culled primitives),
// whether they yielded an evaluation or not: the walk's work.
uint g_visits = 0u;

#endif
