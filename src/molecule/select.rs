//! Atom selections: VMD's selection language with MDAnalysis's aliases, parsed once ([`Selection::parse`]) and evaluated
//! to one flag per atom ([`Selection::matches`]). Errors are one line naming the 1-based character column ([`SelectError`]).
//!
//! ```text
//! selection := or
//! or        := and { "or" and }
//! and       := unary { "and" unary }
//! unary     := "not" unary | "(" or ")" | SINGLETON
//!            | TEXT-KEY value..  | NUMBER-KEY (number | number "to" number | number:number)..  | NUMBER-KEY (< <= > >= == !=) number
//!            | "within" D "of" or | "around" D or | "same" "residue" "as" or | "byres" or
//! ```
//!
//! Precedence, tightest first: `not`, then `and`, then `or`; `within D of`, `same residue as` (and MDAnalysis's `around D`
//! and `byres`) take everything to their right, up to the end or the enclosing `)`: `within 5 of protein and name CA` is
//! `within 5 of (protein and name CA)`, and `not within 5 of A or B` is `not (within 5 of (A or B))`. That is VMD's rule
//! (its AtomParser.y declares `of` and `as` below `or` and `and`, `not` above both), so selections copied from VMD keep their
//! meaning; the shared spec's "within/same bind as tightly as not" was dropped for it. Write `(within 5 of A) and B` for the
//! other reading. MDAnalysis gives `around` and `byres` the same reach, but gives `and` and `or` equal precedence, left to
//! right (`A or B and C` is `(A or B) and C` there and `A or (B and C)` here, as in VMD). VMD's implicit `and` between two
//! selections (`protein name CA`) is not accepted: it is an error asking for `and` or `or`.
//!
//! Values run until the next keyword, operator, parenthesis or comparison. Text values are case-sensitive (`element`
//! excepted); unquoted ones may hold the globs `*` and `?` (MDAnalysis's `name C*`), quoted ones ('..' or "..") are literal
//! (`name "O5'"`; VMD reads "..." as a regular expression). A `'` inside a word belongs to it (`name O5'`). Numbers: a list
//! of values and inclusive ranges (`resid 1 3 10 to 20 30:40`), equal when exactly equal, or one comparison (`beta > 40`).
//! `resid 52A` names an insertion code; `resid 52` matches every insertion code of 52 (VMD's reading: MDAnalysis, where the
//! file has insertion codes, matches only 52 without one), and `resid 52A to 53` runs from 52A through all of 53.
//!
//! Definitions (the field names are [`Atom`]'s):
//! - `index`: `site`. `chain` (alias MDAnalysis's `chainID`): `chain`. `segname` (alias `segid`): `segment`. `type`: `atom_type`.
//!   `element`: `element`, ignoring case (`element CL` matches `Cl`).
//! - `protein`, `nucleic`, `water`: the residue name is in MDAnalysis 2.11's list (ProteinSelection.prot_res,
//!   NucleicSelection.nucl_res, WaterSelection.water_res). VMD decides protein and nucleic from the atoms a residue holds
//!   (CA, C, N, O; P, O1P, C3'..) with bonds, and its water list (as ProDy copies it) is H2O HH0 OHH HOH OH2 SOL WAT TIP
//!   TIP2 TIP3 TIP4.
//! - `backbone`: `protein and name N CA C O` (MDAnalysis's). VMD adds the terminal oxygens (OT1, OT2, OXT..) and the nucleic
//!   backbone (P, O1P, O2P, O3', C3', C4', C5', O5').
//! - `sidechain`: `protein and not backbone`, so it holds the backbone hydrogens (H, HA). VMD walks the bonds from CA away from
//!   the backbone, leaving out HA and H; MDAnalysis has no `sidechain`.
//! - `ion` (alias `ions`): the residue name is in VMD's `ion` macro (VMD 1.9's table, as ProDy and D. E. Shaw Research's
//!   msys copy it): AL BA CA Ca CAL CD CES CLA CL Cl CO CS CU Cu CU1 CUA HG IN IOD K MG MN3 MO3 MO4 MO5 MO6 NA Na NAW OC7 PB
//!   POT PT RB SOD TB TL WO4 YB ZN ZN1 ZN2, plus 'Cl-' and 'K+' from msys's copy (its `legacy_ion`; its new `ion` picks
//!   unbonded atoms by element, and there are no bonds here), and any of these with its charge (`NA+`, GROMACS's way). MDAnalysis
//!   has no `ion`.
//! - `hetero`: the atom came from a HETATM record (`hetero`; never for GRO or PSF). VMD's `hetero` is `not (protein or
//!   nucleic)`; MDAnalysis has `record_type HETATM`.
//! - `hydrogen`: element H or D. VMD guesses from the name (`name "[0-9]?H.*"`, says msys's documentation); MDAnalysis
//!   has no `hydrogen`.
//! - `within D of SEL`: atoms at most D Å from an atom of SEL, SEL's own atoms included (0 < D <= 1000). `around D SEL` is
//!   MDAnalysis's: the same less SEL's atoms.
//! - `same residue as SEL` (alias `byres SEL`): every atom of a residue holding an atom of SEL, a residue being a maximal run
//!   of consecutive atoms with the same chain, segment, resid, insertion code and residue name. VMD's other `same KEY as`
//!   forms are not supported.

use super::Atom;

use std::collections::HashMap;
use std::fmt;
use std::str::FromStr;

use glam::DVec3;

/// The selection used when none is given: surfaces leave out water and ions.
pub const DEFAULT: &str = "not (water or ion)";

/// MDAnalysis 2.11's `ProteinSelection.prot_res`.
const PROTEIN: &[&str] = &[
    "ACE", "ALA", "ALAD", "ARG", "ARGN", "ASF", "ASH", "ASN", "ASN1", "ASP", "ASPH", "CALA", "CARG", "CASF", "CASN", "CASP", "CCYS", "CCYX", "CGLN",
    "CGLU", "CGLY", "CHID", "CHIE", "CHIP", "CILE", "CLEU", "CLYS", "CME", "CMET", "CPHE", "CPRO", "CSER", "CTHR", "CTRP", "CTYR", "CVAL", "CYM",
    "CYS", "CYS1", "CYS2", "CYSH", "CYX", "DAB", "GLH", "GLN", "GLU", "GLUH", "GLY", "HID", "HIE", "HIP", "HIS", "HIS1", "HIS2", "HISA", "HISB",
    "HISD", "HISE", "HISH", "HSD", "HSE", "HSP", "HYP", "ILE", "LEU", "LYN", "LYS", "LYSH", "MET", "MSE", "NALA", "NARG", "NASN", "NASP", "NCYS",
    "NCYX", "NGLN", "NGLU", "NGLY", "NHID", "NHIE", "NHIP", "NILE", "NLEU", "NLYS", "NME", "NMET", "NPHE", "NPRO", "NSER", "NTHR", "NTRP", "NTYR",
    "NVAL", "ORN", "PGLU", "PHE", "PRO", "QLN", "SER", "THR", "TRP", "TYR", "VAL",
];
/// MDAnalysis 2.11's `NucleicSelection.nucl_res`.
const NUCLEIC: &[&str] = &[
    "A", "ADE", "C", "CYT", "DA", "DA3", "DA5", "DC", "DC3", "DC5", "DG", "DG3", "DG5", "DT", "DT3", "DT5", "G", "GUA", "RA", "RA3", "RA5", "RC",
    "RC3", "RC5", "RG", "RG3", "RG5", "RU", "RU3", "RU5", "T", "THY", "U", "URA",
];
/// MDAnalysis 2.11's `WaterSelection.water_res`.
const WATER: &[&str] = &["H2O", "HHO", "HOH", "OH2", "OHH", "SOL", "T3P", "T4P", "T5P", "TIP", "TIP2", "TIP3", "TIP4", "WAT"];
/// VMD's `ion` macro (and 'Cl-', 'K+' from its `legacy_ion`).
const ION: &[&str] = &[
    "AL", "BA", "CA", "Ca", "CAL", "CD", "CES", "CLA", "CL", "Cl", "Cl-", "CO", "CS", "CU", "Cu", "CU1", "CUA", "HG", "IN", "IOD", "K", "K+", "MG",
    "MN3", "MO3", "MO4", "MO5", "MO6", "NA", "Na", "NAW", "OC7", "PB", "POT", "PT", "RB", "SOD", "TB", "TL", "WO4", "YB", "ZN", "ZN1", "ZN2",
];
const BACKBONE: &[&str] = &["N", "CA", "C", "O"];
/// How deep parentheses, `not`, `within` and `same residue as` may nest.
const MAX_DEPTH: usize = 100;
/// The largest distance `within` takes, Å.
const MAX_DISTANCE: f64 = 1000.0;
/// Words that end a list of values and never start one.
const OPERATORS: &[&str] = &["and", "or", "not", "within", "around", "same", "byres", "of", "as", "to"];
/// Every keyword, most used first (for suggestions).
const KEYWORDS: &str = "name resname resid chain protein water nucleic backbone sidechain ion hetero hydrogen all none segname segid element type \
                        index beta occupancy charge mass x y z not within same around byres ions waters chainID";

/// A parsed selection.
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    text: String,
    expr: Expr,
}

/// Why a selection could not be parsed: one line, with the 1-based character column of the bad token.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct SelectError {
    pub column: usize,
    pub message: String,
}

fn fail<T>(column: usize, message: String) -> Result<T, SelectError> {
    Err(SelectError { column, message })
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Flag {
    All,
    None,
    Protein,
    Nucleic,
    Backbone,
    Sidechain,
    Water,
    Ion,
    Hetero,
    Hydrogen,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Text {
    Name,
    Resname,
    Chain,
    Segment,
    Element,
    Type,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Number {
    Resid,
    Index,
    Beta,
    Occupancy,
    Charge,
    Mass,
    X,
    Y,
    Z,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Cmp {
    Lt,
    Le,
    Gt,
    Ge,
    Eq,
    Ne,
}

/// One end of a number range; `icode` only for `resid` (none: any insertion code).
#[derive(Clone, Debug, PartialEq)]
struct Bound {
    value: f64,
    icode: Option<String>,
}

/// A text value: literal, or a glob when unquoted and holding `*` or `?`.
#[derive(Clone, Debug, PartialEq)]
struct Pattern {
    chars: Vec<char>,
    glob: bool,
}

#[derive(Clone, Debug, PartialEq)]
enum Expr {
    Flag(Flag),
    Text(Text, Vec<Pattern>),
    /// Inclusive ranges; a single value is a range from itself to itself.
    Number(Number, Vec<(Bound, Bound)>),
    Compare(Number, Cmp, f64),
    Not(Box<Expr>),
    /// Flat lists, so that long chains of `and` or `or` do not make deep trees.
    And(Vec<Expr>),
    Or(Vec<Expr>),
    Within(f64, Box<Expr>),
    /// MDAnalysis's `around`: `within` less the reference atoms, the inner
    /// selection evaluated once (nesting it stays linear).
    Around(f64, Box<Expr>),
    SameResidue(Box<Expr>),
}

enum Key {
    Flag(Flag),
    Text(Text),
    Number(Number),
}

fn keyword(word: &str) -> Option<Key> {
    use {Flag as F, Number as N, Text as T};
    Some(match word {
        "all" => Key::Flag(F::All),
        "none" => Key::Flag(F::None),
        "protein" => Key::Flag(F::Protein),
        "nucleic" => Key::Flag(F::Nucleic),
        "backbone" => Key::Flag(F::Backbone),
        "sidechain" => Key::Flag(F::Sidechain),
        "water" | "waters" => Key::Flag(F::Water),
        "ion" | "ions" => Key::Flag(F::Ion),
        "hetero" => Key::Flag(F::Hetero),
        "hydrogen" => Key::Flag(F::Hydrogen),
        "name" => Key::Text(T::Name),
        "resname" => Key::Text(T::Resname),
        "chain" | "chainID" => Key::Text(T::Chain),
        "segname" | "segid" => Key::Text(T::Segment),
        "element" => Key::Text(T::Element),
        "type" => Key::Text(T::Type),
        "resid" => Key::Number(N::Resid),
        "index" => Key::Number(N::Index),
        "beta" => Key::Number(N::Beta),
        "occupancy" => Key::Number(N::Occupancy),
        "charge" => Key::Number(N::Charge),
        "mass" => Key::Number(N::Mass),
        "x" => Key::Number(N::X),
        "y" => Key::Number(N::Y),
        "z" => Key::Number(N::Z),
        _ => return None,
    })
}

#[derive(Clone, Debug, PartialEq)]
enum Kind {
    Word(String),
    Quoted(String),
    Open,
    Close,
    Cmp(Cmp),
}

#[derive(Clone, Debug)]
struct Token {
    kind: Kind,
    /// As written (quotes included), for messages.
    raw: String,
    column: usize,
}

impl Token {
    fn is(&self, word: &str) -> bool {
        matches!(&self.kind, Kind::Word(w) if w == word)
    }
    /// The token as messages show it: in single quotes unless it is quoted already.
    fn shown(&self) -> String {
        if let Kind::Quoted(_) = self.kind { self.raw.clone() } else { format!("'{}'", self.raw) }
    }
    /// A word that starts or separates selections rather than being a value.
    fn is_reserved(&self) -> bool {
        matches!(&self.kind, Kind::Word(w) if OPERATORS.contains(&w.as_str()) || keyword(w).is_some())
    }
}

/// Splits the text into words, quoted strings, parentheses and comparisons.
fn tokenize(text: &str) -> Result<Vec<Token>, SelectError> {
    let chars: Vec<char> = text.chars().collect();
    let special = |c: char| c.is_whitespace() || "()\"<>=!".contains(c);
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let (c, start) = (chars[i], i);
        let column = i + 1;
        let kind = match c {
            _ if c.is_whitespace() => {
                i += 1;
                continue;
            }
            '(' | ')' => {
                i += 1;
                if c == '(' { Kind::Open } else { Kind::Close }
            }
            '\'' | '"' => {
                let Some(len) = chars[i + 1..].iter().position(|&d| d == c) else {
                    return fail(column, format!("unclosed quote at column {column}"));
                };
                i += len + 2;
                Kind::Quoted(chars[start + 1..i - 1].iter().collect())
            }
            '<' | '>' | '=' | '!' => {
                let equals = chars.get(i + 1) == Some(&'=');
                let cmp = match (c, equals) {
                    ('<', false) => Cmp::Lt,
                    ('<', true) => Cmp::Le,
                    ('>', false) => Cmp::Gt,
                    ('>', true) => Cmp::Ge,
                    ('=', true) => Cmp::Eq,
                    ('!', true) => Cmp::Ne,
                    _ => return fail(column, format!("unexpected '{c}' at column {column}; comparisons are <, <=, >, >=, == and !=")),
                };
                i += 1 + equals as usize;
                Kind::Cmp(cmp)
            }
            _ => {
                while i < chars.len() && !special(chars[i]) {
                    i += 1;
                }
                Kind::Word(chars[start..i].iter().collect())
            }
        };
        tokens.push(Token { kind, raw: chars[start..i].iter().collect(), column });
    }
    Ok(tokens)
}

/// The closest of `candidates` to `word` when it is a likely typo.
fn suggest<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let best = candidates.into_iter().map(|c| (strsim::levenshtein(word, c), c)).min_by_key(|&(d, _)| d)?;
    (best.0 <= 2 && best.0 < word.chars().count()).then_some(best.1)
}

struct Parser {
    tokens: Vec<Token>,
    pos: usize,
    /// The column just past the text, for "the end".
    end: usize,
    /// How many terms are open around the current one.
    depth: usize,
}

impl Parser {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.pos)
    }
    fn next(&mut self) -> Option<Token> {
        let token = self.tokens.get(self.pos).cloned();
        self.pos += token.is_some() as usize;
        token
    }
    fn eat(&mut self, word: &str) -> bool {
        let found = self.peek().is_some_and(|t| t.is(word));
        self.pos += found as usize;
        found
    }
    /// What comes next, for messages: (`'word'` or `the end`, its column).
    fn found(&self) -> (String, usize) {
        self.peek().map_or(("the end".into(), self.end), |t| (t.shown(), t.column))
    }

    fn or(&mut self) -> Result<Expr, SelectError> {
        let mut terms = vec![self.and()?];
        while self.eat("or") {
            terms.push(self.and()?);
        }
        Ok(if terms.len() == 1 { terms.remove(0) } else { Expr::Or(terms) })
    }

    fn and(&mut self) -> Result<Expr, SelectError> {
        let mut terms = vec![self.unary()?];
        while self.eat("and") {
            terms.push(self.unary()?);
        }
        Ok(if terms.len() == 1 { terms.remove(0) } else { Expr::And(terms) })
    }

    /// A distance after `within` or `around` (the token `word`).
    fn distance(&mut self, word: &Token) -> Result<f64, SelectError> {
        let (found, column) = self.found();
        let value = match self.peek().map(|t| &t.kind) {
            Some(Kind::Word(w)) => w.parse::<f64>().ok().filter(|v| v.is_finite()),
            _ => None,
        };
        let Some(value) = value else {
            return fail(column, format!("expected a number after '{}' at column {column}, found {found}", word.raw));
        };
        if !(value > 0.0 && value <= MAX_DISTANCE) {
            return fail(column, format!("the distance {found} at column {column} must be above 0 and at most {MAX_DISTANCE} (Å)"));
        }
        self.pos += 1;
        Ok(value)
    }

    /// `word` (e.g. `of`) must come next.
    fn expect(&mut self, word: &str, what: &str) -> Result<(), SelectError> {
        if self.eat(word) {
            return Ok(());
        }
        let (found, column) = self.found();
        fail(column, format!("expected {what} at column {column}, found {found}"))
    }

    /// A term, counting how deep terms nest (parentheses, `not`, `within`..) so that no input can overflow the stack.
    fn unary(&mut self) -> Result<Expr, SelectError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            let (_, column) = self.found();
            return fail(column, format!("the selection nests more than {MAX_DEPTH} deep at column {column}"));
        }
        let term = self.term();
        self.depth -= 1;
        term
    }

    fn term(&mut self) -> Result<Expr, SelectError> {
        let Some(token) = self.next() else {
            // Nothing where a selection should start: say after what.
            return match self.pos.checked_sub(1).map(|p| &self.tokens[p]) {
                None => fail(1, "the selection is empty: write 'all' to select every atom".into()),
                Some(t) if t.kind == Kind::Open => fail(t.column, format!("unclosed '(' at column {}", t.column)),
                Some(t) => fail(t.column, format!("'{}' at column {} needs a selection after it", t.raw, t.column)),
            };
        };
        let Kind::Word(word) = &token.kind else {
            if token.kind == Kind::Open {
                let inner = self.or()?;
                return match self.next() {
                    Some(t) if t.kind == Kind::Close => Ok(inner),
                    None => fail(token.column, format!("unclosed '(' at column {}", token.column)),
                    Some(_) => Err(self.trailing(self.pos - 1)),
                };
            }
            return fail(token.column, format!("expected a selection at column {}, found {}", token.column, token.shown()));
        };
        let boxed = |e: Expr| Box::new(e);
        match word.as_str() {
            "not" => return Ok(Expr::Not(boxed(self.unary()?))),
            "within" => {
                let d = self.distance(&token)?;
                self.expect("of", "'of'")?;
                return Ok(Expr::Within(d, boxed(self.or()?)));
            }
            "around" => {
                let d = self.distance(&token)?;
                return Ok(Expr::Around(d, boxed(self.or()?)));
            }
            "same" => {
                self.expect("residue", "'residue as' after 'same'")?;
                self.expect("as", "'as'")?;
                return Ok(Expr::SameResidue(boxed(self.or()?)));
            }
            "byres" => return Ok(Expr::SameResidue(boxed(self.or()?))),
            _ => {}
        }
        match keyword(word) {
            Some(Key::Flag(flag)) => Ok(Expr::Flag(flag)),
            Some(Key::Text(field)) => self.text_values(&token, field),
            Some(Key::Number(field)) => self.number_values(&token, field),
            None if OPERATORS.contains(&word.as_str()) => {
                fail(token.column, format!("expected a selection at column {}, found '{word}'", token.column))
            }
            None => {
                let hint = match suggest(word, KEYWORDS.split_whitespace()) {
                    Some(s) => format!("did you mean '{s}'?"),
                    None => "expected a keyword such as name, resname, resid, chain, protein, water".into(),
                };
                fail(token.column, format!("unknown keyword '{word}' at column {}; {hint}", token.column))
            }
        }
    }

    /// The error for a token at `pos` that cannot follow a complete selection.
    fn trailing(&self, pos: usize) -> SelectError {
        let t = &self.tokens[pos];
        let mut message = format!("unexpected {} at column {}", t.shown(), t.column);
        if t.kind != Kind::Close {
            message += " after a complete selection";
            if let Kind::Word(w) = &t.kind {
                // A misspelt operator (one edit or swap away) rather than a word from nowhere.
                if let Some(s) = ["and", "or"].into_iter().find(|o| strsim::osa_distance(w, o) == 1) {
                    message += &format!("; did you mean '{s}'?");
                } else if t.is_reserved() {
                    message += "; join selections with 'and' or 'or'";
                }
            }
        }
        SelectError { column: t.column, message }
    }

    /// The error for a keyword followed by no value.
    fn no_values(&self, key: &Token) -> SelectError {
        let mut message = format!("'{}' at column {} needs at least one value", key.raw, key.column);
        if let Some(t) = self.peek().filter(|t| t.is_reserved()) {
            message += &format!(" ('{}' at column {} is a keyword: quote it to use it as a value)", t.raw, t.column);
        }
        SelectError { column: key.column, message }
    }

    fn text_values(&mut self, key: &Token, field: Text) -> Result<Expr, SelectError> {
        let mut patterns = Vec::new();
        while let Some(t) = self.peek() {
            if let Kind::Cmp(_) = t.kind {
                return fail(t.column, format!("'{}' at column {} compares numbers; '{}' takes text", t.raw, t.column, key.raw));
            }
            let Some(v) = value(t) else { break };
            patterns.push(Pattern { chars: v.chars().collect(), glob: matches!(t.kind, Kind::Word(_)) && v.contains(['*', '?']) });
            self.pos += 1;
        }
        if let Some(t) = self.peek().filter(|t| t.is("to")) {
            return fail(t.column, format!("'{}' takes no ranges: 'to' at column {}", key.raw, t.column));
        }
        if patterns.is_empty() {
            return Err(self.no_values(key));
        }
        Ok(Expr::Text(field, patterns))
    }

    /// One number of `field` written as `raw` at `column` (a resid may carry an insertion code: `52A`).
    fn bound(key: &Token, field: Number, raw: &str, column: usize) -> Result<Bound, SelectError> {
        let whole = matches!(field, Number::Resid | Number::Index);
        // For a resid, the number is the leading digits (and sign), the insertion code the letters after them.
        let digits = raw.char_indices().find(|&(i, c)| !(c.is_ascii_digit() || (i == 0 && "+-".contains(c)))).map_or(raw.len(), |(i, _)| i);
        let (number, icode) = raw.split_at(if field == Number::Resid { digits } else { raw.len() });
        if whole
            && icode.chars().all(|c| c.is_ascii_alphabetic())
            && let Ok(n) = number.parse::<i64>()
        {
            return Ok(Bound { value: n as f64, icode: (!icode.is_empty()).then(|| icode.to_string()) });
        }
        match raw.parse::<f64>() {
            Ok(v) if v.is_finite() && (!whole || v.fract() == 0.0) => Ok(Bound { value: v, icode: None }),
            Ok(v) if v.is_finite() => fail(column, format!("'{}' takes whole numbers: '{raw}' at column {column} is not one", key.raw)),
            _ => fail(column, format!("'{}' compares with numbers: '{raw}' at column {column} is not one", key.raw)),
        }
    }

    fn number_values(&mut self, key: &Token, field: Number) -> Result<Expr, SelectError> {
        // A comparison: `beta > 40`.
        if let Some(Token { kind: Kind::Cmp(cmp), raw: op, column }) = self.peek().cloned() {
            self.pos += 1;
            let Some((t, raw)) = self.peek().and_then(|t| value(t).map(|v| (t, v))) else {
                return fail(column, format!("'{op}' at column {column} needs a number after it"));
            };
            let message = format!("'{}' compares with numbers: '{raw}' at column {} is not one", key.raw, t.column);
            let (column, parsed) = (t.column, raw.parse::<f64>());
            self.pos += 1;
            return match parsed {
                Ok(v) if v.is_finite() => Ok(Expr::Compare(field, cmp, v)),
                _ => fail(column, message),
            };
        }
        // A list of values and ranges: `a:b` (MDAnalysis) within one word, or `a to b` (VMD) over three.
        let to_error = |t: &Token| SelectError { column: t.column, message: format!("'to' at column {} needs a number on each side", t.column) };
        let mut ranges = Vec::new();
        while let Some(t) = self.peek().cloned() {
            if t.is("to") {
                return Err(to_error(&t));
            }
            let Some(raw) = value(&t).map(str::to_string) else { break };
            self.pos += 1;
            let (lo, hi, written) = if let Some((a, b)) = raw.split_once(':') {
                let colon = t.column + a.chars().count();
                if a.is_empty() || b.is_empty() {
                    return fail(colon, format!("':' at column {colon} needs a number on each side"));
                }
                (Self::bound(key, field, a, t.column)?, Self::bound(key, field, b, colon + 1)?, raw.clone())
            } else if let Some(to) = self.peek().filter(|n| n.is("to")).cloned() {
                self.pos += 1;
                let lo = Self::bound(key, field, &raw, t.column)?;
                let next = self.next();
                let Some((n, b)) = next.as_ref().and_then(|n| value(n).map(|v| (n, v))).filter(|(_, v)| !v.contains(':')) else {
                    return Err(to_error(&to));
                };
                (lo, Self::bound(key, field, b, n.column)?, format!("{raw} to {b}"))
            } else {
                let b = Self::bound(key, field, &raw, t.column)?;
                (b.clone(), b, raw)
            };
            let backwards = match (&lo.icode, &hi.icode) {
                (Some(a), Some(b)) if lo.value == hi.value => a > b,
                _ => lo.value > hi.value,
            };
            if backwards {
                return fail(t.column, format!("the range '{written}' at column {} starts above its end", t.column));
            }
            ranges.push((lo, hi));
            if let Some(n) = self.peek().filter(|n| n.is("to")) {
                return Err(to_error(n));
            }
        }
        if ranges.is_empty() {
            return Err(self.no_values(key));
        }
        Ok(Expr::Number(field, ranges))
    }
}

/// The value a token holds, if it can be one: a quoted string, or a word that is no keyword or operator.
fn value(t: &Token) -> Option<&str> {
    match &t.kind {
        Kind::Word(w) if !t.is_reserved() => Some(w),
        Kind::Quoted(q) => Some(q),
        _ => None,
    }
}

impl Selection {
    pub fn parse(text: &str) -> Result<Selection, SelectError> {
        let tokens = tokenize(text)?;
        let mut parser = Parser { tokens, pos: 0, end: text.chars().count() + 1, depth: 0 };
        let expr = parser.or()?;
        if parser.pos < parser.tokens.len() {
            return Err(parser.trailing(parser.pos));
        }
        Ok(Selection { text: text.to_string(), expr })
    }

    /// One flag per atom of `atoms`, in order: whether it is selected.
    pub fn matches(&self, atoms: &[Atom]) -> Vec<bool> {
        eval(&self.expr, atoms)
    }

    pub fn text(&self) -> &str {
        &self.text
    }
}

impl FromStr for Selection {
    type Err = SelectError;
    fn from_str(text: &str) -> Result<Selection, SelectError> {
        Selection::parse(text)
    }
}

impl fmt::Display for Selection {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(&self.text)
    }
}

/// Whether `text` matches `pattern` (`*`: any run of characters, `?`: any one, when a glob).
fn glob_match(pattern: &Pattern, text: &str, fold_case: bool) -> bool {
    let same = |p: char, t: char| p == t || (fold_case && p.eq_ignore_ascii_case(&t));
    let text: Vec<char> = text.chars().collect();
    let p = &pattern.chars;
    if !pattern.glob {
        return p.len() == text.len() && p.iter().zip(&text).all(|(&a, &b)| same(a, b));
    }
    // Greedy matching that backtracks to the last `*`.
    let (mut i, mut j, mut star) = (0, 0, None);
    while j < text.len() {
        if i < p.len() && p[i] != '*' && (p[i] == '?' || same(p[i], text[j])) {
            (i, j) = (i + 1, j + 1);
        } else if i < p.len() && p[i] == '*' {
            star = Some((i, j));
            i += 1;
        } else if let Some((si, sj)) = star {
            star = Some((si, sj + 1));
            (i, j) = (si + 1, sj + 1);
        } else {
            return false;
        }
    }
    p[i..].iter().all(|&c| c == '*')
}

fn flag(flag: Flag, a: &Atom) -> bool {
    let protein = || PROTEIN.contains(&a.resname.as_str());
    let backbone = || protein() && BACKBONE.contains(&a.name.as_str());
    match flag {
        Flag::All => true,
        Flag::None => false,
        Flag::Protein => protein(),
        Flag::Nucleic => NUCLEIC.contains(&a.resname.as_str()),
        Flag::Backbone => backbone(),
        Flag::Sidechain => protein() && !backbone(),
        Flag::Water => WATER.contains(&a.resname.as_str()),
        // GROMACS writes an ion's charge into its residue name (`NA+`, `CL-`).
        Flag::Ion => ION.contains(&a.resname.as_str()) || ION.contains(&a.resname.trim_end_matches(['+', '-'])),
        Flag::Hetero => a.hetero,
        Flag::Hydrogen => a.element.eq_ignore_ascii_case("H") || a.element.eq_ignore_ascii_case("D"),
    }
}

fn number(field: Number, a: &Atom) -> f64 {
    match field {
        Number::Resid => a.resid as f64,
        Number::Index => a.site as f64,
        Number::Beta => a.beta,
        Number::Occupancy => a.occupancy,
        Number::Charge => a.charge,
        Number::Mass => a.mass,
        Number::X => a.position.x,
        Number::Y => a.position.y,
        Number::Z => a.position.z,
    }
}

/// Whether `a` lies in the inclusive range `lo..=hi` (insertion codes break ties between equal resids).
fn in_range(field: Number, a: &Atom, lo: &Bound, hi: &Bound) -> bool {
    let v = number(field, a);
    let icode = a.icode.as_str();
    (v > lo.value || (v == lo.value && lo.icode.as_deref().is_none_or(|c| icode >= c)))
        && (v < hi.value || (v == hi.value && hi.icode.as_deref().is_none_or(|c| icode <= c)))
}

fn eval(expr: &Expr, atoms: &[Atom]) -> Vec<bool> {
    let each = |test: &dyn Fn(&Atom) -> bool| atoms.iter().map(test).collect();
    match expr {
        Expr::Flag(f) => each(&|a| flag(*f, a)),
        Expr::Text(field, patterns) => each(&|a| {
            let value = match field {
                Text::Name => &a.name,
                Text::Resname => &a.resname,
                Text::Chain => &a.chain,
                Text::Segment => &a.segment,
                Text::Element => &a.element,
                Text::Type => &a.atom_type,
            };
            patterns.iter().any(|p| glob_match(p, value, *field == Text::Element))
        }),
        Expr::Number(field, ranges) => each(&|a| ranges.iter().any(|(lo, hi)| in_range(*field, a, lo, hi))),
        Expr::Compare(field, cmp, x) => each(&|a| {
            let v = number(*field, a);
            match cmp {
                Cmp::Lt => v < *x,
                Cmp::Le => v <= *x,
                Cmp::Gt => v > *x,
                Cmp::Ge => v >= *x,
                Cmp::Eq => v == *x,
                Cmp::Ne => v != *x,
            }
        }),
        Expr::Not(e) => eval(e, atoms).into_iter().map(|s| !s).collect(),
        Expr::And(terms) => terms.iter().map(|t| eval(t, atoms)).reduce(|a, b| a.iter().zip(b).map(|(x, y)| *x && y).collect()).unwrap_or_default(),
        Expr::Or(terms) => terms.iter().map(|t| eval(t, atoms)).reduce(|a, b| a.iter().zip(b).map(|(x, y)| *x || y).collect()).unwrap_or_default(),
        Expr::Within(d, e) => within(atoms, &eval(e, atoms), *d),
        Expr::Around(d, e) => {
            let inner = eval(e, atoms);
            within(atoms, &inner, *d).into_iter().zip(inner).map(|(near, own)| near && !own).collect()
        }
        Expr::SameResidue(e) => same_residue(atoms, &eval(e, atoms)),
    }
}

/// The atoms at most `d` from a selected atom (the selected ones included): the selected atoms go into a uniform grid of
/// cells `d` wide, and each atom looks in its cell and the 26 around it.
fn within(atoms: &[Atom], selected: &[bool], d: f64) -> Vec<bool> {
    within_counted(atoms, selected, d).0
}

/// The work `within` did: grid cells looked up and distances computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct WithinWork {
    cells: usize,
    pairs: usize,
}

/// `within`, counting its work (so that a test bounds the work, not the time it takes).
fn within_counted(atoms: &[Atom], selected: &[bool], d: f64) -> (Vec<bool>, WithinWork) {
    // Saturating casts keep huge or non-finite coordinates in range; they only merge cells, which costs time, not answers.
    let cell = |p: DVec3| [p.x, p.y, p.z].map(|c| (c / d).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<DVec3>> = HashMap::new();
    for (a, _) in atoms.iter().zip(selected).filter(|(_, s)| **s) {
        grid.entry(cell(a.position)).or_default().push(a.position);
    }
    let d2 = d * d;
    let work = std::cell::Cell::new(WithinWork::default());
    let count = |cells: usize, pairs: usize| {
        let w = work.get();
        work.set(WithinWork { cells: w.cells + cells, pairs: w.pairs + pairs });
    };
    let near = |p: DVec3| {
        let c = cell(p);
        (-1..=1).any(|i: i64| {
            (-1..=1).any(|j: i64| {
                (-1..=1).any(|k: i64| {
                    let key = [c[0].wrapping_add(i), c[1].wrapping_add(j), c[2].wrapping_add(k)];
                    count(1, 0);
                    grid.get(&key).is_some_and(|qs| {
                        qs.iter().any(|q| {
                            count(0, 1);
                            p.distance_squared(*q) <= d2
                        })
                    })
                })
            })
        })
    };
    let out = atoms.iter().zip(selected).map(|(a, &s)| s || (!grid.is_empty() && near(a.position))).collect();
    (out, work.get())
}

/// Every atom of a residue (a maximal run of consecutive atoms sharing chain, segment, resid, insertion code and residue
/// name) that holds a selected atom.
fn same_residue(atoms: &[Atom], selected: &[bool]) -> Vec<bool> {
    fn key(a: &Atom) -> (&str, &str, i64, &str, &str) {
        (&a.chain, &a.segment, a.resid, &a.icode, &a.resname)
    }
    let mut out = vec![false; atoms.len()];
    let mut start = 0;
    for end in 1..=atoms.len() {
        if end == atoms.len() || key(&atoms[end]) != key(&atoms[end - 1]) {
            if selected[start..end].iter().any(|&s| s) {
                out[start..end].fill(true);
            }
            start = end;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ALA 1 (N CA C O CB H), GLY 2 in chains A and B back to back, water, sodium, a HETATM ligand, a DNA atom,
    /// then residues 52, 52A and 53; atom i lies at x = the `x` below, with beta 10 i and mass i.
    fn atoms() -> Vec<Atom> {
        let rows = [
            ("N", "ALA", 1, "", "A", "N", 0.0),
            ("CA", "ALA", 1, "", "A", "C", 1.0),
            ("C", "ALA", 1, "", "A", "C", 2.0),
            ("O", "ALA", 1, "", "A", "O", 3.0),
            ("CB", "ALA", 1, "", "A", "C", 4.0),
            ("H", "ALA", 1, "", "A", "H", 5.0),
            ("N", "GLY", 2, "", "A", "N", 10.0),
            ("CA", "GLY", 2, "", "A", "C", 11.0),
            ("CA", "GLY", 2, "", "B", "C", 12.0),
            ("O", "HOH", 3, "", "W", "O", 20.0),
            ("NA", "NA", 4, "", "I", "Na", 30.0),
            ("C1", "LIG", 5, "", "L", "C", 40.0),
            ("O5'", "DA", 7, "", "N", "O", 50.0),
            ("CA", "ALA", 52, "", "A", "C", 60.0),
            ("CA", "ALA", 52, "A", "A", "C", 61.0),
            ("CA", "ALA", 53, "", "A", "C", 62.0),
        ];
        let mut atoms: Vec<Atom> = rows
            .iter()
            .enumerate()
            .map(|(i, &(name, resname, resid, icode, chain, element, x))| Atom {
                name: name.into(),
                resname: resname.into(),
                resid,
                icode: icode.into(),
                chain: chain.into(),
                element: element.into(),
                position: DVec3::new(x, 0.0, 0.0),
                site: i,
                beta: 10.0 * i as f64,
                mass: i as f64,
                segment: if i < 9 { "PROA".into() } else { String::new() },
                atom_type: if name == "CA" { "CT1".into() } else { String::new() },
                ..Default::default()
            })
            .collect();
        atoms[11].hetero = true;
        atoms[11].occupancy = 0.5;
        atoms[3].charge = -0.5;
        atoms[10].charge = 1.0;
        atoms
    }

    /// The indices `text` selects.
    fn sel(text: &str) -> Vec<usize> {
        let selection = Selection::parse(text).unwrap_or_else(|e| panic!("{text}: {e}"));
        selection.matches(&atoms()).iter().enumerate().filter(|(_, s)| **s).map(|(i, _)| i).collect()
    }

    #[test]
    fn keywords() {
        let protein = vec![0, 1, 2, 3, 4, 5, 6, 7, 8, 13, 14, 15];
        let cases: &[(&str, Vec<usize>)] = &[
            ("all", (0..16).collect()),
            ("none", vec![]),
            ("protein", protein.clone()),
            ("nucleic", vec![12]),
            ("backbone", vec![0, 1, 2, 3, 6, 7, 8, 13, 14, 15]),
            ("sidechain", vec![4, 5]),
            ("water", vec![9]),
            ("ion", vec![10]),
            ("ions or waters", vec![9, 10]),
            ("hetero", vec![11]),
            ("hydrogen", vec![5]),
            ("name CA", vec![1, 7, 8, 13, 14, 15]),
            ("name C*", vec![1, 2, 4, 7, 8, 11, 13, 14, 15]),
            ("name ?A", vec![1, 7, 8, 10, 13, 14, 15]),
            ("name 'C*'", vec![]),
            ("name \"O5'\"", vec![12]),
            ("name O5' C1", vec![11, 12]),
            ("resname ALA GLY", protein),
            ("chain B", vec![8]),
            ("chainID B", vec![8]),
            ("segname PROA and name N", vec![0, 6]),
            ("segid PROA and name N", vec![0, 6]),
            ("element na", vec![10]),
            ("type CT1", vec![1, 7, 8, 13, 14, 15]),
            ("resid 2", vec![6, 7, 8]),
            ("resid 3 5 7", vec![9, 11, 12]),
            ("resid +2 '4' 5e0", vec![6, 7, 8, 10, 11]),
            ("resid 52", vec![13, 14]),
            ("resid 52A", vec![14]),
            ("resid 1 to 2", (0..9).collect()),
            ("resid 1:2", (0..9).collect()),
            ("resid 52A:53", vec![14, 15]),
            ("resid 52 to 52A", vec![13, 14]),
            ("resid 4 10 to 60", vec![10, 13, 14, 15]),
            ("resid -5 to 0", vec![]),
            ("resid > 50", vec![13, 14, 15]),
            ("index 0 15", vec![0, 15]),
            ("index 3:5", vec![3, 4, 5]),
            ("beta 100 to 120", vec![10, 11, 12]),
            ("beta > 140", vec![15]),
            ("beta >= 140", vec![14, 15]),
            ("x <= 2", vec![0, 1, 2]),
            ("x < 2", vec![0, 1]),
            ("x == 40", vec![11]),
            ("mass != 0", (1..16).collect()),
            ("charge < 0", vec![3]),
            ("charge 1", vec![10]),
            ("occupancy < 1", vec![11]),
            ("y 0 and z > 0", vec![]),
        ];
        for (text, expected) in cases {
            assert_eq!(&sel(text), expected, "{text}");
        }
    }

    #[test]
    fn precedence() {
        assert_eq!(sel("protein or water and ion"), sel("protein"));
        assert_eq!(sel("(protein or water) and name O"), vec![3, 9]);
        assert_eq!(sel("not protein and not water"), vec![10, 11, 12]);
        assert_eq!(sel("not name CA or name N").len(), 10);
        assert_eq!(sel("not (name CA or name N)").len(), 8);
        // `within` reaches to the end, as in VMD: name O and within 1 of (name CB or name H).
        assert_eq!(sel("name O and within 1 of name CB or name H"), vec![3]);
        assert_eq!(sel("(name O and within 1 of name CB) or name H"), vec![3, 5]);
        assert_eq!(sel("not within 1 of name CB or name H").len(), 13);
    }

    #[test]
    fn within_and_same_residue() {
        assert_eq!(sel("within 1 of name CB"), vec![3, 4, 5]); // 1 Å exactly counts
        assert_eq!(sel("within 0.999 of name CB"), vec![4]); // SEL's own atoms count
        assert_eq!(sel("around 1 name CB"), vec![3, 5]);
        assert_eq!(sel("within 5 of resname LIG"), vec![11]);
        assert_eq!(sel("within 2 of none"), Vec::<usize>::new());
        assert_eq!(sel("same residue as name CB"), (0..6).collect::<Vec<_>>());
        // GLY 2 of chain A and GLY 2 of chain B are neighbours but not one residue.
        assert_eq!(sel("same residue as chain B"), vec![8]);
        assert_eq!(sel("same residue as name CA and resid 2"), vec![6, 7, 8]);
        // `same residue as` and `byres` take everything to their right. The row above reads the same either way;
        // these do not: bound as tightly as `not`, the first would be ALA 1's N (0), the second GLY 2's N (6).
        assert_eq!(sel("same residue as name CB and name N"), Vec::<usize>::new());
        assert_eq!(sel("byres name CB and name N"), Vec::<usize>::new());
        assert_eq!(sel("same residue as resid 2 and name N"), vec![6, 7]);
        assert_eq!(sel("byres resid 2 and name N"), vec![6, 7]);
        assert_eq!(sel("(same residue as resid 2) and name N"), vec![6]);
        assert_eq!(sel("byres resid 52A"), vec![14]);
        assert_eq!(sel("byres name NA"), vec![10]);
    }

    #[test]
    fn default_leaves_out_water_and_ions() {
        let kept = sel(DEFAULT);
        assert!(!kept.contains(&9) && !kept.contains(&10) && kept.contains(&11), "{kept:?}");
        let selection: Selection = DEFAULT.parse().unwrap();
        assert_eq!((selection.text(), selection.to_string().as_str()), (DEFAULT, DEFAULT));
    }

    #[test]
    fn errors() {
        let cases: [(&str, usize, &str); 41] = [
            ("", 1, "the selection is empty: write 'all' to select every atom"),
            ("   ", 1, "the selection is empty: write 'all' to select every atom"),
            ("protein and chian A", 13, "unknown keyword 'chian' at column 13; did you mean 'chain'?"),
            ("name Ω and chian A", 12, "unknown keyword 'chian' at column 12; did you mean 'chain'?"),
            ("xyzzy", 1, "unknown keyword 'xyzzy' at column 1; expected a keyword such as name, resname, resid, chain, protein, water"),
            ("resid", 1, "'resid' at column 1 needs at least one value"),
            ("chain x", 1, "'chain' at column 1 needs at least one value ('x' at column 7 is a keyword: quote it to use it as a value)"),
            ("within of protein", 8, "expected a number after 'within' at column 8, found 'of'"),
            ("within 5 protein", 10, "expected 'of' at column 10, found 'protein'"),
            ("within 0 of protein", 8, "the distance '0' at column 8 must be above 0 and at most 1000 (Å)"),
            ("within 1e9 of all", 8, "the distance '1e9' at column 8 must be above 0 and at most 1000 (Å)"),
            ("within 5 of", 10, "'of' at column 10 needs a selection after it"),
            ("same chain as protein", 6, "expected 'residue as' after 'same' at column 6, found 'chain'"),
            ("same residue of protein", 14, "expected 'as' at column 14, found 'of'"),
            ("name CA and (resid 5", 13, "unclosed '(' at column 13"),
            ("protein and water)", 18, "unexpected ')' at column 18"),
            ("()", 2, "expected a selection at column 2, found ')'"),
            ("protein and or water", 13, "expected a selection at column 13, found 'or'"),
            ("resid 10 to", 10, "'to' at column 10 needs a number on each side"),
            ("resid to 5", 7, "'to' at column 7 needs a number on each side"),
            ("resid 1:5 to 7", 11, "'to' at column 11 needs a number on each side"),
            ("resid 10:", 9, "':' at column 9 needs a number on each side"),
            ("beta > abc", 8, "'beta' compares with numbers: 'abc' at column 8 is not one"),
            ("beta abc", 6, "'beta' compares with numbers: 'abc' at column 6 is not one"),
            ("index 5A", 7, "'index' compares with numbers: '5A' at column 7 is not one"),
            ("beta >", 6, "'>' at column 6 needs a number after it"),
            ("name > 5", 6, "'>' at column 6 compares numbers; 'name' takes text"),
            ("x = 5", 3, "unexpected '=' at column 3; comparisons are <, <=, >, >=, == and !="),
            ("resid 50 to 10", 7, "the range '50 to 10' at column 7 starts above its end"),
            ("resid 52B:52A", 7, "the range '52B:52A' at column 7 starts above its end"),
            ("resid 1.5", 7, "'resid' takes whole numbers: '1.5' at column 7 is not one"),
            ("name A to C", 8, "'name' takes no ranges: 'to' at column 8"),
            ("name 'CA", 6, "unclosed quote at column 6"),
            ("\"CA\"", 1, "expected a selection at column 1, found \"CA\""),
            ("protein foo", 9, "unexpected 'foo' at column 9 after a complete selection"),
            ("protein water", 9, "unexpected 'water' at column 9 after a complete selection; join selections with 'and' or 'or'"),
            ("protein adn water", 9, "unexpected 'adn' at column 9 after a complete selection; did you mean 'and'?"),
            ("protein and", 9, "'and' at column 9 needs a selection after it"),
            ("not", 1, "'not' at column 1 needs a selection after it"),
            (&"(".repeat(100_000), 101, "the selection nests more than 100 deep at column 101"),
            (&"not ".repeat(200), 401, "the selection nests more than 100 deep at column 401"),
        ];
        for (text, column, message) in cases {
            let error = Selection::parse(text).expect_err(text);
            assert_eq!((error.column, error.to_string().as_str()), (column, message), "{text}");
        }
    }

    /// Random and mutated selections never panic, and every error is one line pointing inside the text (or just past it).
    #[test]
    fn never_panics() {
        let words = [
            "name", "CA", "(", ")", "and", "or", "not", "within", "5", "of", "same", "residue", "as", "resid", "1", "to", ":", "'", "\"", "*", "?",
            ">", "=", "!", "<=", "-", "1e400", "nan", "é", "protein", "x", "byres", "around", "52A", "0", "-3", "beta", "chian", "  ",
        ];
        let valid = ["name CA and (resid 1 to 5 or resid 7:9)", "within 3.5 of same residue as name 'O5'' \"C*\"", "beta >= -2 or not x < 1"];
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut rand = |n: usize| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % n as u64) as usize
        };
        let atoms = atoms();
        let long = format!("{}all", "name CA and not ".repeat(50_000));
        assert_eq!(Selection::parse(&long).unwrap().matches(&atoms), vec![false; atoms.len()]);
        // Nested `around` stays one node per level (it was built as within
        // and not of two copies: 2^40 nodes for 40 levels).
        let nested = format!("{}all", "around 1 ".repeat(60));
        if let Ok(s) = Selection::parse(&nested) {
            assert_eq!(s.matches(&atoms).len(), atoms.len());
        }
        for round in 0..20_000 {
            let text: String = if round % 2 == 0 {
                (0..rand(8)).map(|_| format!("{}{}", words[rand(words.len())], [" ", ""][rand(2)])).collect()
            } else {
                let mut chars: Vec<char> = valid[rand(valid.len())].chars().collect();
                for _ in 0..1 + rand(3) {
                    let at = rand(chars.len() + 1);
                    match rand(3) {
                        0 if at < chars.len() => drop(chars.remove(at)),
                        1 if at < chars.len() => chars[at] = "()'\"<=>:* aé9".chars().nth(rand(13)).unwrap(),
                        _ => chars.insert(at, "()'\"<=>:* aé9".chars().nth(rand(13)).unwrap()),
                    }
                }
                chars.into_iter().collect()
            };
            match Selection::parse(&text) {
                Ok(selection) => assert_eq!(selection.matches(&atoms).len(), atoms.len()),
                Err(e) => {
                    assert!(!e.message.contains('\n') && (1..=text.chars().count() + 1).contains(&e.column), "{text:?}: {e:?}");
                }
            }
        }
    }

    /// `within` on 100,000 atoms: the grid agrees with brute force, and does the grid's work, not brute force's. An atom
    /// looks up at most the 27 cells about its own and, in them, computes its distance only to selected atoms less than
    /// 2·sqrt(3)·d away (the far corners of its block of cells): the bound is counted here by brute force, atom by atom.
    /// Brute force computes 99,000 x 1,000 distances; the grid computes 38,424 and looks up 2,593,721 cells for the 99,000
    /// atoms outside the selection (measured; ~0.42 selected atoms in an atom's 27 cells on average). With every atom in
    /// one cell the count was 95,963,655 distances, past both bounds.
    #[test]
    fn within_is_right_and_does_the_grids_work() {
        let mut state = 12345_u64;
        let mut coordinate = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 200.0
        };
        let atoms: Vec<Atom> =
            (0..100_000).map(|i| Atom { site: i, position: DVec3::new(coordinate(), coordinate(), coordinate()), ..Default::default() }).collect();
        let d = 5.0;
        let selected: Vec<bool> = (0..atoms.len()).map(|i| i < 1000).collect();
        let (near, work) = within_counted(&atoms, &selected, d);
        assert_eq!(near, Selection::parse("within 5 of index 0 to 999").unwrap().matches(&atoms));
        let expected: Vec<bool> = atoms.iter().map(|a| atoms[..1000].iter().any(|b| a.position.distance_squared(b.position) <= d * d)).collect();
        assert_eq!(near, expected);
        // Selected atoms are in without a look; every other atom looks up at most 27 cells.
        let looking = atoms.len() - 1000;
        assert!(work.cells <= 27 * looking, "{work:?}: more than 27 cells for each of {looking} atoms");
        // Distances only to selected atoms of the 27 cells, which lie within 2·sqrt(3)·d.
        let reach = 2.0 * 3f64.sqrt() * d;
        let in_reach: usize = atoms[1000..].iter().map(|a| atoms[..1000].iter().filter(|b| a.position.distance(b.position) < reach).count()).sum();
        assert!(work.pairs <= in_reach, "{work:?}: more distances than the {in_reach} pairs within {reach:.2} Å");
        assert!(work.pairs * 1000 < looking * 1000, "{work:?}: over 1/1000 of brute force's {} distances", looking * 1000);
    }
}
