//! GPU-visible data layouts: the one source of truth.
//!
//! This file is compiled twice: into the library, and into `shaders/build.rs`, which
//! calls [`glsl`] to generate `layout.glsl` for the shaders. Every struct is
//! made of 16-byte vectors so that `#[repr(C)]` and GLSL's std430 agree
//! without padding rules to get wrong; `tests` in the library check sizes.

/// Declares `#[repr(C)]` structs of 16-byte vectors and records, for each, the
/// GLSL declaration that mirrors it.
macro_rules! gpu_structs {
    ($( $(#[$meta:meta])* struct $name:ident { $( $(#[$fmeta:meta])* $field:ident : $ty:ident ),* $(,)? } )*) => {
        $(
            $(#[$meta])*
            #[repr(C)]
            #[derive(Clone, Copy, Debug, Default, PartialEq)]
            pub struct $name { $( $(#[$fmeta])* pub $field: $ty ),* }
            // Every field is Pod, and the struct is exactly their sizes
            // summed (no padding): checked here, at compile time.
            const _: () = assert!(std::mem::size_of::<$name>() == 0 $( + std::mem::size_of::<$ty>() )*);
            const _: fn() = || {
                fn pod<T: bytemuck::Pod>() {}
                $( pod::<$ty>(); )*
            };
            // SAFETY: `#[repr(C)]`, every field Pod and no padding (the
            // assertion above), so any bit pattern is a value and zero is one.
            // Written by hand rather than derived: the derive is a proc
            // macro whose build (and the shaders' build script, which
            // includes this file) changes with the features other crates
            // ask of syn, which made every command compile the shaders anew.
            unsafe impl bytemuck::Zeroable for $name {}
            // SAFETY: as for Zeroable above.
            unsafe impl bytemuck::Pod for $name {}
        )*

        /// GLSL declarations of every GPU struct, in declaration order.
        pub fn glsl_structs() -> String {
            let mut s = String::new();
            $(
                s.push_str(concat!("struct ", stringify!($name), " {\n"));
                $( s.push_str(&format!("    {} {};\n", glsl_type(stringify!($ty)), stringify!($field))); )*
                s.push_str("};\n");
            )*
            s
        }

        /// `(name, size in bytes)` of every GPU struct.
        pub fn struct_sizes() -> Vec<(&'static str, usize)> {
            vec![$( (stringify!($name), std::mem::size_of::<$name>()) ),*]
        }
    };
}

/// Four `f32`, GLSL `vec4`.
pub type Vec4 = [f32; 4];
/// Four `u32`, GLSL `uvec4`.
pub type UVec4 = [u32; 4];

fn glsl_type(rust: &str) -> &'static str {
    match rust {
        "Vec4" => "vec4",
        "UVec4" => "uvec4",
        other => panic!("no GLSL type for {other}: GPU structs use Vec4 and UVec4 only"),
    }
}

gpu_structs! {
    /// One primitive. Points: `a.xyz` centre, `a.w` the radius for the
    /// index (as `c.y`: the index walk tests a list entry with one texel).
    /// Planes: `a.xyz` unit normal,
    /// `a.w` offset (the plane is `n·p = offset`).
    /// `b`: x support radius R (compact) or scale r (Gaussian), y 1/R² or
    /// s/r², z weight, w the distance where |dk/dd| peaks (R/√5 or r/√(2s)).
    /// HRBF terms: `a.xyz` the control point, `a.w` α, `b.xyz` β. Affine
    /// functions: `a.xyz` the gradient, `a.w` the offset.
    /// `c`: x the peak of |dk/dd| (the kernel's Lipschitz constant), y the
    /// radius for the index, z (points) the distance within which the
    /// kernel alone reaches iso (1 + 1e-3) (0 where it never does: the
    /// first-crossing bracket, `SC_BRACKET`), w reserved.
    /// `ids`: x kind (`PRIM_*`), y group index (primitives are sorted by group),
    /// z the primitive's own colour (linear RGB, 8 bits a channel, red lowest)
    /// when `GpuGlobals::surface.w` is 1.
    struct GpuPrimitive { a: Vec4, b: Vec4, c: Vec4, ids: UVec4 }

    /// One ray: origin and `tmin` in `o`, unit direction and `tmax` in `d`.
    /// `tmax < tmin` means the ray misses the scene bounds.
    struct GpuRay { o: Vec4, d: Vec4 }

    /// What the marcher found for one ray. `hit`: xyz unit normal (outward,
    /// towards decreasing field), w hit distance or -1. `color`: shaded RGBA.
    /// `counts`: steps, kernel evaluations, refinement evaluations, flags.
    /// `crossings`: x crossings found (transparent rendering; the first
    /// `MAX_CROSSINGS` are in the crossings buffer), y list positions the
    /// march's folds visited (entries of the index's lists, culled
    /// primitives), z loop turns (steps and refinement evaluations), w
    /// reserved.
    struct GpuResult { hit: Vec4, color: Vec4, counts: UVec4, crossings: UVec4 }

    /// What the bounds probe found for one query on `[t0, t1]`. A forward
    /// bound: `lo` = (v, a_lo, b_lo, t_valid), `hi` = (v, a_hi, b_hi, e_hi),
    /// `e_hi` how far above v the upper bound starts (0 except for
    /// quadratic-relaxed-t0). RAA, which is not forward: `lo.x` and `hi.x`
    /// hold its range, slopes 0. Sphere tracing: `lo.x` f at t0, `hi.xyz`
    /// its gradient. Segment tracing: `lo.x` f at t0, `hi.y` the Lipschitz
    /// bound on [t0, t1] (`lo.y` its negative).
    struct GpuBound { lo: Vec4, hi: Vec4 }

    /// A ray's marching state between dispatches (see `render::Renderer::march`):
    /// `v`: t, the previous point t_prev, candidate interval length, reserved;
    /// `n`: steps, kernel evaluations, refinement evaluations, flags;
    /// `node`: the bisection methods' current sub-interval (depth, index),
    /// z crossings found so far (transparent rendering).
    /// `v.w`: the first crossing (transparent rendering).
    /// `light`: transparent rendering's colour so far (rgb) and the last
    /// crossing (w); `trans`: its transmittance so far (rgb).
    /// `trans.w`: f at the previous point.
    /// `refine`: the bracket of a crossing being refined (x, y; one field
    /// evaluation per loop turn, so that no dispatch runs more than one
    /// pass over the primitives per turn) and the field at its ends as the
    /// interpolation uses them (z, w); the refinement's turns and the end
    /// its last turn moved are in bits 16-23 and 24-25 of `n.w`.
    /// `tally`: list positions visited and loop turns so far (see
    /// `GpuResult::crossings`), z where f >= 0 is known (`SC_BRACKET`; float
    /// bits), w the first entry of its tile list still worth reading
    /// (`SC_TILES`, `g_cursor`).
    struct GpuMarchState { v: Vec4, n: UVec4, node: UVec4, light: Vec4, trans: Vec4, refine: Vec4, tally: UVec4 }

    /// Scene-wide constants. `march`: x iso, y minimum step, z refinement
    /// tolerance, w global Lipschitz bound (sphere tracing).
    /// `sizes`: x primitive count, y group count, z light count, w max steps.
    /// `tuning`: x interval growth factor k (Algorithm 1), y the peak below
    /// which a Gaussian imposes no validity interval (`quadratic`), z the
    /// longest candidate interval of a step with the spatial index (0: no
    /// limit), w 1 when the march may skip cells that list no primitive
    /// (the field is -iso < 0 there: every primitive is in the grid).
    /// `surface`: rgb the surface colour, w 1 when every primitive carries
    /// its own colour instead (`GpuPrimitive::ids.z`).
    /// `material`: transparent rendering's absorption per unit length (rgb)
    /// and opacity of a surface crossing (w).
    /// `grid`: the spatial index's box, xyz its minimum corner, w the cell
    /// size; `grid_dims`: xyz cells per axis, w lists per group (the cells
    /// and one everywhere list; see shaders/include/grid.glsl).
    /// `inversion`: field inversion's reference radius, sharpness s, ln of
    /// the blobs' weight and ln of the density floor (src/field/inversion.rs).
    struct GpuGlobals {
        march: Vec4, sizes: UVec4, tuning: Vec4, background: Vec4, surface: Vec4, ambient: Vec4, material: Vec4,
        grid: Vec4, grid_dims: UVec4, inversion: Vec4,
    }

    /// A directional light: `dir.xyz` towards the light (unit), `color.rgb`
    /// already multiplied by the intensity.
    struct GpuLight { dir: Vec4, color: Vec4 }

    /// The camera and the look of a frame made on the GPU (look.comp,
    /// src/render/frame.rs). `eye.xyz` the eye; `right`, `up`, `forward`
    /// the camera's unit axes, with `up.w` 1 for an orthographic camera
    /// (`eye.w` and `right.w` unused: the rays are made from the f64 copies
    /// below);
    /// `box_min`, `box_max` the scene's bounds, with `box_min.w` and
    /// `box_max.w` the view depths where depth cueing starts and ends;
    /// `background.rgb` the background (linear), `background.w` 1 for a
    /// transparent one; `outline.rgb` the outlines' colour, `outline.w`
    /// the depth jump they follow; `dims`: width, height, tiles per row,
    /// samples per pixel; `flags`: x 1 with depth cueing, y the outlines'
    /// width (0: none), z the sub-pixel samples' seed. Shadows and ambient
    /// occlusion (render::light): `ambient.rgb` the scene's ambient light;
    /// `reach`: x how far off the surface their rays start, y the
    /// occlusion rays' length; `lighting`: x the lights, y 1 with shadows,
    /// z occlusion rays per hit. The camera's rays are made in f64, as
    /// the host makes them: each `*64` pair holds a vector's x and y, then
    /// its z and one more number (`eye64_z`: half the image plane's width;
    /// `right64_z`: half its height), as f64 bits, low word first.
    struct GpuLook {
        eye: Vec4, right: Vec4, up: Vec4, forward: Vec4, box_min: Vec4, box_max: Vec4, background: Vec4, outline: Vec4,
        dims: UVec4, flags: UVec4, ambient: Vec4, reach: Vec4, lighting: UVec4,
        eye64: UVec4, eye64_z: UVec4, right64: UVec4, right64_z: UVec4, up64: UVec4, up64_z: UVec4, forward64: UVec4, forward64_z: UVec4,
        min64: UVec4, min64_z: UVec4, max64: UVec4, max64_z: UVec4,
    }

    /// The camera's tile lists built on the GPU (tiles.comp,
    /// src/render/tile_build.rs): the view as `render::tiles` makes it, in
    /// f64 bits (each `*64` pair: a vector's x and y, then its z and one
    /// more number: `eye64_z.zw` half the image plane's width at distance 1,
    /// `forward64_z.zw` half its height); `sizes`: width, height, tiles per
    /// row, tile rows; `counts`: primitives, groups, the entries' capacity,
    /// lists (tiles times groups); `halves`: where the second half of the
    /// sort's keys and values starts, the first word of the scan's
    /// partials, the entries sort's result half (0 or `halves.x`), unused.
    struct GpuTileBuild {
        eye64: UVec4, eye64_z: UVec4, forward64: UVec4, forward64_z: UVec4, right64: UVec4, right64_z: UVec4, up64: UVec4, up64_z: UVec4,
        sizes: UVec4, counts: UVec4, halves: UVec4,
    }
}

/// Primitive kinds (`GpuPrimitive::ids.x`).
pub const PRIM_COMPACT_POINT: u32 = 0;
pub const PRIM_GAUSSIAN_POINT: u32 = 1;
pub const PRIM_COMPACT_PLANE: u32 = 2;
/// One term of a Hermite RBF (src/field/hrbf.rs).
pub const PRIM_HRBF: u32 = 3;
/// An affine function (an HRBF's polynomial term).
pub const PRIM_AFFINE: u32 = 4;

/// Result flags (`GpuResult::counts.w`).
pub const FLAG_HIT: u32 = 1;
/// The step budget ran out before the ray left the scene.
pub const FLAG_OUT_OF_STEPS: u32 = 2;
/// The march of this ray is over; its result is written.
pub const FLAG_DONE: u32 = 4;
/// Marching state: the current point is inside the surface (transparency).
pub const FLAG_INSIDE: u32 = 8;

/// Marching state: a crossing is bracketed by `GpuMarchState::refine` and
/// being bisected.
pub const FLAG_REFINING: u32 = 16;
/// Marching state: the crossing being refined enters the surface.
pub const FLAG_REFINE_ENTERING: u32 = 32;
/// Marching state: the march reached its end; done once the pending
/// refinement is.
pub const FLAG_ENDED: u32 = 64;

/// Refinement of a crossing (specialization constant `SC_REFINE`; see
/// `settings::Refinement`): straddling Illinois regula falsi, or bisection.
pub const REFINE_SECANT: u32 = 0;
pub const REFINE_BISECTION: u32 = 1;
/// The inclusion methods fold their bound over the bracket, which moves
/// both ends; the point methods refine by secant.
pub const REFINE_INCLUSION: u32 = 2;
/// Inclusion refinement: the last turn did not halve the bracket, so the
/// next folds from its middle (`refine_side`).
pub const REFINE_SIDE_SPLIT: u32 = 3;
/// Secant refinement: turns that interpolate before every other turn bisects.
pub const SECANT_FREE_TURNS: u32 = 4;
/// Secant refinement: a point is placed this many tolerances past its
/// estimate, away from the end the last turn moved.
pub const SECANT_STRADDLE: f32 = 0.25;
/// The most turns one refinement takes (a guard: bisection of a float
/// bracket ends far sooner).
pub const MAX_REFINE_TURNS: u32 = 128;

/// Crossings recorded per ray in transparent rendering (more are counted).
pub const MAX_CROSSINGS: u32 = 32;

/// Marching methods (specialization constant `SC_METHOD`).
pub const METHOD_SPHERE: u32 = 0;
pub const METHOD_SEGMENT: u32 = 1;
pub const METHOD_LINEAR_TAYLOR: u32 = 2;
pub const METHOD_QUADRATIC_TAYLOR: u32 = 3;
pub const METHOD_LINEAR: u32 = 4;
pub const METHOD_LINEAR_BISECTION: u32 = 5;
pub const METHOD_RAA: u32 = 6;
pub const METHOD_QUADRATIC: u32 = 7;
pub const METHOD_QUADRATIC_RELAXED_T0: u32 = 8;
pub const METHOD_QUADRATIC_RELAXED_MAX: u32 = 9;
pub const METHOD_FIELD_INVERSION: u32 = 10;
pub const METHOD_FIELD_INVERSION_DYNAMOL: u32 = 11;

/// Specialization constants as `(constant_id, name)`; all are `uint`.
/// `SC_HAS_*` are 0 or 1: a pipeline keeps only the code paths its scene uses.
pub const SPEC_CONSTANTS: &[(u32, &str)] = &[
    (0, "SC_METHOD"),
    (1, "SC_HAS_COMPACT_POINT"),
    (2, "SC_HAS_GAUSSIAN_POINT"),
    (3, "SC_HAS_COMPACT_PLANE"),
    (4, "SC_MULTI_GROUP"),
    (5, "SC_SHADE"),
    (6, "SC_CULL"),
    (7, "SC_EXTENSION"),
    (8, "SC_TRANSPARENT"),
    (9, "SC_SECONDARY"),
    (11, "SC_REFINE"),
    (12, "SC_HAS_HRBF"),
    (13, "SC_HAS_AFFINE"),
    (14, "SC_ANY_HIT"),
];

/// `SC_INDEX`, whether the kernel walks the spatial index, is a build
/// variant, not a specialization constant (its id 10 is retired): the
/// marching kernels are compiled once without the index and once with it
/// (`{stem}_indexed.spv`, `ISOMARCH_INDEXED`), each holding only its own
/// walk. As a constant the other walk would be inlined into every fold and
/// removed only after lavapipe's passes over it, which made building a
/// pipeline take seconds (docs/performance.md).
const VARIANT_CONSTANT: &str = "SC_INDEX";
/// `SC_BRACKET`, the first-crossing bracket and per-ray candidates
/// (shaders/include/fold.glsl), is a build variant too
/// (`march_bracket.spv`, `ISOMARCH_BRACKET`: the index, point kernels
/// only): as a constant its code made the indexed kernel's SPIR-V overflow
/// the 4M ids spirv-opt allows while it optimises.
const BRACKET_CONSTANT: &str = "SC_BRACKET";
/// `SC_TILES`, camera rays' candidates from the screen-space lists
/// (src/render/tiles.rs) instead of the grid walk, is the bracket's kernel
/// with that walk replaced (`march_tiles.spv`, `ISOMARCH_TILES`); the
/// same walk without the bracket marches transparent camera rays, every
/// crossing (`march_tiles_crossings.spv`, `ISOMARCH_TILES_CROSSINGS`).
const TILES_CONSTANT: &str = "SC_TILES";

/// The build variants of shader `stem`: (macro, value, file suffix).
pub fn shader_variants(stem: &str) -> Vec<(&'static str, &'static str, &'static str)> {
    match stem {
        "march" => vec![
            ("ISOMARCH_INDEXED", "1u", "_indexed"),
            ("ISOMARCH_BRACKET", "1u", "_bracket"),
            ("ISOMARCH_TILES", "1u", "_tiles"),
            ("ISOMARCH_TILES_CROSSINGS", "1u", "_tiles_crossings"),
        ],
        "bounds" => vec![("ISOMARCH_INDEXED", "1u", "_indexed")],
        _ => Vec::new(),
    }
}

/// The spatial index (shaders/include/grid.glsl, index.comp): a primitive
/// whose padded box may cover more cells than this goes to its group's
/// everywhere list.
pub const MAX_CELLS_PER_PRIMITIVE: u32 = 512;
/// Counts per block of the index build's prefix sum.
pub const SCAN_BLOCK: u32 = 256;
/// A primitive's box is padded by this fraction of a cell, so that the
/// walk's rounding never misses the cell it looks in.
pub const CELL_PAD: f32 = 1e-3;
/// Cells a march looks ahead in one turn for the next cell that lists a
/// primitive (empty space is skipped, shaders/include/cursor_grid.glsl).
pub const SKIP_CELLS: u32 = 64;

/// The walk of a tile list (src/render/tiles.rs) stops at an entry whose
/// support starts beyond `t + TILE_PAD (1 + |t|)`, and leaves behind one
/// the ray left before `t - TILE_PAD (1 + |t|)`: the rays' f32 parameters
/// round at about 1e-7.
pub const TILE_PAD: f32 = 1e-5;

/// The low bits of a tile list entry's depth word that hold the pixels of
/// its tile the support may cover (src/render/tiles.rs).
pub const TILE_PIXEL_BITS: u32 = 12;

/// tiles.comp's passes (src/render/tile_build.rs), one pipeline each,
/// chosen by the specialization constant `TILE_PASS_CONSTANT`.
pub const TILE_PASS_PROJECT: u32 = 0;
pub const TILE_PASS_HISTOGRAM: u32 = 1;
pub const TILE_PASS_SCAN_REDUCE: u32 = 2;
pub const TILE_PASS_SCAN_TOP: u32 = 3;
pub const TILE_PASS_SCAN_DOWN: u32 = 4;
pub const TILE_PASS_SCATTER: u32 = 5;
pub const TILE_PASS_COUNT: u32 = 6;
pub const TILE_PASS_TOTAL: u32 = 7;
pub const TILE_PASS_EMIT: u32 = 8;
pub const TILE_PASS_RANGES: u32 = 9;
pub const TILE_PASS_STATS: u32 = 10;
pub const TILE_PASSES: u32 = 11;
/// The specialization constant that picks tiles.comp's pass (`TILE_PASS`).
pub const TILE_PASS_CONSTANT: u32 = 21;
/// Values a workgroup of tiles.comp's prefix sum takes (64 invocations,
/// 16 each).
pub const TILE_SCAN_BLOCK: u32 = 1024;
/// tiles.comp's statistics (`tile_stats`): the entries made (more than the
/// capacity when it overflowed), the longest list, the most entries of one
/// tile (all its groups' lists).
pub const TILE_STAT_ENTRIES: u32 = 0;
pub const TILE_STAT_LONGEST: u32 = 1;
pub const TILE_STAT_CROWD: u32 = 2;
pub const TILE_STAT_WORDS: u32 = 4;
/// `push.count` of a pass over the entries: as many as were made (at most
/// the capacity), which only the GPU knows.
pub const TILE_COUNT_ENTRIES: u32 = 0xffff_ffff;

/// Float constants shared with GLSL, as `(name, value)`.
pub const GLSL_FLOAT_CONSTANTS: &[(&str, f32)] = &[
    ("CELL_PAD", CELL_PAD),
    ("TILE_PAD", TILE_PAD),
    ("SECANT_STRADDLE", SECANT_STRADDLE),
    ("INVERSION_OVER_RELAXATION", INVERSION_OVER_RELAXATION),
    ("DYNAMOL_EPSILON", DYNAMOL_EPSILON),
    ("PROVEN_MARGIN", PROVEN_MARGIN),
];

/// A transparent march's proven points lie this fraction of iso past the
/// bound's root (`field::bound::proven_root`, the GPU's `proven_root`), so
/// that a bracket's end is past its crossing beyond the f32 rounding of f.
/// (It was made for a march that went on from the proven point, a jump
/// taken out since: docs/refinement.md; the refinement keeps it.)
pub const PROVEN_MARGIN: f32 = 1e-4;

/// Field inversion's over-relaxation ω (src/field/inversion.rs).
pub const INVERSION_OVER_RELAXATION: f32 = 1.2;
/// dynamol's field inversion (`field-inversion-dynamol`): its step budget,
/// and its hit rule, g below this many reference radii.
pub const DYNAMOL_STEPS: u32 = 32;
pub const DYNAMOL_EPSILON: f32 = 0.0125;

/// Integer constants shared with GLSL, as `(name, value)`.
pub const GLSL_CONSTANTS: &[(&str, u32)] = &[
    ("METHOD_SPHERE", METHOD_SPHERE),
    ("METHOD_SEGMENT", METHOD_SEGMENT),
    ("METHOD_LINEAR_TAYLOR", METHOD_LINEAR_TAYLOR),
    ("METHOD_QUADRATIC_TAYLOR", METHOD_QUADRATIC_TAYLOR),
    ("METHOD_LINEAR", METHOD_LINEAR),
    ("METHOD_LINEAR_BISECTION", METHOD_LINEAR_BISECTION),
    ("METHOD_RAA", METHOD_RAA),
    ("METHOD_QUADRATIC", METHOD_QUADRATIC),
    ("METHOD_QUADRATIC_RELAXED_T0", METHOD_QUADRATIC_RELAXED_T0),
    ("METHOD_QUADRATIC_RELAXED_MAX", METHOD_QUADRATIC_RELAXED_MAX),
    ("METHOD_FIELD_INVERSION", METHOD_FIELD_INVERSION),
    ("METHOD_FIELD_INVERSION_DYNAMOL", METHOD_FIELD_INVERSION_DYNAMOL),
    ("DYNAMOL_STEPS", DYNAMOL_STEPS),
    ("PRIM_COMPACT_POINT", PRIM_COMPACT_POINT),
    ("PRIM_GAUSSIAN_POINT", PRIM_GAUSSIAN_POINT),
    ("PRIM_COMPACT_PLANE", PRIM_COMPACT_PLANE),
    ("PRIM_HRBF", PRIM_HRBF),
    ("PRIM_AFFINE", PRIM_AFFINE),
    ("FLAG_HIT", FLAG_HIT),
    ("FLAG_OUT_OF_STEPS", FLAG_OUT_OF_STEPS),
    ("FLAG_DONE", FLAG_DONE),
    ("FLAG_INSIDE", FLAG_INSIDE),
    ("FLAG_REFINING", FLAG_REFINING),
    ("FLAG_REFINE_ENTERING", FLAG_REFINE_ENTERING),
    ("FLAG_ENDED", FLAG_ENDED),
    ("MAX_CROSSINGS", MAX_CROSSINGS),
    ("LOOK_PASS_CAMERA", LOOK_PASS_CAMERA),
    ("LOOK_PASS_SAMPLE", LOOK_PASS_SAMPLE),
    ("LOOK_PASS_ACCUMULATE", LOOK_PASS_ACCUMULATE),
    ("LOOK_PASS_FINISH", LOOK_PASS_FINISH),
    ("LOOK_PASS_GATE", LOOK_PASS_GATE),
    ("LOOK_PASS_SURFACE", LOOK_PASS_SURFACE),
    ("LOOK_PASS_SPAWN", LOOK_PASS_SPAWN),
    ("LOOK_PASS_OCCLUDE", LOOK_PASS_OCCLUDE),
    ("LOOK_PASS_CONSTANT", LOOK_PASS_CONSTANT),
    ("LOOK_STAT_RAYS", LOOK_STAT_RAYS),
    ("LOOK_STAT_HITS", LOOK_STAT_HITS),
    ("LOOK_STAT_OUT_OF_STEPS", LOOK_STAT_OUT_OF_STEPS),
    ("LOOK_STAT_MAX_STEPS", LOOK_STAT_MAX_STEPS),
    ("LOOK_STAT_STEPS", LOOK_STAT_STEPS),
    ("LOOK_STAT_EVALS", LOOK_STAT_EVALS),
    ("LOOK_STAT_REFINE", LOOK_STAT_REFINE),
    ("LOOK_STAT_VISITS", LOOK_STAT_VISITS),
    ("LOOK_STAT_TURNS", LOOK_STAT_TURNS),
    ("LOOK_STAT_UNFINISHED", LOOK_STAT_UNFINISHED),
    ("LOOK_STAT_SHADOW_RAYS", LOOK_STAT_SHADOW_RAYS),
    ("LOOK_STAT_SHADOW_STEPS", LOOK_STAT_SHADOW_STEPS),
    ("LOOK_STAT_AO_RAYS", LOOK_STAT_AO_RAYS),
    ("LOOK_STAT_AO_STEPS", LOOK_STAT_AO_STEPS),
    ("LOOK_STAT_WORDS", LOOK_STAT_WORDS),
    ("REFINE_SECANT", REFINE_SECANT),
    ("REFINE_BISECTION", REFINE_BISECTION),
    ("REFINE_INCLUSION", REFINE_INCLUSION),
    ("REFINE_SIDE_SPLIT", REFINE_SIDE_SPLIT),
    ("SECANT_FREE_TURNS", SECANT_FREE_TURNS),
    ("MAX_REFINE_TURNS", MAX_REFINE_TURNS),
    ("MAX_CELLS_PER_PRIMITIVE", MAX_CELLS_PER_PRIMITIVE),
    ("SCAN_BLOCK", SCAN_BLOCK),
    ("SKIP_CELLS", SKIP_CELLS),
    ("TILE_PIXEL_BITS", TILE_PIXEL_BITS),
    ("TILE_PASS_PROJECT", TILE_PASS_PROJECT),
    ("TILE_PASS_HISTOGRAM", TILE_PASS_HISTOGRAM),
    ("TILE_PASS_SCAN_REDUCE", TILE_PASS_SCAN_REDUCE),
    ("TILE_PASS_SCAN_TOP", TILE_PASS_SCAN_TOP),
    ("TILE_PASS_SCAN_DOWN", TILE_PASS_SCAN_DOWN),
    ("TILE_PASS_SCATTER", TILE_PASS_SCATTER),
    ("TILE_PASS_COUNT", TILE_PASS_COUNT),
    ("TILE_PASS_TOTAL", TILE_PASS_TOTAL),
    ("TILE_PASS_EMIT", TILE_PASS_EMIT),
    ("TILE_PASS_RANGES", TILE_PASS_RANGES),
    ("TILE_PASS_STATS", TILE_PASS_STATS),
    ("TILE_PASS_CONSTANT", TILE_PASS_CONSTANT),
    ("TILE_SCAN_BLOCK", TILE_SCAN_BLOCK),
    ("TILE_STAT_ENTRIES", TILE_STAT_ENTRIES),
    ("TILE_STAT_LONGEST", TILE_STAT_LONGEST),
    ("TILE_STAT_CROWD", TILE_STAT_CROWD),
    ("TILE_STAT_WORDS", TILE_STAT_WORDS),
    ("TILE_COUNT_ENTRIES", TILE_COUNT_ENTRIES),
];

/// How a kernel may use a storage buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    ReadOnly,
    WriteOnly,
    ReadWrite,
}

impl Access {
    /// The GLSL memory qualifier, with its trailing space.
    fn qualifier(self) -> &'static str {
        match self {
            Access::ReadOnly => "readonly ",
            Access::WriteOnly => "writeonly ",
            Access::ReadWrite => "",
        }
    }
}

/// A GLSL storage block: how it is used, its name and its one member.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block {
    pub access: Access,
    /// The block's name, e.g. `GlobalsBuffer`.
    pub name: &'static str,
    /// Its member as GLSL declares it, e.g. `GpuRay rays[]`.
    pub member: &'static str,
}

/// What a binding of descriptor set 0 declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Resource {
    /// A storage buffer block.
    Buffer(Block),
    /// A uniform buffer block (`std140`; its members must lay out as in
    /// `std430`, vec4 and uvec4 only): on lavapipe a uniform load is
    /// branch-free, where a storage-buffer load is a loop over the lanes
    /// (docs/performance.md). For the few bytes every turn reads.
    Uniform(Block),
    /// A read-only view of a buffer as texels, read with `texelFetch`:
    /// `uniform {sampler} {name};`. On lavapipe a texel fetch is one gather,
    /// where a storage-buffer load is a loop over the lanes with a bounds
    /// check per component (docs/performance.md).
    Texels { sampler: &'static str, name: &'static str, format: TexelFormat },
    /// A view of a buffer as a storage image of texels (`imageLoad`,
    /// `imageStore`): `layout({format}) uniform {image} {name};`. Its size
    /// is limited by maxTexelBufferElements, not maxStorageBufferRange.
    Image { image: &'static str, name: &'static str, format: TexelFormat },
}

/// The format of a buffer's texel view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
// The names are Vulkan's formats (R32_UINT, R32G32_UINT, ...): their
// common suffix is part of each name, not a prefix to strip.
#[allow(clippy::enum_variant_names)]
pub enum TexelFormat {
    /// One `u32` a texel (GLSL `r32ui`).
    R32Uint,
    /// Two `u32` a texel (GLSL `rg32ui`): a tile list's entry, the
    /// primitive and its depth (src/render/tiles.rs).
    Rg32Uint,
    /// Four `u32` a texel (GLSL `rgba32ui`): a [`GpuPrimitive`] is four, read bit for bit (its floats through `uintBitsToFloat`).
    Rgba32Uint,
}

impl TexelFormat {
    /// Bytes of one texel.
    pub fn bytes(self) -> u64 {
        match self {
            TexelFormat::R32Uint => 4,
            TexelFormat::Rg32Uint => 8,
            TexelFormat::Rgba32Uint => 16,
        }
    }

    fn glsl(self) -> &'static str {
        match self {
            TexelFormat::R32Uint => "r32ui",
            TexelFormat::Rg32Uint => "rg32ui",
            TexelFormat::Rgba32Uint => "rgba32ui",
        }
    }
}

/// One binding of descriptor set 0, shared by the march, the bounds probe
/// and the index build kernels. The renderer binds one buffer (or its texel
/// view) to each, in this order; a buffer may be behind several bindings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    pub index: u32,
    pub resource: Resource,
    /// What the bounds probe (`#define BOUNDS_PROBE`) declares here instead.
    pub probe: Option<Block>,
    /// Comment lines written above the declaration.
    pub doc: &'static [&'static str],
}

const fn buffer(index: u32, access: Access, name: &'static str, member: &'static str) -> Binding {
    Binding { index, resource: Resource::Buffer(Block { access, name, member }), probe: None, doc: &[] }
}

/// Every binding, by index from 0.
pub const BINDINGS: &[Binding] = &[
    Binding {
        index: 0,
        resource: Resource::Uniform(Block { access: Access::ReadOnly, name: "GlobalsBuffer", member: "GpuGlobals globals" }),
        probe: None,
        doc: &[],
    },
    Binding {
        doc: &["Written by the host; index.comp reads it here, the march as prim_texels."],
        ..buffer(1, Access::ReadOnly, "PrimitiveBuffer", "GpuPrimitive prims[]")
    },
    buffer(2, Access::ReadOnly, "LightBuffer", "GpuLight lights[]"),
    buffer(3, Access::ReadOnly, "RayBuffer", "GpuRay rays[]"),
    Binding {
        probe: Some(Block { access: Access::WriteOnly, name: "BoundBuffer", member: "GpuBound bounds[]" }),
        ..buffer(4, Access::WriteOnly, "ResultBuffer", "GpuResult results[]")
    },
    buffer(5, Access::ReadWrite, "StateBuffer", "GpuMarchState states[]"),
    Binding { doc: &["Rays still marching after this dispatch."], ..buffer(6, Access::ReadWrite, "ActiveBuffer", "uint active_rays") },
    Binding {
        doc: &["Transparent rendering: each ray's crossings, MAX_CROSSINGS per ray, in", "order; the first is entering, then they alternate."],
        ..buffer(7, Access::ReadWrite, "CrossingBuffer", "float crossings[]")
    },
    Binding {
        doc: &[
            "The spatial index (grid.glsl, index.comp): where each list starts in",
            "the entries, and the total at the end (the march reads it as cell_texels).",
        ],
        ..buffer(8, Access::ReadWrite, "CellBuffer", "uint cell_start[]")
    },
    Binding {
        index: 9,
        resource: Resource::Image { image: "uimageBuffer", name: "cell_entries", format: TexelFormat::R32Uint },
        probe: None,
        doc: &[
            "The lists' entries, written by index.comp (the march reads them as",
            "entry_texels): a storage image, so that it may hold more than a storage",
            "buffer's range (a million blobs' index is 256 MB).",
        ],
    },
    Binding {
        doc: &["The index build's scratch: the longest list, block totals, fill counters."],
        ..buffer(10, Access::ReadWrite, "IndexScratch", "uint index_scratch[]")
    },
    Binding {
        index: 11,
        resource: Resource::Texels { sampler: "usamplerBuffer", name: "prim_texels", format: TexelFormat::Rgba32Uint },
        probe: None,
        doc: &["The marching kernels' view of binding 1: primitive i is texels 4i to 4i + 3 (a, b, c, ids)."],
    },
    Binding {
        index: 12,
        resource: Resource::Texels { sampler: "usamplerBuffer", name: "cell_texels", format: TexelFormat::R32Uint },
        probe: None,
        doc: &["The marching kernels' view of binding 8; march_tiles binds the camera's tile lists' starts here."],
    },
    Binding {
        index: 13,
        resource: Resource::Texels { sampler: "usamplerBuffer", name: "entry_texels", format: TexelFormat::R32Uint },
        probe: None,
        doc: &["The marching kernels' view of binding 9; march_tiles binds the tile lists' entries here."],
    },
];

/// The bindings of look.comp, which makes a frame's camera rays and its
/// image from the march's results (src/render/frame.rs).
pub const LOOK_BINDINGS: &[Binding] = &[
    Binding {
        index: 0,
        resource: Resource::Uniform(Block { access: Access::ReadOnly, name: "LookBuffer", member: "GpuLook look" }),
        probe: None,
        doc: &[],
    },
    Binding {
        doc: &["The march's rays (binding 3 of the march), written by the camera pass."],
        ..buffer(1, Access::ReadWrite, "RayBuffer", "GpuRay rays[]")
    },
    buffer(2, Access::ReadOnly, "ResultBuffer", "GpuResult results[]"),
    Binding {
        doc: &["One sample's pixels: linear colour (rgb) and view depth (w, infinite on a miss)."],
        ..buffer(3, Access::ReadWrite, "SampleBuffer", "vec4 sample_pixels[]")
    },
    Binding { doc: &["The sum of the samples: colour (rgb) and coverage (w)."], ..buffer(4, Access::ReadWrite, "AccumBuffer", "vec4 accum[]") },
    Binding { doc: &["The image: 8-bit sRGB and alpha, red lowest."], ..buffer(5, Access::WriteOnly, "ImageBuffer", "uint image[]") },
    Binding {
        doc: &["The march's statistics (LOOK_STAT_*), 64-bit sums as low and high words."],
        ..buffer(6, Access::ReadWrite, "StatBuffer", "uint stats[]")
    },
    Binding {
        doc: &["The march's count of rays still marching (binding 6 of the march)."],
        ..buffer(7, Access::ReadWrite, "ActiveBuffer", "uint active_rays")
    },
    Binding {
        doc: &["The next slice's workgroups (an indirect dispatch's x, y, z)."],
        ..buffer(8, Access::ReadWrite, "IndirectBuffer", "uint next_groups[]")
    },
    Binding { doc: &["The scene's lights (binding 2 of the march)."], ..buffer(9, Access::ReadOnly, "LightBuffer", "GpuLight lights[]") },
    Binding {
        doc: &[
            "Per camera ray, kept while its shadow and occlusion rays march: x 1 for a",
            "shaded hit, y its unlit colour (packed as the march packs it).",
        ],
        ..buffer(10, Access::ReadWrite, "SurfaceBuffer", "uvec4 surfaces[]")
    },
    Binding {
        doc: &["Per camera ray: the light its shadows take away (rgb) and its occlusion rays", "that hit (w)."],
        ..buffer(11, Access::ReadWrite, "ShadowBuffer", "vec4 shadows[]")
    },
    Binding {
        doc: &["The camera rays of the sample being made, kept while shadow and occlusion", "rays take their place in `rays`."],
        ..buffer(12, Access::ReadWrite, "CameraRayBuffer", "GpuRay camera_rays[]")
    },
];

/// The bindings of tiles.comp, which builds the camera's tile lists on
/// the GPU (src/render/tile_build.rs).
pub const TILES_BINDINGS: &[Binding] = &[
    Binding {
        index: 0,
        resource: Resource::Uniform(Block { access: Access::ReadOnly, name: "TileBuildBuffer", member: "GpuTileBuild build" }),
        probe: None,
        doc: &[],
    },
    Binding { doc: &["The march's primitives (binding 1 of the march)."], ..buffer(1, Access::ReadOnly, "PrimitiveBuffer", "GpuPrimitive prims[]") },
    Binding {
        doc: &["Per primitive: its pixels' columns x0 | x1 << 16, rows y0 | y1 << 16, its", "depth word (pixel bits 0), and its tiles (0: none)."],
        ..buffer(2, Access::ReadWrite, "PrimTileBuffer", "uvec4 prim_tiles[]")
    },
    Binding { doc: &["The radix sort's keys, two halves (build.halves.x)."], ..buffer(3, Access::ReadWrite, "KeyBuffer", "uint sort_keys[]") },
    Binding { doc: &["The radix sort's values, two halves."], ..buffer(4, Access::ReadWrite, "ValueBuffer", "uint sort_values[]") },
    Binding {
        doc: &["The prefix sums' values (histograms, tile counts), then their partials", "(from build.halves.y)."],
        ..buffer(5, Access::ReadWrite, "ScanBuffer", "uint scan[]")
    },
    Binding {
        doc: &["The entries as made, primitive by primitive in depth order (an entry as", "the lists hold it)."],
        ..buffer(6, Access::ReadWrite, "EmittedBuffer", "uvec2 emitted[]")
    },
    Binding { doc: &["The lists' starts (the march's cell_texels)."], ..buffer(7, Access::ReadWrite, "StartBuffer", "uint list_starts[]") },
    Binding { doc: &["The lists' entries (the march's entry_texels)."], ..buffer(8, Access::ReadWrite, "EntryBuffer", "uvec2 list_entries[]") },
    Binding { doc: &["TILE_STAT_* words."], ..buffer(9, Access::ReadWrite, "TileStatBuffer", "uint tile_stats[]") },
];

/// present.comp's bindings (src/gpu/present.rs): the frame's pixels and
/// the window's, one RGBA8 word each. present.comp declares them itself,
/// as [`glsl_present_bindings`] writes them (a unit test checks), so that
/// it includes nothing and no other kernel's cache key changes with it.
pub const PRESENT_BINDINGS: &[Binding] =
    &[buffer(0, Access::ReadOnly, "FrameBuffer", "uint frame_pixels[]"), buffer(1, Access::WriteOnly, "WindowBuffer", "uint window_pixels[]")];

/// The GLSL declarations of [`PRESENT_BINDINGS`].
pub fn glsl_present_bindings() -> String {
    glsl_bindings_of(PRESENT_BINDINGS)
}

/// look.comp's passes (its push constant `pass`).
pub const LOOK_PASS_CAMERA: u32 = 0;
pub const LOOK_PASS_SAMPLE: u32 = 1;
pub const LOOK_PASS_ACCUMULATE: u32 = 2;
pub const LOOK_PASS_FINISH: u32 = 3;
pub const LOOK_PASS_GATE: u32 = 4;
pub const LOOK_PASS_SURFACE: u32 = 5;
pub const LOOK_PASS_SPAWN: u32 = 6;
pub const LOOK_PASS_OCCLUDE: u32 = 7;
/// look.comp's passes, each a pipeline of its own.
pub const LOOK_PASSES: u32 = 8;
/// The specialization constant that picks look.comp's pass (`LOOK_PASS`).
pub const LOOK_PASS_CONSTANT: u32 = 20;

/// look.comp's statistics, by word: counts, then 64-bit sums (two words).
pub const LOOK_STAT_RAYS: u32 = 0;
pub const LOOK_STAT_HITS: u32 = 1;
pub const LOOK_STAT_OUT_OF_STEPS: u32 = 2;
pub const LOOK_STAT_MAX_STEPS: u32 = 3;
pub const LOOK_STAT_STEPS: u32 = 4;
pub const LOOK_STAT_EVALS: u32 = 6;
pub const LOOK_STAT_REFINE: u32 = 8;
pub const LOOK_STAT_VISITS: u32 = 10;
pub const LOOK_STAT_TURNS: u32 = 12;
/// Set when a sample's recorded slices ended with rays still marching.
pub const LOOK_STAT_UNFINISHED: u32 = 14;
/// Shadow and occlusion rays cast, and their steps (64-bit sums).
pub const LOOK_STAT_SHADOW_RAYS: u32 = 15;
pub const LOOK_STAT_SHADOW_STEPS: u32 = 16;
pub const LOOK_STAT_AO_RAYS: u32 = 18;
pub const LOOK_STAT_AO_STEPS: u32 = 19;
pub const LOOK_STAT_WORDS: u32 = 21;

/// The GLSL declaration of `block` at binding `index`.
fn glsl_block(index: u32, block: &Block) -> String {
    format!("layout(std430, binding = {index}) {}buffer {} {{ {}; }};\n", block.access.qualifier(), block.name, block.member)
}

/// The GLSL declaration of `resource` at binding `index`.
fn glsl_resource(index: u32, resource: &Resource) -> String {
    match resource {
        Resource::Buffer(block) => glsl_block(index, block),
        Resource::Uniform(block) => format!("layout(std140, binding = {index}) uniform {} {{ {}; }};\n", block.name, block.member),
        Resource::Texels { sampler, name, .. } => format!("layout(binding = {index}) uniform {sampler} {name};\n"),
        // Only the index build (index.comp defines INDEX_BUILD) declares
        // the storage images: lavapipe builds every kernel that declares
        // an image or a texel buffer for the views bound at its first
        // dispatch, a second or more (docs/performance.md).
        Resource::Image { image, name, format } => {
            format!("#ifdef INDEX_BUILD\nlayout(binding = {index}, {}) uniform {image} {name};\n#endif\n", format.glsl())
        }
    }
}

/// GLSL declarations of every binding, in binding order; the bounds
/// probe's alternatives under `#ifdef BOUNDS_PROBE`.
pub fn glsl_bindings() -> String {
    glsl_bindings_of(BINDINGS)
}

fn glsl_bindings_of(bindings: &[Binding]) -> String {
    let mut s = String::new();
    for b in bindings {
        for line in b.doc {
            s.push_str(&format!("// {line}\n"));
        }
        match &b.probe {
            None => s.push_str(&glsl_resource(b.index, &b.resource)),
            Some(probe) => {
                s.push_str("#ifdef BOUNDS_PROBE\n");
                s.push_str(&glsl_block(b.index, probe));
                s.push_str("#else\n");
                s.push_str(&glsl_resource(b.index, &b.resource));
                s.push_str("#endif\n");
            }
        }
    }
    s
}

/// The whole generated `layout_bindings.glsl`: the bindings over
/// `layout.glsl`'s structs.
pub fn glsl_bindings_file() -> String {
    let mut s = String::from(
        "// Generated by shaders/build.rs from src/layout.rs: do not edit.\n#ifndef LAYOUT_BINDINGS_GLSL\n#define LAYOUT_BINDINGS_GLSL\n#include \"layout.glsl\"\n",
    );
    s.push_str(&glsl_bindings());
    s.push_str("#endif\n");
    s
}

/// The whole generated `look_bindings.glsl`: look.comp's bindings
/// ([`LOOK_BINDINGS`]).
pub fn glsl_look_bindings_file() -> String {
    let mut s = String::from(
        "// Generated by shaders/build.rs from src/layout.rs: do not edit.\n#ifndef LOOK_BINDINGS_GLSL\n#define LOOK_BINDINGS_GLSL\n#include \"layout.glsl\"\n",
    );
    s.push_str(&glsl_bindings_of(LOOK_BINDINGS));
    s.push_str("#endif\n");
    s
}

/// The whole generated `tiles_bindings.glsl`: tiles.comp's bindings
/// ([`TILES_BINDINGS`]).
pub fn glsl_tiles_bindings_file() -> String {
    let mut s = String::from(
        "// Generated by shaders/build.rs from src/layout.rs: do not edit.\n#ifndef TILES_BINDINGS_GLSL\n#define TILES_BINDINGS_GLSL\n#include \"layout.glsl\"\n",
    );
    s.push_str(&glsl_bindings_of(TILES_BINDINGS));
    s.push_str("#endif\n");
    s
}

/// The whole generated `layout.glsl`.
pub fn glsl() -> String {
    let mut s = String::from("// Generated by shaders/build.rs from src/layout.rs: do not edit.\n#ifndef LAYOUT_GLSL\n#define LAYOUT_GLSL\n");
    for (name, value) in GLSL_CONSTANTS {
        s.push_str(&format!("const uint {name} = {value}u;\n"));
    }
    for (name, value) in GLSL_FLOAT_CONSTANTS {
        s.push_str(&format!("const float {name} = {value:e};\n"));
    }
    for (id, name) in SPEC_CONSTANTS {
        s.push_str(&format!("layout(constant_id = {id}) const uint {name} = 0u;\n"));
    }
    // The build variants (shader_variants), or, without one, neither.
    s.push_str(&format!(
        "#if defined(ISOMARCH_TILES)\nconst uint {VARIANT_CONSTANT} = 1u;\nconst uint {BRACKET_CONSTANT} = 1u;\nconst uint {TILES_CONSTANT} = 1u;\n\
         #elif defined(ISOMARCH_TILES_CROSSINGS)\nconst uint {VARIANT_CONSTANT} = 1u;\nconst uint {BRACKET_CONSTANT} = 0u;\nconst uint {TILES_CONSTANT} = 1u;\n\
         #elif defined(ISOMARCH_BRACKET)\nconst uint {VARIANT_CONSTANT} = 1u;\nconst uint {BRACKET_CONSTANT} = 1u;\nconst uint {TILES_CONSTANT} = 0u;\n\
         #elif defined(ISOMARCH_INDEXED)\nconst uint {VARIANT_CONSTANT} = ISOMARCH_INDEXED;\nconst uint {BRACKET_CONSTANT} = 0u;\nconst uint {TILES_CONSTANT} = 0u;\n\
         #else\nconst uint {VARIANT_CONSTANT} = 0u;\nconst uint {BRACKET_CONSTANT} = 0u;\nconst uint {TILES_CONSTANT} = 0u;\n#endif\n"
    ));
    s.push_str(&glsl_structs());
    s.push_str("#endif\n");
    s
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_gpu_struct_is_a_whole_number_of_vec4() {
        for (name, size) in super::struct_sizes() {
            assert!(size > 0 && size % 16 == 0, "{name} is {size} bytes");
        }
        assert!(super::glsl().contains("struct GpuRay {\n    vec4 o;\n    vec4 d;\n};"));
    }

    #[test]
    fn present_comp_declares_the_present_bindings() {
        let source = include_str!("../shaders/present.comp");
        let wanted = super::glsl_present_bindings();
        assert!(source.contains(&wanted), "shaders/present.comp must declare, as they are written here:\n{wanted}");
    }

    #[test]
    fn bindings_are_numbered_from_zero_in_order() {
        for (i, b) in super::BINDINGS.iter().enumerate() {
            assert_eq!(b.index as usize, i, "binding {} ({:?}) is at position {i}", b.index, b.resource);
        }
    }

    /// The generated declarations are those shaders/include/bindings.glsl
    /// wrote by hand.
    #[test]
    fn generated_bindings_declare_every_buffer() {
        let glsl = super::glsl_bindings();
        for declaration in [
            "layout(std140, binding = 0) uniform GlobalsBuffer { GpuGlobals globals; };\n",
            "layout(std430, binding = 1) readonly buffer PrimitiveBuffer { GpuPrimitive prims[]; };\n",
            "layout(std430, binding = 2) readonly buffer LightBuffer { GpuLight lights[]; };\n",
            "layout(std430, binding = 3) readonly buffer RayBuffer { GpuRay rays[]; };\n",
            "#ifdef BOUNDS_PROBE\n\
             layout(std430, binding = 4) writeonly buffer BoundBuffer { GpuBound bounds[]; };\n\
             #else\n\
             layout(std430, binding = 4) writeonly buffer ResultBuffer { GpuResult results[]; };\n\
             #endif\n",
            "layout(std430, binding = 5) buffer StateBuffer { GpuMarchState states[]; };\n",
            "// Rays still marching after this dispatch.\n\
             layout(std430, binding = 6) buffer ActiveBuffer { uint active_rays; };\n",
            "// Transparent rendering: each ray's crossings, MAX_CROSSINGS per ray, in\n\
             // order; the first is entering, then they alternate.\n\
             layout(std430, binding = 7) buffer CrossingBuffer { float crossings[]; };\n",
        ] {
            assert!(glsl.contains(declaration), "missing:\n{declaration}\nin:\n{glsl}");
        }
        let declarations = glsl.matches("layout(").count();
        assert_eq!(declarations, super::BINDINGS.len() + 1, "one declaration per binding, two for binding 4");
        assert!(glsl.contains("layout(binding = 9, r32ui) uniform uimageBuffer cell_entries;\n"));
        assert!(glsl.contains("layout(binding = 11) uniform usamplerBuffer prim_texels;\n"));
        assert!(super::glsl_bindings_file().contains(&glsl));
    }
}
