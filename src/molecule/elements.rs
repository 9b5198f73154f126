//! Element data: van der Waals radii and colours.
//!
//! **Radii** are Bondi's (A. Bondi, "van der Waals Volumes and Radii",
//! J. Phys. Chem. 68 (1964) 441-451, Table I), the table VMD, PyMOL and
//! most surface programs start from, in ångström. Bondi gives no radius
//! for some elements found in structures (Ca, Fe, Mn, Co among them):
//! those, and symbols that are no element, take [`FALLBACK_RADIUS`] and the
//! loader names them in one warning.
//!
//! **Colours** are Jmol's element colours, the usual modern form of the
//! CPK scheme (carbon grey rather than black), given in sRGB and used
//! through [`linear`]. Elements without one take Jmol's pink for unknowns.

/// The radius of an element Bondi's table lacks (and of unknown symbols),
/// in ångström: that of sulfur and phosphorus, the largest radius common in
/// biomolecules, so an unknown atom is not drawn smaller than its
/// neighbours.
pub const FALLBACK_RADIUS: f64 = 1.80;

/// Bondi (1964) van der Waals radii, Å.
const BONDI: &[(&str, f64)] = &[
    ("H", 1.20),
    ("He", 1.40),
    ("Li", 1.82),
    ("C", 1.70),
    ("N", 1.55),
    ("O", 1.52),
    ("F", 1.47),
    ("Ne", 1.54),
    ("Na", 2.27),
    ("Mg", 1.73),
    ("Si", 2.10),
    ("P", 1.80),
    ("S", 1.80),
    ("Cl", 1.75),
    ("Ar", 1.88),
    ("K", 2.75),
    ("Ni", 1.63),
    ("Cu", 1.40),
    ("Zn", 1.39),
    ("Ga", 1.87),
    ("As", 1.85),
    ("Se", 1.90),
    ("Br", 1.85),
    ("Kr", 2.02),
    ("Pd", 1.63),
    ("Ag", 1.72),
    ("Cd", 1.58),
    ("In", 1.93),
    ("Sn", 2.17),
    ("Te", 2.06),
    ("I", 1.98),
    ("Xe", 2.16),
    ("Pt", 1.72),
    ("Au", 1.66),
    ("Hg", 1.55),
    ("Tl", 1.96),
    ("Pb", 2.02),
    ("U", 1.86),
];

/// Jmol element colours, sRGB 0-255.
const JMOL: &[(&str, [u8; 3])] = &[
    ("H", [255, 255, 255]),
    ("He", [217, 255, 255]),
    ("Li", [204, 128, 255]),
    ("C", [144, 144, 144]),
    ("N", [48, 80, 248]),
    ("O", [255, 13, 13]),
    ("F", [144, 224, 80]),
    ("Ne", [179, 227, 245]),
    ("Na", [171, 92, 242]),
    ("Mg", [138, 255, 0]),
    ("Si", [240, 200, 160]),
    ("P", [255, 128, 0]),
    ("S", [255, 255, 48]),
    ("Cl", [31, 240, 31]),
    ("Ar", [128, 209, 227]),
    ("K", [143, 64, 212]),
    ("Ca", [61, 255, 0]),
    ("Mn", [156, 122, 199]),
    ("Fe", [224, 102, 51]),
    ("Co", [240, 144, 160]),
    ("Ni", [80, 208, 80]),
    ("Cu", [200, 128, 51]),
    ("Zn", [125, 128, 176]),
    ("Ga", [194, 143, 143]),
    ("As", [189, 128, 227]),
    ("Se", [255, 161, 0]),
    ("Br", [166, 41, 41]),
    ("Kr", [92, 184, 209]),
    ("Pd", [0, 105, 133]),
    ("Ag", [192, 192, 192]),
    ("Cd", [255, 217, 143]),
    ("In", [166, 117, 115]),
    ("Sn", [102, 128, 128]),
    ("Te", [212, 122, 0]),
    ("I", [148, 0, 148]),
    ("Xe", [66, 158, 176]),
    ("Pt", [208, 208, 224]),
    ("Au", [255, 209, 35]),
    ("Hg", [184, 184, 208]),
    ("Tl", [166, 84, 77]),
    ("Pb", [87, 89, 97]),
    ("U", [0, 143, 255]),
];

/// Standard atomic weights (IUPAC 2021, abridged conventional values), u,
/// of the elements biomolecular topologies hold: for reading elements from
/// masses (PSF).
const MASSES: &[(&str, f64)] = &[
    ("H", 1.008),
    ("He", 4.0026),
    ("Li", 6.94),
    ("B", 10.81),
    ("C", 12.011),
    ("N", 14.007),
    ("O", 15.999),
    ("F", 18.998),
    ("Ne", 20.180),
    ("Na", 22.990),
    ("Mg", 24.305),
    ("Al", 26.982),
    ("Si", 28.085),
    ("P", 30.974),
    ("S", 32.06),
    ("Cl", 35.45),
    ("Ar", 39.95),
    ("K", 39.098),
    ("Ca", 40.078),
    ("Mn", 54.938),
    ("Fe", 55.845),
    ("Co", 58.933),
    ("Ni", 58.693),
    ("Cu", 63.546),
    ("Zn", 65.38),
    ("Se", 78.971),
    ("Br", 79.904),
    ("Rb", 85.468),
    ("Sr", 87.62),
    ("Cd", 112.41),
    ("I", 126.90),
    ("Cs", 132.91),
    ("Ba", 137.33),
];

/// The element whose atomic weight is nearest `mass` (u), if it lies
/// within `tolerance`. Where two elements are that close (Ar and K, Co and
/// Ni), the nearer wins.
pub fn by_mass(mass: f64, tolerance: f64) -> Option<&'static str> {
    MASSES.iter().map(|(s, m)| (*s, (m - mass).abs())).filter(|(_, d)| *d <= tolerance).min_by(|a, b| a.1.total_cmp(&b.1)).map(|(s, _)| s)
}

/// Jmol's colour for an unknown element.
const UNKNOWN_COLOR: [u8; 3] = [255, 20, 147];

/// Element symbols that exist, for reading names that carry no element
/// column (GRO): Bondi's and Jmol's, which cover what biomolecular files
/// hold.
pub fn is_element(symbol: &str) -> bool {
    BONDI.iter().any(|(s, _)| *s == symbol) || JMOL.iter().any(|(s, _)| *s == symbol)
}

/// `symbol` as the tables write it: periodic-table case (`SE`, `se` and
/// `Se` are selenium, as the readers take them), deuterium as hydrogen.
fn table_symbol(symbol: &str) -> String {
    let symbol = super::element_case(symbol);
    if symbol == "D" { "H".to_string() } else { symbol }
}

/// Bondi's radius of `symbol` (any case: `SE` is selenium), if the table
/// has it. Deuterium (`D`) is drawn as hydrogen.
pub fn radius(symbol: &str) -> Option<f64> {
    let symbol = table_symbol(symbol);
    BONDI.iter().find(|(s, _)| *s == symbol).map(|(_, r)| *r)
}

/// An sRGB component 0-255 in linear light (the scene's colours are linear).
pub fn linear(c: u8) -> f64 {
    crate::output::linear_of_srgb(f64::from(c) / 255.0)
}

/// The element's colour (any case, as [`radius`]), linear RGB.
pub fn color(symbol: &str) -> [f64; 3] {
    let symbol = table_symbol(symbol);
    let c = JMOL.iter().find(|(s, _)| *s == symbol).map_or(UNKNOWN_COLOR, |(_, c)| *c);
    c.map(linear)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_biomolecular_elements_have_bondi_radii_and_colours() {
        assert_eq!(radius("C"), Some(1.70));
        assert_eq!(radius("N"), Some(1.55));
        assert_eq!(radius("O"), Some(1.52));
        assert_eq!(radius("S"), Some(1.80));
        assert_eq!(radius("Se"), Some(1.90));
        // Any case, as the readers take a PDB's element column.
        assert_eq!(radius("SE"), Some(1.90));
        assert_eq!(radius(" cl "), radius("Cl"));
        assert_eq!(color("ZN"), color("Zn"));
        assert_eq!(color("FE"), color("Fe"));
        assert_ne!(color("FE"), color("Xx"));
        assert_eq!(radius("Fe"), None);
        assert!(is_element("Fe") && is_element("Zn") && !is_element("Xx"));
        assert!((color("O")[0] - 1.0).abs() < 1e-12);
        assert!(color("C")[0] > 0.2 && color("C")[0] < 0.35);
        assert_eq!(by_mass(12.011, 0.6), Some("C"));
        assert_eq!(by_mass(22.98977, 0.6), Some("Na"));
        assert_eq!(by_mass(3.024, 0.6), None);
        for (s, r) in BONDI {
            assert!((1.0..3.0).contains(r), "{s}");
        }
    }
}
