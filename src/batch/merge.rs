//! One statistics CSV for a whole frame range from the per-shard CSVs of an
//! array job (`isomarch merge-stats`), with the check that every frame of
//! the range is there exactly once.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result, bail};

use super::FrameRange;

/// Where a row came from: file and line (from 1).
#[derive(Clone, Debug, PartialEq, Eq)]
struct Origin {
    file: PathBuf,
    line: usize,
}

impl std::fmt::Display for Origin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.file.display(), self.line)
    }
}

/// The rows of several batch CSVs, by frame.
#[derive(Default)]
pub struct Merge {
    header: Option<(String, PathBuf)>,
    rows: BTreeMap<u64, Vec<(String, Origin)>>,
    files: usize,
}

/// At most this many frames are named in an error; the rest are counted.
const NAMED: usize = 5;

impl Merge {
    /// Adds the rows of one CSV whose text is `text`, read from `file`.
    /// Its header must be the same as the first file's, and begin with
    /// `frame`.
    pub fn add(&mut self, file: &Path, text: &str) -> Result<()> {
        let mut lines = text.lines();
        let Some(header) = lines.next() else {
            bail!("{}: empty file (a batch CSV starts with its header)", file.display());
        };
        if !header.starts_with("frame,") {
            bail!("{}:1: not a batch statistics CSV (the header does not begin with \"frame,\")", file.display());
        }
        match &self.header {
            Some((first, from)) if first != header => {
                bail!("{}:1: header differs from {}'s (were they written by different versions?)", file.display(), from.display())
            }
            Some(_) => {}
            None => self.header = Some((header.to_string(), file.to_path_buf())),
        }
        for (i, line) in lines.enumerate() {
            let origin = Origin { file: file.to_path_buf(), line: i + 2 };
            if line.trim().is_empty() {
                continue;
            }
            let first = line.split(',').next().unwrap_or_default();
            let frame: u64 = first.parse().map_err(|_| anyhow::anyhow!("{origin}: frame {first:?} is not a frame number"))?;
            self.rows.entry(frame).or_default().push((line.to_string(), origin));
        }
        self.files += 1;
        Ok(())
    }

    /// The merged CSV, one row per frame in frame order, when every frame
    /// of `range` is there exactly once and no other frame is.
    pub fn finish(&self, range: FrameRange) -> Result<String> {
        let Some((header, _)) = &self.header else {
            bail!("no input CSV");
        };
        let missing: Vec<u64> = (range.start..range.end).filter(|f| !self.rows.contains_key(f)).collect();
        let twice: Vec<(u64, &Vec<(String, Origin)>)> = self.rows.iter().filter(|(_, r)| r.len() > 1).map(|(&f, r)| (f, r)).collect();
        let outside: Vec<(u64, &Origin)> =
            self.rows.iter().filter(|(f, _)| !(range.start..range.end).contains(*f)).map(|(&f, r)| (f, &r[0].1)).collect();
        let mut problems = Vec::new();
        if !missing.is_empty() {
            let named: Vec<String> = missing.iter().take(NAMED).map(u64::to_string).collect();
            problems.push(format!("{} frame(s) missing ({}{})", missing.len(), named.join(", "), more(missing.len())));
        }
        if !twice.is_empty() {
            let named: Vec<String> = twice
                .iter()
                .take(NAMED)
                .map(|(f, rows)| format!("{f} at {}", rows.iter().map(|(_, o)| o.to_string()).collect::<Vec<_>>().join(" and ")))
                .collect();
            problems.push(format!("{} frame(s) listed more than once ({}{})", twice.len(), named.join("; "), more(twice.len())));
        }
        if !outside.is_empty() {
            let named: Vec<String> = outside.iter().take(NAMED).map(|(f, o)| format!("{f} at {o}")).collect();
            problems.push(format!("{} frame(s) outside {}..{} ({}{})", outside.len(), range.start, range.end, named.join("; "), more(outside.len())));
        }
        if !problems.is_empty() {
            bail!("frames {}..{} are not each listed exactly once in the {} input(s): {}", range.start, range.end, self.files, problems.join("; "));
        }
        let mut out = String::with_capacity(header.len() + self.rows.len() * 100);
        writeln!(out, "{header}")?;
        for rows in self.rows.values() {
            writeln!(out, "{}", rows[0].0)?;
        }
        Ok(out)
    }
}

fn more(n: usize) -> String {
    if n > NAMED { format!(", and {} more", n - NAMED) } else { String::new() }
}

/// Reads `inputs`, checks them against `range` and writes the merged CSV
/// to `output` atomically. Returns the number of frames written.
pub fn merge_files(inputs: &[PathBuf], range: FrameRange, output: &Path) -> Result<u64> {
    let mut merge = Merge::default();
    for input in inputs {
        let text = std::fs::read_to_string(input).with_context(|| format!("reading {}", input.display()))?;
        merge.add(input, &text)?;
    }
    let text = merge.finish(range)?;
    crate::output::write_atomic(output, text.as_bytes())?;
    Ok(range.end - range.start)
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "frame,time_s,file\n";

    fn merged(files: &[(&str, &str)], range: &str) -> Result<String> {
        let mut m = Merge::default();
        for (name, body) in files {
            m.add(Path::new(name), &format!("{HEADER}{body}"))?;
        }
        m.finish(range.parse().unwrap())
    }

    #[test]
    fn shards_merge_in_frame_order() {
        let out = merged(&[("a.csv", "0,0,\"f0\"\n2,0.08,\"f2\"\n"), ("b.csv", "3,0.12,\"f3\"\n1,0.04,\"f1\"\n")], "0..4").unwrap();
        assert_eq!(out, format!("{HEADER}0,0,\"f0\"\n1,0.04,\"f1\"\n2,0.08,\"f2\"\n3,0.12,\"f3\"\n"));
    }

    #[test]
    fn every_frame_exactly_once() {
        let e = merged(&[("a.csv", "0,0,x\n2,0,x\n")], "0..4").unwrap_err().to_string();
        assert!(e.contains("2 frame(s) missing (1, 3)"), "{e}");
        let e = merged(&[("a.csv", "0,0,x\n1,0,x\n"), ("b.csv", "1,0,x\n")], "0..2").unwrap_err().to_string();
        assert!(e.contains("1 at a.csv:3 and b.csv:2"), "{e}");
        let e = merged(&[("a.csv", "0,0,x\n1,0,x\n7,0,x\n")], "0..2").unwrap_err().to_string();
        assert!(e.contains("outside 0..2 (7 at a.csv:4)"), "{e}");
        assert!(!e.contains('\n'), "one line: {e}");
        let e = merged(&[("a.csv", &(0..20).map(|f| format!("{f},0,x\n")).collect::<String>())], "0..30").unwrap_err().to_string();
        assert!(e.contains("10 frame(s) missing (20, 21, 22, 23, 24, and 5 more)"), "{e}");
    }

    #[test]
    fn inputs_must_be_batch_csvs_alike() {
        let mut m = Merge::default();
        m.add(Path::new("a.csv"), "frame,time_s\n0,0\n").unwrap();
        let e = m.add(Path::new("b.csv"), "frame,time_s,extra\n1,0,0\n").unwrap_err().to_string();
        assert!(e.starts_with("b.csv:1: header differs from a.csv's"), "{e}");
        let e = m.add(Path::new("c.csv"), "frame,time_s\nx,0\n").unwrap_err().to_string();
        assert!(e.starts_with("c.csv:2: frame \"x\""), "{e}");
        assert!(m.add(Path::new("d.csv"), "").is_err());
        assert!(m.add(Path::new("e.csv"), "a,b\n").is_err());
    }
}
