//! Hermite radial basis function (HRBF) implicit surfaces: fitting the weights.
//!
//! Given control points `p_i` with unit outward normals `n_i`, the HRBF with
//! the kernel `φ(r) = r³` is
//!
//! ```text
//! f(x) = Σ_i [ α_i φ(|x − p_i|) + β_i · ∇φ(x − p_i) ] + g · x + c
//!      = Σ_i [ α_i r_i³ + 3 r_i β_i · (x − p_i) ] + g · x + c,      r_i = |x − p_i|
//! ```
//!
//! (`∇φ(d) = 3 |d| d`). The field is **positive inside**: the normals point
//! outward, so it must decrease outward. The weights are chosen so that
//!
//! ```text
//! f(p_j) = 0,      ∇f(p_j) = −n_j          for every j,
//! ```
//!
//! and, with the degree-1 polynomial `g · x + c` on, the side conditions of
//! generalised (Hermite) interpolation for this sign convention,
//!
//! ```text
//! Σ_i α_i = 0,      Σ_i (α_i p_i − β_i) = 0,
//! ```
//!
//! which make the system square: `4n + 4` unknowns (`α`, `β`, `g`, `c`) and
//! as many equations (`4n` without the polynomial). They also cancel the
//! field's `|x|³` and `|x|²` growth far away, so with the polynomial `f`
//! grows at most linearly there, with a sign the data decide; without it,
//! `f ≈ (Σ α_i) |x|³` far away.
//!
//! The gradient used in the system is
//!
//! ```text
//! ∇f(x) = g + Σ_i 3 [ α_i r_i (x − p_i) + (β_i · (x − p_i)) (x − p_i) / r_i + r_i β_i ],
//! ```
//!
//! where each term vanishes at its own control point (`r_i = 0`): the `β`
//! term's Hessian is bounded but jumps there.
//!
//! `r³` is conditionally positive definite of order 2 in 3-D, so with the
//! linear polynomial the system is non-singular for any set of distinct points
//! (a linear polynomial with zero value and zero gradient at one point is
//! zero). Without the polynomial there is no such guarantee: a single point
//! gives the zero matrix. [`fit`] therefore rejects coincident points before
//! solving and refuses systems whose condition number exceeds
//! [`CONDITION_LIMIT`].
//!
//! The system is solved in centred, scaled coordinates `x' = (x − m) / s`
//! (`m` the centre of the points' bounding box, `s` half its diagonal), where
//! every distance is at most 2, and the weights are mapped back exactly:
//! with `f(x) = s f'(x')`, `α = α' / s²`, `β = β' / s`, `g = g'` and
//! `c = s c' − g' · m`.

use glam::DVec3;
use nalgebra::{DMatrix, DVector};

/// Tolerance of the interpolation check that [`fit`] makes on its result,
/// relative to the scale of the problem: at every control point
/// `|f(p_j)| ≤ INTERPOLATION_TOLERANCE · L`, where `L` is the diagonal of the
/// points' bounding box (1 for a single point), and
/// `|∇f(p_j) + n_j| ≤ INTERPOLATION_TOLERANCE` (the target gradient has unit
/// length, so this is relative too).
///
/// A backward-stable solve of a system whose condition number is below
/// [`CONDITION_LIMIT`] leaves residuals far below this in practice (measured:
/// at most 3e-13 on random ellipsoid samples, 2e-12 at condition number 3e11);
/// the check is there to catch a solve that went wrong, not rounding.
pub const INTERPOLATION_TOLERANCE: f64 = 1e-6;

/// Largest condition number (ratio of the largest to the smallest singular
/// value of the scaled system) that [`fit`] accepts.
pub const CONDITION_LIMIT: f64 = 1e12;

/// The scene loader marches an HRBF in its control points' box grown on every
/// side by this fraction of the box's largest side, unless the scene gives a
/// margin.
pub const DEFAULT_MARGIN: f64 = 0.25;

/// The largest size one term `α r³ + 3 r β·(x − p)` takes within distance
/// `reach` of its point: `|α| reach³ + 3 |β| reach²`. The scene loader holds
/// it below the GPU's f32 range; tests scale their tolerances by it.
pub fn term_size(alpha: f64, beta: DVec3, reach: f64) -> f64 {
    alpha.abs() * reach.powi(3) + 3.0 * beta.length() * reach * reach
}

/// Two control points closer than this times the bounding-box diagonal of
/// all the points are rejected as coincident (exactly equal ones always are).
pub const COINCIDENCE_TOLERANCE: f64 = 1e-9;

/// The weights of a fitted HRBF (see the module documentation for the field).
/// The control points are not stored: pass the same points to
/// [`HrbfFit::value`] and [`HrbfFit::gradient_at`].
#[derive(Debug, Clone, PartialEq)]
pub struct HrbfFit {
    /// `α_i`, the weights of `|x − p_i|³`.
    pub alpha: Vec<f64>,
    /// `β_i`, the weights of `∇φ(x − p_i) = 3 |x − p_i| (x − p_i)`.
    pub beta: Vec<DVec3>,
    /// `g`, the linear term of the polynomial (zero when it is off).
    pub gradient: DVec3,
    /// `c`, the constant term of the polynomial (zero when it is off).
    pub offset: f64,
}

/// Why [`fit`] found no HRBF.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    #[error("an HRBF needs at least one control point, and none was given")]
    NoPoints,
    #[error("{points} control points but {normals} normals: every control point needs exactly one normal")]
    LengthMismatch { points: usize, normals: usize },
    #[error("control point {index} has a non-finite coordinate: {}", fmt_point(*.point))]
    NonFinitePoint { index: usize, point: DVec3 },
    #[error("control point {index} has a non-finite normal: {}", fmt_point(*.normal))]
    NonFiniteNormal { index: usize, normal: DVec3 },
    #[error("control point {index} has a zero normal (length {length:e}), so it gives no direction")]
    ZeroNormal { index: usize, length: f64 },
    #[error(
        "control points {first} and {second} coincide (at {}, {distance:.3e} apart, \
         under the limit {threshold:.3e} = {COINCIDENCE_TOLERANCE:e} × the bounding-box diagonal): \
         an HRBF cannot take two values or gradients at one place; merge or move them",
        fmt_point(*.at)
    )]
    CoincidentPoints { first: usize, second: usize, at: DVec3, distance: f64, threshold: f64 },
    #[error(
        "a single control point has no HRBF without the polynomial term \
         (every kernel term vanishes at its own point, so the system is zero): turn the polynomial on"
    )]
    SinglePointWithoutPolynomial,
    #[error(
        "the HRBF system is singular or ill-conditioned (condition number {condition:.2e} > {limit:.0e}), \
         typically because control points nearly coincide{}",
        closest_note(*.closest, *.polynomial)
    )]
    IllConditioned {
        condition: f64,
        limit: f64,
        /// The closest pair of control points and their distance, when there are two or more.
        closest: Option<(usize, usize, f64)>,
        polynomial: bool,
    },
    #[error("the solve gave a non-finite weight for control point {index}")]
    NonFiniteWeights { index: usize },
    #[error("the fit does not interpolate: |f(p_{index})| = {residual:.3e} > tolerance {tolerance:.3e}")]
    ValueNotInterpolated { index: usize, residual: f64, tolerance: f64 },
    #[error("the fit does not interpolate the normal: |∇f(p_{index}) + n_{index}| = {residual:.3e} > tolerance {tolerance:.3e}")]
    GradientNotInterpolated { index: usize, residual: f64, tolerance: f64 },
}

fn fmt_point(p: DVec3) -> String {
    format!("({}, {}, {})", p.x, p.y, p.z)
}

fn closest_note(closest: Option<(usize, usize, f64)>, polynomial: bool) -> String {
    let mut note = String::new();
    if let Some((i, j, d)) = closest {
        note += &format!(": the closest control points are {i} and {j}, {d:.3e} apart");
    }
    if !polynomial {
        note += "; the polynomial term is off, and turning it on may help";
    }
    note
}

/// Fits the HRBF weights for `points` with outward `normals` (normalised
/// here; any non-zero length is fine), with the degree-1 polynomial when
/// `polynomial` is true.
///
/// Checks the input (at least one point, as many normals as points, finite
/// coordinates, non-zero normals, no two points closer than
/// [`COINCIDENCE_TOLERANCE`] × the bounding-box diagonal), solves the
/// `(4n + 4)`-square system (`4n` without the polynomial) by LU in centred and
/// scaled coordinates, refuses it when its condition number (from the
/// singular values) exceeds [`CONDITION_LIMIT`], and checks that the result
/// is finite and interpolates within [`INTERPOLATION_TOLERANCE`].
pub fn fit(points: &[DVec3], normals: &[DVec3], polynomial: bool) -> Result<HrbfFit, FitError> {
    if points.is_empty() {
        return Err(FitError::NoPoints);
    }
    if points.len() != normals.len() {
        return Err(FitError::LengthMismatch { points: points.len(), normals: normals.len() });
    }
    if let Some(index) = points.iter().position(|p| !p.is_finite()) {
        return Err(FitError::NonFinitePoint { index, point: points[index] });
    }
    let mut units = Vec::with_capacity(normals.len());
    for (index, &normal) in normals.iter().enumerate() {
        if !normal.is_finite() {
            return Err(FitError::NonFiniteNormal { index, normal });
        }
        match normal.try_normalize() {
            Some(unit) => units.push(unit),
            None => {
                return Err(FitError::ZeroNormal { index, length: normal.length() });
            }
        }
    }

    if points.len() == 1 && !polynomial {
        return Err(FitError::SinglePointWithoutPolynomial);
    }

    let (lo, hi) = bounding_box(points);
    let diagonal = (hi - lo).length();
    if !diagonal.is_finite() {
        // Finite coordinates whose spread overflows: report the extreme point.
        let index = points.iter().enumerate().max_by(|a, b| a.1.abs().max_element().total_cmp(&b.1.abs().max_element())).map_or(0, |(i, _)| i);
        return Err(FitError::NonFinitePoint { index, point: points[index] });
    }
    let threshold = COINCIDENCE_TOLERANCE * diagonal;
    for i in 0..points.len() {
        for j in i + 1..points.len() {
            let distance = points[i].distance(points[j]);
            if distance == 0.0 || distance < threshold {
                return Err(FitError::CoincidentPoints { first: i, second: j, at: points[i], distance, threshold });
            }
        }
    }

    // Centre and scale: every scaled point lies within distance 1 of the origin.
    let centre = (lo + hi) * 0.5;
    let scale = if diagonal > 0.0 { 0.5 * diagonal } else { 1.0 };
    let scaled: Vec<DVec3> = points.iter().map(|&p| (p - centre) / scale).collect();
    let (matrix, rhs) = assemble(&scaled, &units, polynomial);

    let condition = condition_number(&matrix);
    if condition.is_nan() || condition > CONDITION_LIMIT {
        return Err(FitError::IllConditioned { condition, limit: CONDITION_LIMIT, closest: closest_pair(points), polynomial });
    }
    let solution = solve_refined(matrix, &rhs).ok_or_else(|| FitError::IllConditioned {
        condition: f64::INFINITY,
        limit: CONDITION_LIMIT,
        closest: closest_pair(points),
        polynomial,
    })?;

    // Map back: f(x) = s f'((x − m) / s).
    let n = points.len();
    let mut result = HrbfFit {
        alpha: (0..n).map(|i| solution[4 * i] / (scale * scale)).collect(),
        beta: (0..n).map(|i| DVec3::new(solution[4 * i + 1], solution[4 * i + 2], solution[4 * i + 3]) / scale).collect(),
        gradient: DVec3::ZERO,
        offset: 0.0,
    };
    if polynomial {
        let g = DVec3::new(solution[4 * n], solution[4 * n + 1], solution[4 * n + 2]);
        result.gradient = g;
        result.offset = scale * solution[4 * n + 3] - g.dot(centre);
    }
    if let Some(index) = (0..n).find(|&i| !result.alpha[i].is_finite() || !result.beta[i].is_finite()) {
        return Err(FitError::NonFiniteWeights { index });
    }
    if !result.gradient.is_finite() || !result.offset.is_finite() {
        return Err(FitError::NonFiniteWeights { index: n });
    }

    // Check in the caller's coordinates.
    let length = if diagonal > 0.0 { diagonal } else { 1.0 };
    let value_tolerance = INTERPOLATION_TOLERANCE * length;
    for (index, (&p, &unit)) in points.iter().zip(&units).enumerate() {
        let residual = result.value(points, p).abs();
        if residual.is_nan() || residual > value_tolerance {
            return Err(FitError::ValueNotInterpolated { index, residual, tolerance: value_tolerance });
        }
        let residual = (result.gradient_at(points, p) + unit).length();
        if residual.is_nan() || residual > INTERPOLATION_TOLERANCE {
            return Err(FitError::GradientNotInterpolated { index, residual, tolerance: INTERPOLATION_TOLERANCE });
        }
    }
    Ok(result)
}

impl HrbfFit {
    /// `f(x) = Σ_i [α_i r_i³ + 3 r_i β_i · (x − p_i)] + g · x + c`; positive
    /// inside. `points` are the control points the weights were fitted to.
    pub fn value(&self, points: &[DVec3], x: DVec3) -> f64 {
        self.check_len(points);
        let mut f = self.gradient.dot(x) + self.offset;
        for ((&p, &a), &b) in points.iter().zip(&self.alpha).zip(&self.beta) {
            let d = x - p;
            let r = d.length();
            f += r * (a * r * r + 3.0 * b.dot(d));
        }
        f
    }

    /// `∇f(x) = g + Σ_i 3 [α_i r_i d_i + (β_i · d_i) d_i / r_i + r_i β_i]`
    /// with `d_i = x − p_i`; a term is zero at its own point (`r_i = 0`).
    pub fn gradient_at(&self, points: &[DVec3], x: DVec3) -> DVec3 {
        self.check_len(points);
        let mut g = self.gradient;
        for ((&p, &a), &b) in points.iter().zip(&self.alpha).zip(&self.beta) {
            let d = x - p;
            let r = d.length();
            if r > 0.0 {
                g += 3.0 * ((a * r + b.dot(d) / r) * d + r * b);
            }
        }
        g
    }

    fn check_len(&self, points: &[DVec3]) {
        assert_eq!(points.len(), self.alpha.len(), "HrbfFit evaluated with {} control points but fitted to {}", points.len(), self.alpha.len());
    }
}

fn bounding_box(points: &[DVec3]) -> (DVec3, DVec3) {
    points.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), &p| (lo.min(p), hi.max(p)))
}

fn closest_pair(points: &[DVec3]) -> Option<(usize, usize, f64)> {
    let mut best: Option<(usize, usize, f64)> = None;
    for i in 0..points.len() {
        for j in i + 1..points.len() {
            let d = points[i].distance(points[j]);
            if best.is_none_or(|(_, _, b)| d < b) {
                best = Some((i, j, d));
            }
        }
    }
    best
}

/// The interpolation system in the coordinates given. Unknowns: `α_i` at
/// `4i`, `β_i` at `4i + 1 ..= 4i + 3`, then `g` and `c`. Rows: `f(p_j)` at
/// `4j`, `∇f(p_j)` at `4j + 1 ..= 4j + 3`, then the side conditions.
fn assemble(points: &[DVec3], normals: &[DVec3], polynomial: bool) -> (DMatrix<f64>, DVector<f64>) {
    let n = points.len();
    let size = 4 * n + if polynomial { 4 } else { 0 };
    let mut a = DMatrix::<f64>::zeros(size, size);
    let mut b = DVector::<f64>::zeros(size);
    for j in 0..n {
        for i in 0..n {
            if i == j {
                continue; // each term has zero value and gradient at its own point
            }
            let d = (points[j] - points[i]).to_array();
            let r = (points[j] - points[i]).length();
            a[(4 * j, 4 * i)] = r * r * r;
            for k in 0..3 {
                a[(4 * j, 4 * i + 1 + k)] = 3.0 * r * d[k]; // β_i · ∇φ
                a[(4 * j + 1 + k, 4 * i)] = 3.0 * r * d[k]; // α_i ∇φ
                for l in 0..3 {
                    // ∇(3 r β · d) = 3 (β · d) d / r + 3 r β
                    let delta = if k == l { r } else { 0.0 };
                    a[(4 * j + 1 + k, 4 * i + 1 + l)] = 3.0 * (d[k] * d[l] / r + delta);
                }
            }
        }
        let nj = normals[j].to_array();
        for k in 0..3 {
            b[4 * j + 1 + k] = -nj[k];
        }
        if polynomial {
            let pj = points[j].to_array();
            for k in 0..3 {
                a[(4 * j, 4 * n + k)] = pj[k];
                a[(4 * j + 1 + k, 4 * n + k)] = 1.0;
            }
            a[(4 * j, 4 * n + 3)] = 1.0;
        }
    }
    if polynomial {
        // Σ α_i = 0 and Σ (α_i p_i − β_i) = 0.
        for i in 0..n {
            let pi = points[i].to_array();
            a[(4 * n, 4 * i)] = 1.0;
            for k in 0..3 {
                a[(4 * n + 1 + k, 4 * i)] = pi[k];
                a[(4 * n + 1 + k, 4 * i + 1 + k)] = -1.0;
            }
        }
    }
    (a, b)
}

/// `σ_max / σ_min`, infinite for a singular matrix (never NaN), and for
/// one whose SVD does not converge within a bounded number of iterations
/// (`singular_values()` has no bound: on exactly repeated points, which
/// `fit` refuses before this, it was seen not to return).
fn condition_number(matrix: &DMatrix<f64>) -> f64 {
    let Some(svd) = matrix.clone().try_svd_unordered(false, false, f64::EPSILON, 100 * matrix.nrows().max(1)) else {
        return f64::INFINITY;
    };
    let sigma = svd.singular_values;
    let max = sigma.iter().copied().fold(0.0, f64::max);
    let min = sigma.iter().copied().fold(f64::INFINITY, f64::min);
    if sigma.iter().any(|s| !s.is_finite()) || min <= 0.0 { f64::INFINITY } else { max / min }
}

/// LU solve with one step of iterative refinement; `None` if singular or non-finite.
fn solve_refined(matrix: DMatrix<f64>, rhs: &DVector<f64>) -> Option<DVector<f64>> {
    let lu = matrix.clone().lu();
    let mut x = lu.solve(rhs)?;
    let residual = rhs - &matrix * &x;
    if let Some(dx) = lu.solve(&residual)
        && dx.iter().all(|v| v.is_finite())
    {
        x += dx;
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    fn random_unit(rng: &mut Pcg64Mcg) -> DVec3 {
        loop {
            let v = DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }

    /// `n` points on the ellipsoid `Σ ((x − centre)_k / axes_k)² = 1` with its
    /// analytic outward normals (not normalised, so `fit` must do it).
    fn ellipsoid(rng: &mut Pcg64Mcg, n: usize, centre: DVec3, axes: DVec3) -> (Vec<DVec3>, Vec<DVec3>) {
        (0..n)
            .map(|_| {
                let q = random_unit(rng) * axes;
                (centre + q, q / (axes * axes))
            })
            .unzip()
    }

    /// Worst residuals, checked independently of `fit`'s own check.
    fn residuals(h: &HrbfFit, points: &[DVec3], normals: &[DVec3]) -> (f64, f64) {
        let mut worst = (0.0f64, 0.0f64);
        for (&p, &n) in points.iter().zip(normals) {
            worst.0 = worst.0.max(h.value(points, p).abs());
            worst.1 = worst.1.max((h.gradient_at(points, p) + n.normalize()).length());
        }
        worst
    }

    fn diagonal(points: &[DVec3]) -> f64 {
        let (lo, hi) = bounding_box(points);
        (hi - lo).length()
    }

    fn assert_interpolates(h: &HrbfFit, points: &[DVec3], normals: &[DVec3]) {
        let (v, g) = residuals(h, points, normals);
        let l = diagonal(points).max(if points.len() == 1 { 1.0 } else { 0.0 });
        assert!(v <= INTERPOLATION_TOLERANCE * l, "value residual {v:e}");
        assert!(g <= INTERPOLATION_TOLERANCE, "gradient residual {g:e}");
        assert!(h.alpha.iter().all(|a| a.is_finite()));
        assert!(h.beta.iter().all(|b| b.is_finite()));
        assert!(h.gradient.is_finite() && h.offset.is_finite());
    }

    fn random_problem(rng: &mut Pcg64Mcg) -> (Vec<DVec3>, Vec<DVec3>) {
        let n = rng.random_range(4..=40);
        let centre = DVec3::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0));
        let axes = if rng.random_bool(0.3) {
            DVec3::splat(rng.random_range(0.2..4.0))
        } else {
            DVec3::new(rng.random_range(0.2..4.0), rng.random_range(0.2..4.0), rng.random_range(0.2..4.0))
        };
        ellipsoid(rng, n, centre, axes)
    }

    #[test]
    fn random_sets_interpolate() {
        let mut rng = Pcg64Mcg::seed_from_u64(0x4852_4246);
        let mut worst = (0.0f64, 0.0f64);
        for trial in 0..60 {
            let (points, normals) = random_problem(&mut rng);
            for polynomial in [true, false] {
                let h = fit(&points, &normals, polynomial).unwrap_or_else(|e| panic!("trial {trial}, polynomial {polynomial}: {e}"));
                assert_interpolates(&h, &points, &normals);
                let (v, g) = residuals(&h, &points, &normals);
                worst = (worst.0.max(v / diagonal(&points)), worst.1.max(g));
                if polynomial {
                    // The side conditions hold.
                    let sa: f64 = h.alpha.iter().sum();
                    let sb: DVec3 = (0..points.len()).map(|i| h.alpha[i] * points[i] - h.beta[i]).sum();
                    let size = h.alpha.iter().map(|a| a.abs()).sum::<f64>() + 1.0;
                    assert!(sa.abs() <= 1e-9 * size, "Σα = {sa:e}");
                    assert!(sb.length() <= 1e-9 * size * (1.0 + 10.0), "Σ(αp − β) = {sb}");
                } else {
                    assert_eq!((h.gradient, h.offset), (DVec3::ZERO, 0.0));
                }
            }
        }
        eprintln!("worst relative value residual {:e}, gradient residual {:e}", worst.0, worst.1);
    }

    #[test]
    fn gradient_matches_central_differences() {
        let mut rng = Pcg64Mcg::seed_from_u64(7);
        for _ in 0..10 {
            let (points, normals) = random_problem(&mut rng);
            let h = fit(&points, &normals, rng.random_bool(0.5)).unwrap();
            let (lo, hi) = bounding_box(&points);
            let grow = (hi - lo) * 0.3;
            let step = 1e-5 * diagonal(&points);
            for _ in 0..20 {
                let x = DVec3::new(
                    rng.random_range(lo.x - grow.x..hi.x + grow.x),
                    rng.random_range(lo.y - grow.y..hi.y + grow.y),
                    rng.random_range(lo.z - grow.z..hi.z + grow.z),
                );
                let analytic = h.gradient_at(&points, x);
                let numeric = DVec3::new(
                    h.value(&points, x + DVec3::X * step) - h.value(&points, x - DVec3::X * step),
                    h.value(&points, x + DVec3::Y * step) - h.value(&points, x - DVec3::Y * step),
                    h.value(&points, x + DVec3::Z * step) - h.value(&points, x - DVec3::Z * step),
                ) / (2.0 * step);
                let err = (analytic - numeric).length();
                assert!(err <= 1e-5 * (1.0 + analytic.length()), "at {x}: {analytic} vs {numeric}");
            }
            // At a control point the gradient is the target, from either side.
            let p = points[0];
            let numeric = (h.value(&points, p + DVec3::X * step) - h.value(&points, p - DVec3::X * step)) / (2.0 * step);
            assert!((numeric + normals[0].normalize().x).abs() < 1e-4);
        }
    }

    fn fibonacci_sphere(n: usize, radius: f64, centre: DVec3) -> (Vec<DVec3>, Vec<DVec3>) {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let rho = (1.0 - z * z).sqrt();
                let t = golden * i as f64;
                let u = DVec3::new(rho * t.cos(), rho * t.sin(), z);
                (centre + radius * u, u)
            })
            .unzip()
    }

    #[test]
    fn sphere() {
        let centre = DVec3::new(0.3, -0.2, 0.5);
        let (points, normals) = fibonacci_sphere(26, 1.5, centre);
        for polynomial in [true, false] {
            let h = fit(&points, &normals, polynomial).unwrap();
            assert!(h.value(&points, centre) > 0.0);
            let mut rng = Pcg64Mcg::seed_from_u64(3);
            for _ in 0..12 {
                let dir = random_unit(&mut rng);
                assert!(h.value(&points, centre + 2.5 * dir) < 0.0);
                // Bisect the zero crossing along the ray.
                let (mut a, mut b) = (0.0, 2.5);
                for _ in 0..60 {
                    let m = 0.5 * (a + b);
                    if h.value(&points, centre + m * dir) > 0.0 { a = m } else { b = m }
                }
                assert!((a - 1.5f64).abs() <= 0.05 * 1.5, "radius {a} along {dir}");
            }
        }
    }

    /// The internal centring and scaling does not change the result: the
    /// weights equal those of the system solved directly in the caller's
    /// coordinates, and moving or scaling the points moves or scales the field.
    #[test]
    fn scaling_is_exact() {
        let mut rng = Pcg64Mcg::seed_from_u64(11);
        for polynomial in [true, false] {
            let (points, normals) = ellipsoid(&mut rng, 12, DVec3::new(0.4, 0.1, -0.3), DVec3::new(1.2, 0.9, 0.7));
            let h = fit(&points, &normals, polynomial).unwrap();
            let units: Vec<DVec3> = normals.iter().map(|n| n.normalize()).collect();
            let (a, b) = assemble(&points, &units, polynomial);
            let direct = a.lu().solve(&b).unwrap();
            let n = points.len();
            for i in 0..n {
                assert!((h.alpha[i] - direct[4 * i]).abs() <= 1e-8 * (1.0 + direct[4 * i].abs()));
                let db = DVec3::new(direct[4 * i + 1], direct[4 * i + 2], direct[4 * i + 3]);
                assert!((h.beta[i] - db).length() <= 1e-8 * (1.0 + db.length()));
            }
            if polynomial {
                let g = DVec3::new(direct[4 * n], direct[4 * n + 1], direct[4 * n + 2]);
                assert!((h.gradient - g).length() <= 1e-8);
                assert!((h.offset - direct[4 * n + 3]).abs() <= 1e-8);
            }

            let (shift, s) = (DVec3::new(100.0, -40.0, 7.0), 3.5);
            let moved: Vec<DVec3> = points.iter().map(|&p| s * p + shift).collect();
            let hm = fit(&moved, &normals, polynomial).unwrap();
            for _ in 0..20 {
                let x = DVec3::new(rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0));
                let (f, fm) = (h.value(&points, x), hm.value(&moved, s * x + shift));
                assert!((fm - s * f).abs() <= 1e-8 * s * (1.0 + f.abs()), "{fm} vs {}", s * f);
                let (g, gm) = (h.gradient_at(&points, x), hm.gradient_at(&moved, s * x + shift));
                assert!((g - gm).length() <= 1e-8 * (1.0 + g.length()));
            }
        }
    }

    #[test]
    fn input_errors() {
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        let n = [-DVec3::ONE, DVec3::X, DVec3::Y, DVec3::Z];
        assert_eq!(fit(&[], &[], true), Err(FitError::NoPoints));
        assert_eq!(fit(&p, &n[..3], true), Err(FitError::LengthMismatch { points: 4, normals: 3 }));
        let mut bad = p;
        bad[2].y = f64::NAN;
        assert!(matches!(fit(&bad, &n, true), Err(FitError::NonFinitePoint { index: 2, .. })));
        bad[2].y = f64::INFINITY;
        assert!(matches!(fit(&bad, &n, true), Err(FitError::NonFinitePoint { index: 2, .. })));
        let mut bad = n;
        bad[1].z = f64::NAN;
        assert!(matches!(fit(&p, &bad, false), Err(FitError::NonFiniteNormal { index: 1, .. })));
        bad[1] = DVec3::ZERO;
        let e = fit(&p, &bad, true).unwrap_err();
        assert!(matches!(e, FitError::ZeroNormal { index: 1, .. }));
        assert!(e.to_string().contains("control point 1 has a zero normal"), "{e}");
        // Overflowing spread.
        let far = [DVec3::splat(-1e308), DVec3::splat(1e308)];
        assert!(matches!(fit(&far, &[DVec3::X, DVec3::X], true), Err(FitError::NonFinitePoint { .. })));
    }

    #[test]
    fn coincident_points_are_rejected_before_solving() {
        let mut p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, DVec3::new(0.1, 0.2, 0.3)];
        let mut n = vec![-DVec3::ONE, DVec3::X, DVec3::Y, DVec3::Z, DVec3::Z];
        p.push(p[4]);
        n.push(-DVec3::Z); // same place, opposite normal
        let e = fit(&p, &n, true).unwrap_err();
        assert!(matches!(e, FitError::CoincidentPoints { first: 4, second: 5, .. }), "{e:?}");
        assert!(e.to_string().starts_with("control points 4 and 5 coincide (at (0.1, 0.2, 0.3)"), "{e}");
        // Same normal: still rejected (the system would be singular).
        n[5] = DVec3::Z;
        assert!(matches!(fit(&p, &n, false), Err(FitError::CoincidentPoints { .. })));
        // Below the relative threshold.
        p[5] = p[4] + DVec3::new(0.0, 0.0, 1e-10);
        assert!(matches!(fit(&p, &n, true), Err(FitError::CoincidentPoints { first: 4, second: 5, .. })));
        // All points the same (zero diagonal).
        let e = fit(&[DVec3::ONE, DVec3::ONE], &[DVec3::X, DVec3::Y], true).unwrap_err();
        assert!(matches!(e, FitError::CoincidentPoints { first: 0, second: 1, .. }));
    }

    /// Points just above the coincidence threshold with opposite normals: the
    /// system is (numerically) singular, and `fit` says so, naming them.
    #[test]
    fn nearly_coincident_points_are_ill_conditioned() {
        let (mut points, mut normals) = fibonacci_sphere(10, 1.0, DVec3::ZERO);
        points.push(points[3] + DVec3::new(2e-6, 0.0, 0.0));
        normals.push(-normals[3]);
        for polynomial in [true, false] {
            let e = fit(&points, &normals, polynomial).unwrap_err();
            match &e {
                FitError::IllConditioned { condition, closest: Some((3, 10, _)), .. } => {
                    assert!(*condition > CONDITION_LIMIT)
                }
                other => panic!("{other:?}"),
            }
            let text = e.to_string();
            assert!(text.contains("ill-conditioned") && text.contains("control points are 3 and 10"), "{text}");
        }
        // Far enough apart with the same normal: a valid fit.
        normals[10] = normals[3];
        points[10] = points[3] + 1e-2 * DVec3::new(normals[3].y, -normals[3].x, 0.0).normalize();
        let h = fit(&points, &normals, true).unwrap();
        assert_interpolates(&h, &points, &normals);
    }

    #[test]
    fn single_point() {
        let p = [DVec3::new(0.5, -1.0, 2.0)];
        let n = [DVec3::new(0.0, 3.0, 4.0)];
        // With the polynomial: the plane through p with normal n.
        let h = fit(&p, &n, true).unwrap();
        assert_interpolates(&h, &p, &n);
        assert_eq!(h.alpha, vec![0.0]);
        assert_eq!(h.beta, vec![DVec3::ZERO]);
        let u = n[0].normalize();
        for t in [-2.0, -0.5, 0.3, 1.7] {
            let x = p[0] + t * u + DVec3::new(0.0, 4.0, -3.0) * 0.7; // move along the plane too
            assert!((h.value(&p, x) + t).abs() < 1e-12);
        }
        // Without: the matrix would be zero.
        let e = fit(&p, &n, false).unwrap_err();
        assert_eq!(e, FitError::SinglePointWithoutPolynomial);
        assert!(e.to_string().contains("without the polynomial term"), "{e}");
        // And the check behind it: the zero system has an infinite condition number, not NaN.
        let (a, _) = assemble(&p, &n, false);
        assert_eq!(condition_number(&a), f64::INFINITY);
    }

    /// Two points, no polynomial: the 8×8 system is regular; so is it with.
    #[test]
    fn two_points() {
        let p = [DVec3::ZERO, DVec3::new(1.0, 0.5, 0.0)];
        for n in [[-DVec3::X, DVec3::X], [DVec3::Z, -DVec3::Z], [DVec3::Y, DVec3::Y]] {
            for polynomial in [true, false] {
                let h = fit(&p, &n, polynomial).unwrap();
                assert_interpolates(&h, &p, &n);
            }
        }
    }

    fn grid_on_plane() -> Vec<DVec3> {
        (0..16).map(|k| DVec3::new((k % 4) as f64 * 0.5, (k / 4) as f64 * 0.5 + 0.1 * (k % 4) as f64, 0.0)).collect()
    }

    /// Points on z = 0 with normals alternating +z and −z: contradictory for a
    /// surface, but distinct points always give a regular system with the
    /// polynomial, and the fit interpolates (a wavy surface through them).
    #[test]
    fn coplanar_alternating_normals() {
        let points = grid_on_plane();
        let normals: Vec<DVec3> = (0..points.len()).map(|k| if k % 2 == 0 { DVec3::Z } else { -DVec3::Z }).collect();
        for polynomial in [true, false] {
            let h = fit(&points, &normals, polynomial).unwrap();
            assert_interpolates(&h, &points, &normals);
        }
    }

    /// Points on z = 0 with normals in that plane (a circle with radial
    /// normals): the fit interpolates and is symmetric in z.
    #[test]
    fn coplanar_in_plane_normals() {
        let (points, normals): (Vec<DVec3>, Vec<DVec3>) = (0..9)
            .map(|k| {
                let t = k as f64 * std::f64::consts::TAU / 9.0;
                let u = DVec3::new(t.cos(), t.sin(), 0.0);
                (1.2 * u, u)
            })
            .unzip();
        for polynomial in [true, false] {
            match fit(&points, &normals, polynomial) {
                Ok(h) => {
                    assert_interpolates(&h, &points, &normals);
                    let x = DVec3::new(0.3, -0.2, 0.7);
                    let mirrored = x * DVec3::new(1.0, 1.0, -1.0);
                    assert!((h.value(&points, x) - h.value(&points, mirrored)).abs() < 1e-9);
                    assert!(h.value(&points, DVec3::ZERO) > 0.0);
                }
                Err(e) => panic!("polynomial {polynomial}: {e}"),
            }
        }
        // Random in-plane normals on the grid, too.
        let points = grid_on_plane();
        let normals: Vec<DVec3> = (0..points.len()).map(|k| DVec3::new((k as f64).cos(), (k as f64).sin(), 0.0)).collect();
        for polynomial in [true, false] {
            assert_interpolates(&fit(&points, &normals, polynomial).unwrap(), &points, &normals);
        }
    }

    /// Collinear points and other awkward but distinct inputs: always either a
    /// fit that interpolates, or an error; never a NaN.
    #[test]
    fn awkward_inputs_never_give_nan() {
        let mut rng = Pcg64Mcg::seed_from_u64(99);
        let mut errors = 0;
        for trial in 0..200 {
            let n = rng.random_range(1..=12);
            let kind = trial % 4;
            let points: Vec<DVec3> = (0..n)
                .map(|k| match kind {
                    0 => DVec3::X * k as f64,                                                         // collinear, evenly spaced
                    1 => DVec3::new(k as f64, 0.0, 0.0) * 1e-6,                                       // tiny
                    2 => DVec3::new(1e5, 0.0, 0.0) + random_unit(&mut rng) * (k as f64 + 1.0) * 1e-3, // far away
                    _ => random_unit(&mut rng) * rng.random_range(0.9..1.1),
                })
                .collect();
            let normals: Vec<DVec3> = (0..n).map(|_| random_unit(&mut rng)).collect();
            for polynomial in [true, false] {
                match fit(&points, &normals, polynomial) {
                    Ok(h) => assert_interpolates(&h, &points, &normals),
                    Err(e) => {
                        // In practice only this one: distinct points are fine otherwise.
                        assert_eq!((n, polynomial, &e), (1, false, &FitError::SinglePointWithoutPolynomial));
                        errors += 1;
                        assert!(!e.to_string().is_empty());
                        if let FitError::IllConditioned { condition, .. } = e {
                            assert!(!condition.is_nan());
                        }
                    }
                }
            }
        }
        eprintln!("{errors} of 400 awkward fits refused");
    }

    #[test]
    fn error_messages_are_one_line() {
        let errors = [
            FitError::NoPoints,
            FitError::LengthMismatch { points: 3, normals: 2 },
            FitError::NonFinitePoint { index: 2, point: DVec3::new(0.0, f64::NAN, 1.0) },
            FitError::NonFiniteNormal { index: 2, normal: DVec3::new(0.0, f64::INFINITY, 1.0) },
            FitError::ZeroNormal { index: 4, length: 0.0 },
            FitError::CoincidentPoints { first: 3, second: 7, at: DVec3::new(0.1, 0.2, 0.3), distance: 0.0, threshold: 1e-9 },
            FitError::IllConditioned { condition: 3.2e15, limit: 1e12, closest: Some((1, 2, 1e-7)), polynomial: true },
            FitError::SinglePointWithoutPolynomial,
            FitError::IllConditioned { condition: f64::INFINITY, limit: 1e12, closest: None, polynomial: false },
            FitError::NonFiniteWeights { index: 1 },
            FitError::ValueNotInterpolated { index: 5, residual: 1e-3, tolerance: 1e-6 },
            FitError::GradientNotInterpolated { index: 5, residual: 1e-3, tolerance: 1e-6 },
        ];
        for e in errors {
            let s = e.to_string();
            assert!(!s.contains('\n') && !s.is_empty(), "{s}");
            eprintln!("{s}");
        }
    }

    /// A few hundred points (the sizes the scene files use at most): the
    /// condition number grows slowly with density (about 2e6 at 300 points
    /// on the unit sphere), far from the limit.
    #[test]
    fn dense_sphere() {
        let (points, normals) = fibonacci_sphere(160, 1.0, DVec3::new(2.0, 0.0, -1.0));
        let h = fit(&points, &normals, true).unwrap();
        assert_interpolates(&h, &points, &normals);
        assert!(h.value(&points, DVec3::new(2.0, 0.0, -1.0)) > 0.0);
    }
}
