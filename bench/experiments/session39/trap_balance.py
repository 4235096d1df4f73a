#!/usr/bin/python3
"""Hard disks in a harmonic trap: is the cloud in hydrostatic equilibrium with the hard-disk
equation of state? (pipelines/trap-hard-disks.yaml; docs/model-notes.md, "Trap".)

In local equilibrium the pressure balances the trap's force, dP/dr = −ρ(r) k r, so the pressure
at radius r is the weight of the cloud outside it,

    P_force(r) = k ∫_r^∞ ρ(r') r' dr'        (k_BT = 1: D = μ = 1),

while the local density gives P_EOS(r) = ρ(r) Z(η(r)), Z from Liu's hard-disk equation of state
(Mol. Phys. 2021), η = ρ π σ²/4. Both come from the same frames: ρ(r) is the particles' radial
density about the trap centre (minimum image), averaged over the frames at t ≥ --from.

  trap_balance.py FILE.h5 [--k 0.02] [--from 100] [--bin 1.0] [--out FIG.png]
"""
import argparse
import sys

import h5py
import numpy as np


def liu_z(eta):
    return (1 + eta**2 / 8 + eta**4 / 18 - 4 * eta**6 / 21) / (1 - eta) ** 2


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("file")
    ap.add_argument("--k", type=float, default=0.02)
    ap.add_argument("--from", dest="t0", type=float, default=100.0)
    ap.add_argument("--bin", type=float, default=1.0)
    ap.add_argument("--sigma", type=float, default=1.0)
    ap.add_argument("--out")
    a = ap.parse_args()

    with h5py.File(a.file, "r") as f:
        pos = f["particles/all/position/value"][()]
        t = f["particles/all/position/time"][()]
        L = np.asarray(f["particles/all/box/edges"][()], dtype=float).reshape(-1)[:2]
    keep = t >= a.t0
    if not keep.any():
        sys.exit(f"{a.file}: no frame at t ≥ {a.t0} (last t = {t[-1]:g})")
    d = pos[keep][..., :2] - 0.5 * L
    d -= L * np.rint(d / L)
    r = np.hypot(d[..., 0], d[..., 1]).reshape(-1)
    frames = int(keep.sum())
    edges = np.arange(0.0, 0.5 * L.min() + a.bin, a.bin)
    counts, _ = np.histogram(r, bins=edges)
    area = np.pi * (edges[1:] ** 2 - edges[:-1] ** 2)
    rho = counts / area / frames
    mid = 0.5 * (edges[1:] + edges[:-1])
    eta = rho * np.pi * a.sigma**2 / 4
    p_eos = rho * liu_z(eta)
    # ρ(r') 2π r' dr' counts the particles in a shell, so k ∫_r^∞ ρ r' dr' = k/(2π) × (particles beyond
    # r a frame): from the particles themselves, no binning.
    rs = np.sort(r)
    beyond = rs.size - np.searchsorted(rs, mid)
    p_force = a.k * beyond / (2 * np.pi) / frames
    n = pos.shape[1]
    # Over the plane: ∫ P_force dA = k/2 ⟨Σ r_i²⟩, the trap's virial, against ∫ P_EOS dA (the disks
    # beyond L/2, in the box's corners, counted as an ideal gas); both are N for an ideal gas.
    virial = 0.5 * a.k * (r**2).sum() / frames
    local = (p_eos * area).sum() + (r >= edges[-1]).sum() / frames
    print(f"{a.file}: {frames} frames at t ≥ {a.t0:g}, N = {n}, k = {a.k:g}")
    print(f"trap virial k/2 <sum r^2> = {virial:.2f}, integral of rho Z(eta) dA = {local:.2f}: hard-core parts "
          f"(minus N) {virial - n:.2f} and {local - n:.2f}, ratio {(local - n) / (virial - n):.4f}")
    print(" r      rho      eta     P_EOS    P_force  P_EOS/P_force-1")
    for j in range(mid.size):
        if counts[j] == 0:
            continue
        print(f"{mid[j]:5.2f}  {rho[j]:.4f}  {eta[j]:.4f}  {p_eos[j]:.4f}  {p_force[j]:.4f}  "
              f"{p_eos[j] / p_force[j] - 1:+.4f}")
    if a.out:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5.5, 3.8))
        m = counts > 0
        ax.plot(mid[m], p_force[m], "k-", label=r"trap's weight $k\int_r^\infty \rho\, r'\, dr'$")
        ax.plot(mid[m], p_eos[m], "o", ms=3.5, label=r"$\rho(r)\, Z(\eta(r))$, Liu's hard-disk EOS")
        ax.plot(mid[m], rho[m], "--", color="0.5", lw=1, label=r"$\rho(r)$: an ideal gas's pressure")
        ax.set_xlabel("distance from the trap centre r / σ")
        ax.set_ylabel("pressure βPσ²")
        ax2 = ax.twinx()
        ax2.plot(mid[m], eta[m], color="tab:green", lw=1, alpha=0.7)
        ax2.set_ylabel("packing fraction η(r)", color="tab:green")
        ax2.set_ylim(0, 0.75)  # below the legend
        ax.legend(loc="upper right", fontsize="small", frameon=False)
        ax.set_title(f"{pos.shape[1]} hard disks in a harmonic trap, k = {a.k:g} k_BT/σ²", fontsize="medium")
        fig.tight_layout()
        fig.savefig(a.out, dpi=110)
        print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
