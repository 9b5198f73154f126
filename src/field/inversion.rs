//! Field inversion (Bruckner 2019, "Dynamic visibility-driven molecular
//! surfaces", the paper's [Bru19] baseline for molecules; dynamol's
//! `surface-fs.glsl`): the Gaussian density is turned into an approximate
//! distance and sphere-traced.
//!
//! For one blob `w e^{-s d²/r²}` the density F at distance d gives d back:
//! `d = r sqrt(ln(w/F)/s)`, and its surface (F = iso) lies at
//! `r sqrt(ln(w/iso)/s)`. Field inversion applies that inverse to the whole
//! sum, with one reference blob for every atom:
//!
//! ```text
//! g(p) = r_ref ( sqrt(ln(w/F(p))/s) - sqrt(ln(w/iso)/s) )
//! ```
//!
//! and steps by `ω g` (ω = 1.2, the over-relaxation dynamol takes from
//! Keinert et al. 2014). g is exact for a lone blob of radius r_ref, and
//! it is 0 on the surface, but it is no distance bound: where blobs blend,
//! F exceeds every single term and |∇g| may exceed 1, and ω > 1 may step
//! over a thin part. So it is not conservative, and it is measured against
//! the f64 reference by its miss rate instead of being held to the
//! no-missed-crossing tests.
//!
//! Choices where dynamol differs (docs/molecules.md):
//!
//! - **r_ref** is the scene's smallest radius, so that g never exceeds the
//!   distance to a lone atom's surface. dynamol steps by the normalised
//!   `sqrt(-ln F / s) - 1` itself (radius 1 in its units, ångström).
//! - **The hit rule** of `field-inversion` is every method's: a crossing
//!   where f >= 0, refined, the minimum step and the step budget as for the
//!   others. `field-inversion-dynamol` takes dynamol's: a hit, unrefined,
//!   where g < 0.0125 r_ref (or f >= 0), at most 32 steps, and out of steps
//!   the point of smallest g taken as the hit (step.glsl `step_apply`,
//!   mirrored in `field::march`).
//! - **Where no atom reaches** (the spatial index clips each Gaussian
//!   where it falls below its group's threshold τ, [`clip::threshold`]),
//!   the density is taken as τ, so g stays the distance to a lone atom
//!   at its clip.
//!
//! It needs what it assumes: one group of Gaussian points sharing s and
//! the weight (a molecule scene); [`Inversion::of_field`] refuses others.

use crate::field::{Field, PrimEval, clip};
use crate::settings::GAUSSIAN_BOUNDS_FRACTION;

/// The over-relaxation factor ω of every step (dynamol's `omega`).
pub const OVER_RELAXATION: f64 = crate::layout::INVERSION_OVER_RELAXATION as f64;

/// What field inversion needs of a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inversion {
    /// The reference radius: the smallest r.
    pub r_ref: f64,
    /// The shared sharpness s.
    pub s: f64,
    /// ln of the shared weight w.
    pub ln_w: f64,
    /// ln of the density floor: the index's clipping threshold τ.
    pub ln_floor: f64,
}

impl Inversion {
    /// The inversion of `field`, or why it has none (one line).
    pub fn of_field(field: &Field) -> Result<Inversion, String> {
        if field.groups.len() != 1 {
            return Err(format!("field-inversion marches one sum of Gaussian blobs (a molecule); this scene has {} groups", field.groups.len()));
        }
        let prims = &field.groups[0];
        let mut out: Option<Inversion> = None;
        for p in prims {
            let Some(k) = p.kernel().filter(|k| k.gaussian && matches!(p, crate::field::PrimEval::Point(_))) else {
                return Err("field-inversion marches Gaussian point blobs only (a molecule); this scene has other primitives".into());
            };
            let s = k.inv * k.scale * k.scale;
            let o = out.get_or_insert(Inversion { r_ref: k.scale, s, ln_w: k.weight.ln(), ln_floor: 0.0 });
            let same = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs());
            if !same(o.s, s) || !same(o.ln_w.exp(), k.weight) {
                return Err("field-inversion needs every blob to share its sharpness s and weight (its inverse is that of one blob)".into());
            }
            o.r_ref = o.r_ref.min(k.scale);
        }
        let mut o = out.ok_or("field-inversion: the scene has no blob")?;
        if o.ln_w <= field.iso.ln() {
            return Err("field-inversion: a blob's weight must exceed iso, or a lone blob has no surface to invert towards".into());
        }
        let gaussians: Vec<clip::Gaussian> = prims
            .iter()
            .filter_map(|p| match p {
                PrimEval::Point(q) => Some(clip::Gaussian { center: q.center, r: q.kernel.scale, s: o.s, weight: q.kernel.weight }),
                _ => None,
            })
            .collect();
        o.ln_floor = clip::threshold(&gaussians, GAUSSIAN_BOUNDS_FRACTION * field.iso).ln();
        Ok(o)
    }

    /// `g` at a point where the density (the field plus iso) is `density`.
    pub fn distance(&self, density: f64, iso: f64) -> f64 {
        let a = (self.ln_w - density.ln().max(self.ln_floor)).max(0.0) / self.s;
        let b = (self.ln_w - iso.ln()) / self.s;
        self.r_ref * (a.sqrt() - b.sqrt())
    }

    /// The step from a point where the field (density - iso) is `f`.
    pub fn step(&self, f: f64, iso: f64) -> f64 {
        OVER_RELAXATION * self.distance(f + iso, iso).abs()
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::scene::Scene;

    fn scene(blobs: &str) -> Scene {
        Scene::parse(&format!("Scene(camera: (eye: (0.0, 0.0, 9.0), target: (0.0, 0.0, 0.0)), iso: 1.0, groups: [(primitives: [{blobs}])])"), "t")
            .unwrap()
    }

    #[test]
    fn a_lone_blob_inverts_to_the_exact_distance() {
        let s = scene("Point(center: (0.0, 0.0, 0.0), kernel: Gaussian(r: 1.5, s: 2.0, weight: Some(7.38905609893065)))");
        let field = Field::new(&s);
        let inv = Inversion::of_field(&field).unwrap();
        for d in [1.6, 2.0, 3.0] {
            let f = field.value(DVec3::new(d, 0.0, 0.0));
            assert!((inv.distance(f + 1.0, 1.0) - (d - 1.5)).abs() < 1e-9, "{d}");
        }
    }

    #[test]
    fn scenes_it_cannot_invert_are_refused_in_one_line() {
        let mixed = scene(
            "Point(center: (0.0, 0.0, 0.0), kernel: Gaussian(r: 1.5, s: 2.0)), Point(center: (1.0, 0.0, 0.0), kernel: Gaussian(r: 1.5, s: 3.0))",
        );
        assert!(Inversion::of_field(&Field::new(&mixed)).unwrap_err().contains("share"));
        let compact = scene("Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 1.0))");
        assert!(Inversion::of_field(&Field::new(&compact)).unwrap_err().contains("Gaussian"));
    }
}
