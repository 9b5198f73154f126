#!/usr/bin/env python3
"""Reference atom selections from an independent implementation,
MDAnalysis's `select_atoms`, for the selection-language tests.

Writes tests/data/selections/reference.csv: a block of '#' comment lines
(this script; the MDAnalysis, gemmi and numpy versions), then the CSV header
`file,isomarch,mdanalysis,count,indices` and one row per expression pair:
the file (relative to the repository root), the expression in isomarch's
grammar (VMD's, /tmp/notes/grammar.md at the time) and the same selection
in MDAnalysis's grammar (both CSV-quoted), the number of atoms selected,
and their 0-based indices, ascending, compressed into ranges
(`0-5 9 12-40`).

    python3 -m venv /tmp/mda && /tmp/mda/bin/pip install MDAnalysis==2.11.0 gemmi==0.7.5
    /tmp/mda/bin/python scripts/selection-reference.py

The values committed were written with MDAnalysis 2.11.0, gemmi 0.7.5 and
numpy 2.4.6.

Indices. An atom's index is its place among the file's coordinate
records in file order, 0-based: every ATOM/HETATM record of the first
model (alternate locations included) of a PDB or mmCIF file, every atom
line of a GRO file, every !NATOM line of a PSF -- MDAnalysis's own atom
index, since MDAnalysis keeps every record (checked below against a
plain reading of each file: same count, same positions in the same
order). isomarch keeps fewer atoms than records: of an atom site given
in several alternate locations it keeps only the first given (PDB:
the name and columns 18-27; mmCIF: names, chains, numbers, insertion
code), and it skips GRO dummy and virtual sites (names beginning MW, DM,
LP, EP, VS) and PSF sites of mass <= 0.05. So each expression is
evaluated on the AtomGroup of the atoms isomarch keeps (distances in
`around` see only those) and the original indices are written. The
script prints, per file, the records MDAnalysis reads, the records with
an alternate location, the records dropped and the residue names.

Routes. 1A8O.pdb: MDAnalysis's PDB reader. 6WG6.cif.gz: MDAnalysis 2.11's
own mmCIF reader (MMCIFParser/MMCIFReader, which read through gemmi:
chain = auth_asym_id, resid = auth_seq_id, record_type = group_PDB). adk.psf:
MDAnalysis's PSF reader, positions (for `within`, x, y, z) from the first
frame of adk_dims.dcd. The GRO files: MDAnalysis's GRO reader (which
gives no elements, no chains and no record types, so `element`, `chain`
and `hetero` are not used on them).

Distance selections run with periodic=False: MDAnalysis applies the unit
cell of a GRO file by default, isomarch's `within` does not. Every
`within` and every comparison of a real number is checked for ties: the
script prints the least distance between a value and its threshold, and
stops when it is under 1e-3 (float32 in MDAnalysis, f64 in isomarch),
but for values equal to a whole-number threshold, which both hold exactly.
"""
import gzip
import os
import sys
import warnings

import gemmi  # MDAnalysis 2.11 reads mmCIF through it
import MDAnalysis as mda
import numpy as np
from MDAnalysis.lib.distances import capped_distance

warnings.filterwarnings("ignore")  # DCD and guesser chatter

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, ".."))
OUT = os.path.join(ROOT, "tests", "data", "selections", "reference.csv")

PDB = "tests/data/molecules/1A8O.pdb"
CIF = "tests/data/molecules/6WG6.cif.gz"
PSF = "tests/data/trajectories/adk.psf"
DCD = "tests/data/trajectories/adk_dims.dcd"
OPLS = "tests/data/trajectories/adk_oplsaa.gro.gz"
YIIP = "tests/data/trajectories/YiiP_lipids.gro.gz"

# GRO names of sites isomarch does not read as atoms (src/molecule/gro.rs).
NOT_ATOMS = ("MW", "DM", "LP", "EP", "VS")

# VMD's `ion` macro (VMD 1.9.3's atomselect macros): isomarch's `ion`.
# MDAnalysis has no `ion`: its side of a pair is the explicit list of the
# residue names of the file's ions. None of these names occurs in the five
# files: adk_oplsaa's sodium ions are residue "NA+" (atom "NA"), YiiP's zinc
# sites residue "ZNM" (atom ZND and dummies DM1-DM6). The `ion` rows below
# are on adk_oplsaa with MDAnalysis's side `resname NA+`: they hold only
# if isomarch's list has NA+ (GROMACS's OPLS-AA name for Na+).
VMD_ION = (
    "AL BA CA Ca CAL CD CES CLA CL Cl CO CS CU Cu CU1 CUA HG IN IOD K MG MN3 MO3 MO4 "
    "MO5 MO6 NA Na NAW OC7 PB POT PT RB SOD TB TL WO4 YB ZN ZN1 ZN2"
).split()

# (file, isomarch, MDAnalysis, checks): checks name the ties to look for,
# ("within", cutoff, MDAnalysis selection of the centres) or
# ("cmp", attribute, threshold).
PAIRS = [
    # 1A8O: one chain A, 88 waters (HOH), selenomethionine (MSE, HETATM).
    (PDB, "all", "all", []),
    (PDB, "protein", "protein", []),
    (PDB, "water", "water", []),
    (PDB, "hetero", "record_type HETATM", []),
    (PDB, "backbone", "backbone", []),
    (PDB, "element Se", "element Se", []),
    (PDB, "hydrogen or element Se", "element H D or element Se", []),
    (PDB, "beta > 40", "prop tempfactor > 40", [("cmp", "tempfactors", 40.0)]),
    (PDB, "occupancy < 1", "prop occupancy < 1", [("cmp", "occupancies", 1.0)]),
    (PDB, "resid 151 to 160", "resid 151:160", []),
    (PDB, "chain A and name CA", "chainID A and name CA", []),
    (PDB, "index 5", "index 5", []),
    (PDB, "name C* and not name CA", "name C* and not name CA", []),
    # VMD: `and` binds tighter than `or`; MDAnalysis gives both one
    # precedence (left to right), so its side needs the parentheses.
    (PDB, "resname ALA or resname GLY and name CA", "resname ALA or (resname GLY and name CA)", []),
    # Where the grammars differ, each difference on its own (README.md):
    # MDAnalysis's left-to-right reading of the same text is isomarch's
    # bracketed one; its `around` leaves out SEL, which isomarch's `around`
    # alias does too and `within` does not; `within` takes everything to
    # its right; `byres` is an alias of `same residue as`.
    (PDB, "(resname ALA or resname GLY) and name CA", "resname ALA or resname GLY and name CA", []),
    (
        PDB,
        "(within 5 of (resname MSE and name SE)) and not (resname MSE and name SE)",
        "around 5 (resname MSE and name SE)",
        [("within", 5.0, "resname MSE and name SE")],
    ),
    (PDB, "around 5 (resname MSE and name SE)", "around 5 (resname MSE and name SE)", [("within", 5.0, "resname MSE and name SE")]),
    (
        PDB,
        "within 3 of name SE and resname MSE",
        "(around 3 (name SE and resname MSE)) or (name SE and resname MSE)",
        [("within", 3.0, "name SE and resname MSE")],
    ),
    # The row above gives the same 16 atoms under both readings of `within`
    # (SE atoms are MSE's): the next two separate them. Taking everything to
    # its right, `within 3 of resname MSE and name SE` is `within 3 of
    # (resname MSE and name SE)`, 16 atoms; bound as tightly as `not`, it
    # would be `(within 3 of resname MSE) and name SE`, the 4 SE atoms. So
    # too `same residue as` and `byres`: 32 atoms (the 4 MSE residues), or
    # the 4 SE atoms. MDAnalysis's `byres` also takes everything to its
    # right, so its side of the last row is the same text.
    (
        PDB,
        "within 3 of resname MSE and name SE",
        "(around 3 (resname MSE and name SE)) or (resname MSE and name SE)",
        [("within", 3.0, "resname MSE and name SE")],
    ),
    (PDB, "same residue as resname MSE and name SE", "byres (resname MSE and name SE)", []),
    (PDB, "byres resname MSE and name SE", "byres resname MSE and name SE", []),
    (PDB, "byres name SE", "byres name SE", []),
    (
        PDB,
        "within 5 of (resname MSE and name SE)",
        "(around 5 (resname MSE and name SE)) or (resname MSE and name SE)",
        [("within", 5.0, "resname MSE and name SE")],
    ),
    (
        PDB,
        "same residue as (water and within 3.5 of protein)",
        "byres (water and ((around 3.5 protein) or protein))",
        [("within", 3.5, "protein")],
    ),
    # The default selection; no ion names here, so MDAnalysis's side is `not water`.
    (PDB, "not (water or ion)", "not water", []),
    # 6WG6: 14 chains A-N, DNA (DT) in chains M and N, no HETATM, no hydrogens.
    (CIF, "nucleic", "nucleic", []),
    (CIF, "chain M N", "chainID M N", []),
    (CIF, "sidechain and chain B", "(protein and not backbone) and chainID B", []),
    (CIF, "element P S", "element P S", []),
    (CIF, "index 0 to 99", "index 0:99", []),
    (CIF, "chain A and resid 500 502 510 to 520", "chainID A and resid 500 502 510:520", []),
    (CIF, "beta > 150", "prop tempfactor > 150", [("cmp", "tempfactors", 150.0)]),
    (CIF, "name \"O5'\"", "name O5'", []),
    (CIF, "backbone and not (chain A B C D E F G H I J)", "backbone and not (chainID A B C D E F G H I J)", []),
    (
        CIF,
        "same residue as (protein and within 4 of nucleic)",
        "byres (protein and ((around 4 nucleic) or nucleic))",
        [("within", 4.0, "nucleic")],
    ),
    # adk.psf: one segment 4AKE (isomarch's chain and segname), positions
    # from the first frame of adk_dims.dcd; MDAnalysis has no elements for
    # a PSF, isomarch derives them from the mass.
    (PSF, "segname 4AKE and name CA", "segid 4AKE and name CA", []),
    (PSF, "chain 4AKE and resid 100", "segid 4AKE and resid 100", []),
    (PSF, "hydrogen", "prop mass < 1.5", [("cmp", "masses", 1.5)]),
    (PSF, "protein and not hydrogen and resid 1 to 10", "protein and not prop mass < 1.5 and resid 1:10", []),
    (PSF, "resname HSD and sidechain", "resname HSD and (protein and not backbone)", []),
    (PSF, "resid 1 3 200 to 214", "resid 1 3 200:214", []),
    (PSF, "resid > 200 and resid <= 210", "prop resid > 200 and prop resid <= 210", []),
    (PSF, "mass > 30", "prop mass > 30", [("cmp", "masses", 30.0)]),
    (PSF, "charge < -0.65", "prop charge < -0.65", [("cmp", "charges", -0.65)]),
    (PSF, "type 56", "type 56", []),
    (
        PSF,
        "x < 0 and y > 2 and z >= -2.5",
        "prop x < 0 and prop y > 2 and prop z >= -2.5",
        [("cmp", "x", 0.0), ("cmp", "y", 2.0), ("cmp", "z", -2.5)],
    ),
    (PSF, "within 6 of resid 1", "(around 6 resid 1) or resid 1", [("within", 6.0, "resid 1")]),
    (
        PSF,
        "same residue as (within 3 of (resname HSD and name NE2))",
        "byres ((around 3 (resname HSD and name NE2)) or (resname HSD and name NE2))",
        [("within", 3.0, "resname HSD and name NE2")],
    ),
    (PSF, "index 3300 to 3340 or index 0", "index 3300:3340 or index 0", []),
    # adk_oplsaa: TIP4P water (SOL; its MW sites are not atoms), 4 Na+ (NA+).
    (OPLS, "water and resid 215 to 230", "water and resid 215:230", []),
    (OPLS, "ion", "resname NA+", []),
    (OPLS, "not (water or ion)", "not (water or resname NA+)", []),
    (OPLS, "hydrogen and not water and resid 1 to 3", "name H* and not water and resid 1:3", []),
    (OPLS, "backbone and resid 10 to 50", "backbone and resid 10:50", []),
    (OPLS, "index 47600 to 47680", "index 47600:47680", []),
    (
        OPLS,
        "same residue as (within 3 of resname NA+)",
        "byres ((around 3 resname NA+) or resname NA+)",
        [("within", 3.0, "resname NA+")],
    ),
    # YiiP: protein (two chains), POPE/POPG lipids, 8 zinc sites ZNM (ZND
    # plus dummies DM1-DM6, which are not atoms).
    (YIIP, "resname POPG and name P", "resname POPG and name P", []),
    (YIIP, "resname PO*", "resname PO*", []),
    (YIIP, "name C3? and resname POPE and resid 300 to 310", "name C3? and resname POPE and resid 300:310", []),
    (YIIP, "resid 7 8 9", "resid 7 8 9", []),
    (YIIP, "sidechain and resid 100 to 110", "(protein and not backbone) and resid 100:110", []),
    (YIIP, "hydrogen and resname ZNM POPG and resid 296 518", "name H* and resname ZNM POPG and resid 296 518", []),
    (YIIP, "within 4.5 of resname ZNM", "(around 4.5 resname ZNM) or resname ZNM", [("within", 4.5, "resname ZNM")]),
    (
        YIIP,
        "same residue as (within 3 of resname ZNM)",
        "byres ((around 3 resname ZNM) or resname ZNM)",
        [("within", 3.0, "resname ZNM")],
    ),
    (YIIP, "not protein and not resname PO*", "not protein and not resname PO*", []),
]


def opener(path):
    return gzip.open(path, "rt") if path.endswith(".gz") else open(path)


def plain_positions(rel):
    """The file's coordinate records read as plain text, in file order:
    (positions, alternate-location site keys) -- the site key (or None
    when the record gives no alternate location) and the first model only.
    None of positions for a PSF (it has none)."""
    path = os.path.join(ROOT, rel)
    pos, alt = [], []
    with opener(path) as fh:
        lines = fh.read().splitlines()
    if rel.endswith(".pdb"):
        for line in lines:
            if line.startswith("ENDMDL"):
                break
            if line.startswith(("ATOM  ", "HETATM")):
                pos.append([float(line[30:38]), float(line[38:46]), float(line[46:54])])
                a = line[16]
                alt.append(((line[12:16], line[17:27]), a) if a != " " else None)
    elif ".cif" in rel:
        tags, rows, inloop = [], [], False
        for line in lines:
            if line.startswith("_atom_site."):
                tags.append(line.split()[0][len("_atom_site.") :])
                inloop = True
            elif inloop and line.startswith(("ATOM", "HETATM")):
                rows.append(line.split())
            elif inloop and rows:
                break
        c = {t: i for i, t in enumerate(tags)}
        first = rows[0][c["pdbx_PDB_model_num"]]
        for r in rows:
            if r[c["pdbx_PDB_model_num"]] != first:
                continue
            pos.append([float(r[c["Cartn_x"]]), float(r[c["Cartn_y"]]), float(r[c["Cartn_z"]])])
            a = r[c["label_alt_id"]]
            key = tuple(r[c[t]] for t in ("label_atom_id", "label_comp_id", "auth_asym_id", "auth_seq_id", "pdbx_PDB_ins_code"))
            alt.append((key, a) if a not in (".", "?") else None)
    elif ".gro" in rel:
        n = int(lines[1])
        for line in lines[2 : 2 + n]:
            pos.append([10 * float(line[20:28]), 10 * float(line[28:36]), 10 * float(line[36:44])])
            alt.append(None)
    else:  # PSF
        start = next(i for i, l in enumerate(lines) if "!NATOM" in l)
        n = int(lines[start].split()[0])
        return None, [None] * n
    return np.array(pos), alt


def load(rel):
    path = os.path.join(ROOT, rel)
    if rel == PSF:
        return mda.Universe(path, os.path.join(ROOT, DCD))
    return mda.Universe(path)


def kept(rel, u, alt):
    """The mask of the records isomarch keeps as atoms."""
    keep = np.ones(len(u.atoms), bool)
    first = {}
    for i, a in enumerate(alt):
        if a is not None:
            site, loc = a
            if first.setdefault(site, loc) != loc:
                keep[i] = False
    if ".gro" in rel:
        keep &= np.array([not n.upper().startswith(NOT_ATOMS) for n in u.atoms.names])
    if rel == PSF:
        keep &= u.atoms.masses > 0.05
    return keep


def residue_runs_agree(rel, group):
    """Whether MDAnalysis's residues (what `byres` spreads over) are
    isomarch's: maximal runs of consecutive atoms with the same chain,
    segment, residue number, insertion code and residue name."""
    resids = group.resids
    if ".gro" in rel:  # isomarch's GRO chains: a new one where numbers drop
        chain = np.concatenate([[0], np.cumsum(np.diff(resids) < 0)]).astype(str)
    elif rel == PSF:
        chain = group.segids
    else:
        chain = group.chainIDs
    icodes = group.icodes if hasattr(group, "icodes") else np.full(len(group), "")
    key = list(zip(chain, resids, icodes, group.resnames))
    ours = np.array([k != j for k, j in zip(key[1:], key[:-1])])
    theirs = np.diff(group.resindices) != 0
    return np.array_equal(ours, theirs)


def ranges(idx):
    out, k = [], 0
    while k < len(idx):
        j = k
        while j + 1 < len(idx) and idx[j + 1] == idx[j] + 1:
            j += 1
        out.append(str(idx[k]) if j == k else f"{idx[k]}-{idx[j]}")
        k = j + 1
    return " ".join(out)


def tie_gap(group, check):
    """The least distance from any value to its threshold."""
    if check[0] == "within":
        _, cutoff, centre = check
        sel = group.select_atoms(centre, periodic=False)
        rest = group - sel
        pairs, d = capped_distance(sel.positions, rest.positions, cutoff + 0.1, return_distances=True)
        if len(d) == 0:
            return np.inf
        dmin = np.full(len(rest), np.inf)
        np.minimum.at(dmin, pairs[:, 1], d)
        return float(np.min(np.abs(dmin[np.isfinite(dmin)] - cutoff)))
    _, attr, threshold = check
    if attr in "xyz":
        values = group.positions[:, "xyz".index(attr)]
    else:
        values = getattr(group, attr)
    return float(np.min(np.abs(values.astype(np.float64) - threshold)))


def quote(s):
    return '"' + s.replace('"', '""') + '"'


def main():
    print(f"MDAnalysis {mda.__version__}, gemmi {gemmi.__version__}, numpy {np.__version__}", file=sys.stderr)
    groups = {}
    for rel in dict.fromkeys(p[0] for p in PAIRS):
        u = load(rel)
        pos, alt = plain_positions(rel)
        assert len(alt) == len(u.atoms), f"{rel}: MDAnalysis reads {len(u.atoms)} atoms, the file has {len(alt)} records"
        if pos is not None:
            err = np.abs(u.atoms.positions - pos).max()
            assert err < 1e-3, f"{rel}: MDAnalysis's positions differ from the file's records in order ({err})"
        keep = kept(rel, u, alt)
        n_alt = sum(a is not None for a in alt)
        names = " ".join(sorted(set(u.atoms.resnames)))
        print(
            f"{rel}: {len(u.atoms)} records read by MDAnalysis (same order as the file), "
            f"{n_alt} with an alternate location, {int((~keep).sum())} not kept "
            f"(dummy/virtual sites or later alternate locations), {int(keep.sum())} atoms kept; "
            f"{len(set(u.atoms.resnames))} residue names: {names}",
            file=sys.stderr,
        )
        assert residue_runs_agree(rel, u.atoms[keep]), f"{rel}: MDAnalysis's residues are not isomarch's"
        groups[rel] = (u, u.atoms[keep])

    rows, used = [], set()
    for rel, iso, expr, checks in PAIRS:
        u, group = groups[rel]
        sel = group.select_atoms(expr, periodic=False)
        idx = np.unique(sel.indices)
        assert len(idx) > 0, f"{rel}: {expr!r} selects nothing"
        assert iso == "all" or len(idx) < len(group), f"{rel}: {expr!r} selects every atom"
        assert np.isin(idx, group.indices).all()
        for check in checks:
            gap = tie_gap(group, check)
            # Values equal to a whole-number threshold are exact in float32
            # and f64 alike (1.00 against `occupancy < 1`): no tie.
            exact = gap == 0 and check[0] == "cmp" and float(check[2]).is_integer()
            assert gap >= 1e-3 or exact, f"{rel}: {expr!r}: a value {gap} from its threshold {check}"
            print(f"  {iso!r}: {check[:2]} nearest value {gap:.4f} from the threshold", file=sys.stderr)
        rows.append(f"{rel},{quote(iso)},{quote(expr)},{len(idx)},{ranges(idx.tolist())}")
        print(f"{rel}: {iso!r} -> {len(idx)} atoms", file=sys.stderr)

    head = [
        "# Written by scripts/selection-reference.py: MDAnalysis's select_atoms for each",
        "# isomarch expression, over the atoms isomarch keeps; 0-based indices of the file's records.",
        f"# MDAnalysis {mda.__version__}, gemmi {gemmi.__version__}, numpy {np.__version__}",
        "# Rows using `ion` (adk_oplsaa) hold only if isomarch's ion list has NA+ (README.md).",
        "file,isomarch,mdanalysis,count,indices",
    ]
    os.makedirs(os.path.dirname(OUT), exist_ok=True)
    with open(OUT + ".tmp", "w") as fh:
        fh.write("\n".join(head + rows) + "\n")
    os.replace(OUT + ".tmp", OUT)
    print(f"{OUT}: {len(rows)} selections, {os.path.getsize(OUT)} bytes", file=sys.stderr)


if __name__ == "__main__":
    main()
