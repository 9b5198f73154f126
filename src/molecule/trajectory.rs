//! Trajectories: the frames of a simulation (XTC, DCD) or of a file of
//! several models (PDB and mmCIF ensembles, multi-frame GRO), read one
//! frame at a time for the atoms of a topology (docs/trajectories.md).
//!
//! A topology ([`Molecule`]) names the atoms and where each one's
//! coordinates sit in a frame ([`super::Atom::site`]); a [`Frames`] source
//! reads frame k's coordinates for every site, in ångström, as the file
//! gives them (no periodic unwrapping). Sources seek: XTC by the frame
//! offsets read once on opening (molly), DCD by its fixed frame size, text
//! files by reading forward (again from the start to go back), so memory
//! holds one frame, whatever the trajectory's length.
//!
//! Every problem is one line naming the file and the frame.

use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use glam::DVec3;

use super::pbc::{Cell, Molecules, Pbc, Unwrap};
use super::{Format, Molecule, MoleculeError};

/// One frame: the coordinates of every site (Å; NaN where the frame has
/// none, as for a site left out of one model), and its simulation time.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub index: usize,
    /// Picoseconds, where the file gives a time.
    pub time_ps: Option<f64>,
    pub positions: Vec<DVec3>,
    /// The periodic box, where the file gives one for this frame.
    pub cell: Option<Cell>,
}

/// A simulation time in picoseconds as messages print it: to six
/// significant digits, the precision of the f32 times and time steps that
/// XTC and DCD store, without trailing zeros, so that times read as the
/// simulation wrote them (`1` and `41`, not `0.9999999119200185` and
/// `40.99999638872076`; `40.5`, not `40.500000`).
pub fn ps(t: f64) -> String {
    if t == 0.0 || !t.is_finite() {
        return format!("{}", if t == 0.0 { 0.0 } else { t });
    }
    let decimals = (5 - t.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{t:.decimals$}");
    let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.') } else { &s };
    if s == "-0" { "0".to_string() } else { s.to_string() }
}

/// A source of frames.
pub trait Frames: Send {
    /// The number of frames.
    fn len(&self) -> usize;
    /// Whether there are none (never, once opened).
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Reads frame `index` (< `len()`).
    fn read(&mut self, index: usize) -> Result<Frame, MoleculeError>;
}

/// The trajectory formats, by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Xtc,
    Dcd,
    /// PDB, mmCIF or GRO: models or frames one after another.
    Text(Format),
}

/// The kind of trajectory file `path` is, by extension.
pub fn kind_of(path: &Path) -> Option<Kind> {
    let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
    if name.ends_with(".xtc") {
        return Some(Kind::Xtc);
    }
    if name.ends_with(".dcd") {
        return Some(Kind::Dcd);
    }
    super::format_of(path).map(Kind::Text)
}

fn fail(file: &str, frame: Option<usize>, message: impl std::fmt::Display) -> MoleculeError {
    MoleculeError { file: file.into(), line: None, message: frame.map_or_else(|| message.to_string(), |k| format!("frame {k}: {message}")) }
}

/// A topology and its frames.
pub struct Trajectory {
    /// The atoms, with the positions of frame 0.
    pub topology: Molecule,
    /// The trajectory file (the topology's own when it has the frames).
    pub source: String,
    pub frames: Box<dyn Frames>,
    /// Molecules made whole across the periodic box (`--pbc`), where
    /// they are.
    pub unwrap: Option<Unwrap>,
    /// Frames made between each pair of saved ones (`--interpolate K`):
    /// frame r is then (r mod (K+1)) / (K+1) of the way from saved frame
    /// r / (K+1) to the next ([`Trajectory::between`]).
    pub interpolate: usize,
    /// The saved frames last read for interpolating, at most two.
    pub(crate) saved: Vec<Frame>,
}

impl std::fmt::Debug for Trajectory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Trajectory").field("source", &self.source).field("frames", &self.frames.len()).finish()
    }
}

/// Reads a topology: a PSF, or a molecule file's first model.
pub fn read_topology(path: &Path) -> Result<Molecule, MoleculeError> {
    let file = path.display().to_string();
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("psf")) {
        let bytes = std::fs::read(path).map_err(|e| fail(&file, None, format!("cannot read: {e}")))?;
        let text = String::from_utf8(bytes).map_err(|_| fail(&file, None, "not text: a byte that is not UTF-8"))?;
        return super::psf::parse(&text, &file);
    }
    super::read(path)
}

/// Opens `topology` with the frames of `trajectory`, or with its own
/// models or frames when there is no trajectory. The topology's positions
/// are set to frame 0's; a frame count of 0, or sites that do not match
/// the topology's, are errors.
pub fn open(topology: &Path, trajectory: Option<&Path>) -> Result<Trajectory, MoleculeError> {
    open_with(topology, trajectory, Pbc::None).map(|(t, _)| t)
}

/// [`open`], with molecules made whole across the periodic box as `pbc`
/// says ([`Pbc::Auto`]: where frame 0 has a box and a molecule split by
/// it). Says what was done, where something was: the note printed on
/// opening.
pub fn open_with(topology: &Path, trajectory: Option<&Path>, pbc: Pbc) -> Result<(Trajectory, Option<String>), MoleculeError> {
    let mut top = read_topology(topology)?;
    let (path, own) = match trajectory {
        Some(t) => (t, false),
        None => (topology, true),
    };
    let source = path.display().to_string();
    if own && top.source.ends_with(".psf") {
        return Err(fail(&top.source, None, "a PSF topology has no coordinates: give its trajectory (DCD, XTC) after it"));
    }
    let frames: Box<dyn Frames> = match kind_of(path) {
        Some(Kind::Xtc) => Box::new(xtc::XtcFrames::open(path, Some(top.sites))?),
        Some(Kind::Dcd) => Box::new(dcd::DcdFrames::open(path, Some(top.sites))?),
        Some(Kind::Text(format)) => Box::new(TextFrames::open(path, format)?),
        None => {
            return Err(fail(
                &source,
                None,
                "not a trajectory: expected .xtc, .dcd, or a multi-model .pdb, .cif or multi-frame .gro (optionally .gz)",
            ));
        }
    };
    let mut t = Trajectory { topology: top.clone(), source, frames, unwrap: None, interpolate: 0, saved: Vec::new() };
    let first = t.frames.read(0)?;
    top.atoms = t.atoms_at(&first)?;
    t.topology = top;
    let note = t.set_pbc(pbc, first)?;
    Ok((t, note))
}

impl Trajectory {
    /// Makes molecules whole from now on as `pbc` says, `first` being
    /// frame 0 as read; sets the topology's positions to frame 0's as
    /// drawn. The note to print, where molecules are made whole.
    pub fn set_pbc(&mut self, pbc: Pbc, first: Frame) -> Result<Option<String>, MoleculeError> {
        self.unwrap = None;
        if pbc == Pbc::None {
            return Ok(None);
        }
        let Some(cell) = first.cell else {
            if pbc == Pbc::Auto {
                return Ok(None);
            }
            return Err(fail(&self.source, Some(0), format!("--pbc {}: the file gives no periodic box", pbc.name())));
        };
        let started = std::time::Instant::now();
        let molecules = Molecules::of_topology(&self.topology.atoms, &self.topology.bonds, Some(&cell));
        let mut positions = first.positions.clone();
        let split = molecules.make_whole(&mut positions, &cell);
        if pbc == Pbc::Auto && !split {
            return Ok(None);
        }
        let count = molecules.len();
        let mut unwrap = Unwrap::new(molecules);
        if pbc == Pbc::Center {
            // On every atom until told the atoms drawn (the stager does).
            unwrap.center = Some(self.topology.atoms.iter().map(|a| a.site).collect());
        }
        self.unwrap = Some(unwrap);
        let first = self.read(0)?;
        self.topology.atoms = self.atoms_at(&first)?;
        let what = super::pbc::note(pbc, &cell, count, !self.topology.bonds.is_empty(), started.elapsed().as_secs_f64(), true);
        Ok(Some(format!("{}: {what}", self.source)))
    }

    /// Moves frames so that the centre of `sites` is the box's
    /// (`--pbc center`), after making them whole; sets the topology's
    /// positions to frame 0's as drawn.
    pub fn center_on(&mut self, sites: Vec<usize>) -> Result<(), MoleculeError> {
        if let Some(u) = &mut self.unwrap {
            u.center = Some(sites);
            let first = self.read(0)?;
            self.topology.atoms = self.atoms_at(&first)?;
        }
        Ok(())
    }

    /// Makes `k` frames between each pair of saved ones from now on
    /// (`--interpolate K`; 0: the saved frames only).
    pub fn set_interpolate(&mut self, k: usize) {
        self.interpolate = k;
        self.saved.clear();
    }

    /// The saved frames that frame `r` lies between and how far it is
    /// from the first to the second: (i, i, 0) for saved frame i itself.
    pub fn between(&self, r: usize) -> (usize, usize, f64) {
        let step = self.interpolate + 1;
        let (i, j) = (r / step, r % step);
        if j == 0 { (i, i, 0.0) } else { (i, i + 1, j as f64 / step as f64) }
    }

    /// The number of saved frames (the file's).
    pub fn saved_len(&self) -> usize {
        self.frames.len()
    }

    /// Frame `r`: saved frame r, or with `--interpolate`, the saved frame
    /// or the positions between two ([`Trajectory::between`]) linearly
    /// interpolated, each atom moving the short way across the periodic
    /// box where the frames have one (by the minimum image of its
    /// displacement: an atom that leaves through one face and comes in
    /// through the other does not fly across the picture), after the
    /// molecules are made whole where they are; the time likewise.
    pub fn read(&mut self, r: usize) -> Result<Frame, MoleculeError> {
        if self.interpolate == 0 {
            return self.read_saved(r);
        }
        let (i, j, t) = self.between(r);
        let a = self.saved_frame(i)?;
        if j == i {
            return Ok(Frame { index: r, ..a });
        }
        let b = self.saved_frame(j)?;
        let positions = a
            .positions
            .iter()
            .zip(&b.positions)
            .map(|(&p, &q)| {
                let d = q - p;
                p + t * a.cell.map_or(d, |c| c.minimum_image(d))
            })
            .collect();
        let time_ps = a.time_ps.zip(b.time_ps).map(|(x, y)| x + t * (y - x));
        Ok(Frame { index: r, time_ps, positions, cell: a.cell })
    }

    /// Saved frame `i`, from the two kept where it is one of them.
    fn saved_frame(&mut self, i: usize) -> Result<Frame, MoleculeError> {
        if let Some(f) = self.saved.iter().find(|f| f.index == i) {
            return Ok(f.clone());
        }
        let f = self.read_saved(i)?;
        self.saved.push(f.clone());
        if self.saved.len() > 2 {
            self.saved.remove(0);
        }
        Ok(f)
    }

    /// Reads saved frame `k`, its molecules made whole where they are
    /// ([`Trajectory::unwrap`]): frames before it are read first where
    /// their molecules' centres are not known (at most 31 after a seek,
    /// once frame k-1's region has been read).
    pub fn read_saved(&mut self, k: usize) -> Result<Frame, MoleculeError> {
        let mut frame = self.frames.read(k)?;
        if self.unwrap.is_none() {
            return Ok(frame);
        }
        let before = if k == 0 {
            None
        } else {
            let known = self.unwrap.as_ref().and_then(|u| u.known_before(k - 1));
            let from = match known {
                Some(j) => j + 1,
                None => 0,
            };
            for j in from..k {
                let mut f = self.frames.read(j)?;
                self.whole(&mut f)?;
            }
            self.unwrap.as_ref().and_then(|u| u.centres_of(k - 1)).map(<[DVec3]>::to_vec)
        };
        self.whole_after(&mut frame, before.as_deref())?;
        Ok(frame)
    }

    /// Makes `frame` whole after the frame before it, whose centres are
    /// known.
    fn whole(&mut self, frame: &mut Frame) -> Result<(), MoleculeError> {
        let before = if frame.index == 0 { None } else { self.unwrap.as_ref().and_then(|u| u.centres_of(frame.index - 1)).map(<[DVec3]>::to_vec) };
        self.whole_after(frame, before.as_deref())
    }

    fn whole_after(&mut self, frame: &mut Frame, before: Option<&[DVec3]>) -> Result<(), MoleculeError> {
        self.check(frame)?;
        let Some(cell) = frame.cell else {
            return Err(fail(
                &self.source,
                Some(frame.index),
                "no periodic box in this frame, where frame 0 has one (--pbc none keeps the file's coordinates)",
            ));
        };
        let u = self.unwrap.as_mut().expect("unwrapping");
        u.apply(frame.index, &mut frame.positions, &cell, before);
        Ok(())
    }

    /// The number of frames: the saved ones, and with `--interpolate K`,
    /// K more between each pair.
    pub fn len(&self) -> usize {
        let n = self.frames.len();
        if n == 0 { 0 } else { (n - 1) * (self.interpolate + 1) + 1 }
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Checks that `frame` holds the topology's sites, with coordinates
    /// for every atom.
    pub fn check(&self, frame: &Frame) -> Result<(), MoleculeError> {
        if frame.positions.len() != self.topology.sites {
            return Err(fail(
                &self.source,
                Some(frame.index),
                format!("it holds {} atoms where the topology {} has {}", frame.positions.len(), self.topology.source, self.topology.sites),
            ));
        }
        if let Some(a) = self.topology.atoms.iter().find(|a| !frame.positions[a.site].is_finite()) {
            return Err(fail(&self.source, Some(frame.index), format!("no coordinates for the atom of {} line {}", self.topology.source, a.line)));
        }
        Ok(())
    }

    /// The topology's atoms at `frame`'s positions.
    pub fn atoms_at(&self, frame: &Frame) -> Result<Vec<super::Atom>, MoleculeError> {
        self.check(frame)?;
        let mut atoms = self.topology.atoms.clone();
        for a in &mut atoms {
            a.position = frame.positions[a.site];
        }
        Ok(atoms)
    }

    /// The molecule as it is at `frame`.
    pub fn molecule_at(&self, frame: &Frame) -> Result<Molecule, MoleculeError> {
        Ok(Molecule { atoms: self.atoms_at(frame)?, extra_models: 0, ..self.topology.clone() })
    }
}

/// Runs `f`, turning a panic inside it (a third-party decoder meeting a
/// corrupt file) into an error, without the panic's message on stderr.
pub(crate) fn guarded<T>(f: impl FnOnce() -> std::io::Result<T>) -> Result<T, String> {
    use std::cell::Cell;
    use std::sync::Once;
    thread_local!(static QUIET: Cell<bool> = const { Cell::new(false) });
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET.with(Cell::get) {
                previous(info);
            }
        }));
    });
    QUIET.with(|q| q.set(true));
    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    QUIET.with(|q| q.set(false));
    match out {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) if e.kind() == std::io::ErrorKind::UnexpectedEof => Err("the file is cut short inside this frame".into()),
        Ok(Err(e)) => Err(format!("corrupt ({e})")),
        Err(_) => Err("corrupt: its data cannot be decoded".into()),
    }
}

/// A file opened for reading, gzip decompressed on the fly (by its magic
/// bytes).
fn open_text(path: &Path, file: &str) -> Result<Box<dyn BufRead + Send>, MoleculeError> {
    let mut f = File::open(path).map_err(|e| fail(file, None, format!("cannot read: {e}")))?;
    let mut magic = [0u8; 2];
    let n = f.read(&mut magic).map_err(|e| fail(file, None, format!("cannot read: {e}")))?;
    f.seek(SeekFrom::Start(0)).map_err(|e| fail(file, None, format!("cannot read: {e}")))?;
    Ok(if n == 2 && magic == [0x1f, 0x8b] {
        Box::new(BufReader::new(flate2::read::MultiGzDecoder::new(BufReader::new(f))))
    } else {
        Box::new(BufReader::new(f))
    })
}

/// Models (PDB `MODEL`, mmCIF `pdbx_PDB_model_num`) or frames (GRO blocks)
/// of a text file, read forward.
struct TextFrames {
    path: PathBuf,
    file: String,
    format: Format,
    count: usize,
    /// The reader, the next frame it reads, and the lines read before it.
    reader: Option<(Box<dyn BufRead + Send>, usize, usize)>,
    /// A line read ahead (PDB: the next `MODEL`).
    pending: Option<String>,
    /// PDB: the box of the last `CRYST1` read, for the models after it
    /// that give none of their own (a file that gives it once, on top).
    cryst1: Option<Cell>,
}

impl TextFrames {
    fn open(path: &Path, format: Format) -> Result<TextFrames, MoleculeError> {
        let file = path.display().to_string();
        let mut t = TextFrames { path: path.into(), file, format, count: 0, reader: None, pending: None, cryst1: None };
        t.count = match format {
            Format::Cif => {
                let m = super::read(path)?;
                m.extra_models + 1
            }
            _ => {
                // One pass to count the frames (and find a file cut short).
                let mut n = 0;
                while t.frame_text(n)?.is_some() {
                    n += 1;
                }
                n
            }
        };
        t.reader = None;
        if t.count == 0 {
            return Err(fail(&t.file, None, "no frames"));
        }
        Ok(t)
    }

    fn line(&mut self) -> Result<Option<String>, MoleculeError> {
        if let Some(l) = self.pending.take() {
            return Ok(Some(l));
        }
        let (reader, _, lines) = self.reader.as_mut().expect("open reader");
        let mut buf = Vec::new();
        match reader.read_until(b'\n', &mut buf) {
            Ok(0) => Ok(None),
            Ok(_) => {
                *lines += 1;
                let at = *lines;
                String::from_utf8(buf).map(Some).map_err(|_| MoleculeError {
                    file: self.file.clone(),
                    line: Some(at),
                    message: "not text: a byte that is not UTF-8".into(),
                })
            }
            Err(e) => Err(MoleculeError { file: self.file.clone(), line: Some(*lines + 1), message: format!("cannot read: {e}") }),
        }
    }

    /// The text of frame `k` and the lines before it, reading forward
    /// (from the start when `k` lies behind); `None` past the last frame.
    fn frame_text(&mut self, k: usize) -> Result<Option<(String, usize)>, MoleculeError> {
        if self.reader.as_ref().is_none_or(|r| r.1 > k) {
            self.reader = Some((open_text(&self.path, &self.file)?, 0, 0));
            self.pending = None;
            self.cryst1 = None;
        }
        loop {
            let next = self.reader.as_ref().map_or(0, |r| r.1);
            let chunk = match self.format {
                Format::Gro => self.gro_block()?,
                _ => self.pdb_model()?,
            };
            let Some(chunk) = chunk else { return Ok(None) };
            if self.format == Format::Pdb
                && let Some(line) = chunk.0.lines().find(|l| l.starts_with("CRYST1"))
            {
                self.cryst1 = super::pdb::cryst1(line);
            }
            if let Some(r) = self.reader.as_mut() {
                r.1 += 1;
            }
            if next == k {
                return Ok(Some(chunk));
            }
        }
    }

    /// One GRO block: title, count, atoms, box.
    fn gro_block(&mut self) -> Result<Option<(String, usize)>, MoleculeError> {
        let before = self.reader.as_ref().map_or(0, |r| r.2);
        let Some(title) = self.line()? else { return Ok(None) };
        if title.trim().is_empty() && self.reader.as_ref().is_some_and(|r| r.1 > 0) {
            // Trailing blank lines after the last box.
            return Ok(None);
        }
        let mut text = title;
        let Some(count) = self.line()? else {
            return Err(MoleculeError {
                file: self.file.clone(),
                line: Some(before + 1),
                message: "the file is cut short after a frame's title".into(),
            });
        };
        let n: usize = count.trim().parse().map_err(|_| MoleculeError {
            file: self.file.clone(),
            line: Some(before + 2),
            message: format!("the atom count {:?} is not a whole number", count.trim()),
        })?;
        text.push_str(&count);
        for _ in 0..=n {
            match self.line()? {
                Some(l) => text.push_str(&l),
                None => break,
            }
        }
        Ok(Some((text, before)))
    }

    /// One PDB model: the lines up to its `ENDMDL` (or the next `MODEL`);
    /// a file without `MODEL` records is one model.
    fn pdb_model(&mut self) -> Result<Option<(String, usize)>, MoleculeError> {
        let before = self.reader.as_ref().map_or(0, |r| r.2) - usize::from(self.pending.is_some());
        let mut text = String::new();
        let mut seen_model = false;
        let mut any = false;
        while let Some(l) = self.line()? {
            any = true;
            if l.starts_with("MODEL") {
                if seen_model {
                    self.pending = Some(l);
                    break;
                }
                seen_model = true;
            }
            if l.starts_with("ENDMDL") {
                text.push_str(&l);
                break;
            }
            text.push_str(&l);
        }
        let atoms = text.lines().any(|l| l.starts_with("ATOM  ") || l.starts_with("HETATM"));
        Ok((any && atoms).then_some((text, before)))
    }
}

impl Frames for TextFrames {
    fn len(&self) -> usize {
        self.count
    }

    fn read(&mut self, index: usize) -> Result<Frame, MoleculeError> {
        let in_frame = |mut e: MoleculeError| {
            if !e.message.starts_with("frame ") {
                e.message = format!("frame {index}: {}", e.message);
            }
            e
        };
        let (m, time_ps) = self.parse(index).map_err(in_frame)?;
        let mut positions = vec![DVec3::NAN; m.sites];
        for a in &m.atoms {
            positions[a.site] = a.position;
        }
        let cell = if self.format == Format::Pdb { self.cryst1 } else { m.cell };
        Ok(Frame { index, time_ps, positions, cell })
    }
}

impl TextFrames {
    /// The molecule of frame `index`, and its time.
    fn parse(&mut self, index: usize) -> Result<(Molecule, Option<f64>), MoleculeError> {
        Ok(match self.format {
            Format::Cif => {
                let bytes = std::fs::read(&self.path).map_err(|e| fail(&self.file, Some(index), format!("cannot read: {e}")))?;
                let text = super::text_of(bytes, &self.file)?;
                (super::cif::parse_model(&text, &self.file, index)?, None)
            }
            format => {
                let Some((text, before)) = self.frame_text(index)? else {
                    return Err(fail(&self.file, Some(index), format!("the file holds {} frames", self.count)));
                };
                match format {
                    Format::Gro => {
                        let time = text.lines().next().and_then(gro_time);
                        (super::gro::parse_at(&text, &self.file, before)?, time)
                    }
                    _ => (super::pdb::parse_at(&text, &self.file, before)?, None),
                }
            }
        })
    }
}

/// The time a GROMACS title gives (`... t= 100.00000 step= 50000`), ps.
fn gro_time(title: &str) -> Option<f64> {
    let rest = &title[title.find("t=")? + 2..];
    rest.split_whitespace().next()?.parse().ok().filter(|t: &f64| t.is_finite())
}

pub mod xtc {
    //! GROMACS XTC through molly: frame offsets on opening, then each frame
    //! read at its offset.

    use super::*;

    pub struct XtcFrames {
        reader: molly::XTCReader<File>,
        file: String,
        offsets: Box<[u64]>,
        /// Where each frame ends.
        ends: Box<[u64]>,
        atoms: usize,
        frame: molly::Frame,
    }

    impl XtcFrames {
        /// Opens `path` for a topology of `sites` atoms (`None`: as many
        /// as its first frame holds).
        pub fn open(path: &Path, sites: Option<usize>) -> Result<XtcFrames, MoleculeError> {
            let file = path.display().to_string();
            let length = std::fs::metadata(path).map_err(|e| fail(&file, None, format!("cannot read: {e}")))?.len();
            let mut reader = molly::XTCReader::open(path).map_err(|e| fail(&file, None, format!("cannot read: {e}")))?;
            // The end of every frame: the last one past the file's end is
            // a file cut short.
            let ends =
                guarded(|| reader.determine_offsets_exclusive(None)).map_err(|e| fail(&file, None, format!("not a readable XTC file: {e}")))?;
            if ends.is_empty() {
                return Err(fail(&file, None, "no frames (an empty or non-XTC file)"));
            }
            if let Some(k) = ends.iter().position(|&e| e > length) {
                return Err(fail(
                    &file,
                    Some(k),
                    format!("the file is cut short inside this frame ({length} bytes, the frame ends at byte {})", ends[k]),
                ));
            }
            let mut offsets = vec![0u64];
            offsets.extend(&ends[..ends.len() - 1]);
            let mut x = XtcFrames { reader, file, offsets: offsets.into(), ends, atoms: 0, frame: molly::Frame::default() };
            let header = x.header(0)?;
            let sites = sites.unwrap_or(header);
            if header != sites {
                return Err(fail(&x.file, Some(0), format!("it holds {header} atoms where the topology has {sites}")));
            }
            x.atoms = header;
            Ok(x)
        }

        /// The atom count in frame `k`'s header (its second word).
        fn header(&mut self, k: usize) -> Result<usize, MoleculeError> {
            let mut f = File::open(&self.file).map_err(|e| fail(&self.file, Some(k), format!("cannot read: {e}")))?;
            f.seek(SeekFrom::Start(self.offsets[k] + 4)).map_err(|e| fail(&self.file, Some(k), format!("cannot read: {e}")))?;
            let mut b = [0u8; 4];
            f.read_exact(&mut b).map_err(|_| fail(&self.file, Some(k), "the file is cut short inside this frame's header"))?;
            let atoms = u32::from_be_bytes(b) as usize;
            // XTC spends at least a bit on an atom (and frames of up to 9
            // atoms are not compressed): a count beyond that is corrupt,
            // and would have molly allocate its coordinates (found by the
            // fuzzer: 2.2 billion atoms in a frame of 100 bytes).
            let bytes = self.ends[k] - self.offsets[k];
            if atoms > 9 && atoms as u64 > 8 * bytes {
                return Err(fail(&self.file, Some(k), format!("corrupt: it claims {atoms} atoms in {bytes} bytes")));
            }
            Ok(atoms)
        }
    }

    impl Frames for XtcFrames {
        fn len(&self) -> usize {
            self.offsets.len()
        }

        fn read(&mut self, index: usize) -> Result<Frame, MoleculeError> {
            // The atom count first: molly sizes its buffers by it, and a
            // corrupt count would ask for any amount of memory.
            let atoms = self.header(index)?;
            if atoms != self.atoms {
                return Err(fail(&self.file, Some(index), format!("it holds {atoms} atoms where frame 0 holds {}", self.atoms)));
            }
            let offset = self.offsets[index];
            let (reader, frame) = (&mut self.reader, &mut self.frame);
            guarded(|| reader.read_frame_at_offset::<false>(frame, offset, &molly::selection::AtomSelection::All))
                .map_err(|e| fail(&self.file, Some(index), e))?;
            if frame.natoms() != self.atoms {
                return Err(fail(&self.file, Some(index), format!("it holds {} atoms where frame 0 holds {}", frame.natoms(), self.atoms)));
            }
            // nm to Å, each f32 coordinate widened first.
            let positions = frame.coords().map(|p| DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])) * 10.0).collect();
            // The box: three vectors of three f32 each, nm.
            let v =
                |i: usize| DVec3::new(f64::from(frame.boxvec[3 * i]), f64::from(frame.boxvec[3 * i + 1]), f64::from(frame.boxvec[3 * i + 2])) * 10.0;
            Ok(Frame { index, time_ps: Some(f64::from(frame.time)), positions, cell: Cell::new(v(0), v(1), v(2)) })
        }
    }
}

pub mod dcd {
    //! CHARMM/NAMD DCD: Fortran unformatted records (each framed by its
    //! length in 4 bytes, either byte order): an 84-byte header (`CORD`,
    //! frame count, first step, steps between frames, the time step in
    //! AKMA units, whether frames carry a unit cell), the title, the atom
    //! count, then per frame an optional unit cell (6 doubles) and the x, y
    //! and z of every atom as f32 (Å). Fixed atoms are refused.

    use super::*;

    /// One AKMA time unit in picoseconds (CHARMM's, as MDAnalysis uses).
    pub const AKMA_PS: f64 = 4.888_821e-2;

    pub struct DcdFrames {
        file: String,
        f: File,
        big: bool,
        atoms: usize,
        frames: usize,
        first: u64,
        frame_bytes: u64,
        cell: bool,
        /// Time of frame 0 and between frames, ps.
        start_ps: f64,
        step_ps: f64,
    }

    fn int(b: &[u8], big: bool) -> i32 {
        let a = [b[0], b[1], b[2], b[3]];
        if big { i32::from_be_bytes(a) } else { i32::from_le_bytes(a) }
    }

    impl DcdFrames {
        /// Opens `path` for a topology of `sites` atoms (`None`: as many
        /// as its header says).
        pub fn open(path: &Path, sites: Option<usize>) -> Result<DcdFrames, MoleculeError> {
            let file = path.display().to_string();
            let bad = |m: &str| fail(&file, None, format!("not a readable DCD file: {m}"));
            let mut f = File::open(path).map_err(|e| fail(&file, None, format!("cannot read: {e}")))?;
            let length = f.metadata().map_err(|e| fail(&file, None, format!("cannot read: {e}")))?.len();
            let mut head = [0u8; 92];
            f.read_exact(&mut head).map_err(|_| bad("shorter than its header"))?;
            let big = match (i32::from_le_bytes([head[0], head[1], head[2], head[3]]), i32::from_be_bytes([head[0], head[1], head[2], head[3]])) {
                (84, _) => false,
                (_, 84) => true,
                _ => return Err(bad("its first record is not the 84-byte header")),
            };
            if &head[4..8] != b"CORD" || int(&head[88..92], big) != 84 {
                return Err(bad("no CORD header"));
            }
            let icntrl = |i: usize| int(&head[8 + 4 * i..12 + 4 * i], big);
            let declared = icntrl(0);
            let (istart, nsavc, fixed) = (icntrl(1), icntrl(2), icntrl(8));
            let charmm = icntrl(19) != 0;
            // The time step is the float in the tenth control word.
            let delta = f32::from_bits(icntrl(9) as u32);
            let cell = charmm && icntrl(10) != 0;
            if charmm && icntrl(11) != 0 {
                return Err(bad("4D coordinates are not supported"));
            }
            if fixed != 0 {
                return Err(fail(&file, None, format!("{fixed} fixed atoms: DCD files with fixed atoms are not supported")));
            }
            // The title record, then the atom count.
            let mut word = [0u8; 4];
            let mut read_word = |f: &mut File| -> Result<i32, MoleculeError> {
                f.read_exact(&mut word).map_err(|_| bad("cut short inside its header"))?;
                Ok(int(&word, big))
            };
            let title = read_word(&mut f)?;
            if !(4..=1 << 20).contains(&title) {
                return Err(bad("a title record of impossible length"));
            }
            f.seek(SeekFrom::Current(i64::from(title))).map_err(|_| bad("cut short inside its title"))?;
            if read_word(&mut f)? != title || read_word(&mut f)? != 4 {
                return Err(bad("its title record is not framed by its length"));
            }
            let atoms = read_word(&mut f)?;
            if read_word(&mut f)? != 4 || atoms <= 0 {
                return Err(bad("no atom count after the title"));
            }
            let atoms = atoms as usize;
            let sites = sites.unwrap_or(atoms);
            if atoms != sites {
                return Err(fail(&file, None, format!("it holds {atoms} atoms where the topology has {sites}")));
            }
            let first = f.stream_position().map_err(|e| fail(&file, None, format!("cannot read: {e}")))?;
            let frame_bytes = if cell { 56 } else { 0 } + 3 * (8 + 4 * atoms as u64);
            let whole = (length - first) / frame_bytes;
            if (length - first) % frame_bytes != 0 {
                return Err(fail(
                    &file,
                    Some(whole as usize),
                    format!("the file is cut short inside this frame ({} of its {frame_bytes} bytes)", (length - first) % frame_bytes),
                ));
            }
            // The header's frame count is often stale (writers that stop
            // early leave it as planned): the file's length decides, as in
            // MDAnalysis and VMD.
            let _ = declared;
            let step_ps = f64::from(nsavc) * f64::from(delta) * AKMA_PS;
            let start_ps = f64::from(istart) * f64::from(delta) * AKMA_PS;
            if whole == 0 {
                return Err(fail(&file, None, "no frames"));
            }
            Ok(DcdFrames { file, f, big, atoms, frames: whole as usize, first, frame_bytes, cell, start_ps, step_ps })
        }
    }

    impl Frames for DcdFrames {
        fn len(&self) -> usize {
            self.frames
        }

        fn read(&mut self, index: usize) -> Result<Frame, MoleculeError> {
            let err = |m: String| fail(&self.file, Some(index), m);
            let mut buf = vec![0u8; self.frame_bytes as usize];
            self.f.seek(SeekFrom::Start(self.first + index as u64 * self.frame_bytes)).map_err(|e| err(format!("cannot read: {e}")))?;
            self.f.read_exact(&mut buf).map_err(|_| err("the file is cut short inside this frame".into()))?;
            // The unit cell: a record of six f64.
            let cell = if self.cell {
                let length = int(&buf[0..4], self.big);
                if length != 48 || int(&buf[52..56], self.big) != 48 {
                    return Err(err(format!("corrupt: its unit cell record is framed by {length} bytes, not 48")));
                }
                let values: Vec<f64> = buf[4..52]
                    .chunks_exact(8)
                    .map(|c| {
                        let a: [u8; 8] = c.try_into().expect("8 bytes");
                        if self.big { f64::from_be_bytes(a) } else { f64::from_le_bytes(a) }
                    })
                    .collect();
                Cell::from_dcd([values[0], values[1], values[2], values[3], values[4], values[5]])
            } else {
                None
            };
            let mut at = if self.cell { 56 } else { 0 };
            let n = self.atoms;
            let mut axes = [vec![0f32; 0], vec![], vec![]];
            for (axis, out) in axes.iter_mut().enumerate() {
                let length = int(&buf[at..at + 4], self.big);
                let end = int(&buf[at + 4 + 4 * n..at + 8 + 4 * n], self.big);
                if length as usize != 4 * n || end != length {
                    return Err(err(format!("corrupt: its {} record is framed by {length} and {end} bytes, not {}", ["x", "y", "z"][axis], 4 * n)));
                }
                *out = buf[at + 4..at + 4 + 4 * n]
                    .chunks_exact(4)
                    .map(|c| {
                        let a = [c[0], c[1], c[2], c[3]];
                        f32::from_bits(if self.big { u32::from_be_bytes(a) } else { u32::from_le_bytes(a) })
                    })
                    .collect();
                at += 8 + 4 * n;
            }
            let positions: Vec<DVec3> = (0..n).map(|i| DVec3::new(f64::from(axes[0][i]), f64::from(axes[1][i]), f64::from(axes[2][i]))).collect();
            if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
                return Err(err(format!("corrupt: atom {} has coordinates that are not numbers", i + 1)));
            }
            Ok(Frame { index, time_ps: Some(self.start_ps + index as f64 * self.step_ps), positions, cell })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_print_rounded_to_the_csvs_precision() {
        assert_eq!(ps(0.9999999119200185), "1");
        assert_eq!(ps(40.99999638872076), "41");
        assert_eq!(ps(40.5), "40.5");
        assert_eq!(ps(0.0), "0");
        assert_eq!(ps(1234.5), "1234.5");
        assert_eq!(ps(80000.0), "80000");
        assert_eq!(ps(100.000008), "100");
        assert_eq!(ps(0.002), "0.002");
    }

    #[test]
    fn gromacs_titles_give_times() {
        assert_eq!(gro_time("Generated by trjconv : t=  100.00000 step= 50000"), Some(100.0));
        assert_eq!(gro_time("Protein in water"), None);
    }

    /// Two atoms in a 10 Å cube: atom 0 still, atom 1 stepping +3 Å in x
    /// a frame from x = 8, wrapped into the box by the file (8, 1, 4, 7).
    struct Crossing;

    impl Frames for Crossing {
        fn len(&self) -> usize {
            4
        }
        fn read(&mut self, index: usize) -> Result<Frame, MoleculeError> {
            let x = (8.0 + 3.0 * index as f64).rem_euclid(10.0);
            let cell = Cell::from_gro(&[1.0, 1.0, 1.0]);
            Ok(Frame { index, time_ps: Some(2.0 * index as f64), positions: vec![DVec3::new(5.0, 5.0, 5.0), DVec3::new(x, 5.0, 5.0)], cell })
        }
    }

    fn crossing() -> Trajectory {
        let atom = |site: usize| super::super::Atom { element: "O".into(), resid: site as i64 + 1, site, line: site + 1, ..Default::default() };
        let topology = Molecule {
            source: "t.gro".into(),
            atoms: vec![atom(0), atom(1)],
            skipped_sites: None,
            extra_models: 0,
            sites: 2,
            cell: None,
            bonds: Vec::new(),
        };
        Trajectory { topology, source: "t.xtc".into(), frames: Box::new(Crossing), unwrap: None, interpolate: 0, saved: Vec::new() }
    }

    #[test]
    fn interpolated_frames_lie_between_saved_ones_and_cross_the_box_the_short_way() {
        let mut t = crossing();
        assert_eq!(t.len(), 4);
        t.set_interpolate(3);
        assert_eq!(t.len(), 3 * 4 + 1);
        assert_eq!((t.between(0), t.between(4), t.between(6), t.between(12)), ((0, 0, 0.0), (1, 1, 0.0), (1, 2, 0.5), (3, 3, 0.0)));
        assert_eq!(t.between(5), (1, 2, 0.25));
        // Saved frames are the file's.
        for i in 0..4 {
            let mut saved = t.frames.read(i).unwrap();
            saved.index = 4 * i;
            assert_eq!(t.read(4 * i).unwrap(), saved);
        }
        // Between: atom 1 goes from 8 to 11 (entering at 1), never back
        // across the box; the time and atom 0 likewise.
        for r in 1..4 {
            let f = t.read(r).unwrap();
            let x = 8.0 + 3.0 * r as f64 / 4.0;
            assert!((f.positions[1].x - x).abs() < 1e-12, "frame {r}: {} where {x}", f.positions[1].x);
            assert_eq!(f.positions[0], DVec3::new(5.0, 5.0, 5.0));
            assert_eq!(f.time_ps, Some(0.5 * r as f64));
        }
        // The midpoint of saved frames 2 and 3 (4 to 7).
        assert_eq!(t.read(10).unwrap().positions[1], DVec3::new(5.5, 5.0, 5.0));
        // Read backwards too.
        assert_eq!(t.read(2).unwrap().positions[1].x, 9.5);
        // Without a box, straight from one to the other.
        let mut plain = crossing();
        plain.frames = Box::new(NoBox(Crossing));
        plain.set_interpolate(1);
        assert_eq!(plain.read(1).unwrap().positions[1].x, 4.5, "8 to 1 through the middle");
    }

    struct NoBox(Crossing);

    impl Frames for NoBox {
        fn len(&self) -> usize {
            self.0.len()
        }
        fn read(&mut self, index: usize) -> Result<Frame, MoleculeError> {
            Ok(Frame { cell: None, ..self.0.read(index)? })
        }
    }

    #[test]
    fn kinds_come_from_extensions() {
        assert_eq!(kind_of(Path::new("a/run.XTC")), Some(Kind::Xtc));
        assert_eq!(kind_of(Path::new("run.dcd")), Some(Kind::Dcd));
        assert_eq!(kind_of(Path::new("nmr.pdb.gz")), Some(Kind::Text(Format::Pdb)));
        assert_eq!(kind_of(Path::new("run.trr")), None);
    }
}
