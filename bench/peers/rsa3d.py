#!/usr/bin/env python3
"""Random sequential addition of N unit spheres (no two centres closer than sigma = 1) in a periodic
cube at true volume fraction phi, written as a LAMMPS data file (atom_style atomic).
The same kind of start as flipflow's `system.init: random` (RSA, r >= sigma), not the same points.
Usage: rsa3d.py N PHI SEED OUT.data"""
import math, random, sys

N, phi, seed, out = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
L = (N * math.pi / 6.0 / phi) ** (1.0 / 3.0)
m = int(L)                      # cells of side L/m >= 1 = sigma
h = L / m
rng = random.Random(seed)
cells = {}
pos = []
for i in range(N):
    for _ in range(100000):
        x, y, z = rng.random() * L, rng.random() * L, rng.random() * L
        cx, cy, cz = int(x / h) % m, int(y / h) % m, int(z / h) % m
        ok = True
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    for j in cells.get(((cx + dx) % m, (cy + dy) % m, (cz + dz) % m), ()):
                        px, py, pz = pos[j]
                        ax, ay, az = x - px, y - py, z - pz
                        ax -= L * round(ax / L); ay -= L * round(ay / L); az -= L * round(az / L)
                        if ax * ax + ay * ay + az * az < 1.0:
                            ok = False; break
                    if not ok: break
                if not ok: break
            if not ok: break
        if ok: break
    else:
        sys.exit("RSA jammed")
    cells.setdefault((cx, cy, cz), []).append(i)
    pos.append((x, y, z))
with open(out, "w") as f:
    f.write(f"RSA start: N={N} phi={phi} seed={seed} L={L!r}\n\n{N} atoms\n1 atom types\n\n")
    f.write(f"0 {L!r} xlo xhi\n0 {L!r} ylo yhi\n0 {L!r} zlo zhi\n\nMasses\n\n1 1.0\n\nAtoms # atomic\n\n")
    for i, (x, y, z) in enumerate(pos):
        f.write(f"{i + 1} 1 {x!r} {y!r} {z!r}\n")
print(f"wrote {out}: N={N} L={L:.6f} phi={N * math.pi / 6 / L**3:.6f}")
