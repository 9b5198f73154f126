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
}


def main():
    out_dir = os.path.join(DATA, "reference")
    os.makedirs(out_dir, exist_ok=True)
    print(f"MDAnalysis {mda.__version__}, numpy {np.__version__}", file=sys.stderr)
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
