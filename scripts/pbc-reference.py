#!/usr/bin/env python3
"""Reference of molecules made whole across the periodic box, from an
independent implementation, MDAnalysis, for tests/trajectories.rs
(`adk_is_made_whole_as_mdanalysis_makes_it`).

AdK in its water box (tests/data/trajectories/adk_oplsaa.gro.gz and its
XTC) is wrapped into GROMACS's rhombic dodecahedron: the protein is in
pieces. Its bonds are guessed as MDAnalysis guesses them (van der Waals
radii, fudge factor 0.55, nearest images in the box), and every frame of
the XTC is made whole with `MDAnalysis.lib.mdamath.make_whole` on each
fragment, as `MDAnalysis.transformations.unwrap` does. Writes to
tests/data/trajectories/reference/:

- adk_oplsaa_bonds.csv: the protein's bonds, as pairs of atom indices in
  the file (0-based, counting every site).
- adk_oplsaa_whole.csv: for every frame, the atoms that make_whole moved,
  and by how many of each box vector (a, b, c): `frame,atom,na,nb,nc`.
  Atoms not listed stay where the file has them.

    python3 -m venv /tmp/mda && /tmp/mda/bin/pip install MDAnalysis==2.11.0
    /tmp/mda/bin/python scripts/pbc-reference.py

The values committed were written with MDAnalysis 2.11.0 and numpy 2.4.6.
"""
import os
import sys

import MDAnalysis as mda
import numpy as np
from MDAnalysis.guesser.default_guesser import DefaultGuesser
from MDAnalysis.lib.mdamath import make_whole, triclinic_vectors

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "tests", "data", "trajectories")


def write(path, rows):
    with open(path + ".tmp", "w") as fh:
        fh.write("\n".join(rows) + "\n")
    os.replace(path + ".tmp", path)


def main():
    print(f"MDAnalysis {mda.__version__}, numpy {np.__version__}", file=sys.stderr)
    u = mda.Universe(os.path.join(DATA, "adk_oplsaa.gro.gz"), os.path.join(DATA, "adk_oplsaa.xtc"))
    protein = u.select_atoms("protein")
    u.trajectory[0]
    guesser = DefaultGuesser(u, box=u.dimensions)
    bonds = guesser.guess_bonds(protein, protein.positions)
    u.add_TopologyAttr("bonds", bonds)
    fragments = protein.fragments
    print(f"{len(protein)} protein atoms, {len(bonds)} bonds, {len(fragments)} fragments", file=sys.stderr)
    out = os.path.join(DATA, "reference")
    write(os.path.join(out, "adk_oplsaa_bonds.csv"), ["a,b"] + [f"{min(a, b)},{max(a, b)}" for a, b in sorted((min(a, b), max(a, b)) for a, b in bonds)])
    rows = ["frame,atom,na,nb,nc"]
    for ts in u.trajectory:
        raw = protein.positions.astype(np.float64)
        for frag in fragments:
            make_whole(frag)
        whole = protein.positions.astype(np.float64)
        vectors = triclinic_vectors(ts.dimensions).astype(np.float64)
        n = (whole - raw) @ np.linalg.inv(vectors)
        counts = np.rint(n)
        # Whole box vectors, to the f32 precision of the positions.
        assert np.abs(n - counts).max() < 1e-3, f"frame {ts.frame}: a shift that is not whole box vectors"
        for i in np.nonzero(np.any(counts != 0, axis=1))[0]:
            na, nb, nc = (int(v) for v in counts[i])
            rows.append(f"{ts.frame},{protein[i].index},{na},{nb},{nc}")
        # Whole: every bond shorter than 2 Å.
        at = {a.index: k for k, a in enumerate(protein)}
        longest = max(np.linalg.norm(whole[at[a]] - whole[at[b]]) for a, b in bonds)
        assert longest < 2.0, f"frame {ts.frame}: a bond of {longest} Å after make_whole"
        print(f"frame {ts.frame}: box {ts.dimensions}, longest bond {longest:.3f} Å", file=sys.stderr)
    write(os.path.join(out, "adk_oplsaa_whole.csv"), rows)
    print(f"{len(rows) - 1} atoms moved over {len(u.trajectory)} frames", file=sys.stderr)


if __name__ == "__main__":
    main()
