#!/usr/bin/env python3
"""Reference values of the test trajectories from an independent reader,
MDAnalysis, for tests/trajectories.rs.

For each trajectory in tests/data/trajectories, writes reference/<name>.csv
in the layout of `isomarch frames TOPOLOGY TRAJECTORY --atoms 0,1,MID,LAST`:
frame, time (ps), atom count, the mean position over all atoms (Å), and the
positions of atoms 0, 1, n//2 and n-1 (Å) in every frame.

    python3 -m venv /tmp/mda && /tmp/mda/bin/pip install MDAnalysis==2.11.0
    /tmp/mda/bin/python scripts/trajectory-reference.py

The values committed were written with MDAnalysis 2.11.0 and numpy 2.4.6.
"""
import os
import sys

import MDAnalysis as mda
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "tests", "data", "trajectories")

# name: (topology, trajectory or None)
PAIRS = {
    "YiiP_lipids": ("YiiP_lipids.gro.gz", "YiiP_lipids.xtc"),
    "adk_oplsaa": ("adk_oplsaa.gro.gz", "adk_oplsaa.xtc"),
    "adk_dims": ("adk.psf", "adk_dims.dcd"),
    "adk_cell": ("adk.psf", "adk_cell.dcd"),
    "adk_prec": ("adk_oplsaa.gro.gz", "adk_prec.xtc"),
}
# adk_big.dcd is checked against adk_cell.csv: the same frames. MDAnalysis
# 2.11 reads its coordinates (checked below) but not its time step (frame
# 1 at 5.3e36 ps), so its own rows would be wrong in that column.


def write_variants():
    """Trajectories the readers meet in the wild, written here with
    MDAnalysis from the shipped ones: a DCD with a unit cell in every frame
    (CHARMM's extra block), the same file big-endian (every Fortran record
    and its 4-byte words swapped), and an XTC of precision 100 (two
    decimals of a nm; GROMACS writes 1000 unless told)."""
    u = mda.Universe(os.path.join(DATA, "adk.psf"), os.path.join(DATA, "adk_dims.dcd"))
    cell = os.path.join(DATA, "adk_cell.dcd")
    with mda.Writer(cell, n_atoms=len(u.atoms)) as w:
        for ts in u.trajectory[:8]:
            ts.dimensions = [60.0 + ts.frame, 70.0, 80.0, 90.0, 90.0, 90.0]
            w.write(u.atoms)
    data = open(cell, "rb").read()
    out, at = bytearray(), 0
    while at < len(data):
        (n,) = np.frombuffer(data[at : at + 4], "<i4")
        body = data[at + 4 : at + 4 + n]
        swapped = bytearray(body)
        # Every field of a DCD record is a 4-byte word (ints, f32) but the
        # title lines (80-byte text) and the unit cell (f64s, 8 bytes).
        if at == 0:  # the header: "CORD", then 20 ints
            swapped = body[:4] + np.frombuffer(body[4:], "<i4").astype(">i4").tobytes()
        elif n == 48:  # the unit cell: six f64
            swapped = np.frombuffer(body, "<f8").astype(">f8").tobytes()
        elif n % 80 == 4 and at < 200:  # the titles: their count, then text
            swapped = np.frombuffer(body[:4], "<i4").astype(">i4").tobytes() + body[4:]
        else:  # the atom count, and each frame's x, y and z (f32)
            swapped = np.frombuffer(body, "<i4").astype(">i4").tobytes()
        marker = np.array([n], ">i4").tobytes()
        out += marker + swapped + marker
        at += 8 + n
    with open(os.path.join(DATA, "adk_big.dcd"), "wb") as fh:
        fh.write(out)
    little = mda.Universe(os.path.join(DATA, "adk.psf"), cell)
    big = mda.Universe(os.path.join(DATA, "adk.psf"), os.path.join(DATA, "adk_big.dcd"))
    for a, b in zip(little.trajectory, big.trajectory):
        assert np.array_equal(little.atoms.positions, big.atoms.positions), f"frame {a.frame}: big-endian coordinates differ"
        assert np.allclose(a.dimensions, b.dimensions), f"frame {a.frame}: big-endian unit cell differs"
    v = mda.Universe(os.path.join(DATA, "adk_oplsaa.gro.gz"), os.path.join(DATA, "adk_oplsaa.xtc"))
    with mda.coordinates.XTC.XTCWriter(os.path.join(DATA, "adk_prec.xtc"), n_atoms=len(v.atoms), precision=2) as w:
        for ts in v.trajectory[:3]:
            w.write(v.atoms)


def main():
    out_dir = os.path.join(DATA, "reference")
    os.makedirs(out_dir, exist_ok=True)
    print(f"MDAnalysis {mda.__version__}, numpy {np.__version__}", file=sys.stderr)
    write_variants()
    for name, (top, traj) in PAIRS.items():
        u = mda.Universe(os.path.join(DATA, top), os.path.join(DATA, traj))
        n = len(u.atoms)
        atoms = [0, 1, n // 2, n - 1]
        head = "frame,time_ps,atoms,mean_x,mean_y,mean_z" + "".join(f",x{i},y{i},z{i}" for i in atoms)
        rows = [head]
        for ts in u.trajectory:
            p = u.atoms.positions.astype(np.float64)
            m = p.mean(axis=0)
            row = f"{ts.frame},{ts.time:.6f},{n},{m[0]:.6f},{m[1]:.6f},{m[2]:.6f}"
            row += "".join(f",{p[i][0]:.6f},{p[i][1]:.6f},{p[i][2]:.6f}" for i in atoms)
            rows.append(row)
        path = os.path.join(out_dir, f"{name}.csv")
        with open(path + ".tmp", "w") as fh:
            fh.write("\n".join(rows) + "\n")
        os.replace(path + ".tmp", path)
        print(f"{path}: {len(rows) - 1} frames of {n} atoms", file=sys.stderr)


if __name__ == "__main__":
    main()
