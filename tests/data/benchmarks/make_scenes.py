#!/usr/bin/env python3
"""Writes the benchmark scenes' primitives as CSV (seeded, reproducible).
Columns: group,x,y,z,R  (compact kernel support radius R) -- see docs/benchmark-protocol.md.
Run: python3 make_scenes.py   (needs only the standard library)"""
import math, random

def write(name, rows):
    with open(f"{name}.csv", "w") as f:
        f.write("group,x,y,z,R\n")
        for g, x, y, z, r in rows:
            f.write(f"{g},{x:.6f},{y:.6f},{z:.6f},{r:.6f}\n")

def fig10():
    rnd = random.Random(10); rows = []
    for i in range(20):                      # a ring: blending between neighbours, grazing views along it
        a = 2 * math.pi * i / 20
        rows.append((0, 5 * math.cos(a), rnd.uniform(-0.3, 0.3), 5 * math.sin(a), 1.6 if i % 2 else 2.2))
    for i in range(10):                      # a helix through the ring's centre
        s = i / 9
        a = 3 * math.pi * s
        rows.append((0, 1.2 * math.cos(a), -3 + 6 * s, 1.2 * math.sin(a), 1.4 + 0.6 * s))
    for i in range(6):                       # a loose cluster on top
        rows.append((0, rnd.gauss(0, 0.8), 4 + rnd.gauss(0, 0.6), rnd.gauss(0, 0.8), rnd.uniform(1.2, 1.8)))
    return rows

def fig17():
    rnd = random.Random(17); rows = []; p = [0.0, 0.0, 0.0]
    for i in range(30):                      # a random-walk chain of blobs blended by sum
        rows.append((0, p[0], p[1], p[2], rnd.uniform(1.5, 2.5)))
        d = [rnd.gauss(0, 1) for _ in range(3)]; n = math.sqrt(sum(c * c for c in d))
        p = [p[k] + 1.6 * d[k] / n for k in range(3)]
    return rows

def fig1():
    rnd = random.Random(1); rows = []
    e = 5 / math.sqrt(8)                     # tetrahedron of edge 5
    corners = [(e, e, e), (e, -e, -e), (-e, e, -e), (-e, -e, e)]
    for g, c in enumerate(corners):          # four sum groups, overlapping, combined by max
        for _ in range(7):
            rows.append((g, c[0] + rnd.gauss(0, 1.0), c[1] + rnd.gauss(0, 1.0), c[2] + rnd.gauss(0, 1.0), rnd.uniform(1.4, 2.2)))
    return rows

def fig16():
    rnd = random.Random(16); rows = []
    for i in range(3):                       # a 3x3 grid of blobs above the ground plane; rest positions
        for j in range(3):
            rows.append((0, (i - 1) * 2.0, 2.5, (j - 1) * 2.0, 2.0))
    return rows, [rnd.uniform(0, 2 * math.pi) for _ in rows]

if __name__ == "__main__":
    write("fig10", fig10()); write("fig17", fig17()); write("fig1", fig1())
    rows, phases = fig16(); write("fig16", rows)
    with open("fig16_phases.csv", "w") as f:
        f.write("index,phase\n")
        for i, ph in enumerate(phases):
            f.write(f"{i},{ph:.6f}\n")
