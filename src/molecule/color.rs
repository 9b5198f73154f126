//! Colours of atoms by a value (B-factor, occupancy, values given per
//! atom) through a palette and a range, and by residue: its class
//! (VMD's ResType) or its name (Jmol's "shapely" colours).
//!
//! Palettes are evaluated in sRGB (as published) and converted to the
//! linear RGB the renderer shades in, like the element colours.

use anyhow::{Result, bail};

use super::elements::linear;

/// How values become colours (`--palette`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Palette {
    /// matplotlib's viridis: dark purple at the range's low end, yellow at
    /// its high end, perceptually uniform.
    #[default]
    Viridis,
    /// Diverging: blue (#2166AC) at the low end, white at the middle of
    /// the range, red (#B2182B) at the high end, linear in sRGB between
    /// (ColorBrewer RdBu's ends, and true white in the middle).
    BlueWhiteRed,
    /// AlphaFold's four pLDDT bands on the value itself (the range is not
    /// used): very high (>= 90) dark blue, confident (70-90) light blue,
    /// low (50-70) yellow, very low (< 50) orange.
    Alphafold,
}

/// AlphaFold DB's pLDDT band colours (sRGB), from the lowest band up, with
/// each band's lower bound.
pub const ALPHAFOLD_BANDS: [(f64, [u8; 3]); 4] =
    [(f64::NEG_INFINITY, [0xFF, 0x7D, 0x45]), (50.0, [0xFF, 0xDB, 0x13]), (70.0, [0x65, 0xCB, 0xF3]), (90.0, [0x00, 0x53, 0xD6])];

const BLUE: [u8; 3] = [0x21, 0x66, 0xAC];
const WHITE: [u8; 3] = [0xFF, 0xFF, 0xFF];
const RED: [u8; 3] = [0xB2, 0x18, 0x2B];

/// The values mapped onto the palette's ends (`--range MIN:MAX`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub min: f64,
    pub max: f64,
}

impl Range {
    /// `MIN:MAX`, finite, MIN below MAX.
    pub fn parse(text: &str) -> Result<Range> {
        let Some((a, b)) = text.split_once(':') else {
            bail!("--range takes MIN:MAX (two numbers and a colon, e.g. 0:100), got {text:?}");
        };
        let number = |s: &str| s.trim().parse::<f64>().ok().filter(|v| v.is_finite());
        let (Some(min), Some(max)) = (number(a), number(b)) else {
            bail!("--range takes MIN:MAX with two finite numbers, got {text:?}");
        };
        if min >= max {
            bail!("--range MIN:MAX needs MIN below MAX, got {text:?}");
        }
        Ok(Range { min, max })
    }

    /// The smallest and largest of `values` (finite ones); `None` when
    /// there are none.
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<Range> {
        let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values.into_iter().filter(|v| v.is_finite()) {
            min = min.min(v);
            max = max.max(v);
        }
        (min <= max).then_some(Range { min, max })
    }

    /// Where `v` falls, from 0 at `min` to 1 at `max`, clamped; the middle
    /// when the range is a single value.
    pub fn fraction(&self, v: f64) -> f64 {
        if self.max > self.min { ((v - self.min) / (self.max - self.min)).clamp(0.0, 1.0) } else { 0.5 }
    }
}

impl std::fmt::Display for Range {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "{}:{}", self.min, self.max)
    }
}

fn srgb(c: [u8; 3]) -> [f64; 3] {
    [linear(c[0]), linear(c[1]), linear(c[2])]
}

impl Palette {
    /// The colour (linear RGB) of `value` in `range`.
    pub fn color(self, value: f64, range: Range) -> [f64; 3] {
        self.srgb(value, range).map(linear)
    }

    /// The colour as published (sRGB, 8 bits) of `value` in `range`.
    pub fn srgb(self, value: f64, range: Range) -> [u8; 3] {
        let t = range.fraction(value);
        let c = match self {
            Palette::Viridis => colorous::VIRIDIS.eval_continuous(t),
            Palette::BlueWhiteRed => {
                let (from, to, f) = if t < 0.5 { (BLUE, WHITE, 2.0 * t) } else { (WHITE, RED, 2.0 * t - 1.0) };
                return std::array::from_fn(|i| (f64::from(from[i]) + f * (f64::from(to[i]) - f64::from(from[i]))).round() as u8);
            }
            Palette::Alphafold => {
                let band = ALPHAFOLD_BANDS.iter().rev().find(|(low, _)| value >= *low).map_or(ALPHAFOLD_BANDS[0].1, |b| b.1);
                return band;
            }
        };
        [c.r, c.g, c.b]
    }

    /// Whether the palette uses the range (AlphaFold's bands do not).
    pub fn uses_range(self) -> bool {
        self != Palette::Alphafold
    }
}

/// VMD's residue classes (its ResType colouring): nonpolar white, polar
/// green, acidic red, basic blue; `None` for residues that are none of
/// the twenty amino acids (they keep their element colours).
pub fn restype(resname: &str) -> Option<[f64; 3]> {
    let class = match resname {
        "ALA" | "GLY" | "ILE" | "LEU" | "MET" | "MSE" | "PHE" | "PRO" | "TRP" | "VAL" => [255, 255, 255],
        "ASN" | "CYS" | "GLN" | "SER" | "THR" | "TYR" => [0, 160, 0],
        "ASP" | "GLU" => [220, 0, 0],
        "ARG" | "HIS" | "HSD" | "HSE" | "HSP" | "HID" | "HIE" | "HIP" | "LYS" => [0, 0, 220],
        _ => return None,
    };
    Some(srgb(class))
}

/// Jmol's "shapely" residue colours (RasMol's), for amino acids and
/// nucleotides; `None` for other residues (they keep their element
/// colours).
pub fn shapely(resname: &str) -> Option<[f64; 3]> {
    const TABLE: &[(&str, [u8; 3])] = &[
        ("ALA", [0x8C, 0xFF, 0x8C]),
        ("ARG", [0x00, 0x00, 0x7C]),
        ("ASN", [0xFF, 0x7C, 0x70]),
        ("ASP", [0xA0, 0x00, 0x42]),
        ("CYS", [0xFF, 0xFF, 0x70]),
        ("GLN", [0xFF, 0x4C, 0x4C]),
        ("GLU", [0x66, 0x00, 0x00]),
        ("GLY", [0xFF, 0xFF, 0xFF]),
        ("HIS", [0x70, 0x70, 0xFF]),
        ("ILE", [0x00, 0x4C, 0x00]),
        ("LEU", [0x45, 0x5E, 0x45]),
        ("LYS", [0x47, 0x47, 0xB8]),
        ("MET", [0xB8, 0xA0, 0x42]),
        ("PHE", [0x53, 0x4C, 0x52]),
        ("PRO", [0x52, 0x52, 0x52]),
        ("SER", [0xFF, 0x70, 0x42]),
        ("THR", [0xB8, 0x4C, 0x00]),
        ("TRP", [0x4F, 0x46, 0x00]),
        ("TYR", [0x8C, 0x70, 0x4C]),
        ("VAL", [0xFF, 0x8C, 0xFF]),
        ("A", [0xA0, 0xA0, 0xFF]),
        ("C", [0xFF, 0x8C, 0x4B]),
        ("G", [0xFF, 0x70, 0x70]),
        ("T", [0xA0, 0xFF, 0xA0]),
        ("U", [0xFF, 0x80, 0x80]),
        ("DA", [0xA0, 0xA0, 0xFF]),
        ("DC", [0xFF, 0x8C, 0x4B]),
        ("DG", [0xFF, 0x70, 0x70]),
        ("DT", [0xA0, 0xFF, 0xA0]),
    ];
    TABLE.iter().find(|(n, _)| *n == resname).map(|(_, c)| srgb(*c))
}

/// What a colouring by value shows: its palette over its range, and what
/// the values are (`--legend` draws it under the image).
#[derive(Clone, Debug, PartialEq)]
pub struct Legend {
    pub palette: Palette,
    pub range: Range,
    pub label: String,
}

impl Legend {
    /// The colour bar: 256 samples over the range (AlphaFold's bands over
    /// pLDDT 0 to 100, whatever the range).
    pub fn color_bar(&self) -> crate::output::ColorBar {
        let range = if self.palette.uses_range() { self.range } else { Range { min: 0.0, max: 100.0 } };
        let colors = (0..256).map(|k| self.palette.srgb(range.min + (range.max - range.min) * f64::from(k) / 255.0, range)).collect();
        let show = |v: f64| {
            let s = format!("{v:.2}");
            let s = s.trim_end_matches('0').trim_end_matches('.');
            if s == "-0" { "0".to_string() } else { s.to_string() }
        };
        crate::output::ColorBar { colors, low: show(range.min), high: show(range.max), label: self.label.clone() }
    }
}

/// Values to colour atoms by, one row per frame (`--color-values FILE`,
/// Python's `values=`): a row holds one value per atom of the file (by
/// site) or per atom drawn (in order).
#[derive(Clone, Debug, PartialEq)]
pub struct Values {
    /// Where they came from, for messages.
    pub source: String,
    rows: Vec<Vec<f64>>,
}

impl Values {
    /// Values given as rows (frames) of numbers, all finite, every row as
    /// long as the first.
    pub fn from_rows(rows: Vec<Vec<f64>>, source: &str) -> Result<Values> {
        let Some(width) = rows.first().map(Vec::len) else { bail!("{source}: no values") };
        if width == 0 {
            bail!("{source}: no values");
        }
        for (k, row) in rows.iter().enumerate() {
            if row.len() != width {
                bail!("{source}: row {} has {} values where the first has {width}: every frame needs one value per atom", k + 1, row.len());
            }
            if let Some(i) = row.iter().position(|v| !v.is_finite()) {
                bail!("{source}: value {} of row {} is not a finite number", i + 1, k + 1);
            }
        }
        Ok(Values { source: source.into(), rows })
    }

    /// A CSV file of numbers (`#` comment lines and blank lines skipped,
    /// no header): one line of one value per atom, or a column of them
    /// (one value per line), or one line per frame of a trajectory.
    pub fn read(path: &std::path::Path) -> Result<Values> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("{file}: cannot read the values: {e}"))?;
        let mut reader =
            csv::ReaderBuilder::new().has_headers(false).flexible(true).comment(Some(b'#')).trim(csv::Trim::All).from_reader(text.as_bytes());
        let mut rows = Vec::new();
        for record in reader.records() {
            let record = record.map_err(|e| anyhow::anyhow!("{file}: {e}"))?;
            let line = record.position().map_or(0, |p| p.line());
            if record.iter().all(str::is_empty) {
                continue;
            }
            let row = record
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    v.parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| anyhow::anyhow!("{file}:{line}: value {} ({v:?}) is not a finite number", i + 1))
                })
                .collect::<Result<Vec<f64>>>()?;
            rows.push(row);
        }
        // A column of single values is one frame.
        if rows.len() > 1 && rows.iter().all(|r| r.len() == 1) {
            rows = vec![rows.into_iter().map(|r| r[0]).collect()];
        }
        Values::from_rows(rows, &file)
    }

    /// Values per frame (rows).
    pub fn frames(&self) -> usize {
        self.rows.len()
    }

    /// Values per row.
    pub fn width(&self) -> usize {
        self.rows[0].len()
    }

    /// The row of frame `k`: the single row for every frame, else row k.
    pub fn row(&self, k: usize) -> Result<&[f64]> {
        match self.rows.len() {
            1 => Ok(&self.rows[0]),
            n if k < n => Ok(&self.rows[k]),
            n => bail!("{}: {n} rows of values, none for frame {k}: give one row per frame, or one row for all", self.source),
        }
    }

    /// The least and greatest value of every row: one range for a whole
    /// trajectory, so a colour means the same value in every frame.
    pub fn range(&self) -> Range {
        Range::of(self.rows.iter().flatten().copied()).unwrap_or(Range { min: 0.0, max: 1.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_parse_and_clamp() {
        let r = Range::parse("10:50").unwrap();
        assert_eq!((r.fraction(10.0), r.fraction(30.0), r.fraction(50.0), r.fraction(99.0), r.fraction(-5.0)), (0.0, 0.5, 1.0, 1.0, 0.0));
        for bad in ["10", "50:10", "1:1", "a:2", "1:inf", ":"] {
            assert!(Range::parse(bad).is_err(), "{bad}");
        }
        assert_eq!(Range::of([3.0, f64::NAN, -1.0, 2.0]), Some(Range { min: -1.0, max: 3.0 }));
        assert_eq!(Range::of([]), None);
        assert_eq!(Range { min: 2.0, max: 2.0 }.fraction(2.0), 0.5);
    }

    #[test]
    fn palettes_have_their_published_ends() {
        let r = Range { min: 0.0, max: 100.0 };
        assert_eq!(Palette::Viridis.srgb(0.0, r), [0x44, 0x01, 0x54]);
        assert_eq!(Palette::Viridis.srgb(100.0, r), [0xFD, 0xE7, 0x25]);
        let bwr = (Palette::BlueWhiteRed.srgb(0.0, r), Palette::BlueWhiteRed.srgb(50.0, r), Palette::BlueWhiteRed.srgb(100.0, r));
        assert_eq!(bwr, ([0x21, 0x66, 0xAC], [0xFF; 3], [0xB2, 0x18, 0x2B]));
        assert_eq!(Palette::BlueWhiteRed.srgb(25.0, r), [0x90, 0xB3, 0xD6], "halfway from blue to white");
        let af: Vec<[u8; 3]> = [10.0, 50.0, 69.9, 70.0, 89.9, 90.0, 100.0].iter().map(|&v| Palette::Alphafold.srgb(v, r)).collect();
        assert_eq!(
            af,
            [
                [0xFF, 0x7D, 0x45],
                [0xFF, 0xDB, 0x13],
                [0xFF, 0xDB, 0x13],
                [0x65, 0xCB, 0xF3],
                [0x65, 0xCB, 0xF3],
                [0x00, 0x53, 0xD6],
                [0x00, 0x53, 0xD6]
            ]
        );
    }

    #[test]
    fn residues_have_classes_and_names() {
        assert_eq!(restype("LYS"), restype("ARG"));
        assert_ne!(restype("LYS"), restype("ASP"));
        assert_eq!(restype("HOH"), None);
        assert_eq!(shapely("GLY"), Some([1.0, 1.0, 1.0]));
        assert_eq!(shapely("HEM"), None);
    }
}
